#!/usr/bin/env bash
# scripts/bench.sh --baseline on two build directories whose bench/ binary is canned_bench.sh
# (Google Benchmark's command line, fixed times): each benchmark runs one repetition at a time in
# the two builds, current first in odd repetitions and baseline first in even ones
# (interleaved), a benchmark the baseline lacks runs only in the current build (and does not end
# the script), and the table puts each figure beside its baseline. Usage: bench_sh_test.sh
# SOURCE_DIR
set -euo pipefail
source_dir="$1"
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
fail=0
check() { if ! eval "$1"; then echo "FAILED: $2"; fail=1; fi; }

# make_canned_build <dir> <ms> <benchmark name> [<benchmark name> ...]: a build directory whose
# bench/canned_bench lists the names and reports <ms> milliseconds for each
make_canned_build() {
  local dir="$1" ms="$2"
  shift 2
  mkdir -p "$dir/bench" "$dir/meshes"
  : >"$dir/meshes/liver_30000.msh"  # present: bench.sh does not call gmsh
  cp "$here/canned_bench.sh" "$dir/bench/canned_bench"
  printf '%s\n' "$@" >"$dir/bench/canned_bench.names"
  echo "$ms" >"$dir/bench/canned_bench.ms"
}

make_canned_build "$tmp/current" 10 Solve/2660 LiverStep/2660 NewOnly/2660
make_canned_build "$tmp/baseline" 20 Solve/2660 LiverStep/2660
rc=0
NSIM_BUILD_DIR="$tmp/current" "$source_dir/scripts/bench.sh" --no-build --reps 2 --cpu 0 \
  --two-cores none --baseline "$tmp/baseline" --out "$tmp/out" 2>"$tmp/log" || rc=$?
check '[ "$rc" = 0 ]' "bench.sh exits 0 (got $rc; log: $(tail -3 "$tmp/log"))"
# the runs in order, as "<label> <benchmark>" from bench.sh's "== <label>: <binary> (^<name>$)"
order="$(sed -n 's|^== \([a-z]*\): canned_bench (^\([A-Za-z]*\)/.*|\1 \2|p' "$tmp/log" |
  paste -sd, -)"
expected="current Solve,baseline Solve,baseline Solve,current Solve"
expected+=",current LiverStep,baseline LiverStep,baseline LiverStep,current LiverStep"
expected+=",current NewOnly,current NewOnly"
check '[ "$order" = "$expected" ]' "interleaved order (got $order)"
raw="$(ls "$tmp/out/raw" 2>/dev/null | paste -sd' ' -)"
check '[ "$(wc -w <<<"$raw")" = 10 ]' "one raw file per benchmark, build and repetition (got $raw)"
table="$(cat "$tmp/out/bench.md" 2>/dev/null || true)"
liver_row="$(grep -F '| `LiverStep/2660` |' <<<"$table" || true)"
new_row="$(grep -F '| `NewOnly/2660` |' <<<"$table" || true)"
# columns: benchmark, binary, median, ..., baseline median, baseline p99, median / baseline
check 'grep -qF "| canned_bench | 10 ms |" <<<"$liver_row" && grep -qF "| 20 ms | – | 0.5x |" <<<"$liver_row"' \
  "LiverStep/2660 beside its baseline (got $liver_row)"
check 'grep -qF "| canned_bench | 10 ms |" <<<"$new_row" && grep -qE "\| – \| – \| – \| – \|$" <<<"$new_row"' \
  "NewOnly/2660 without a baseline (got $new_row)"
echo "bench_sh_test: $([ "$fail" = 0 ] && echo ok || echo failed)"
exit "$fail"
