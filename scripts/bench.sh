#!/usr/bin/env bash
# Builds the benchmarks (Release) and runs every benchmark binary single-threaded on one core,
# with repetitions; writes results/bench_<date>/bench.json (the runs' Google Benchmark JSON
# merged) and bench.md (a table: median, p99 where a benchmark reports a step distribution, and
# the ratios to the baselines of the same run: one solve with the double factor (Solve/<size>,
# the floor of any step) and refactorize-every-step (LiverStepRefactorEveryStep/<size>, the naive step); with
# --baseline DIR also the same benchmarks from another build and the ratio to them).
#
#   scripts/bench.sh [--reps N] [--filter REGEX] [--baseline BUILD_DIR] [--cpu C]
#                    [--two-cores LIST|none] [--out DIR] [--no-build] [--readme]
#
#   --reps N          repetitions of each benchmark (default 5); aggregates: median (and mean,
#                     stddev, cv) over the repetitions
#   --filter REGEX    only benchmarks matching REGEX (Google Benchmark --benchmark_filter);
#                     the floor and naive baselines are always run for the sizes selected
#   --baseline DIR    a second build directory (e.g. of the previous release): its bench/
#                     binaries run the same benchmarks, in the same session, as another column;
#                     each benchmark runs one repetition at a time, alternately in the two
#                     builds and in alternating order (current first in odd repetitions), so
#                     that a machine's drift over the run, and the order, cancel in the ratio
#   --cpu C           the core everything runs on (taskset -c C; default 1)
#   --two-cores LIST  also run the step-sequence benchmarks (*Sequence*) on these cores (default
#                     0,1): the background factor refresh needs a second core to be off the
#                     critical path; "none" skips this pass
#   --out DIR         output directory (default results/bench_<date>)
#   --no-build        use the binaries as they are
#   --readme          also write the goals table (the speed goals beside this run's figures)
#                     into README.md, between its bench:goals markers
# Environment: NSIM_BUILD_DIR (default build-bench/), NSIM_JOBS (build jobs, default 2).
# The 30000-node liver (scaling) is generated into <build>/meshes on the first run (gmsh).
# The machine should be quiet: the numbers are wall times.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${NSIM_BUILD_DIR:-$root/build-bench}"
reps=5
filter=""
baseline=""
cpu=1
two_cores="0,1"
out=""
do_build=1
readme=""
while [ $# -gt 0 ]; do
  case "$1" in
    --reps) reps="$2"; shift 2 ;;
    --filter) filter="$2"; shift 2 ;;
    --baseline) baseline="$(cd "$2" && pwd)"; shift 2 ;;
    --cpu) cpu="$2"; shift 2 ;;
    --two-cores) two_cores="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --no-build) do_build=0; shift ;;
    --readme) readme="$root/README.md"; shift ;;
    -h|--help) awk 'NR > 1 && !/^#/ { exit } NR > 1 { sub(/^# ?/, ""); print }' "$0"; exit 0 ;;
    *) echo "bench.sh: unknown argument $1 (see --help)" >&2; exit 2 ;;
  esac
done
python=/usr/bin/python3
[ -x "$python" ] || python="$(command -v python3)"

if [ "$do_build" = 1 ]; then
  launcher=()
  command -v ccache >/dev/null &&
    launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
  generator=()
  command -v ninja >/dev/null && generator=(-G Ninja)
  if [ ! -f "$build/CMakeCache.txt" ]; then
    cmake -S "$root" -B "$build" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release \
      -DNSIM_BUILD_BENCHMARKS=ON "${launcher[@]}"
  fi
  targets=()
  for f in "$root"/tests/bench/*_bench.cpp; do targets+=("$(basename "$f" .cpp)"); done
  cmake --build "$build" -j "${NSIM_JOBS:-2}" --target "${targets[@]}"
fi
[ -d "$build/bench" ] || { echo "bench.sh: no $build/bench (build first)" >&2; exit 1; }

out="${out:-$root/results/bench_$(date +%Y%m%d-%H%M%S)}"
mkdir -p "$out/raw"
export OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 OMP_THREAD_LIMIT=1

# the ~30000-node liver of the scaling benchmarks (fem_bench */30000) is generated, not
# committed: once per build directory, by gmsh (about 15 s)
large_dir="$build/meshes"
if [ ! -f "$large_dir/liver_30000.msh" ]; then
  if command -v gmsh >/dev/null; then
    "$root/scripts/make_meshes.sh" --large "$large_dir" >&2 ||
      echo "bench.sh: could not make the 30000-node mesh; its benchmarks are skipped" >&2
  else
    echo "bench.sh: no gmsh; the 30000-node benchmarks are skipped" >&2
  fi
fi
export NSIM_LARGE_MESH_DIR="$large_dir"

# the floor and the naive step of the 2660-node liver (the size of the scene benchmarks) are
# always measured with the rest
always='Solve/2660$|LiverStepRefactorEveryStep/2660$'
selection="${filter:+($filter)|$always}"

# the benchmarks of <binary> in the selection <filter>, one a line ([sequences-only]: only the
# step sequences)
list_tests() {
  local bin="$1" sel="$2" only_sequences="${3:-}" names
  names="$("$bin" --benchmark_list_tests=true ${sel:+"--benchmark_filter=$sel"} 2>/dev/null ||
    true)"
  [ -n "$only_sequences" ] && names="$(grep Sequence <<<"$names" || true)"
  printf '%s' "$names"
}

# run_binary <label> <binary> <cpus> <filter> <output stem> [repetitions]: one invocation,
# reps repetitions unless given
run_binary() {
  local label="$1" bin="$2" cpus="$3" sel="$4" stem="$5" n="${6:-$reps}"
  local args=(--benchmark_repetitions="$n" --benchmark_report_aggregates_only=true
              --benchmark_out="$out/raw/${label}__${stem}.json" --benchmark_out_format=json)
  [ -n "$sel" ] && args+=(--benchmark_filter="$sel")
  echo "== $label: $(basename "$bin") ${sel:+($sel) }on cpu $cpus" >&2
  taskset -c "$cpus" "$bin" "${args[@]}" >&2 || echo "bench.sh: $bin failed (exit $?)" >&2
}

# run <label> <build_dir> <cpus> <filter> [sequences-only]: every binary of <build_dir>/bench
run() {
  local label="$1" dir="$2" cpus="$3" sel="$4" only_sequences="${5:-}" bin names bin_sel
  for bin in "$dir"/bench/*_bench; do
    [ -x "$bin" ] || continue
    names="$(list_tests "$bin" "$sel" "$only_sequences")"
    [ -n "$names" ] || continue
    bin_sel="$sel"
    [ -n "$only_sequences" ] && bin_sel="^($(paste -sd'|' <<<"$names"))\$"
    run_binary "$label" "$bin" "$cpus" "$bin_sel" "$(basename "$bin")"
  done
}

# run_interleaved <suffix> <cpus> <filter> [sequences-only]: each benchmark one repetition at a
# time, alternately in the current and the baseline build, and in alternating order (current
# first in odd repetitions, baseline first in even ones), so that the two columns are measured
# seconds apart and neither always runs first (a machine whose speed drifts over the run drifts
# both alike; a benchmark that runs right after another pays, or gains from, its state alike)
run_interleaved() {
  local suffix="$1" cpus="$2" sel="$3" only_sequences="${4:-}" bin name test base_names i
  for bin in "$build"/bench/*_bench; do
    [ -x "$bin" ] || continue
    name="$(basename "$bin")"
    base_names=""
    if [ -x "$baseline/bench/$name" ]; then
      base_names="$(list_tests "$baseline/bench/$name" "$sel" "$only_sequences")"
    fi
    i=0
    while IFS= read -r test; do
      [ -n "$test" ] || continue
      i=$((i + 1))
      # the name as a regular expression matching only itself
      local exact="^$(sed 's/[][\\.^$*+?(){}|]/\\&/g' <<<"$test")\$" r in_base=0
      # a benchmark the baseline does not have gets no baseline figure
      grep -qxF "$test" <<<"$base_names" && in_base=1
      for ((r = 1; r <= reps; r++)); do
        if [ "$in_base" = 1 ] && [ $((r % 2)) = 0 ]; then
          run_binary "baseline$suffix" "$baseline/bench/$name" "$cpus" "$exact" "${name}__${i}__r$r" 1
        fi
        run_binary "current$suffix" "$bin" "$cpus" "$exact" "${name}__${i}__r$r" 1
        if [ "$in_base" = 1 ] && [ $((r % 2)) = 1 ]; then
          run_binary "baseline$suffix" "$baseline/bench/$name" "$cpus" "$exact" "${name}__${i}__r$r" 1
        fi
      done
    done <<<"$(list_tests "$bin" "$sel" "$only_sequences")"
  done
}

if [ -n "$baseline" ]; then
  run_interleaved "" "$cpu" "$selection"
  if [ "$two_cores" != none ]; then run_interleaved -2cores "$two_cores" "$filter" sequences; fi
else
  run current "$build" "$cpu" "$selection"
  if [ "$two_cores" != none ]; then run current-2cores "$build" "$two_cores" "$filter" sequences; fi
fi

"$python" "$root/scripts/bench_report.py" --cpu "$cpu" --two-cores "$two_cores" \
  --build "$build" ${baseline:+--baseline "$baseline"} ${readme:+--readme "$readme"} "$out"
echo "bench.sh: wrote $out/bench.json and $out/bench.md" >&2
