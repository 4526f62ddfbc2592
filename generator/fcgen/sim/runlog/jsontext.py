"""The run log's JSON text: plain data in, deterministic text out (sorted keys, one sample row per line, ``repr``
floats, non-finite floats as strings), and compressed files read back."""

from __future__ import annotations

import gzip
import json
import lzma
import math
from collections.abc import Mapping
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np

NONFINITE_OUT = {"nan": "NaN", "inf": "Infinity", "-inf": "-Infinity"}
NONFINITE_IN = {"NaN": math.nan, "Infinity": math.inf, "-Infinity": -math.inf}


def plain(value: Any, where: str) -> Any:
    """Deep-convert to JSON-representable Python data (numpy scalars/arrays -> Python), or raise ValueError."""
    if isinstance(value, Mapping):
        out = {}
        for k, v in value.items():
            if not isinstance(k, str):
                raise ValueError(f"{where}: dict keys must be strings, got {k!r}")
            out[k] = plain(v, f"{where}.{k}")
        return out
    if isinstance(value, np.ndarray):
        return plain(value.tolist(), where)
    if isinstance(value, (list, tuple)):
        return [plain(v, f"{where}[{i}]") for i, v in enumerate(value)]
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


def encode_nonfinite(value: Any) -> Any:
    """A nested list with its non-finite floats as the strings ``NaN``, ``Infinity``, ``-Infinity``."""
    if isinstance(value, list):
        return [encode_nonfinite(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return NONFINITE_OUT[repr(value)]
    return value


def decode_nonfinite(value: Any) -> Any:
    """Inverse of ``encode_nonfinite``: those strings back to floats."""
    if isinstance(value, str):
        return NONFINITE_IN.get(value, value)
    if isinstance(value, list):
        return [decode_nonfinite(v) for v in value]
    return value


def reject_constant(name: str) -> float:
    """``json.loads``' hook for a bare NaN or Infinity: refused."""
    raise ValueError(f"run log: bare {name} is not valid JSON; non-finite floats are written as strings")


def _scalar(v: Any) -> str:
    """One JSON scalar: ``repr`` of a float (bit-exact round trip), ASCII strings."""
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


def emit(obj: Any, level: int) -> str:
    """JSON text: objects indented with sorted keys; a list of scalars on one line, other lists one item per line."""
    pad, pad1 = "  " * level, "  " * (level + 1)
    if isinstance(obj, dict):
        if not obj:
            return "{}"
        items = [f"{pad1}{json.dumps(k, ensure_ascii=True)}: {emit(obj[k], level + 1)}" for k in sorted(obj)]
        return "{\n" + ",\n".join(items) + "\n" + pad + "}"
    if isinstance(obj, list):
        if not obj:
            return "[]"
        if all(not isinstance(v, (list, dict)) for v in obj):
            return "[" + ", ".join(_scalar(v) for v in obj) + "]"
        return "[\n" + ",\n".join(pad1 + emit(v, level + 1) for v in obj) + "\n" + pad + "]"
    return _scalar(obj)


def read_text(path: str | PathLike[str]) -> str:
    """The text of a plain, xz- or gzip-compressed UTF-8 file (told apart by the first bytes); ValueError if not
    text."""
    raw = Path(path).read_bytes()
    try:
        if raw.startswith(b"\xfd7zXZ\x00"):
            raw = lzma.decompress(raw)
        elif raw.startswith(b"\x1f\x8b"):
            raw = gzip.decompress(raw)
        return raw.decode("utf-8")
    except (lzma.LZMAError, OSError, EOFError, UnicodeDecodeError) as exc:
        raise ValueError(f"{path}: not a text file ({exc})") from None
