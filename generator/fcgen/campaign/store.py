"""Campaign results: a Parquet dataset folder of part files, one row per finished run.

Parts are written atomically (a ``.tmp`` file renamed to ``part-*.parquet``), so an interrupted campaign leaves only
whole parts behind; the runs already in the folder are skipped when the campaign is started again. ``compact``
merges the parts of a finished campaign into one file.

The merge is idempotent whatever moment it is killed at: the merged file names, in its Parquet metadata
(``fcgen.merged_parts``), the parts it replaces. It appears in one rename; from then on those parts are ignored by
every read and removed by ``repair`` (run when a campaign starts or resumes, and by ``compact``), so the folder always
holds one row per run. ``read_results`` refuses a dataset with duplicate runs (e.g. parts copied in by hand),
naming them.
"""

from __future__ import annotations

import json
import os
import time
import uuid
from pathlib import Path

from ..extras import require
from ..testhook import pause_point

with require("campaign", "the campaign's result store"):
    import pandas as pd
    import pyarrow as pa
    import pyarrow.parquet as pq

PART_GLOB = "part-*.parquet"
#: the merged file of a finished campaign: zstd is 25 % smaller than the parts' snappy (per-RTI times of 12,000 runs
#: 15 MB instead of 20 MB), at a compression cost paid once
COMPACT_COMPRESSION = "zstd"
#: the Parquet metadata key of a merged file: the JSON list of the part names it replaces
MERGED_KEY = b"fcgen.merged_parts"
#: the columns that identify a run (``Task.run_id``)
RUN_ID = ("config", "samples", "seed", "clock")
#: the columns ``fcgen report`` needs (``campaign.task.make_row`` writes them and more)
REQUIRED_COLUMNS = (
    "config",
    "scenario",
    "formulation",
    "obstacles",
    "circles",
    "model",
    "seed",
    "samples",
    "progress",
    "collision",
    "n_collision_samples",
    "time_rti_ms",
    "time_total_ms_mean",
    "time_prepare_ms_mean",
    "time_feedback_ms_mean",
    "qp_iter_mean",
    "qp_n",
    "qp_m",
    "qp_nnz_a",
    "n_opp_par",
    "n_controls",
    "n_states",
    "max_slack",
    "a_lat_bound",
    "a_lat_over_samples",
    "a_lat_excess_max",
    "a_lat_excess_mean",
    "wall_s",
    "cpu_s",
    "t_start",
    "t_end",
    "worker",
    "solver_hash",
    "clock",
    "controller",
    "backend",
)


class ResultStore:
    """The results folder of one campaign."""

    def __init__(self, folder: str | Path):
        self.folder = Path(folder)
        if self.folder.exists() and not self.folder.is_dir():
            raise ValueError(f"results = {str(self.folder)!r} is invalid: allowed a folder (a Parquet dataset)")

    def _files(self) -> list[Path]:
        return sorted(self.folder.glob(PART_GLOB)) if self.folder.is_dir() else []

    @staticmethod
    def _superseded(files: list[Path]) -> set[str]:
        """Names of parts that a merged file in ``files`` replaces (left behind by a merge killed part-way)."""
        gone: set[str] = set()
        for p in files:
            meta = _open(p).schema_arrow.metadata or {}
            if MERGED_KEY in meta:
                gone.update(json.loads(meta[MERGED_KEY]))
        return gone

    def parts(self) -> list[Path]:
        """The part files whose rows count (parts already merged into another file are left out)."""
        files = self._files()
        gone = self._superseded(files)
        return [p for p in files if p.name not in gone]

    def repair(self) -> list[Path]:
        """Finish a merge that was killed part-way: remove the parts a merged file replaces; returns them."""
        files = self._files()
        gone = self._superseded(files)
        removed = [p for p in files if p.name in gone]
        for p in removed:
            p.unlink(missing_ok=True)
        return removed

    def write(self, rows: list[dict]) -> Path | None:
        """Append ``rows`` as one new part file (atomic); returns its path."""
        if not rows:
            return None
        return self._write_table(pa.Table.from_pylist(rows))

    def _write_table(self, table: pa.Table, compression: str = "snappy") -> Path:
        self.folder.mkdir(parents=True, exist_ok=True)
        name = f"part-{time.strftime('%Y%m%dT%H%M%S')}-{uuid.uuid4().hex[:8]}"
        tmp, final = self.folder / f".{name}.tmp", self.folder / f"{name}.parquet"
        try:
            pq.write_table(table, tmp, compression=compression)
            os.replace(tmp, final)
        except OSError as exc:
            tmp.unlink(missing_ok=True)
            raise OSError(f"{final}: cannot write the results part ({exc})") from None
        return final

    def table(self, columns: list[str] | None = None) -> pa.Table | None:
        """Every row of every part as one Arrow table (None when there is none). Each part is read by
        ``ParquetFile`` (no dataset discovery per file: ~0.5 ms a part instead of ~2.5 ms with ``pd.read_parquet``,
        which matters with the hundreds of parts of a long campaign)."""
        parts = self.parts()
        if not parts:
            return None
        return pa.concat_tables([_read(p, columns) for p in parts], promote_options="permissive")

    def read(self, columns: list[str] | None = None) -> pd.DataFrame:
        """Every row of every part (an empty frame when there is none)."""
        tab = self.table(columns)
        return pd.DataFrame(columns=columns or []) if tab is None else tab.to_pandas()

    def done(self) -> set[tuple[str, int, int, str]]:
        """The run ids (config key, samples, seed, clock) already in the folder."""
        df = self.read(list(RUN_ID))
        return {(c, int(n), int(s), k) for c, n, s, k in zip(*(df[c] for c in RUN_ID))}

    def needs_compact(self) -> bool:
        """More than one part, or a run twice in the folder."""
        parts = self.parts()
        return len(parts) > 1 or bool(parts and duplicate_runs(self.read(list(RUN_ID))))

    def compact(self) -> Path | None:
        """Merge all parts into one (duplicate runs keep their first row); returns the merged file. Idempotent and
        safe to kill at any moment (see the module docstring)."""
        self.repair()
        parts = self.parts()
        if not parts or not self.needs_compact():
            return parts[0] if parts else None
        tab = self.table()
        assert tab is not None  # parts exist
        df = tab.to_pandas().drop_duplicates(list(RUN_ID), keep="first")
        df = df.sort_values(list(RUN_ID), kind="stable").reset_index(drop=True)
        pause_point("merge:before")
        merged = pa.Table.from_pandas(df, schema=tab.schema, preserve_index=False).replace_schema_metadata(
            {MERGED_KEY: json.dumps([p.name for p in parts]).encode()}
        )  # the parts' schema (types as written)
        merged = self._write_table(merged, compression=COMPACT_COMPRESSION)
        pause_point("merge:written")
        for i, p in enumerate(parts):
            p.unlink()
            if i == 0:
                pause_point("merge:partial")
        pause_point("merge:after")
        return merged


def _unreadable(path: Path, exc: BaseException) -> OSError:
    return OSError(
        f"{path}: not a readable Parquet file ({str(exc).splitlines()[0]}); move it out of the results "
        f"folder (its runs are then computed again)"
    )


def _open(path: Path) -> pq.ParquetFile:
    """A Parquet file; OSError naming it when it is damaged (a truncated part, another file)."""
    try:
        return pq.ParquetFile(path)
    except (pa.ArrowException, OSError) as exc:
        raise _unreadable(path, exc) from None


def _read(path: Path, columns: list[str] | None) -> pa.Table:
    pf = _open(path)
    try:
        return pf.read(columns=columns)
    except (pa.ArrowException, OSError) as exc:
        raise _unreadable(path, exc) from None


def duplicate_runs(df: pd.DataFrame) -> list[tuple]:
    """The run ids (config, samples, seed, clock) that occur more than once in ``df``."""
    if df.empty or any(c not in df.columns for c in RUN_ID):
        return []
    dup = df[df.duplicated(list(RUN_ID), keep=False)]
    return sorted({tuple(r) for r in dup[list(RUN_ID)].itertuples(index=False, name=None)})


def read_results(path: str | Path) -> pd.DataFrame:
    """A results folder (the dataset) or one Parquet file, as a frame; clear error when it is neither."""
    path = Path(path)
    if path.is_dir():
        df = ResultStore(path).read()
    elif path.is_file() and path.suffix == ".parquet":
        df = _read(path, None).to_pandas()
    else:
        raise FileNotFoundError(
            f"results = {str(path)!r} is invalid: allowed a campaign results folder or a .parquet file"
        )
    if df.empty:
        raise ValueError(f"results = {str(path)!r} holds no runs")
    missing = [c for c in REQUIRED_COLUMNS if c not in df.columns]
    if missing:
        raise ValueError(
            f"results = {str(path)!r} lacks the column(s) {', '.join(missing)}: not written by this "
            f"fcgen's campaign (run it again into a new folder)"
        )
    dup = duplicate_runs(df)
    if dup:
        shown = "; ".join(f"{c} seed {s} ({n} samples, {k})" for c, n, s, k in dup[:3])
        raise ValueError(
            f"results = {str(path)!r} holds {len(dup)} run(s) more than once ({shown}"
            f"{'; ...' if len(dup) > 3 else ''}): parts copied in twice? `fcgen campaign` with the same "
            f"--out merges them (one row per run)"
        )
    return df
