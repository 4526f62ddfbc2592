#!/usr/bin/env bash
# The main job from a fresh clone: set up, generate the paper's default solver (truck, lifted ODE, ellipse), build it,
# run it in closed loop in the C firmware harness, run the Python reference on the same scenario, compare, summarize.
# Usage: bash scripts/main.sh [fcgen demo options, e.g. --seed 5 --samples 200]
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
.venv/bin/fcgen demo "$@"
