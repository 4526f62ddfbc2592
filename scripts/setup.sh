#!/usr/bin/env bash
# Set up fcgen from a fresh clone: system tools (apt-get, only if missing), a venv in .venv, the package + test extras.
# Idempotent: a second run only re-installs the package (fast); two at once run one after the other.
# Usage: bash scripts/setup.sh
set -euo pipefail
cd "$(dirname "$0")/.."

# apt_install waits for another install's lock (FCGEN_APT_WAIT s); setup_lock: a second set-up of this clone waits
source scripts/setup_lib.sh
setup_lock

need=()
command -v cc >/dev/null 2>&1 || need+=(gcc libc6-dev)
command -v make >/dev/null 2>&1 || need+=(make)
command -v python3 >/dev/null 2>&1 || need+=(python3 python3-venv python3-pip)
# the Cortex-M targets (fcgen build/firmware-sim/bench/footprint --target), the toolchain-file test, static analysis
command -v arm-none-eabi-gcc >/dev/null 2>&1 || need+=(gcc-arm-none-eabi)
if ! command -v arm-none-eabi-gcc >/dev/null 2>&1 \
   || [ "$(arm-none-eabi-gcc -print-file-name=rdimon.specs)" = "rdimon.specs" ]; then
  need+=(libnewlib-arm-none-eabi)
fi
command -v qemu-system-arm >/dev/null 2>&1 || need+=(qemu-system-arm)
command -v cppcheck >/dev/null 2>&1 || need+=(cppcheck)
command -v cmake >/dev/null 2>&1 || need+=(cmake)
# the contract fuzzer: clang's float-cast-overflow sanitizer and libFuzzer (tests/fuzzbuild.py falls back to gcc)
command -v clang >/dev/null 2>&1 || need+=(clang)
if [ "${#need[@]}" -gt 0 ]; then apt_install "${need[@]}"; fi

python3 - <<'PY' || { echo "setup: fcgen needs Python >= 3.11" >&2; exit 1; }
import sys; sys.exit(0 if sys.version_info >= (3, 11) else 1)
PY

if [ ! -x .venv/bin/python ]; then
  python3 -m venv .venv 2>/dev/null || { apt_install python3-venv && python3 -m venv .venv; }
fi
.venv/bin/python -m pip install -q --upgrade pip
.venv/bin/python -m pip install -q -e '.[test]'
# commonroad-crime, the criticality measures of CommonRoad runs (docs/commonroad.md): its releases need commonroad-clcs,
# which pins osqp~=0.6.5 against fcgen's osqp==1.1.3, so pip cannot resolve it beside fcgen and it is no extra; these
# are installed without their declared dependencies (they import and run with fcgen's), then what they import
.venv/bin/python -m pip install -q --no-deps commonroad-crime==0.4.5 commonroad-clcs==2025.2.0 \
  commonroad-reach==2025.2.1 commonroad-route-planner==2025.1.0
.venv/bin/python -m pip install -q imageio==2.38.2 Cython==3.3.1 opencv-python-headless==5.1.0.95 seaborn==0.13.2
echo "setup: ready ($(.venv/bin/fcgen --version))" >&2
