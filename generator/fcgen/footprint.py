"""Memory footprint of a generated solver on a target (``fcgen footprint``): flash, RAM and the worst stack.

The solver's libraries are compiled for the target with ``-fstack-usage -fcallgraph-info=su`` into
``build/<target>/footprint``. Per object file (ELF section headers, read here):

- flash = ``.text`` + ``.rodata`` + the initial values of ``.data`` (stored in flash, copied at start-up);
- RAM = ``.data`` + ``.bss`` (static; no heap);
- stack: GCC's per-function frame sizes (``.su``) summed along the deepest call chain of GCC's call graphs
  (``.ci``) from each API function of ``<name>_solver.h``. An indirect call is resolved to every function whose
  address the objects of the same component take (relocations outside branch instructions): in OSQP's sources
  (``osqp/``) its linear-system function table, in ours the solver's table of CasADi functions. The call of the
  clock hook (``<name>_set_clock``) is an indirect call of ours as well: it is charged as a call of the deepest of
  those functions, so a hook needing more stack than that is not covered. ``bytes_direct`` is the bound with the
  indirect calls left out. C-library callees (``memcpy``, ``sqrt``, ``sin``, ...) have no ``.su`` and are
  listed, not counted. A recursive cycle makes the bound infinite (reported).
"""

from __future__ import annotations

import json
import re
import struct
import subprocess
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .build import build
from .solver_folder import FolderLike, as_folder
from .targets import README_BEGIN, README_END, get_target

SHF_WRITE, SHF_ALLOC, SHF_EXECINSTR, SHT_NOBITS = 0x1, 0x2, 0x4, 8
KEYS = ("text", "rodata", "data", "bss")
INDIRECT = "__indirect_call"
FOOTPRINT_VARIANT = "footprint"
"""The build variant measured (``build/<target>/footprint``; its objects carry the stack-usage output)."""
_BRANCH_RELOCS = (
    "R_ARM_THM_CALL",
    "R_ARM_THM_JUMP24",
    "R_ARM_THM_JUMP19",
    "R_ARM_CALL",
    "R_ARM_JUMP24",
    "R_ARM_PLT32",
    "R_X86_64_PLT32",
    "R_X86_64_PC32",
)


def section_sizes(obj: Path) -> dict[str, int]:
    """``text``, ``rodata``, ``data``, ``bss`` bytes of an ELF object (32- or 64-bit, little-endian)."""
    raw = Path(obj).read_bytes()
    if raw[:4] != b"\x7fELF" or raw[5] != 1:
        raise ValueError(f"{obj}: not a little-endian ELF file")
    is64 = raw[4] == 2
    if is64:
        (shoff,) = struct.unpack_from("<Q", raw, 0x28)
        shentsize, shnum = struct.unpack_from("<HH", raw, 0x3A)
    else:
        (shoff,) = struct.unpack_from("<I", raw, 0x20)
        shentsize, shnum = struct.unpack_from("<HH", raw, 0x2E)
    out = dict.fromkeys(KEYS, 0)
    for i in range(shnum):
        base = shoff + i * shentsize
        if is64:
            _, sh_type, sh_flags = struct.unpack_from("<IIQ", raw, base)
            (size,) = struct.unpack_from("<Q", raw, base + 0x20)
        else:
            _, sh_type, sh_flags = struct.unpack_from("<III", raw, base)
            (size,) = struct.unpack_from("<I", raw, base + 0x14)
        if not sh_flags & SHF_ALLOC:
            continue
        if sh_flags & SHF_EXECINSTR:
            out["text"] += size
        elif not sh_flags & SHF_WRITE:
            out["rodata"] += size
        elif sh_type == SHT_NOBITS:
            out["bss"] += size
        else:
            out["data"] += size
    return out


# ----------------------------------------------------------------------------- call graph

_NODE = re.compile(r'node: \{ title: "([^"]+)" label: "([^"]*)"')
_EDGE = re.compile(r'edge: \{ sourcename: "([^"]+)" targetname: "([^"]+)"')
_BYTES = re.compile(r"\\n(\d+) bytes \(([^)]*)\)")


@dataclass
class CallGraph:
    """Frame sizes and call edges of the objects (GCC ``-fcallgraph-info=su``)."""

    frame: dict[str, int] = field(default_factory=dict)  # defined function -> stack bytes
    qualifier: dict[str, str] = field(default_factory=dict)  # static / dynamic / dynamic,bounded
    calls: dict[str, set[str]] = field(default_factory=dict)  # caller -> callees (names as GCC writes them)
    address_taken: dict[str, set[str]] = field(default_factory=dict)  # component -> functions
    component: dict[str, str] = field(default_factory=dict)  # defined function -> component

    def add_ci(self, text: str, component: str) -> None:
        for title, label in _NODE.findall(text):
            m = _BYTES.search(label)
            if m:
                self.frame[title] = int(m.group(1))
                self.qualifier[title] = m.group(2)
                self.component[title] = component
        for src, dst in _EDGE.findall(text):
            self.calls.setdefault(src, set()).add(dst)

    def indirect_targets(self, caller: str) -> list[str]:
        found = self.address_taken.get(self.component.get(caller, ""), set())
        return sorted(self.resolve(f) for f in found if self.resolve(f) in self.frame)

    def resolve(self, name: str) -> str:
        """A callee as written in a caller's file -> the defined function (static ones are ``file:name``)."""
        if name in self.frame:
            return name
        hits = [f for f in self.frame if f.endswith(":" + name)]
        return hits[0] if len(hits) == 1 else name

    def worst(self, root: str, indirect: bool = True) -> tuple[float, list[str], set[str]]:
        """Deepest stack from ``root``: (bytes, chain, callees without frame data); inf on recursion."""
        memo: dict[str, tuple[float, list[str]]] = {}
        unknown: set[str] = set()
        on_path: set[str] = set()

        def visit(fn: str) -> tuple[float, list[str]]:
            if fn in memo:
                return memo[fn]
            if fn in on_path:
                return float("inf"), [fn, "(recursion)"]
            on_path.add(fn)
            best, chain = 0.0, []
            for callee in sorted(self.calls.get(fn, ())):
                if callee == INDIRECT and not indirect:
                    continue
                targets = self.indirect_targets(fn) if callee == INDIRECT else [self.resolve(callee)]
                for t in targets:
                    if t not in self.frame:
                        unknown.add(t)
                        continue
                    d, c = visit(t)
                    if d > best:
                        best, chain = d, c
            on_path.discard(fn)
            res = (self.frame[fn] + best, [fn, *chain])
            memo[fn] = res
            return res

        d, chain = visit(self.resolve(root))
        return d, chain, unknown


def address_taken(readelf: str, obj: Path) -> set[str]:
    """Function symbols referenced by non-branch relocations (their address is stored or loaded)."""
    res = subprocess.run([readelf, "-rW", str(obj)], capture_output=True, text=True, check=True)
    names = set()
    for line in res.stdout.splitlines():
        parts = line.split()
        if len(parts) >= 5 and parts[2].startswith("R_") and parts[2] not in _BRANCH_RELOCS:
            names.add(parts[4])
    return names


# ----------------------------------------------------------------------------- the command


def api_functions(header: Path, name: str) -> list[str]:
    """The functions ``<name>_solver.h`` declares (without the prefix), in their order."""
    found = re.findall(rf"^[A-Za-z_][\w ]*?\*?\b{name}_(\w+)\(", Path(header).read_text(), re.M)
    return list(dict.fromkeys(found))


def footprint(folder: FolderLike, target: str = "cortex-m7") -> dict:
    """Build the libraries for ``target`` with stack-usage output and measure them; returns the JSON-able result.
    ``folder``: a :class:`~.solver_folder.SolverFolder` or its path."""
    tgt = get_target(target)
    folder = as_folder(folder)
    name = folder.name
    build(folder, target=target, variant=FOOTPRINT_VARIANT, extra_cflags="-fstack-usage -fcallgraph-info=su")
    obj_dir = folder.build_dir(target=target, variant=FOOTPRINT_VARIANT) / "obj"
    objs = sorted(obj_dir.rglob("*.o"))
    if not objs:
        raise FileNotFoundError(f"{obj_dir}: no object files")
    readelf = tgt.tool("readelf") if tgt.bare_metal else "readelf"
    graph = CallGraph()
    per_object: list[dict[str, Any]] = []
    for o in objs:
        sizes = section_sizes(o)
        component = o.relative_to(obj_dir).parts[0] if len(o.relative_to(obj_dir).parts) > 1 else "solver"
        ci = o.with_suffix(".ci")
        if ci.is_file():
            graph.add_ci(ci.read_text(), component)
        graph.address_taken.setdefault(component, set()).update(address_taken(readelf, o))
        per_object.append(
            {
                "object": o.relative_to(obj_dir).as_posix(),
                **sizes,
                "flash": sizes["text"] + sizes["rodata"] + sizes["data"],
                "ram": sizes["data"] + sizes["bss"],
            }
        )
    total = {k: sum(r[k] for r in per_object) for k in (*KEYS, "flash", "ram")}
    stack: dict[str, dict[str, Any]] = {}
    unknown: set[str] = set()
    for fn in api_functions(folder.header, name):
        d, chain, unk = graph.worst(f"{name}_{fn}")
        unknown |= unk
        stack[fn] = {"bytes": d, "chain": chain, "bytes_direct": graph.worst(f"{name}_{fn}", indirect=False)[0]}
    worst_fn = max(stack, key=lambda k: stack[k]["bytes"])
    dynamic = sorted(f for f, q in graph.qualifier.items() if q != "static")
    return {
        "format": "fcgen-footprint/1",
        "solver": name,
        "target": tgt.name,
        "cflags": tgt.cflags(),
        "objects": per_object,
        "total": total,
        "stack": {
            "worst_bytes": stack[worst_fn]["bytes"],
            "worst_entry": f"{name}_{worst_fn}",
            "worst_chain": stack[worst_fn]["chain"],
            "per_entry": stack,
            "indirect_targets": {
                c: sorted({graph.resolve(f) for f in fs if graph.resolve(f) in graph.frame})
                for c, fs in sorted(graph.address_taken.items())
            },
            "not_counted": sorted(u for u in unknown if u != INDIRECT),
            "dynamic_frames": dynamic,
            "note": "indirect calls (the clock hook's too) resolved to the address-taken functions of the "
            "caller's component; C-library callees (not_counted) are not included",
        },
    }


def format_footprint(res: dict) -> str:
    """Per-object table, totals and the worst stack."""
    rows: list[tuple[str, ...]] = [("object", "text", "rodata", "data", "bss", "flash", "RAM")]
    for r in res["objects"]:
        rows.append((r["object"], *(str(r[k]) for k in (*KEYS, "flash", "ram"))))
    t = res["total"]
    rows.append(("total", *(str(t[k]) for k in (*KEYS, "flash", "ram"))))
    w = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    lines = [
        f"footprint of {res['solver']} on {res['target']} ({res['cflags']}), bytes; flash = text + rodata + "
        f"data (initial values), RAM = data + bss"
    ]
    for i, r in enumerate(rows):
        if i == len(rows) - 1:
            lines.append("  ".join("-" * v for v in w))
        lines.append("  ".join(c.ljust(w[0]) if j == 0 else c.rjust(w[j]) for j, c in enumerate(r)))
        if i == 0:
            lines.append("  ".join("-" * v for v in w))
    s = res["stack"]
    lines.append(
        f"flash {t['flash']} bytes ({t['flash'] / 1024:.1f} KiB), RAM {t['ram']} bytes "
        f"({t['ram'] / 1024:.1f} KiB), worst stack {s['worst_bytes']:.0f} bytes ({s['worst_entry']}: "
        + " -> ".join(c.split(":")[-1] for c in s["worst_chain"])
        + ")"
    )
    lines.append(
        "stack per API function (indirect calls resolved / direct calls only): "
        + ", ".join(f"{k} {v['bytes']:.0f}/{v['bytes_direct']:.0f}" for k, v in s["per_entry"].items() if v["bytes"])
    )
    lines.append(
        "indirect calls (the clock hook's too) charged as the deepest address-taken function of the "
        f"caller's component; not counted: C library ({', '.join(s['not_counted']) or 'none'})"
    )
    if s["dynamic_frames"]:
        lines.append(f"dynamic stack frames: {', '.join(s['dynamic_frames'])}")
    return "\n".join(lines)


def write_footprint(res: dict, out: Path | str) -> Path:
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(res, indent=1, sort_keys=True) + "\n")
    return out


def readme_section(res: dict) -> str:
    """The README's footprint figures (between the markers the template writes)."""
    t, s = res["total"], res["stack"]
    return (
        f"{README_BEGIN}\nMeasured by `fcgen footprint . --target {res['target']}` ({res['cflags']}): "
        f"flash {t['flash']} bytes (text {t['text']}, rodata {t['rodata']}, data image {t['data']}), "
        f"RAM {t['ram']} bytes (data {t['data']} + bss {t['bss']}), worst stack {s['worst_bytes']:.0f} bytes "
        f"({s['worst_entry']}; C library not included, the clock hook charged as the deepest indirect "
        f"callee).\n{README_END}"
    )


def fill_readme(gen_dir: Path, res: dict) -> Path:
    """Replace the footprint section of the folder's README with the measured figures."""
    path = Path(gen_dir) / "README.md"
    text = path.read_text()
    i, j = text.find(README_BEGIN), text.find(README_END)
    if i < 0 or j < i:
        raise ValueError(f"{path}: no footprint section (markers {README_BEGIN} ... {README_END})")
    path.write_text(text[:i] + readme_section(res) + text[j + len(README_END) :])
    return path
