#!/usr/bin/env bash
# The run command: installs missing packages, builds, then runs the closed loop on this machine
# and writes a results folder. direct_sim (patient, robot, breathing) and inverse_sim (the
# controller: registration to predicted markers, Jacobian, control law) talk over DDS
# (configs/dds/local.xml); the default is the thesis §5.2 insertion: rigid needle, breathing,
# prediction on, in lockstep mode with a 1-step latency: reproducible, and on a 2-core machine
# neither process is starved (in realtime mode on 2 cores direct_sim reaches about 24 of its
# 50 steps/s and some runs stall short of the target; see README "Limitations").
#
#   scripts/run.sh [--in-process] [--secure [DIR]] [--duration S] [scenario.yaml]
#                  [-- extra direct_sim options]
#   --in-process: both loops in one process (direct_sim run --in-process), lockstep, no DDS:
#                 the same results folder and, to the last digit, the same numbers as the
#                 two-process lockstep run
#   --secure [DIR]: DDS Security: each process authenticates with its credentials in DIR and
#                 the topics are encrypted (README "DDS Security"); without DIR,
#                 $NSIM_CREDENTIALS_DIR or results/credentials, made by
#                 scripts/make_credentials.sh when missing
#   --duration S: simulated time (default the scenario's run.duration)
#   NSIM_PREDICTION=off scripts/run.sh     (register to the measured markers)
#   NSIM_MODE=realtime scripts/run.sh      (wall-clock pacing; NSIM_MODE=lockstep is the default,
#                                           NSIM_LATENCY_STEPS=N, default 1)
#   NSIM_DURATION=S scripts/run.sh         (the same as --duration S)
#
# Writes results/run_<date>/ (or $NSIM_RESULTS_DIR): summary.json (merged: final error and
# amplitude, rates, loop latency, nRMS per marker, rejected counts, all settings; the full
# summaries of both processes under "direct" and "inverse"), timeseries.csv (direct_sim),
# distance.png (thesis fig. 5.9), view.avi and view.png, and the two logs. Both processes are
# bounded in time and killed by PID on exit. The replay demo is scripts/replay_demo.sh.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
scenario="$root/configs/scenarios/liver_breathing.yaml"
in_process=0
duration="${NSIM_DURATION:-}"
secure=""        # the credentials folder with --secure
secure_default=0  # --secure without DIR: the default folder, made when missing
while [ $# -gt 0 ]; do
  case "$1" in
    --in-process) in_process=1; shift ;;
    --secure=*) secure="${1#--secure=}"; shift ;;
    --secure)
      # DIR is the next argument unless that is an option or a scenario file
      if [ $# -ge 2 ] && [[ "$2" != -* ]] && { [ -d "$2" ] || [[ "$2" != *.yaml && "$2" != *.yml ]]; }; then
        secure="$2"; shift 2
      else
        secure="${NSIM_CREDENTIALS_DIR:-$root/results/credentials}"; secure_default=1; shift
      fi ;;
    --duration)
      [ $# -ge 2 ] || { echo "run: --duration needs a value (s)" >&2; exit 2; }
      duration="$2"; shift 2 ;;
    --duration=*) duration="${1#--duration=}"; shift ;;
    -h|--help) sed -n '2,29p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    --) shift; break ;;
    -*) echo "run: unknown option '$1' (see --help)" >&2; exit 2 ;;
    *) scenario="$(realpath "$1")"; shift ;;
  esac
done
extra_direct=("$@")
[ -f "$scenario" ] || { echo "run: no such scenario: $scenario" >&2; exit 2; }
if [ -n "$duration" ] && ! [[ "$duration" =~ ^[0-9]*\.?[0-9]+$ ]]; then
  echo "run: --duration must be a positive number of seconds, got '$duration'" >&2; exit 2
fi

if [ -n "$secure" ]; then
  [ "$in_process" = 0 ] || { echo "run: --secure needs the two processes over DDS: not with --in-process" >&2; exit 2; }
fi

"$root/scripts/setup.sh"
if [ -n "$secure" ]; then
  if [ "$secure_default" = 1 ] && [ ! -e "$secure/ca.pem" ]; then
    echo "run: no credentials in $secure: making them (scripts/make_credentials.sh)"
    "$root/scripts/make_credentials.sh" --out "$secure"
  fi
  [ -f "$secure/ca.pem" ] || { echo "run: no credentials in '$secure' (scripts/make_credentials.sh --out '$secure' makes them)" >&2; exit 2; }
  secure="$(realpath "$secure")"
fi
echo "run: building (scripts/build.sh) ..."
"$root/scripts/build.sh" >/dev/null
bin="${NSIM_BUILD_DIR:-$root/build}/bin"

out="${NSIM_RESULTS_DIR:-$root/results/run_$(date +%Y%m%d_%H%M%S)}"
mkdir -p "$out"
out="$(realpath "$out")"
prediction="${NSIM_PREDICTION:-on}"
# a 2 s liveliness lease (default 0.5 s): on a loaded 2-core machine 0.5 s can expire while
# both processes are alive; the robot still holds after safety.hold_timeout without targets
dds=(--dds-config "$root/configs/dds/local.xml" --domain "${NSIM_DOMAIN:-0}" --partition "run$$"
     --lease 2)
[ -n "$secure" ] && dds+=(--secure "$secure")
NSIM_MODE="${NSIM_MODE:-lockstep}"
mode_args=(--mode "$NSIM_MODE")
direct_args=("${mode_args[@]}")
if [ "${NSIM_MODE:-}" = "lockstep" ]; then
  latency="${NSIM_LATENCY_STEPS:-1}"
  direct_args+=(--latency-steps "$latency")
fi
[ -n "$duration" ] && direct_args+=(--duration "$duration")
# the controller measures its latency (prediction.measure_latency): nothing to pass for it
controller_args=(--prediction "$prediction")

pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  for p in "${pids[@]}"; do wait "$p" 2>/dev/null || true; done
}
trap cleanup EXIT
trap 'echo "run: interrupted"; exit 130' INT TERM

# direct_sim run TIMEOUT ARGS...: in the background, bounded by timeout(1) (a hung run cannot
# outlive it), its progress lines shown as they come; sets direct_code when it has exited
run_direct() {
  local limit="$1"; shift
  timeout -s KILL "$limit" "$bin/direct_sim" run --config "$scenario" --out "$out/direct" "$@" \
    > "$out/direct.log" 2>&1 &
  local dir=$!; pids+=("$dir")
  tail -n +1 -f --pid="$dir" "$out/direct.log" &
  local tailer=$!
  direct_code=0; wait "$dir" || direct_code=$?
  wait "$tailer" 2>/dev/null || true
}

if [ "$in_process" = 1 ]; then
  [ "$NSIM_MODE" = lockstep ] || { echo "run: --in-process runs in lockstep only (NSIM_MODE=$NSIM_MODE)" >&2; exit 2; }
  echo "run: closed loop in one process, scenario $scenario, prediction $prediction, lockstep"
  echo "run: results in $out"
  run_direct 1800 --in-process "${direct_args[@]}" "${controller_args[@]}" "${extra_direct[@]}"
  pids=()
  inverse_code=$direct_code
else
  echo "run: closed loop, scenario $scenario, prediction $prediction${NSIM_MODE:+, mode $NSIM_MODE}${secure:+, DDS Security with $secure}"
  echo "run: results in $out"
  "$bin/inverse_sim" run --config "$scenario" --out "$out/inverse" --timeout 600 --start-timeout 60 \
    "${mode_args[@]}" "${controller_args[@]}" "${dds[@]}" > "$out/inverse.log" 2>&1 &
  inv=$!; pids+=("$inv")
  run_direct 600 "${direct_args[@]}" "${extra_direct[@]}" "${dds[@]}"
  inverse_code=0
  for _ in $(seq 1 100); do kill -0 "$inv" 2>/dev/null || break; sleep 0.1; done
  if kill -0 "$inv" 2>/dev/null; then
    echo "run: inverse_sim did not stop after direct_sim finished; killing it (PID $inv)"
    kill "$inv" 2>/dev/null || true
  fi
  wait "$inv" || inverse_code=$?
  pids=()
  echo "run: direct_sim exit $direct_code, inverse_sim exit $inverse_code (logs: direct.log, inverse.log)"
  tail -n 2 "$out/inverse.log"
fi

if [ ! -f "$out/direct/summary.json" ]; then
  echo "run: direct_sim wrote no summary, see $out/direct.log" >&2
  exit 1
fi
inverse_summary="$out/inverse/summary.json"
[ -f "$inverse_summary" ] || { echo "run: inverse_sim wrote no summary" >&2; inverse_summary=/dev/null; }
for f in timeseries.csv view.avi view.png; do
  [ -f "$out/direct/$f" ] && ln -sf "direct/$f" "$out/$f"
done
jq -n --slurpfile d "$out/direct/summary.json" --slurpfile i <(cat "$inverse_summary" 2>/dev/null || echo '{}') \
  --arg scenario "$scenario" --argjson dcode "$direct_code" --argjson icode "$inverse_code" '
  ($d[0]) as $d | (($i[0]) // {}) as $i | {
    scenario: $scenario,
    direct_exit: $d.exit, direct_exit_code: $dcode,
    inverse_ending: $i.ending, inverse_exit_code: $icode,
    final_error_mm: $d.final_error_mm,
    final_error_amplitude_mm: $d.final_error_amplitude_mm,
    steady_window_s: $d.steady_window_s,
    min_tip_to_target_distance_mm: $d.min_tip_to_target_distance_mm,
    direct_rate_hz: $d.direct_rate_hz,
    inverse_rate_hz: $i.inverse_rate_hz,
    loop_latency_ms: $d.loop_latency_ms,
    nrms_percent: $i.nrms_percent,
    prediction_rms_mm: $i.prediction_rms_mm,
    rejected: {direct_targets: $d.targets.rejected_total,
               direct_targets_by_reason: $d.targets.rejected,
               direct_transport_invalid: $d.targets.transport_invalid,
               direct_hold_steps: $d.targets.hold_steps,
               direct_lockstep_timeouts: $d.targets.lockstep_timeouts,
               inverse_frames: $i.rejected_frames, inverse_frames_skipped: $i.frames_skipped,
               inverse_invalid_outputs: $i.invalid_outputs},
    controller_lost: $d.controller_lost,
    punctured: $d.punctured,
    settings: {mode: $d.mode, direct: $d.settings, inverse: $i.settings},
    outputs: {timeseries: "timeseries.csv", plot: "distance.png", video: "view.avi", png: "view.png"},
    direct: $d, inverse: $i}' > "$out/summary.json"

plot_ok=1
if [ -x /usr/bin/python3 ] && /usr/bin/python3 -c "import matplotlib" 2>/dev/null; then
  /usr/bin/python3 "$root/scripts/plot_results.py" run "$out" || plot_ok=0
else
  echo "run: the plot could not be made: /usr/bin/python3 with matplotlib is missing (apt-get install python3-matplotlib)" >&2
  plot_ok=0
fi
[ "$plot_ok" = 1 ] || echo "run: WARNING: no distance.png" >&2

echo
jq -r 'def r(d): if type == "number" then (. * pow(10; d) | round) / pow(10; d) else "n/a" end;
       "run: final error \(.final_error_mm | r(2)) mm (mean over t = \(.steady_window_s[0] | r(2)) .. \(.steady_window_s[1] | r(2)) s), amplitude \(.final_error_amplitude_mm | r(2)) mm",
       "run: direct \(.direct_rate_hz | r(1)) Hz, inverse \(.inverse_rate_hz | r(1)) Hz, loop latency mean \(.loop_latency_ms.mean | r(0)) ms (p95 \(.loop_latency_ms.p95 | r(0)) ms)",
       "run: nRMS per marker (%): \(.nrms_percent | map(r(1)))",
       "run: rejected targets \(.rejected.direct_targets), rejected frames \(.rejected.inverse_frames), hold steps \(.rejected.direct_hold_steps)"' "$out/summary.json"
echo "run: results in $out"
[ "$direct_code" -eq 0 ] && [ "$inverse_code" -eq 0 ] && [ "$plot_ok" = 1 ]
