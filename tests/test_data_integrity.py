"""Nothing lost: golden suites, campaign results and worker processes survive overwrites, kills and hand edits.

Every kill here is a real SIGKILL of a real ``fcgen`` process. To kill at an exact moment of a write (between two
renames of a merge, say) the process is started with ``FCGEN_PAUSE_AT=<point>`` (``fcgen.testhook``): it stops at
that point, announces it in a flag file, and the test then SIGKILLs it there.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from fcgen.campaign.store import RUN_ID, ResultStore
from fcgen.suite import load_suite

ROOT = Path(__file__).resolve().parents[1]
SOLVER = ROOT / "generated" / "truck_lifted_ellipse"
FCGEN = str(Path(sys.executable).with_name("fcgen"))


def fcgen(*args, env=None, timeout=300) -> subprocess.CompletedProcess:
    return subprocess.run(
        [FCGEN, *map(str, args)], capture_output=True, text=True, timeout=timeout, env={**os.environ, **(env or {})}
    )


def kill_at(point: str, args, tmp: Path, timeout: float = 240) -> str:
    """Run ``fcgen ARGS`` until it reaches the pause point ``point``, SIGKILL it (its whole process group) there;
    returns what it printed."""
    flag = tmp / f"paused-{point.replace(':', '-')}"
    flag.unlink(missing_ok=True)
    env = {**os.environ, "FCGEN_PAUSE_AT": point, "FCGEN_PAUSE_FLAG": str(flag)}
    proc = subprocess.Popen(
        [FCGEN, *map(str, args)],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        start_new_session=True,
    )
    try:
        deadline = time.monotonic() + timeout
        while not flag.exists():
            if proc.poll() is not None:
                pytest.fail(
                    f"fcgen {' '.join(map(str, args))} ended (exit {proc.returncode}) before {point}:\n"
                    f"{proc.stdout.read()}"
                )
            if time.monotonic() > deadline:
                pytest.fail(f"{point} not reached in {timeout} s")
            time.sleep(0.05)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        out = proc.communicate()[0]
    assert proc.returncode == -signal.SIGKILL
    return out


# ----------------------------------------------------------------------------- 1-2: record


@pytest.fixture(scope="module")
def old_suite(tmp_path_factory) -> Path:
    """A small suite (seed 0, 30 samples) of the checked-in solver: the data a new record must not lose."""
    out = tmp_path_factory.mktemp("suite") / "old"
    res = fcgen("record", SOLVER, "-o", out, "--seeds", "0", "--samples", "30")
    assert res.returncode == 0, res.stderr
    return out


def _files(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def test_record_refuses_to_replace_a_suite_without_force_and_names_what_would_be_lost(old_suite, tmp_path):
    g = shutil.copytree(old_suite, tmp_path / "g")
    before = _files(g)
    res = fcgen("record", SOLVER, "-o", g, "--seeds", "1", "--samples", "30")
    assert res.returncode == 1
    assert res.stderr.count("\n") == 1 and "truck_seed0.json.xz" in res.stderr and "--force" in res.stderr
    assert _files(g) == before  # not one byte changed
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "notes.txt").write_text("mine")
    res = fcgen("record", SOLVER, "-o", tmp_path / "other", "--seeds", "1", "--samples", "30", "--force")
    assert res.returncode == 1 and "notes.txt" in res.stderr  # a folder of other files: never, even with --force
    assert (tmp_path / "other" / "notes.txt").read_text() == "mine"
    # with --force: replaced, and a file of the folder that is no suite's stays
    (g / "README.txt").write_text("kept")
    res = fcgen("record", SOLVER, "-o", g, "--seeds", "1", "--samples", "30", "--force")
    assert res.returncode == 0, res.stderr
    man, _logs = load_suite(g)
    assert [e["seed"] for e in man["logs"]] == [1] and (g / "README.txt").read_text() == "kept"
    assert not (g / "truck_seed0.json.xz").exists()
    assert not list(tmp_path.glob(".g.fcgen-*"))  # no leftovers


def test_record_checks_its_path_before_building(tmp_path):
    (tmp_path / "f").write_text("x")
    t0 = time.monotonic()
    res = fcgen("record", SOLVER, "-o", tmp_path / "f" / "sub")
    assert res.returncode == 1 and f"{tmp_path / 'f'} is a file" in res.stderr
    assert res.stderr.count("\n") == 1 and time.monotonic() - t0 < 30


@pytest.mark.parametrize(
    "point, survivor", [("record:log", "old"), ("record:before-swap", "old"), ("record:after-swap", "new")]
)
def test_a_record_killed_at_any_moment_leaves_one_whole_suite(old_suite, tmp_path, point, survivor):
    """SIGKILL after the first new log, after the last file before the swap, and right after the swap: the folder
    holds the old suite or the new one, whole (``regress`` against a copy of the old one: exit 0 or a clean new
    suite), never a mix."""
    g = shutil.copytree(old_suite, tmp_path / "g")
    kill_at(point, ["record", SOLVER, "-o", g, "--seeds", "1-2", "--samples", "30", "--force"], tmp_path)
    man, _logs = load_suite(g)  # checksums, seeds, lengths as in the manifest
    assert [e["seed"] for e in man["logs"]] == ([0] if survivor == "old" else [1, 2])
    if survivor == "old":
        assert _files(g) == _files(old_suite)
        res = fcgen("regress", g, old_suite)
        assert res.returncode == 0, res.stdout + res.stderr
    else:
        res = fcgen("regress", SOLVER, g)  # the new suite is the solver's: its replay matches
        assert res.returncode == 0, res.stdout + res.stderr
    left = [p.name for p in tmp_path.iterdir() if p.name.startswith(".g.fcgen-")]
    assert len(left) <= 1  # a hidden temporary folder may remain (documented); nothing else


# ----------------------------------------------------------------------------- 3: the campaign's merge

CAMPAIGN = [
    "campaign",
    "--scenarios",
    "truck",
    "--formulations",
    "lifted",
    "--obstacles",
    "ellipse",
    "--samples",
    "5",
    "--jobs",
    "1",
]


@pytest.fixture(scope="module")
def cache(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("solvers")


@pytest.fixture(scope="module")
def half_done(tmp_path_factory, cache) -> Path:
    """Results of seeds 0-1 (one part): the next call with 4 seeds computes 2 runs, a second part, then merges."""
    out = tmp_path_factory.mktemp("campaign") / "res"
    res = fcgen(*CAMPAIGN, "--seeds", "2", "--cache", cache, "--out", out)
    assert res.returncode == 0, res.stdout + res.stderr
    assert len(ResultStore(out).parts()) == 1
    return out


def _rows(out: Path) -> list[tuple]:
    df = ResultStore(out).read(list(RUN_ID))
    return sorted(tuple(r) for r in df.itertuples(index=False, name=None))


@pytest.mark.parametrize("point", ["merge:before", "merge:written", "merge:partial", "merge:after"])
def test_a_campaign_killed_before_during_or_after_its_merge_keeps_one_row_per_run(half_done, cache, tmp_path, point):
    out = shutil.copytree(half_done, tmp_path / "res")
    args = [*CAMPAIGN, "--seeds", "4", "--cache", cache, "--out", out]
    kill_at(point, args, tmp_path)
    rows = _rows(out)
    assert len(rows) == 4 and len(set(rows)) == 4, rows  # every run once, whatever the moment
    res = fcgen("report", out, "-o", tmp_path / "rep", "--no-example")
    assert res.returncode == 0, res.stderr
    assert "4 seeds x 5 samples (4 runs)" in (tmp_path / "rep" / "README.md").read_text()
    res = fcgen(*args)  # the resume repairs / finishes the merge
    assert res.returncode == 0, res.stderr
    assert "0 runs computed, 4 already done" in res.stdout
    files = sorted(out.glob("*.parquet"))
    assert len(files) == 1 and pq.read_table(files[0]).num_rows == 4


def test_report_refuses_duplicate_runs_and_a_resume_merges_them(half_done, cache, tmp_path):
    out = shutil.copytree(half_done, tmp_path / "res")
    part = next(out.glob("*.parquet"))
    shutil.copy(part, out / "part-copied-by-hand.parquet")  # the same two runs again
    res = fcgen("report", out, "-o", tmp_path / "rep", "--no-example")
    assert res.returncode == 1 and "2 run(s) more than once" in res.stderr
    assert "truck/lifted/EL/c/osqp seed 0 (5 samples, cpu)" in res.stderr and res.stderr.count("\n") == 1
    res = fcgen(*CAMPAIGN, "--seeds", "2", "--cache", cache, "--out", out)
    assert res.returncode == 0 and "0 runs computed, 2 already done" in res.stdout
    assert len(_rows(out)) == 2 and len(list(out.glob("*.parquet"))) == 1
    assert fcgen("report", out, "-o", tmp_path / "rep", "--no-example").returncode == 0


def test_a_truncated_part_is_named(half_done, cache, tmp_path):
    out = shutil.copytree(half_done, tmp_path / "res")
    part = next(out.glob("*.parquet"))
    part.write_bytes(part.read_bytes()[:-100])
    for args in (
        [*CAMPAIGN, "--seeds", "2", "--cache", cache, "--out", out],
        ["report", out, "-o", tmp_path / "rep", "--no-example"],
    ):
        res = fcgen(*args)
        assert res.returncode == 1 and f"{part}: not a readable Parquet file" in res.stderr, res.stderr


def test_campaign_fails_on_its_paths_before_computing(tmp_path, cache):
    (tmp_path / "f").write_text("x")
    for opt in ("--out", "--cache", "--report"):
        paths = {"--out": tmp_path / "res", "--cache": cache, "--report": tmp_path / "rep"}
        paths[opt] = tmp_path / "f" / "sub"
        args = [*CAMPAIGN, "--seeds", "1"] + [x for k, v in paths.items() for x in (k, v)]
        res = fcgen(*args)
        assert res.returncode == 1 and f"{tmp_path / 'f'} is a file" in res.stderr, res.stderr
        assert "runs computed" not in res.stdout and not (tmp_path / "res").exists()


def test_report_refuses_an_existing_report_without_force_and_keeps_other_files(half_done, tmp_path):
    rep = tmp_path / "rep"
    assert fcgen("report", half_done, "-o", rep, "--no-example").returncode == 0
    (rep / "RUN.md").write_text("hand-written")
    page = (rep / "README.md").read_bytes()
    res = fcgen("report", half_done, "-o", rep, "--no-example")
    assert res.returncode == 1 and "README.md" in res.stderr and "--force" in res.stderr
    res = fcgen("report", half_done, "-o", rep, "--no-example", "--force")
    assert res.returncode == 0, res.stderr
    assert (rep / "RUN.md").read_text() == "hand-written" and (rep / "README.md").read_bytes() == page


# ----------------------------------------------------------------------------- 4: workers die with their parent


def _children(pid: int) -> list[int]:
    """The live descendants of ``pid`` (from /proc; zombies count as gone)."""
    kids: dict[int, list[int]] = {}
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                stat = (d / "stat").read_text()
            except OSError:
                continue
            fields = stat[stat.rindex(")") + 2 :].split()
            if fields[0] != "Z":
                kids.setdefault(int(fields[1]), []).append(int(d.name))
    out, todo = [], [pid]
    while todo:
        for c in kids.get(todo.pop(), []):
            out.append(c)
            todo.append(c)
    return out


def _alive(pid: int) -> bool:
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat[stat.rindex(")") + 2] != "Z"


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
@pytest.mark.parametrize("scheduler", [None, "local"])
def test_a_sigkilled_campaign_leaves_no_worker(cache, tmp_path, scheduler):
    args = [
        *CAMPAIGN[:-2],
        "--samples",
        "400",
        "--seeds",
        "40",
        "--jobs",
        "2",
        "--cache",
        cache,
        "--out",
        tmp_path / "res",
    ] + (["--scheduler", scheduler] if scheduler else [])
    proc = subprocess.Popen(
        [FCGEN, *map(str, args)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True
    )
    try:
        deadline = time.monotonic() + 120
        workers: list[int] = []
        while time.monotonic() < deadline and proc.poll() is None:
            workers = [
                p
                for p in _children(proc.pid)
                if "fcgen" in Path(f"/proc/{p}/cmdline").read_bytes().decode(errors="replace")
                or b"multiprocessing" in Path(f"/proc/{p}/cmdline").read_bytes()
            ]
            if len(workers) >= 2 and _busy(workers):
                break
            time.sleep(0.2)
        assert proc.poll() is None and len(workers) >= 2, workers
        everyone = _children(proc.pid)
        os.kill(proc.pid, signal.SIGKILL)  # the parent only, not its group
        proc.wait()
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline and any(_alive(p) for p in everyone):
            time.sleep(0.1)
        assert not [p for p in everyone if _alive(p)], "orphaned: " + ", ".join(
            Path(f"/proc/{p}/cmdline").read_bytes().decode(errors="replace") for p in everyone if _alive(p)
        )
    finally:
        with __import__("contextlib").suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()


def _busy(pids: list[int]) -> bool:
    """At least two of ``pids`` have used CPU time (the workers are running runs, not starting)."""
    used = 0
    for p in pids:
        try:
            stat = Path(f"/proc/{p}/stat").read_text()
        except OSError:
            continue
        f = stat[stat.rindex(")") + 2 :].split()
        used += int(f[11]) + int(f[12]) > 150  # utime + stime > 1.5 s of CPU (imports done, running)
    return used >= 2


# ----------------------------------------------------------------------------- 5: regress trusts no hand edit

GOLDEN = SOLVER / "golden"


def _edited(tmp_path: Path, edit) -> Path:
    import json

    g = shutil.copytree(GOLDEN, tmp_path / "edited")
    man = json.loads((g / "manifest.json").read_text())
    edit(man)
    (g / "manifest.json").write_text(json.dumps(man, indent=1, sort_keys=True) + "\n")
    return g


def _regress(*args):
    from click.testing import CliRunner

    from fcgen.cli import main

    return CliRunner().invoke(main, ["regress", *map(str, args)])


@pytest.mark.parametrize(
    "field, edit",
    [
        ("precision", lambda m: m.update(precision="float")),  # would switch to the float-vs-double tolerances
        ("problem.sizes.NU", lambda m: m["problem"]["sizes"].update(NU=3)),
        ("problem.sizes.NOPP", lambda m: m["problem"]["sizes"].update(NOPP=2)),
        ("problem.formulation", lambda m: m["problem"].update(formulation="conventional")),
        ("solver", lambda m: m.update(solver="other")),
        ("settings.seeds", lambda m: m["settings"].update(seeds=[0, 1, 2])),
        ("settings.samples", lambda m: m["settings"].update(samples=100)),
    ],
)
def test_regress_refuses_a_manifest_that_disagrees_with_its_logs(tmp_path, field, edit):
    g = _edited(tmp_path, edit)
    for new, golden in ((g, GOLDEN), (GOLDEN, g), (SOLVER, g)):
        res = _regress(new, golden)
        assert res.exit_code == 2, res.output
        assert res.stderr.count("\n") == 1 and f"field {field} is" in res.stderr, res.stderr


def test_regress_notes_another_problem_source_or_qp_size(tmp_path):
    """What may legitimately change between the golden's solver and NEW (the problem.py, the QP's sizes with a newer
    generator) cannot be derived from the logs: it is compared with the solver folder / other suite and noted."""

    def edit(m):
        m["problem"]["problem_py_sha256"] = "0" * 64
        m["problem"]["sizes"]["QP_M"] = 900

    g = _edited(tmp_path, edit)
    for new in (SOLVER, GOLDEN):
        res = _regress(new, g)
        assert res.exit_code == 0, res.output
        assert "problem.py differs from the one the golden suite was recorded with" in res.output
        assert "QP_M 928 vs 900" in res.output


# ----------------------------------------------------------------------------- 6: ways out and paths checked first


def test_generate_timeout_stops_a_problem_file_that_never_returns(tmp_path):
    hang = tmp_path / "hang.py"
    hang.write_text("while True:\n    pass\n")
    out = tmp_path / "solver"
    t0 = time.monotonic()
    res = fcgen("generate", hang, "-o", out, "--timeout", "2")
    assert res.returncode == 1 and "longer than --timeout 2 s" in res.stderr and res.stderr.count("\n") == 1
    assert time.monotonic() - t0 < 30 and not out.exists() and list(tmp_path.iterdir()) == [hang]
    res = fcgen("generate", hang, "-o", tmp_path / "hang.py" / "sub", "--timeout", "2")  # the path first
    assert res.returncode == 1 and "is a file" in res.stderr


def test_bench_refuses_to_replace_its_results_file_before_computing(tmp_path):
    solver = shutil.copytree(SOLVER, tmp_path / "s", ignore=shutil.ignore_patterns("build", "golden", "lib"))
    out = tmp_path / "b.json"
    args = ["bench", solver, "--seeds", "1", "--samples", "3", "--no-python", "--out", out]
    assert fcgen(*args).returncode == 0
    first = out.read_bytes()
    t0 = time.monotonic()
    res = fcgen(*args)
    assert res.returncode == 1 and f"--out {out}: exists" in res.stderr and "--force" in res.stderr
    assert out.read_bytes() == first and time.monotonic() - t0 < 20
    assert fcgen(*args, "--force").returncode == 0 and out.read_bytes() != first  # new timings
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".b.json")]  # no temporary left


def test_generate_refuses_to_replace_a_hand_edited_file_of_the_same_solver(tmp_path):
    out = tmp_path / "s"
    assert fcgen("generate", "truck_lifted_ellipse", "-o", out).returncode == 0
    assert fcgen("generate", "truck_lifted_ellipse", "-o", out).returncode == 0  # unchanged: regenerated
    main_c = out / "main.c"
    main_c.write_text(main_c.read_text() + "/* my change */\n")
    res = fcgen("generate", "truck_lifted_ellipse", "-o", out)
    assert res.returncode == 1 and "main.c changed since fcgen generated it" in res.stderr and "--force" in res.stderr
    assert main_c.read_text().endswith("/* my change */\n")
    assert fcgen("generate", "truck_lifted_ellipse", "-o", out, "--force").returncode == 0
    assert "my change" not in main_c.read_text()


def test_generate_and_report_killed_before_their_swap_leave_the_old_folder(half_done, tmp_path):
    """The new folder is complete beside the old one when the kill comes: the old one is intact, byte for byte."""
    out = tmp_path / "s"
    assert fcgen("generate", "truck_lifted_ellipse", "-o", out).returncode == 0
    before = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    # the float build of the same problem: every file would change
    kill_at("generate:before-swap", ["generate", "truck_lifted_ellipse", "-o", out, "--float"], tmp_path)
    assert {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()} == before
    rep = tmp_path / "rep"
    assert fcgen("report", half_done, "-o", rep, "--no-example").returncode == 0
    page = (rep / "README.md").read_bytes()
    (rep / "README.md").write_bytes(page + b"old")
    kill_at("report:before-swap", ["report", half_done, "-o", rep, "--no-example", "--force"], tmp_path)
    assert (rep / "README.md").read_bytes() == page + b"old"
