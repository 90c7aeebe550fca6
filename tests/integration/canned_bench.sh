#!/usr/bin/env bash
# A benchmark binary for bench_sh_test: answers Google Benchmark's command line
# (--benchmark_list_tests=true, --benchmark_filter=REGEX, --benchmark_out=FILE) for the benchmark
# names listed one a line in <this file>.names, each reporting the wall time in <this file>.ms
# (milliseconds) as its median aggregate. Other options are accepted and ignored.
set -euo pipefail
list=0
filter=.
out=/dev/null
for arg in "$@"; do
  case "$arg" in
    --benchmark_list_tests=true) list=1 ;;
    --benchmark_filter=*) filter="${arg#--benchmark_filter=}" ;;
    --benchmark_out=*) out="${arg#--benchmark_out=}" ;;
  esac
done
names="$(grep -E -- "$filter" "$0.names" || true)"
if [ "$list" = 1 ]; then
  printf '%s\n' "$names"
  exit 0
fi
ms="$(cat "$0.ms")"
{
  echo '{"context": {}, "benchmarks": ['
  separator=""
  while IFS= read -r name; do
    [ -n "$name" ] || continue
    printf '%s{"name": "%s_median", "run_name": "%s", "run_type": "aggregate", ' \
      "$separator" "$name" "$name"
    printf '"aggregate_name": "median", "real_time": %s, "time_unit": "ms", "repetitions": 1}\n' "$ms"
    separator=","
  done <<<"$names"
  echo ']}'
} >"$out"
