#!/usr/bin/env bash
# Controller takeover, measured: the closed loop over DDS (configs/dds/local.xml), prediction
# off, once undisturbed and once for each kill time, where inverse_sim is killed (SIGKILL) when
# the simulated time reaches it and a new inverse_sim is started once direct_sim has noticed the
# loss; prints each run's exit, takeovers, final error and (lockstep) whether its
# timeseries.csv equals the undisturbed run's. Needs a build (scripts/build.sh).
#
#   scripts/takeover.sh [--realtime] [--duration S] [--scenario FILE] KILL_AT_S ...
#   e.g. scripts/takeover.sh 2 5 8      (liver_test_coarse.yaml, lockstep, 11 s)
#   NSIM_BUILD_DIR: the build (default build/); NSIM_RESULTS_DIR: where the runs go
#   (default results/takeover_<date>/)
#
# Every process is bounded in time and killed by PID on exit.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
scenario="$root/configs/scenarios/liver_test_coarse.yaml"
mode=lockstep
duration=11
kills=()
while [ $# -gt 0 ]; do
  case "$1" in
    --realtime) mode=realtime; shift ;;
    --duration) [ $# -ge 2 ] || { echo "takeover: --duration needs a value (s)" >&2; exit 2; }
                duration="$2"; shift 2 ;;
    --scenario) [ $# -ge 2 ] || { echo "takeover: --scenario needs a file" >&2; exit 2; }
                scenario="$(realpath "$2")"; shift 2 ;;
    -h|--help) sed -n '2,13p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    -*) echo "takeover: unknown option '$1' (see --help)" >&2; exit 2 ;;
    *) [[ "$1" =~ ^[0-9]*\.?[0-9]+$ ]] || { echo "takeover: a kill time is seconds, got '$1'" >&2; exit 2; }
       kills+=("$1"); shift ;;
  esac
done
[ -f "$scenario" ] || { echo "takeover: no such scenario: $scenario" >&2; exit 2; }
bin="${NSIM_BUILD_DIR:-$root/build}/bin"
[ -x "$bin/direct_sim" ] && [ -x "$bin/inverse_sim" ] || { echo "takeover: build first (scripts/build.sh)" >&2; exit 2; }
out="${NSIM_RESULTS_DIR:-$root/results/takeover_$(date +%Y%m%d_%H%M%S)}"
mkdir -p "$out"

pids=()
cleanup() {
  for p in "${pids[@]}"; do kill -9 "$p" 2>/dev/null || true; done
  for p in "${pids[@]}"; do wait "$p" 2>/dev/null || true; done
}
trap cleanup EXIT
trap 'echo "takeover: interrupted"; exit 130' INT TERM

# wait_for SECONDS COMMAND...: polls COMMAND every 20 ms; false after SECONDS
wait_for() {
  local end=$((SECONDS + $1)); shift
  until "$@"; do [ $SECONDS -lt $end ] || return 1; sleep 0.02; done
}
# the simulated time of the last complete row of a timeseries.csv reached $2
reached() { [ -f "$1" ] && awk -F, -v t="$2" 'NR > 1 { last = $1 } END { exit !(last >= t) }' "$1"; }

controller() {  # controller NAME: an inverse_sim in the run's folder, in the background
  "$bin/inverse_sim" run --config "$scenario" --out "$dir/$1" --mode "$mode" --prediction off \
    --timeout $((60 + 4 * ${duration%.*})) --start-timeout 30 --quiet --lease 1 "${dds[@]}" \
    > "$dir/$1.log" 2>&1 &
  last_pid=$!; pids+=("$last_pid")
}

# run NAME [KILL_AT]: one closed loop; prints its line
run() {
  dir="$out/$1"; mkdir -p "$dir"
  dds=(--dds-config "$root/configs/dds/local.xml" --domain "${NSIM_DOMAIN:-0}" --partition "takeover$$_$1")
  controller inverse; local first=$last_pid
  timeout -s KILL $((120 + 4 * ${duration%.*})) "$bin/direct_sim" run --config "$scenario" \
    --out "$dir/direct" --mode "$mode" --duration "$duration" --no-video --quiet --lease 3 \
    "${dds[@]}" > "$dir/direct.log" 2>&1 &
  local direct=$!; pids+=("$direct")
  if [ -n "${2:-}" ]; then
    wait_for 120 reached "$dir/direct/timeseries.csv" "$2" || { echo "$1: never reached t = $2 s"; return; }
    kill -9 "$first"; wait "$first" 2>/dev/null || true
    wait_for 30 grep -q "inverse_sim lost" "$dir/direct.log" || { echo "$1: the loss was not noticed"; return; }
    controller inverse2
  fi
  local code=0; wait "$direct" || code=$?
  for p in "${pids[@]}"; do wait_for 10 bash -c "! kill -0 $p 2>/dev/null" || kill -9 "$p" 2>/dev/null || true; done
  pids=()
  local same=""
  if [ "$mode" = lockstep ] && [ -n "${2:-}" ]; then
    cmp -s "$out/undisturbed/direct/timeseries.csv" "$dir/direct/timeseries.csv" && same=", timeseries.csv = undisturbed" || same=", timeseries.csv differs"
  fi
  jq -r --arg name "$1" --arg code "$code" --arg same "$same" \
    '"\($name): exit \(.exit) (\($code)), takeovers \(.controller_takeovers), final error \(.final_error_mm * 1000 | round / 1000) mm\($same)"' \
    "$dir/direct/summary.json"
}

echo "takeover: $scenario, $mode, $duration s, kills at: ${kills[*]:-none} (runs in $out)"
run undisturbed
for t in "${kills[@]}"; do run "kill_at_$t" "$t"; done
