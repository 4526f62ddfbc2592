#!/usr/bin/env bash
# The static checks CI runs (scripts/test.sh calls this before pytest): lint, formatting, types, the hand-written C's
# style, the layers. Exit 1 on the first finding. Tools from .venv (pinned in the [test] extra).
# Usage: bash scripts/check.sh
set -euo pipefail
cd "$(dirname "$0")/.."
bin=.venv/bin
"$bin/ruff" check
"$bin/ruff" format --check
"$bin/mypy"
# the hand-written C: csrc/, firmware_sim/, benchmarks/ and the tests' C (not generated/ nor the templates)
git ls-files -- 'csrc/*.[ch]' 'firmware_sim/*.[ch]' 'benchmarks/*.[ch]' 'tests/*.[ch]' \
  | xargs "$bin/clang-format" --dry-run -Werror
"$bin/lint-imports"
echo "check: ruff, ruff format, mypy, clang-format, lint-imports clean" >&2
