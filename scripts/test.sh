#!/usr/bin/env bash
# The test command: installs missing packages, builds, runs the whole test suite (ctest).
# Exits non-zero on any failure.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/scripts/setup.sh"
"$root/scripts/build.sh"
build="${NSIM_BUILD_DIR:-$root/build}"
# one core per test process; the physics benchmarks and rates are measured on one core too
export OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 OMP_THREAD_LIMIT=1
ctest --test-dir "$build" --output-on-failure -j "${NSIM_TEST_JOBS:-2}" "$@"
