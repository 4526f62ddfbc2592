#!/usr/bin/env bash
# Set up (scripts/setup.sh), run the static checks (scripts/check.sh), check that generated/ regenerates byte for byte,
# then run the test suite on 2 workers. Usage: bash scripts/test.sh [extra pytest arguments]
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
bash scripts/check.sh
.venv/bin/fcgen regenerate --check generated
.venv/bin/python -m pytest -q -n 2 "$@"
