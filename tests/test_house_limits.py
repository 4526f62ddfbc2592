"""The house limits (CONTRIBUTING.md): no module of generator/fcgen over 500 lines, no hand-written C file over 1,000
lines, no Python or C function over 80 lines; the few exceptions are listed here with their reason.
``python tests/test_house_limits.py`` prints the longest that remain."""

from __future__ import annotations

import ast
import re
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "generator" / "fcgen"
MODULE_MAX, C_FILE_MAX, FUNCTION_MAX = 500, 1000, 80

# name -> why it stays longer (each entry must still exceed the limit: a stale exception fails the test)
EXCEPTIONS: dict[str, str] = {}


def python_modules() -> list[Path]:
    return sorted(p for p in PACKAGE.rglob("*.py") if "templates" not in p.parts)


def hand_written_c() -> list[Path]:
    """csrc/, firmware_sim/, benchmarks/ and the tests' C: what clang-format checks (not generated/, not templates)."""
    out = subprocess.run(
        ["git", "ls-files", "--", "csrc/*.[ch]", "firmware_sim/*.[ch]", "benchmarks/*.[ch]", "tests/*.[ch]"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=True,
    ).stdout.split()
    return [ROOT / f for f in out]


def _rel(p: Path) -> str:
    return p.relative_to(ROOT).as_posix()


def python_functions() -> list[tuple[int, str]]:
    """(lines, 'path:name') of every function and method (its decorators excluded, its docstring included)."""
    out = []
    for p in python_modules():
        for node in ast.walk(ast.parse(p.read_text())):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                out.append((node.end_lineno - node.lineno + 1, f"{_rel(p)}:{node.name}"))
    return out


def c_functions(text: str) -> list[tuple[str, int]]:
    """(name, lines) of each function definition in clang-formatted C: a signature at column 0 whose body opens with
    ``{`` at the end of a line and closes with ``}`` alone at column 0."""
    lines, out, i = text.split("\n"), [], 0
    while i < len(lines):
        line = lines[i]
        if line[:1].isalpha() and "(" in line and "=" not in line.split("(")[0]:
            j = i
            while j < len(lines) and not lines[j].rstrip().endswith(("{", ";")):
                j += 1
            if j < len(lines) and lines[j].rstrip().endswith("{"):
                k = j + 1
                while k < len(lines) and lines[k] != "}":
                    k += 1
                m = re.search(r"(\w+)\s*\(", line)
                out.append((m.group(1) if m else line, k - i + 1))
                i = k
        i += 1
    return out


def over_limits() -> list[tuple[int, int, str]]:
    """(lines, limit, what) of everything over its limit."""
    out = []
    for p in python_modules():
        n = len(p.read_text().splitlines())
        if n > MODULE_MAX:
            out.append((n, MODULE_MAX, _rel(p)))
    for n, name in python_functions():
        if n > FUNCTION_MAX:
            out.append((n, FUNCTION_MAX, name))
    for p in hand_written_c():
        text = p.read_text()
        if len(text.splitlines()) > C_FILE_MAX:
            out.append((len(text.splitlines()), C_FILE_MAX, _rel(p)))
        for name, n in c_functions(text):
            if n > FUNCTION_MAX:
                out.append((n, FUNCTION_MAX, f"{_rel(p)}:{name}"))
    return sorted(out, reverse=True)


def test_c_functions_are_found_and_measured():
    text = "static int f(int a,\n             int b) {\n  return a + b;\n}\n\nint g(void);\nvoid h(void) {\n  g();\n}\n"
    assert c_functions(text) == [("f", 4), ("h", 3)]


def test_nothing_over_the_house_limits_but_the_listed_exceptions():
    over = over_limits()
    unexpected = [f"{what}: {n} lines (limit {lim})" for n, lim, what in over if what not in EXCEPTIONS]
    assert not unexpected, "over the house limits:\n" + "\n".join(unexpected)
    stale = sorted(set(EXCEPTIONS) - {what for _, _, what in over})
    assert not stale, f"exceptions no longer needed (remove them): {stale}"


if __name__ == "__main__":
    fns = sorted(python_functions(), reverse=True)[:10]
    print("longest Python functions:\n" + "\n".join(f"  {n:4d}  {name}" for n, name in fns))
    mods = sorted(((len(p.read_text().splitlines()), _rel(p)) for p in python_modules()), reverse=True)[:10]
    print("longest modules:\n" + "\n".join(f"  {n:4d}  {name}" for n, name in mods))
    cf = sorted(((n, f"{_rel(p)}:{f}") for p in hand_written_c() for f, n in c_functions(p.read_text())), reverse=True)
    print("longest C functions:\n" + "\n".join(f"  {n:4d}  {name}" for n, name in cf[:5]))
    print("over the limits:\n" + "\n".join(f"  {n:4d} > {lim}  {w}" for n, lim, w in over_limits()))
