"""``RunLog``: one closed-loop run, validated and normalized on construction, written to and read from its JSON file."""

from __future__ import annotations

import gzip
import json
import lzma
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .jsontext import decode_nonfinite, emit, encode_nonfinite, plain, read_text, reject_constant
from .schema import (
    CONTROLLER_KINDS,
    DIM_KEYS,
    FORMAT_VERSION,
    META_KEYS,
    OPTIONAL_FIELDS,
    OPTIONAL_STATE_FIELDS,
    ROAD_ARRAY_KEYS,
    SAMPLE_FIELDS,
    STATE_FIELDS,
)


def _coerce_array(name: str, value: Any, kind: str, shape: tuple[int, ...]) -> NDArray[Any]:
    """Convert ``value`` to a read-only array of the given kind and exact shape, or raise ValueError naming ``name``."""
    try:
        if kind == "float":
            arr = np.array(decode_nonfinite(value) if isinstance(value, list) else value, dtype=np.float64)
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
    out = plain(value, name)
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


def _meta(value: Any) -> dict[str, Any]:
    """The ``meta`` field validated (``META_KEYS``, ``CONTROLLER_KINDS``) as plain data."""
    if not isinstance(value, Mapping):
        raise ValueError("field 'meta': expected a dict")
    meta = plain(value, "meta")
    for key in META_KEYS:
        if key not in meta:
            raise ValueError(f"field 'meta': missing key {key!r}")
    if meta["controller"] not in CONTROLLER_KINDS:
        raise ValueError(f"field 'meta.controller': expected one of {CONTROLLER_KINDS}, got {meta['controller']!r}")
    if not isinstance(meta["versions"], dict) or not isinstance(meta["extra"], dict):
        raise ValueError("field 'meta': 'versions' and 'extra' must be dicts")
    return meta


def _road(value: Any) -> dict[str, Any]:
    """The ``road`` field validated: ``ds`` > 0 and the ``ROAD_ARRAY_KEYS`` arrays of one length."""
    if not isinstance(value, Mapping):
        raise ValueError("field 'road': expected a dict")
    if "ds" not in value:
        raise ValueError("field 'road': missing key 'ds'")
    road = plain({k: v for k, v in value.items() if k not in ROAD_ARRAY_KEYS}, "road")
    if isinstance(road["ds"], bool) or not isinstance(road["ds"], (int, float)) or road["ds"] <= 0:
        raise ValueError(f"field 'road.ds': expected a positive number, got {road['ds']!r}")
    road["ds"] = float(road["ds"])
    for key in ROAD_ARRAY_KEYS:
        if key not in value:
            raise ValueError(f"field 'road': missing key {key!r}")
    m = len(np.asarray(value["s"]).reshape(-1)) if np.ndim(value["s"]) == 1 else -1
    if m < 0:
        raise ValueError("field 'road.s': expected a 1-D array")
    for key in ROAD_ARRAY_KEYS:
        road[key] = _coerce_array(f"road.{key}", value[key], "float", (m,))
    return road


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
    #: the model formula's a_lat on a foreign plant's states, (K + 1,) (docs/plants.md)
    a_lat_model: NDArray[np.float64] | None = field(default=None)
    #: the control the plant got after latency and steering lag, (K, 2)
    control_applied: NDArray[np.float64] | None = field(default=None)
    #: the plant's input limits that cut the control (flags: 1 steering rate, 2 steering angle, 4 acceleration)
    plant_cut: NDArray[np.int64] | None = field(default=None)

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "meta", _meta(self.meta))
        set_(self, "road", _road(self.road))
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
        for name, (kind, trailing) in SAMPLE_FIELDS.items():
            rows = k1 if name in STATE_FIELDS else k1 - 1
            shape = (rows, *tuple(n_opp if d == "O" else d for d in trailing))
            set_(self, name, _coerce_array(name, getattr(self, name), kind, shape))
        for name, (kind, trailing) in OPTIONAL_FIELDS.items():
            value = getattr(self, name)
            if value is not None:
                set_(self, name, _coerce_array(name, value, kind, self._optional_shape(name, value, trailing)))

    def _optional_shape(self, name: str, value: Any, trailing: tuple[Any, ...]) -> tuple[int, ...]:
        n = self.meta["N"]
        if isinstance(n, bool) or not isinstance(n, int) or n < 1:
            raise ValueError(f"field 'meta.N': expected a positive integer for {name!r}, got {n!r}")
        given = np.shape(decode_nonfinite(value) if isinstance(value, list) else value)
        shape = [self.n_states if name in OPTIONAL_STATE_FIELDS else self.n_controls]
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
        return tuple(SAMPLE_FIELDS) + self.optional_fields()

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
                lst = encode_nonfinite(lst)
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
        return emit(self.to_dict(), 0) + "\n"

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
    def from_dict(cls, data: Mapping[str, Any]) -> RunLog:
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
        missing = [k for k in SAMPLE_FIELDS if k not in samples]
        if missing:
            raise ValueError(f"field 'samples': missing field(s) {missing}")
        unknown = sorted(set(samples) - set(SAMPLE_FIELDS) - set(OPTIONAL_FIELDS))
        if unknown:
            raise ValueError(f"field 'samples': unknown field(s) {unknown} for format {FORMAT_VERSION}")
        road = data["road"]
        if isinstance(road, Mapping):
            road = {k: (decode_nonfinite(v) if k in ROAD_ARRAY_KEYS else v) for k, v in road.items()}
        return cls(
            meta=data["meta"],
            road=road,
            opponents=data["opponents"],
            ego=data.get("ego"),
            **{name: samples[name] for name in SAMPLE_FIELDS},
            **{name: samples[name] for name in OPTIONAL_FIELDS if name in samples},
        )

    @classmethod
    def from_json_string(cls, text: str) -> RunLog:
        """Parse and validate the contents of a run-log file."""
        try:
            data = json.loads(text, parse_constant=reject_constant)
        except json.JSONDecodeError as exc:
            raise ValueError(f"run log: invalid JSON ({exc})") from None
        return cls.from_dict(data)

    @classmethod
    def from_json(cls, path: str | PathLike[str]) -> RunLog:
        """Read and validate a run-log file written by ``to_json`` (plain, xz or gzip: told by its first bytes)."""
        return cls.from_json_string(read_text(path))
