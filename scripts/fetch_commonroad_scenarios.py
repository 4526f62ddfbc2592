#!/usr/bin/env python3
"""Download the public CommonRoad scenarios of a checked-in list into a cache folder, each kept only when its SHA-256
(or, where the list has none, its git blob id) is the list's (docs/commonroad.md, "At scale").

    python scripts/fetch_commonroad_scenarios.py                       # GitHub raw at the list's pinned commit
    python scripts/fetch_commonroad_scenarios.py --source /path/to/commonroad-search   # a clone or bare mirror
    python scripts/fetch_commonroad_scenarios.py --source /a/folder/of/xml/files

Then: ``fcgen campaign --commonroad CACHE --scenario-list LIST ...``. Exit 1 when a file was not fetched or had
another hash (each named on one line).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from fcgen.commonroad.catalog import fetch, read_list

ROOT = Path(__file__).resolve().parent.parent


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--list", default=str(ROOT / "docs/commonroad/commonroad_search_scenarios.csv"))
    ap.add_argument("--cache", default=str(Path.home() / ".cache/fcgen/commonroad"), help="the folder to fill")
    ap.add_argument(
        "--source",
        default="github",
        help="github (raw files at the pinned commit), a git clone or mirror of the source repository, or a folder",
    )
    ap.add_argument("--dataset", action="append", help="only this data set (USA_US101, DEU_Muc, ...); repeatable")
    a = ap.parse_args(argv)
    rows = read_list(a.list)
    if a.dataset:
        rows = [r for r in rows if r.dataset in set(a.dataset)]
    counts = fetch(rows, a.cache, a.source)
    print(
        f"{len(rows)} listed: {counts['fetched']} fetched, {counts['cached']} already in {a.cache}, "
        f"{counts['mismatch']} with another hash, {counts['failed']} not fetched"
    )
    return 1 if counts["mismatch"] or counts["failed"] else 0


if __name__ == "__main__":
    sys.exit(main())
