#!/usr/bin/env bash
# The cost of DDS Security on the closed loop: the same run (direct_sim and inverse_sim over
# DDS on this machine) without and with --secure, alternately, RUNS times each; prints the loop
# latency of every run (direct_sim's summary.json: frame sent -> its target received, ms) and
# the median over the runs of its median and p99, and the CPU time both processes took. Uses the
# built executables (scripts/build.sh first); the credentials are made in the results folder.
# Both processes are bounded in time and killed by PID on exit.
#
#   scripts/security_overhead.sh [--runs N] [--duration S] [--mode lockstep|realtime]
#                                [scenario.yaml]
#
# Defaults: 6 runs, 4 s simulated, lockstep, configs/scenarios/liver_test_coarse.yaml, prediction
# off. Writes results/security_overhead_<date>/ (or $NSIM_RESULTS_DIR): the runs and table.txt.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
scenario="$root/configs/scenarios/liver_test_coarse.yaml"
runs=6; duration=4; mode=lockstep
while [ $# -gt 0 ]; do
  case "$1" in
    --runs) runs="$2"; shift 2 ;;
    --duration) duration="$2"; shift 2 ;;
    --mode) mode="$2"; shift 2 ;;
    -h|--help) sed -n '2,13p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    -*) echo "security_overhead: unknown option '$1' (see --help)" >&2; exit 2 ;;
    *) scenario="$(realpath "$1")"; shift ;;
  esac
done
[[ "$runs" =~ ^[1-9][0-9]?$ ]] || { echo "security_overhead: --runs must be 1..99" >&2; exit 2; }
[[ "$duration" =~ ^[0-9]*\.?[0-9]+$ ]] || { echo "security_overhead: --duration must be a number (s)" >&2; exit 2; }
[ "$mode" = lockstep ] || [ "$mode" = realtime ] || { echo "security_overhead: --mode lockstep|realtime" >&2; exit 2; }
bin="${NSIM_BUILD_DIR:-$root/build}/bin"
[ -x "$bin/direct_sim" ] || { echo "security_overhead: no $bin/direct_sim (scripts/build.sh)" >&2; exit 1; }
out="${NSIM_RESULTS_DIR:-$root/results/security_overhead_$(date +%Y%m%d_%H%M%S)}"
mkdir -p "$out"; out="$(realpath "$out")"
"$root/scripts/make_credentials.sh" --out "$out/credentials" --days 1 > /dev/null

pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  for p in "${pids[@]}"; do wait "$p" 2>/dev/null || true; done
}
trap cleanup EXIT

# one closed loop into $out/$1 with the extra DDS options that follow
run_loop() {
  local dir="$out/$1"; shift
  local dds=(--dds-config "$root/configs/dds/local.xml" --domain "${NSIM_DOMAIN:-0}"
             --partition "overhead$$" --lease 3 "$@")
  # bash's time: the CPU time (user + system, s) of each process into DIR.*.cpu
  (TIMEFORMAT='%U %S'; time timeout -s KILL 300 "$bin/inverse_sim" run --config "$scenario" \
    --out "$dir/inverse" --mode "$mode" --prediction off --timeout 280 --start-timeout 60 \
    --quiet "${dds[@]}" > "$dir.inverse.log" 2>&1) 2> "$dir.inverse.cpu" &
  local inv=$!; pids=("$inv")
  (TIMEFORMAT='%U %S'; time timeout -s KILL 300 "$bin/direct_sim" run --config "$scenario" \
    --out "$dir/direct" --mode "$mode" --duration "$duration" --no-video --quiet "${dds[@]}" \
    > "$dir.direct.log" 2>&1) 2> "$dir.direct.cpu" ||
    { echo "security_overhead: direct_sim failed, see $dir.direct.log" >&2; exit 1; }
  wait "$inv" || { echo "security_overhead: inverse_sim failed, see $dir.inverse.log" >&2; exit 1; }
  pids=()
}
# the CPU time of both processes of run $1 (s)
cpu() { cat "$out/$1.direct.cpu" "$out/$1.inverse.cpu" | awk '{s += $1 + $2} END {print s}'; }

load="$(cut -d ' ' -f 1-3 /proc/loadavg)"
# which goes first alternates, so that a drift of the machine's load favours neither
for i in $(seq 1 "$runs"); do
  if [ $((i % 2)) = 1 ]; then
    run_loop "plain$i"
    run_loop "secure$i" --secure "$out/credentials"
  else
    run_loop "secure$i" --secure "$out/credentials"
    run_loop "plain$i"
  fi
done

{
  echo "loop latency (ms), $mode, $duration s simulated, $(basename "$scenario"), $runs runs each, load average before: $load"
  printf '%-4s %10s %10s %10s %10s %10s %10s\n' run plain_med plain_p99 secure_med secure_p99 \
    plain_cpu_s secure_cpu_s
  for i in $(seq 1 "$runs"); do
    printf '%-4s %10.2f %10.2f %10.2f %10.2f %10.2f %10.2f\n' "$i" \
      "$(jq .loop_latency_ms.median "$out/plain$i/direct/summary.json")" \
      "$(jq .loop_latency_ms.p99 "$out/plain$i/direct/summary.json")" \
      "$(jq .loop_latency_ms.median "$out/secure$i/direct/summary.json")" \
      "$(jq .loop_latency_ms.p99 "$out/secure$i/direct/summary.json")" \
      "$(cpu "plain$i")" "$(cpu "secure$i")"
  done
  median() { sort -g | awk '{v[NR] = $1} END {print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2}'; }
  for kind in plain secure; do
    for stat in median p99; do
      printf '%s %s over runs: %.2f ms\n' "$kind" "$stat" "$(for i in $(seq 1 "$runs"); do
        jq ".loop_latency_ms.$stat" "$out/$kind$i/direct/summary.json"; done | median)"
    done
    printf '%s CPU time of both processes, median over runs: %.2f s\n' "$kind" \
      "$(for i in $(seq 1 "$runs"); do cpu "$kind$i"; done | median)"
  done
} | tee "$out/table.txt"
