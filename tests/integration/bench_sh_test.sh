#!/usr/bin/env bash
# scripts/bench.sh --baseline on two made-up build directories whose bench/ binaries are small
# scripts speaking Google Benchmark's command line (list, filter, JSON out): each benchmark
# runs in the current build and then at once in the baseline (interleaved), a benchmark the
# baseline lacks runs only in the current build (and does not end the script), and the table
# puts each figure beside its baseline. Usage: bench_sh_test.sh SOURCE_DIR
set -euo pipefail
source_dir="$1"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
fail=0
check() { if ! eval "$1"; then echo "FAILED: $2"; fail=1; fi; }

# make_build DIR MS TEST...: a build directory whose bench/fake_bench lists TEST... and reports
# MS milliseconds for each
make_build() {
  local dir="$1" ms="$2"
  shift 2
  mkdir -p "$dir/bench" "$dir/meshes"
  : >"$dir/meshes/liver_30000.msh"  # bench.sh would otherwise make it with gmsh
  printf '%s\n' "$@" >"$dir/bench/fake_bench.tests"
  cat >"$dir/bench/fake_bench" <<SCRIPT
#!/usr/bin/env bash
list=0; filter=.; out=/dev/null
for a in "\$@"; do
  case "\$a" in
    --benchmark_list_tests=true) list=1 ;;
    --benchmark_filter=*) filter="\${a#--benchmark_filter=}" ;;
    --benchmark_out=*) out="\${a#--benchmark_out=}" ;;
  esac
done
names="\$(grep -E -- "\$filter" "\$0.tests" || true)"
if [ "\$list" = 1 ]; then printf '%s\n' "\$names"; exit 0; fi
{
  echo '{"context": {}, "benchmarks": ['
  sep=""
  while IFS= read -r n; do
    [ -n "\$n" ] || continue
    printf '%s{"name": "%s_median", "run_name": "%s", "run_type": "aggregate", "aggregate_name": "median", "real_time": $ms, "time_unit": "ms", "repetitions": 1}\n' "\$sep" "\$n" "\$n"
    sep=","
  done <<<"\$names"
  echo ']}'
} >"\$out"
echo "ran \$names"
SCRIPT
  chmod +x "$dir/bench/fake_bench"
}

make_build "$tmp/current" 10 "Solve/2660" "LiverStep/2660" "NewOnly/2660"
make_build "$tmp/baseline" 20 "Solve/2660" "LiverStep/2660"
rc=0
NSIM_BUILD_DIR="$tmp/current" "$source_dir/scripts/bench.sh" --no-build --reps 1 --cpu 0 \
  --two-cores none --baseline "$tmp/baseline" --out "$tmp/out" 2>"$tmp/log" || rc=$?
check '[ "$rc" = 0 ]' "bench.sh exits 0 (got $rc; log: $(tail -3 "$tmp/log"))"
# the order of the runs: current then baseline for each benchmark the baseline has
order="$(grep '^== ' "$tmp/log" | sed 's/^== \([a-z]*\): fake_bench (^\([A-Za-z]*\).*/\1 \2/' | paste -sd, -)"
check '[ "$order" = "current Solve,baseline Solve,current LiverStep,baseline LiverStep,current NewOnly" ]' \
  "interleaved order (got $order)"
check '[ "$(ls "$tmp/out/raw" | wc -l)" = 5 ]' "one raw file per benchmark and build ($(ls "$tmp/out/raw" | paste -sd' ' -))"
md="$tmp/out/bench.md"
check 'grep -q "^| \`LiverStep/2660\` | fake_bench | 10 ms |.*| 20 ms | – | 0.5x |" "$md"' \
  "LiverStep/2660 beside its baseline ($(grep LiverStep "$md" || true))"
check 'grep -q "^| \`NewOnly/2660\` | fake_bench | 10 ms |.*| – | – | – | – |$" "$md"' \
  "NewOnly/2660 without a baseline ($(grep NewOnly "$md" || true))"
echo "bench_sh_test: $([ "$fail" = 0 ] && echo ok || echo failed)"
exit "$fail"
