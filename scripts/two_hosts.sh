#!/usr/bin/env bash
# The closed loop on "two machines": direct_sim in one network namespace (10.77.0.1), inverse_sim
# in another (10.77.0.2), joined by a veth pair, with the two-machine DDS configuration
# (configs/dds/two_hosts.xml: explicit peers, no multicast). Needs root (ip netns, nft).
#
#   scripts/two_hosts.sh [scenario.yaml] [--loss PCT] [--mode lockstep|realtime]
#                        [--latency-steps N] [--duration S] [--prediction on|off]
#                        [--rt-priority N] [--secure [DIR]] [--no-build]
#
# --loss PCT drops PCT % of the packets arriving in each namespace (nftables input rule
# "numgen random mod 100 < PCT drop"); DDS's reliable protocol resends them. --mode lockstep
# (default): the latency is simulated in the application, --latency-steps N (default 1);
# realtime: both loops run on the wall clock and the latency is what the network, the loss and
# the solvers make it (summary.json: loop_latency_ms, the controller's measured horizon). Writes
# results/two_hosts_<date>/ (or $NSIM_RESULTS_DIR): direct/, inverse/, the logs and summary.json
# (merged, like scripts/run.sh). Namespaces, veth pair and rules are removed on exit, and both
# processes are killed by PID. --secure [DIR]: DDS Security, as in scripts/run.sh (without DIR,
# $NSIM_CREDENTIALS_DIR or results/credentials, made when missing). --rt-priority N: realtime,
# direct_sim's loop thread in SCHED_FIFO at N (run.rt_priority; this script runs as root).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
scenario="$root/configs/scenarios/liver_test_coarse.yaml"
loss=0; latency=1; mode=lockstep; duration=""; prediction=on; build=1; secure=""; secure_default=0
rt_priority=""
while [ $# -gt 0 ]; do
  case "$1" in
    --secure=*) secure="${1#--secure=}"; shift ;;
    --secure)
      # DIR is the next argument unless that is an option or a scenario file
      if [ $# -ge 2 ] && [[ "$2" != -* ]] && { [ -d "$2" ] || [[ "$2" != *.yaml && "$2" != *.yml ]]; }; then
        secure="$2"; shift 2
      else
        secure="${NSIM_CREDENTIALS_DIR:-$root/results/credentials}"; secure_default=1; shift
      fi ;;
    --loss) loss="$2"; shift 2 ;;
    --latency-steps) latency="$2"; shift 2 ;;
    --mode) mode="$2"; shift 2 ;;
    --duration) duration="$2"; shift 2 ;;
    --prediction) prediction="$2"; shift 2 ;;
    --rt-priority) rt_priority="$2"; shift 2 ;;
    --no-build) build=0; shift ;;
    -h|--help) sed -n '2,19p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    -*) echo "two_hosts: unknown option '$1' (see --help)" >&2; exit 2 ;;
    *) scenario="$(realpath "$1")"; shift ;;
  esac
done
[[ "$loss" =~ ^[0-9]+$ ]] && [ "$loss" -le 100 ] || { echo "two_hosts: --loss must be 0..100, got '$loss'" >&2; exit 2; }
[[ "$latency" =~ ^[0-9]+$ ]] || { echo "two_hosts: --latency-steps must be an integer >= 0" >&2; exit 2; }
case "$mode" in lockstep|realtime) ;; *) echo "two_hosts: --mode must be lockstep or realtime, got '$mode'" >&2; exit 2 ;; esac
[ -f "$scenario" ] || { echo "two_hosts: no such scenario: $scenario" >&2; exit 2; }
if [ "$(id -u)" -ne 0 ]; then echo "two_hosts: needs root (ip netns, nft)" >&2; exit 2; fi

if [ "$build" = 1 ]; then
  "$root/scripts/setup.sh"
  "$root/scripts/build.sh" >/dev/null
fi
if [ -n "$secure" ]; then
  if [ "$secure_default" = 1 ] && [ ! -e "$secure/ca.pem" ]; then
    echo "two_hosts: no credentials in $secure: making them (scripts/make_credentials.sh)"
    "$root/scripts/make_credentials.sh" --out "$secure"
  fi
  [ -f "$secure/ca.pem" ] || { echo "two_hosts: no credentials in '$secure' (scripts/make_credentials.sh --out '$secure' makes them)" >&2; exit 2; }
  secure="$(realpath "$secure")"
fi
bin="${NSIM_BUILD_DIR:-$root/build}/bin"
out="${NSIM_RESULTS_DIR:-$root/results/two_hosts_$(date +%Y%m%d_%H%M%S)}"
mkdir -p "$out"; out="$(realpath "$out")"

# shellcheck source=scripts/netns_pair.sh
. "$root/scripts/netns_pair.sh"
tag="nsim$$"
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  for p in "${pids[@]}"; do wait "$p" 2>/dev/null || true; done
  netns_pair_down
}
trap cleanup EXIT
trap 'echo "two_hosts: interrupted"; exit 130' INT TERM

netns_pair_up "$tag" || { echo "two_hosts: cannot make the two namespaces and their veth pair" >&2; exit 1; }
ns1="$NETNS_A"; ns2="$NETNS_B"
netns_pair_loss "$loss" || { echo "two_hosts: cannot make the loss rules (nft)" >&2; exit 1; }
echo "two_hosts: direct_sim on 10.77.0.1 ($ns1), inverse_sim on 10.77.0.2 ($ns2), loss $loss %, $( [ "$mode" = lockstep ] && echo "lockstep latency $latency steps" || echo realtime)${secure:+, DDS Security with $secure}"
echo "two_hosts: results in $out"

common=(--dds-config "$root/configs/dds/two_hosts.xml" --domain "${NSIM_DOMAIN:-0}" --partition "$tag" --lease 3)
[ -n "$secure" ] && common+=(--secure "$secure")
ip netns exec "$ns2" "$bin/inverse_sim" run --config "$scenario" --out "$out/inverse" --mode "$mode" \
  --prediction "$prediction" --timeout 900 --start-timeout 60 \
  "${common[@]}" > "$out/inverse.log" 2>&1 &
inv=$!; pids+=("$inv")
direct_args=(--mode "$mode" --no-video)
[ "$mode" = lockstep ] && direct_args+=(--latency-steps "$latency")
[ -n "$duration" ] && direct_args+=(--duration "$duration")
[ -n "$rt_priority" ] && direct_args+=(--rt-priority "$rt_priority")
timeout -s KILL 900 ip netns exec "$ns1" "$bin/direct_sim" run --config "$scenario" --out "$out/direct" \
  "${direct_args[@]}" "${common[@]}" > "$out/direct.log" 2>&1 &
dir=$!; pids+=("$dir")
tail -n +1 -f --pid="$dir" "$out/direct.log" &
tailer=$!
dcode=0; wait "$dir" || dcode=$?
wait "$tailer" 2>/dev/null || true
for _ in $(seq 1 50); do kill -0 "$inv" 2>/dev/null || break; sleep 0.1; done
kill "$inv" 2>/dev/null || true
icode=0; wait "$inv" || icode=$?
pids=()
[ "$loss" -eq 0 ] || netns_pair_dropped | sed 's/^/two_hosts: /'
[ -f "$out/direct/summary.json" ] || { echo "two_hosts: direct_sim wrote no summary (exit $dcode)" >&2; exit 1; }
jq -n --slurpfile d "$out/direct/summary.json" --slurpfile i <(cat "$out/inverse/summary.json" 2>/dev/null || echo '{}') \
  --argjson loss "$loss" --argjson latency "$latency" --arg mode "$mode" '($d[0]) as $d | ($i[0] // {}) as $i | {
    loss_percent: $loss, mode: $mode, latency_steps: (if $mode == "lockstep" then $latency else null end), direct_exit: $d.exit, inverse_ending: $i.ending,
    final_error_mm: $d.final_error_mm, final_error_amplitude_mm: $d.final_error_amplitude_mm,
    direct_rate_hz: $d.direct_rate_hz, inverse_rate_hz: $i.inverse_rate_hz,
    loop_latency_ms: $d.loop_latency_ms, nrms_percent: $i.nrms_percent,
    lockstep_timeouts: $d.targets.lockstep_timeouts, rejected_targets: $d.targets.rejected_total,
    inverse_frames_missing: $i.frames_missing, inverse_frames_skipped: $i.frames_skipped,
    direct: $d, inverse: $i}' > "$out/summary.json"
jq -r '"two_hosts: \(.direct_exit) / \(.inverse_ending): final error \(.final_error_mm) mm, amplitude \(.final_error_amplitude_mm) mm, loop latency \(.loop_latency_ms.mean) ms, lockstep timeouts \(.lockstep_timeouts), frames missing \(.inverse_frames_missing)"' "$out/summary.json"
[ "$dcode" -eq 0 ] && [ "$icode" -eq 0 ]
