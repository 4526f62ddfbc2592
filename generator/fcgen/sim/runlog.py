"""The versioned JSON run log of one closed-loop run (format ``fcgen-runlog/1``, documented in docs/runlog.md).

Users regression-compare run logs in CI (C controller vs Python reference, or against a stored
baseline), so the file format is stable, strictly validated on read and written deterministically:
sorted keys, fixed layout, floats written with ``repr`` (shortest round-tripping decimal), so a
write/read round trip reproduces every float bit for bit.

Sample timing (SPEC section 1): states are logged at ``t_0 .. t_K`` (``K + 1`` *state samples*),
controls ``u_0 .. u_{K-1}`` (``K`` *control samples*); ``u_k`` is applied during ``[t_k, t_k + dt)``
and the solver statistics of sample ``k`` belong to the solve that produced ``u_k``.
"""

from __future__ import annotations

import gzip
import json
import lzma
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import lru_cache
from importlib import metadata
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..backends import QP_STATUSES

__all__ = [
    "FORMAT_VERSION",
    "CONTROLLER_KINDS",
    "META_KEYS",
    "ROAD_ARRAY_KEYS",
    "DIM_KEYS",
    "STATE_FIELDS",
    "CONTROL_FIELDS",
    "OPTIONAL_FIELDS",
    "QP_STATUS_NAMES",
    "qp_status_name",
    "package_versions",
    "make_meta",
    "RunLog",
    "summary",
    "compare",
]

#: Format identifier written to and required in every file (see the versioning policy in docs/runlog.md).
FORMAT_VERSION = "fcgen-runlog/1"

#: Allowed values of ``meta["controller"]``.
CONTROLLER_KINDS: tuple[str, ...] = ("python-reference", "c", "c-firmware_sim", "c-fmu")

#: Keys ``meta`` must contain (more keys are allowed and preserved).
META_KEYS: tuple[str, ...] = (
    "problem", "formulation", "obstacle_model", "scenario", "seed", "N", "dt", "versions", "controller", "extra",
)

#: Array keys of ``road`` (all of one length M, on a uniform grid of spacing ``road["ds"]``).
ROAD_ARRAY_KEYS: tuple[str, ...] = ("s", "kappa", "gamma_x", "gamma_y", "phi_gamma")

#: Keys of a vehicle-dimension mapping (``ego`` and each entry of ``opponents``), metres.
DIM_KEYS: tuple[str, ...] = ("l_f", "l_r", "l_r_ch", "l_f_ch", "w_ch")

# name -> (dtype kind, trailing shape); "O" in a trailing shape stands for the number of opponents.
#: Per-state-sample fields (K + 1 rows, times t_0 .. t_K).
STATE_FIELDS: dict[str, tuple[str, tuple[Any, ...]]] = {
    "t": ("float", ()),
    "ego_frenet": ("float", (5,)),
    "ego_cartesian": ("float", (3,)),
    "opp_cartesian": ("float", ("O", 3)),
    "opp_frenet": ("float", ("O", 3)),
    "collision": ("bool", ()),
    "a_lat": ("float", ()),
}
#: Per-control-sample fields (K rows, one per applied control / solver call).
CONTROL_FIELDS: dict[str, tuple[str, tuple[Any, ...]]] = {
    "control": ("float", (2,)),
    "time_prepare": ("float", ()),
    "time_feedback": ("float", ()),
    "time_total": ("float", ()),
    "qp_iter": ("int", ()),
    "qp_status": ("int", ()),
    "max_slack": ("float", ()),
}
_SAMPLE_FIELDS = {**STATE_FIELDS, **CONTROL_FIELDS}
#: Optional per-control-sample fields (K rows; for replay comparison, docs/runlog.md): "N" in a trailing shape is
#: ``meta["N"]``, "*" any positive size (one value for all rows). A log either has a field with this shape or not.
OPTIONAL_FIELDS: dict[str, tuple[str, tuple[Any, ...]]] = {
    "exit_code": ("int", ()),
    "plan_states": ("float", ("N+1", "*")),
    "plan_controls": ("float", ("N", "*")),
}

#: Generic QP status codes (``fcgen.backends.QP_STATUSES``: the same for every QP backend, C and Python alike), without
#: the ``QP_`` prefix, lower case. The backend's own status is not logged.
QP_STATUS_NAMES: dict[int, str] = {code: name.removeprefix("QP_").lower()
                                   for code, name in enumerate(QP_STATUSES, start=1)}

_NONFINITE_OUT = {"nan": "NaN", "inf": "Infinity", "-inf": "-Infinity"}
_NONFINITE_IN = {"NaN": math.nan, "Infinity": math.inf, "-Infinity": -math.inf}


def qp_status_name(code: int) -> str:
    """Name of a generic QP status code (``"unknown_<code>"`` for other codes, e.g. 0: no QP solved)."""
    return QP_STATUS_NAMES.get(int(code), f"unknown_{int(code)}")


def package_versions() -> dict[str, str]:
    """Installed versions of fcgen, casadi, osqp and numpy, for ``meta["versions"]`` (no imports needed)."""
    return dict(_package_versions())


@lru_cache(maxsize=1)
def _package_versions() -> dict[str, str]:
    """``package_versions`` looked up once per process (the metadata scan costs ~7 ms; installs do not change)."""
    out = {}
    for name in ("fcgen", "casadi", "osqp", "numpy"):
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "unknown"
    return out


def make_meta(
    *,
    problem: str,
    formulation: str,
    obstacle_model: str,
    scenario: str,
    seed: int,
    N: int,
    dt: float,
    controller: str,
    n_bound: float | None = None,
    extra: Mapping[str, Any] | None = None,
    versions: Mapping[str, str] | None = None,
) -> dict[str, Any]:
    """Build a valid ``meta`` dict, filling in the package versions of the running interpreter."""
    meta: dict[str, Any] = {
        "problem": problem,
        "formulation": formulation,
        "obstacle_model": obstacle_model,
        "scenario": scenario,
        "seed": int(seed),
        "N": int(N),
        "dt": float(dt),
        "controller": controller,
        "versions": dict(package_versions() if versions is None else versions),
        "extra": dict(extra or {}),
    }
    if n_bound is not None:
        meta["n_bound"] = float(n_bound)
    return meta


# ----------------------------------------------------------------------------- plain-data helpers


def _plain(value: Any, where: str) -> Any:
    """Deep-convert to JSON-representable Python data (numpy scalars/arrays -> Python), or raise ValueError."""
    if isinstance(value, Mapping):
        out = {}
        for k, v in value.items():
            if not isinstance(k, str):
                raise ValueError(f"{where}: dict keys must be strings, got {k!r}")
            out[k] = _plain(v, f"{where}.{k}")
        return out
    if isinstance(value, np.ndarray):
        return _plain(value.tolist(), where)
    if isinstance(value, (list, tuple)):
        return [_plain(v, f"{where}[{i}]") for i, v in enumerate(value)]
    if value is None or isinstance(value, (str, bool)):
        return value
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        if not math.isfinite(float(value)):
            raise ValueError(f"{where}: non-finite float {value!r} only allowed in numeric arrays")
        return float(value)
    raise ValueError(f"{where}: value of type {type(value).__name__} is not JSON-representable")


def _decode_nonfinite(value: Any) -> Any:
    if isinstance(value, str):
        return _NONFINITE_IN.get(value, value)
    if isinstance(value, list):
        return [_decode_nonfinite(v) for v in value]
    return value


def _coerce_array(name: str, value: Any, kind: str, shape: tuple[int, ...]) -> NDArray[Any]:
    """Convert ``value`` to a read-only array of the given kind and exact shape, or raise ValueError naming ``name``."""
    try:
        if kind == "float":
            arr = np.array(_decode_nonfinite(value) if isinstance(value, list) else value, dtype=np.float64)
        else:
            raw = np.array(value)
            if raw.size and raw.dtype.kind not in "biuf":
                raise ValueError(f"dtype {raw.dtype}")
            if kind == "int":
                if raw.size and raw.dtype.kind == "f" and not np.all(np.isfinite(raw) & (raw == np.round(raw))):
                    raise ValueError("non-integer values")
                arr = raw.astype(np.int64)
            else:  # bool
                if raw.size and raw.dtype.kind != "b" and not np.all((raw == 0) | (raw == 1)):
                    raise ValueError("values other than 0/1")
                arr = raw.astype(np.bool_)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"field {name!r}: cannot convert to a {kind} array ({exc})") from None
    if arr.size == 0 and math.prod(shape) == 0:
        arr = arr.reshape(shape)
    if arr.shape != shape:
        raise ValueError(f"field {name!r}: expected shape {shape}, got {arr.shape}")
    arr = arr.copy()
    arr.flags.writeable = False
    return arr


def _dims(name: str, value: Any) -> dict[str, Any]:
    if not isinstance(value, Mapping):
        raise ValueError(f"field {name!r}: expected a dict of vehicle dimensions, got {type(value).__name__}")
    out = _plain(value, name)
    for key in DIM_KEYS:
        if key not in out:
            raise ValueError(f"field {name!r}: missing dimension {key!r}")
        v = out[key]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or v < 0:
            raise ValueError(f"field '{name}.{key}': expected a non-negative number, got {v!r}")
        out[key] = float(v)
    if out["w_ch"] <= 0 or out["l_r_ch"] + out["l_f_ch"] <= 0:
        raise ValueError(f"field {name!r}: chassis must have positive length and width")
    return out


# ----------------------------------------------------------------------------- the log


@dataclass(frozen=True, eq=False)
class RunLog:
    """One closed-loop run. Validated and normalized on construction; arrays are read-only copies.

    ``K`` = number of control samples; state fields have ``K + 1`` rows, control fields ``K`` rows
    (see ``STATE_FIELDS`` / ``CONTROL_FIELDS``); ``O`` = ``len(opponents)``. Units: SI (docs/runlog.md).
    """

    meta: dict[str, Any]
    road: dict[str, Any]
    opponents: list[dict[str, Any]]
    # per state sample (K + 1)
    t: NDArray[np.float64]
    ego_frenet: NDArray[np.float64]
    ego_cartesian: NDArray[np.float64]
    opp_cartesian: NDArray[np.float64]
    opp_frenet: NDArray[np.float64]
    collision: NDArray[np.bool_]
    a_lat: NDArray[np.float64]
    # per control sample (K)
    control: NDArray[np.float64]
    time_prepare: NDArray[np.float64]
    time_feedback: NDArray[np.float64]
    time_total: NDArray[np.float64]
    qp_iter: NDArray[np.int64]
    qp_status: NDArray[np.int64]
    max_slack: NDArray[np.float64]
    #: ego vehicle dimensions (keys ``DIM_KEYS``); None only for logs that do not know them
    ego: dict[str, Any] | None = field(default=None)
    # optional per control sample (K), None when the log does not carry them
    #: solver exit code of each sample (0 = OK)
    exit_code: NDArray[np.int64] | None = field(default=None)
    #: planned states x_0 .. x_N of each sample's solution, (K, N + 1, nx)
    plan_states: NDArray[np.float64] | None = field(default=None)
    #: planned controls u_0 .. u_{N-1} of each sample's solution, (K, N, nu)
    plan_controls: NDArray[np.float64] | None = field(default=None)

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        # meta
        if not isinstance(self.meta, Mapping):
            raise ValueError("field 'meta': expected a dict")
        meta = _plain(self.meta, "meta")
        for key in META_KEYS:
            if key not in meta:
                raise ValueError(f"field 'meta': missing key {key!r}")
        if meta["controller"] not in CONTROLLER_KINDS:
            raise ValueError(f"field 'meta.controller': expected one of {CONTROLLER_KINDS}, got {meta['controller']!r}")
        if not isinstance(meta["versions"], dict) or not isinstance(meta["extra"], dict):
            raise ValueError("field 'meta': 'versions' and 'extra' must be dicts")
        set_(self, "meta", meta)
        # road
        if not isinstance(self.road, Mapping):
            raise ValueError("field 'road': expected a dict")
        if "ds" not in self.road:
            raise ValueError("field 'road': missing key 'ds'")
        road = _plain({k: v for k, v in self.road.items() if k not in ROAD_ARRAY_KEYS}, "road")
        if isinstance(road["ds"], bool) or not isinstance(road["ds"], (int, float)) or road["ds"] <= 0:
            raise ValueError(f"field 'road.ds': expected a positive number, got {road['ds']!r}")
        road["ds"] = float(road["ds"])
        for key in ROAD_ARRAY_KEYS:
            if key not in self.road:
                raise ValueError(f"field 'road': missing key {key!r}")
        m = len(np.asarray(self.road["s"]).reshape(-1)) if np.ndim(self.road["s"]) == 1 else -1
        if m < 0:
            raise ValueError("field 'road.s': expected a 1-D array")
        for key in ROAD_ARRAY_KEYS:
            road[key] = _coerce_array(f"road.{key}", self.road[key], "float", (m,))
        set_(self, "road", road)
        # vehicles
        if not isinstance(self.opponents, (list, tuple)):
            raise ValueError("field 'opponents': expected a list of dicts")
        set_(self, "opponents", [_dims(f"opponents[{i}]", o) for i, o in enumerate(self.opponents)])
        if self.ego is not None:
            set_(self, "ego", _dims("ego", self.ego))
        # samples
        n_opp = len(self.opponents)
        t = np.asarray(self.t)
        if t.ndim != 1 or t.shape[0] < 1:
            raise ValueError(f"field 't': expected a 1-D array with at least one state sample, got shape {t.shape}")
        k1 = t.shape[0]
        for name, (kind, trailing) in _SAMPLE_FIELDS.items():
            rows = k1 if name in STATE_FIELDS else k1 - 1
            shape = (rows,) + tuple(n_opp if d == "O" else d for d in trailing)
            set_(self, name, _coerce_array(name, getattr(self, name), kind, shape))
        for name, (kind, trailing) in OPTIONAL_FIELDS.items():
            value = getattr(self, name)
            if value is not None:
                set_(self, name, _coerce_array(name, value, kind, self._optional_shape(name, value, trailing)))

    def _optional_shape(self, name: str, value: Any, trailing: tuple[Any, ...]) -> tuple[int, ...]:
        n = self.meta["N"]
        if isinstance(n, bool) or not isinstance(n, int) or n < 1:
            raise ValueError(f"field 'meta.N': expected a positive integer for {name!r}, got {n!r}")
        given = np.shape(_decode_nonfinite(value) if isinstance(value, list) else value)
        shape = [self.n_controls]
        for i, d in enumerate(trailing, start=1):
            if d == "*":
                d = given[i] if len(given) > i and given[i] > 0 else 1
            shape.append({"N": n, "N+1": n + 1}.get(d, d))
        return tuple(shape)

    def optional_fields(self) -> tuple[str, ...]:
        """Names of the optional fields (``OPTIONAL_FIELDS``) this log carries."""
        return tuple(name for name in OPTIONAL_FIELDS if getattr(self, name) is not None)

    def sample_fields(self) -> tuple[str, ...]:
        """Names of all per-sample fields this log carries (required first, then optional)."""
        return tuple(_SAMPLE_FIELDS) + self.optional_fields()

    # -- sizes
    @property
    def n_states(self) -> int:
        """Number of state samples, ``K + 1``."""
        return int(self.t.shape[0])

    @property
    def n_controls(self) -> int:
        """Number of control samples, ``K``."""
        return int(self.t.shape[0]) - 1

    # -- JSON
    def to_dict(self) -> dict[str, Any]:
        """Plain-data form of the file contents (arrays as nested lists, non-finite floats as strings)."""
        def arr(a: NDArray[Any]) -> Any:
            lst = a.tolist()
            if a.dtype.kind == "f" and not np.all(np.isfinite(a)):
                lst = _encode_nonfinite(lst)
            return lst

        road = {k: (arr(v) if k in ROAD_ARRAY_KEYS else v) for k, v in self.road.items()}
        return {
            "format": FORMAT_VERSION,
            "meta": self.meta,
            "road": road,
            "ego": self.ego,
            "opponents": self.opponents,
            "samples": {name: arr(getattr(self, name)) for name in self.sample_fields()},
        }

    def to_json_string(self) -> str:
        """The file contents: deterministic JSON (sorted keys, one sample row per line, repr floats)."""
        return _emit(self.to_dict(), 0) + "\n"

    def to_json(self, path: str | PathLike[str]) -> Path:
        """Write the log to ``path`` (UTF-8, LF line endings; xz- or gzip-compressed if it ends in ``.xz``/``.gz``)."""
        path = Path(path)
        data = self.to_json_string().encode("utf-8")
        if path.suffix == ".xz":
            data = lzma.compress(data, preset=9)
        elif path.suffix == ".gz":
            data = gzip.compress(data, compresslevel=9, mtime=0)
        path.write_bytes(data)
        return path

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> "RunLog":
        """Inverse of ``to_dict``; validates the format version, the fields and all shapes (ValueError)."""
        if not isinstance(data, Mapping):
            raise ValueError("run log: top level must be a JSON object")
        fmt = data.get("format")
        if fmt != FORMAT_VERSION:
            raise ValueError(f"field 'format': expected {FORMAT_VERSION!r}, got {fmt!r}")
        top = {"format", "meta", "road", "ego", "opponents", "samples"}
        for key in sorted(top - {"ego"}):
            if key not in data:
                raise ValueError(f"run log: missing field {key!r}")
        unknown = sorted(set(data) - top)
        if unknown:
            raise ValueError(f"run log: unknown field(s) {unknown} for format {FORMAT_VERSION}")
        samples = data["samples"]
        if not isinstance(samples, Mapping):
            raise ValueError("field 'samples': expected an object")
        missing = [k for k in _SAMPLE_FIELDS if k not in samples]
        if missing:
            raise ValueError(f"field 'samples': missing field(s) {missing}")
        unknown = sorted(set(samples) - set(_SAMPLE_FIELDS) - set(OPTIONAL_FIELDS))
        if unknown:
            raise ValueError(f"field 'samples': unknown field(s) {unknown} for format {FORMAT_VERSION}")
        road = data["road"]
        if isinstance(road, Mapping):
            road = {k: (_decode_nonfinite(v) if k in ROAD_ARRAY_KEYS else v) for k, v in road.items()}
        return cls(
            meta=data["meta"],
            road=road,
            opponents=data["opponents"],
            ego=data.get("ego"),
            **{name: samples[name] for name in _SAMPLE_FIELDS},
            **{name: samples[name] for name in OPTIONAL_FIELDS if name in samples},
        )

    @classmethod
    def from_json_string(cls, text: str) -> "RunLog":
        """Parse and validate the contents of a run-log file."""
        try:
            data = json.loads(text, parse_constant=_reject_constant)
        except json.JSONDecodeError as exc:
            raise ValueError(f"run log: invalid JSON ({exc})") from None
        return cls.from_dict(data)

    @classmethod
    def from_json(cls, path: str | PathLike[str]) -> "RunLog":
        """Read and validate a run-log file written by ``to_json`` (plain, xz or gzip: told by its first bytes)."""
        return cls.from_json_string(read_text(path))


def read_text(path: str | PathLike[str]) -> str:
    """The text of a plain, xz- or gzip-compressed UTF-8 file (told apart by the first bytes); ValueError if not text."""
    raw = Path(path).read_bytes()
    try:
        if raw.startswith(b"\xfd7zXZ\x00"):
            raw = lzma.decompress(raw)
        elif raw.startswith(b"\x1f\x8b"):
            raw = gzip.decompress(raw)
        return raw.decode("utf-8")
    except (lzma.LZMAError, OSError, EOFError, UnicodeDecodeError) as exc:
        raise ValueError(f"{path}: not a text file ({exc})") from None


def _reject_constant(name: str) -> float:
    raise ValueError(f"run log: bare {name} is not valid JSON; non-finite floats are written as strings")


def _encode_nonfinite(value: Any) -> Any:
    if isinstance(value, list):
        return [_encode_nonfinite(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return _NONFINITE_OUT[repr(value)]
    return value


# ----------------------------------------------------------------------------- deterministic emitter


def _scalar(v: Any) -> str:
    if v is None:
        return "null"
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):  # never reached for validated logs; kept strict
            raise ValueError(f"non-finite float {v!r} cannot be written")
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=True)
    raise TypeError(f"cannot write {type(v).__name__}")


def _emit(obj: Any, level: int) -> str:
    """JSON text: objects indented with sorted keys; a list of scalars on one line, other lists one item per line."""
    pad, pad1 = "  " * level, "  " * (level + 1)
    if isinstance(obj, dict):
        if not obj:
            return "{}"
        items = [f"{pad1}{json.dumps(k, ensure_ascii=True)}: {_emit(obj[k], level + 1)}" for k in sorted(obj)]
        return "{\n" + ",\n".join(items) + "\n" + pad + "}"
    if isinstance(obj, list):
        if not obj:
            return "[]"
        if all(not isinstance(v, (list, dict)) for v in obj):
            return "[" + ", ".join(_scalar(v) for v in obj) + "]"
        return "[\n" + ",\n".join(pad1 + _emit(v, level + 1) for v in obj) + "\n" + pad + "]"
    return _scalar(obj)


# ----------------------------------------------------------------------------- analysis


def _stats_ms(*xs: NDArray[np.float64]) -> list[dict[str, float]]:
    """Mean, median, p99 and max in ms of each of the arrays ``xs`` (one length): one numpy call per statistic along
    the rows of their stack (row by row the values of the calls on each array; median and percentile cost ~0.1 ms a
    call)."""
    if xs[0].size == 0:
        return [{"mean": math.nan, "median": math.nan, "p99": math.nan, "max": math.nan} for _ in xs]
    ms = 1e3 * np.stack(xs)
    stats = zip(np.mean(ms, axis=1).tolist(), np.median(ms, axis=1).tolist(), np.percentile(ms, 99, axis=1).tolist(),
                np.max(ms, axis=1).tolist())
    return [{"mean": a, "median": b, "p99": c, "max": d} for a, b, c, d in stats]


def summary(log: RunLog) -> dict[str, Any]:
    """Metrics of one run (SPEC section 7), as plain Python numbers.

    Keys: ``progress`` (final minus initial ``s``, m), ``s_final`` (m), ``n_states``, ``n_controls``,
    ``n_collision_samples``, ``time_total_ms`` / ``time_prepare_ms`` / ``time_feedback_ms`` (dicts with
    mean, median, p99, max in ms), ``qp_iter_mean``, ``qp_iter_max``, ``qp_status_counts`` (status name ->
    count, names from ``QP_STATUS_NAMES``), ``max_slack``, ``max_abs_a_lat`` (m/s^2). Statistics over an
    empty set are NaN (``qp_iter_max``: 0).
    """
    s = log.ego_frenet[:, 0]
    counts: dict[str, int] = {}
    codes, n_codes = np.unique(log.qp_status, return_counts=True)
    for code, n in zip(codes.tolist(), n_codes.tolist()):
        name = qp_status_name(code)
        counts[name] = counts.get(name, 0) + n
    k = log.n_controls
    t_total, t_prepare, t_feedback = _stats_ms(log.time_total, log.time_prepare, log.time_feedback)
    return {
        "progress": float(s[-1] - s[0]),
        "s_final": float(s[-1]),
        "n_states": log.n_states,
        "n_controls": k,
        "n_collision_samples": int(np.count_nonzero(log.collision)),
        "time_total_ms": t_total,
        "time_prepare_ms": t_prepare,
        "time_feedback_ms": t_feedback,
        "qp_iter_mean": float(np.mean(log.qp_iter)) if k else math.nan,
        "qp_iter_max": int(np.max(log.qp_iter)) if k else 0,
        "qp_status_counts": dict(sorted(counts.items())),
        "max_slack": float(np.max(log.max_slack)) if k else math.nan,
        "max_abs_a_lat": float(np.max(np.abs(log.a_lat))),
    }


def compare(log_a: RunLog, log_b: RunLog) -> dict[str, float]:
    """Max absolute difference of every per-sample array between two runs (e.g. C vs Python reference).

    Returns ``{field: max |a - b|}`` for all fields of ``STATE_FIELDS`` and ``CONTROL_FIELDS`` (bool and
    int fields are compared as numbers, so 0 means identical). NaN at the same place in both counts as
    equal; NaN in one only gives ``inf``. Timing fields are included but naturally differ between runs.
    Optional fields (``OPTIONAL_FIELDS``) are compared when both logs carry them.
    Raises ValueError if the shapes differ (different number of samples or opponents).
    """
    out: dict[str, float] = {}
    common = [n for n in log_a.sample_fields() if n in log_b.sample_fields()]
    for name in common:
        a = np.asarray(getattr(log_a, name), dtype=np.float64)
        b = np.asarray(getattr(log_b, name), dtype=np.float64)
        if a.shape != b.shape:
            raise ValueError(f"field {name!r}: shapes differ, {a.shape} vs {b.shape}")
        if a.size == 0:
            out[name] = 0.0
            continue
        with np.errstate(invalid="ignore"):
            d = np.abs(a - b)
        both_nan = np.isnan(a) & np.isnan(b)
        d[both_nan] = 0.0
        d[np.isnan(d)] = math.inf  # NaN in only one of them (equal infinities are fixed next)
        same_inf = np.isinf(a) & (a == b)
        d[same_inf] = 0.0
        out[name] = float(np.max(d))
    return out
