#!/usr/bin/env bash
# One run of a batch of scripts/experiments.sh: the command that GNU parallel (locally or over
# ssh) or a Slurm array task executes once per job, and the code that turns a run's folder into
# its runs.csv row (used again by experiments.sh when it collects the batch).
#
#   scripts/experiment_run.sh run --out DIR --bin BIN [--transport in_process|dds|two_hosts]
#       [--loss PCT] [--mode lockstep|realtime] [--latency-steps N] [--duration S]
#       [--localization-delay S] [--link-delay S] [--timeout S]
#       [--partition-prefix P] [--domain N]  SETTING RUN SEED E CONFIG FLAGS
#   scripts/experiment_run.sh row DIR/SETTING/run_RUN SETTING RUN SEED E
#
# run: runs the closed loop of one setting and run into DIR/SETTING/run_RUN/ (direct/,
# inverse/, direct.log and, over DDS, inverse.log), with the breathing seed SEED and the
# patient's Young's modulus E (Pa); FLAGS are the controller's options of the setting, one
# argument ("--prediction on --dof joint7"); --localization-delay S is the controller's (without
# it: the scenario's prediction.localization_delay). in_process (the default): direct_sim run
# --in-process, both loops in one process, no DDS. dds: inverse_sim run and direct_sim run as
# two processes on their own partition P_SETTING_RUN, so that runs side by side do not meet.
# two_hosts: the same two processes on two "machines", as scripts/two_hosts.sh: direct_sim in a
# network namespace of its own (10.77.0.1), inverse_sim in another (10.77.0.2), joined by a
# veth pair, the two-machine DDS configuration (configs/dds/two_hosts.xml); --loss PCT drops
# PCT % of the packets arriving in each namespace (default 0); the namespaces are this run's
# (made and removed here) and the counts of dropped packets go to direct.log. Needs root.
# --loss PCT with in_process: each frame and each target lost with probability PCT % (direct_sim
# run --in-process --loss, seeded by SEED): the loss of a network, reproducible to the bit.
# --mode realtime (dds, two_hosts): both loops on the wall clock, the latency whatever the machine
# makes it (the controller measures it; --latency-steps does not apply); lockstep (default):
# the latency of --latency-steps, simulated, results reproducible to the bit. --link-delay S
# (realtime): the controller takes each frame up and writes each target S seconds late
# (inverse_sim run --link-delay), a slower network than this machine's.
# One core per run: OPENBLAS_NUM_THREADS, OMP_NUM_THREADS and OMP_THREAD_LIMIT are set to 1
# here, so it holds whatever started the job (parallel, ssh, Slurm). Prints one progress line;
# exits with direct_sim's exit code (0 success, 1 runtime failure, 2 bad input).
# row: prints the run's runs.csv row (setting,run,seed,young_modulus_pa,exit,final_error_mm,...)
# from its summaries, "no_summary" in the exit column when direct/summary.json is missing.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
export OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 OMP_THREAD_LIMIT=1

die() { echo "experiment_run: $*" >&2; exit 2; }

# the runs.csv fields after setting,run,seed,young_modulus_pa, from the run folder's summaries
row_fields() {  # row_fields RUN_DIR
  local dir="$1"
  if [ ! -f "$dir/direct/summary.json" ]; then echo "no_summary,,,,,,,,"; return; fi
  jq -r --slurpfile i <(cat "$dir/inverse/summary.json" 2>/dev/null || echo '{}') '
    ($i[0] // {}) as $i |
    [.exit, .final_error_mm, .final_error_amplitude_mm, .min_tip_to_target_distance_mm,
     .direct_rate_hz, $i.inverse_rate_hz, .loop_latency_ms.mean,
     (($i.nrms_percent // []) | map(select(. != null)) | if length > 0 then add / length else null end),
     .targets.rejected_total] | map(if . == null then "" else tostring end) | join(",")' \
    "$dir/direct/summary.json"
}

if [ "${1:-}" = row ]; then
  [ $# -eq 6 ] || die "row takes RUN_DIR SETTING RUN SEED E (see the top of $0)"
  echo "$3,$4,$5,$6,$(row_fields "$2")"
  exit 0
fi
[ "${1:-}" = run ] || die "the first argument must be 'run' or 'row' (see the top of $0)"
shift

out=""; bin=""; transport=in_process; mode=lockstep; latency=1; duration=20; delay=""; timeout=600
prefix="exp$$"; domain=0; loss=""; link_delay=""
while [ $# -gt 0 ]; do
  case "$1" in
    --out) out="$2"; shift 2 ;;
    --bin) bin="$2"; shift 2 ;;
    --transport) transport="$2"; shift 2 ;;
    --loss) loss="$2"; shift 2 ;;
    --mode) mode="$2"; shift 2 ;;
    --latency-steps) latency="$2"; shift 2 ;;
    --duration) duration="$2"; shift 2 ;;
    --localization-delay) delay="$2"; shift 2 ;;
    --link-delay) link_delay="$2"; shift 2 ;;
    --timeout) timeout="$2"; shift 2 ;;
    --partition-prefix) prefix="$2"; shift 2 ;;
    --domain) domain="$2"; shift 2 ;;
    --*) die "unknown option '$1'" ;;
    *) break ;;
  esac
done
[ $# -eq 6 ] || die "run takes SETTING RUN SEED E CONFIG FLAGS after its options, got $# arguments"
name="$1"; r="$2"; rseed="$3"; emod="$4"; cfg="$5"; read -ra flags <<< "$6"
[ -n "$out" ] || die "--out is required"
case "$transport" in in_process|dds|two_hosts) ;; *) die "--transport must be in_process, dds or two_hosts, got '$transport'" ;; esac
case "$mode" in lockstep|realtime) ;; *) die "--mode must be lockstep or realtime, got '$mode'" ;; esac
[ "$mode" = lockstep ] || [ "$transport" != in_process ] || die "--mode realtime needs --transport dds or two_hosts (in_process is lockstep only)"
if [ -n "$loss" ]; then
  [ "$transport" != dds ] || die "--loss needs --transport two_hosts or in_process (over dds on this machine nothing is lost)"
  [[ "$loss" =~ ^[0-9]+$ ]] && [ "$loss" -le 100 ] || die "--loss must be 0..100 (percent), got '$loss'"
fi
[ -z "$link_delay" ] || [ "$mode" = realtime ] || die "--link-delay is for --mode realtime (lockstep: --latency-steps)"
[ "$transport" != two_hosts ] || [ "$(id -u)" -eq 0 ] || die "--transport two_hosts needs root (ip netns, nft)"
[ -x "$bin/direct_sim" ] || die "no direct_sim in --bin '$bin' (build first, or set NSIM_BUILD_DIR)"
[ -f "$cfg" ] || die "no such scenario: $cfg"

dir="$out/$name/run_$r"
rm -rf "$dir"; mkdir -p "$dir"   # a rerun (e.g. parallel --resume-failed) starts clean
pids=()
# parallel's --timeout and Slurm's time limit send TERM: take the simulators down with us
# shellcheck disable=SC2317  # called by the trap
stop() {
  local p; for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  echo "experiments: $name run $r: stopped (timeout or interrupt)"; exit 143
}
trap stop TERM INT
# two_hosts: this run's namespaces, removed however the script ends (the processes in them are
# gone by then: killed by stop, or finished)
if [ "$transport" = two_hosts ]; then
  # shellcheck source=scripts/netns_pair.sh
  . "$root/scripts/netns_pair.sh"
  trap netns_pair_down EXIT
  netns_pair_up "nx$$" || { echo "experiment_run: cannot make the two namespaces and their veth pair" >&2; exit 1; }
  netns_pair_loss "${loss:-0}" || { echo "experiment_run: cannot make the loss rules (nft)" >&2; exit 1; }
fi

common=(--config "$cfg" --mode "$mode" --duration "$duration" --seed "$rseed" --young-modulus "$emod"
        --no-video --quiet)
[ "$mode" = realtime ] || common+=(--latency-steps "$latency")
# the controller's options: the setting's, and the localization delay unless the scenario's holds
ctl=("${flags[@]}")
[ -z "$delay" ] || ctl+=(--localization-delay "$delay")
code=0
if [ "$transport" = in_process ]; then
  lossy=(); [ -z "$loss" ] || lossy=(--loss "$loss")
  "$bin/direct_sim" run "${common[@]}" --in-process "${lossy[@]}" --out "$dir/direct" \
    --controller-out "$dir/inverse" "${ctl[@]}" > "$dir/direct.log" 2>&1 &
  pids=($!)
  wait "${pids[0]}" || code=$?
else
  # a 3 s liveliness lease in lockstep, which needs no fast dead-peer detection (a shorter lease
  # can expire on a loaded 2-core machine: measured, both sides declared the other dead at 0.5 s
  # while a build ran); realtime: 2 s, as scripts/run.sh (the robot holds after
  # safety.hold_timeout without targets whatever the lease)
  lease=3; [ "$mode" = lockstep ] || lease=2
  xml=local.xml; [ "$transport" = dds ] || xml=two_hosts.xml
  dds=(--dds-config "$root/configs/dds/$xml" --domain "$domain" --lease "$lease" --partition "${prefix}_${name}_$r")
  direct_ns=(); inverse_ns=()
  [ "$transport" = dds ] || { direct_ns=(ip netns exec "$NETNS_A"); inverse_ns=(ip netns exec "$NETNS_B"); }
  "${inverse_ns[@]}" "$bin/inverse_sim" run --config "$cfg" --out "$dir/inverse" --mode "$mode" --timeout "$timeout" \
    "${ctl[@]}" ${link_delay:+--link-delay "$link_delay"} --quiet "${dds[@]}" > "$dir/inverse.log" 2>&1 &
  ip=$!; pids=("$ip")
  timeout -s KILL "$timeout" "${direct_ns[@]}" "$bin/direct_sim" run "${common[@]}" --out "$dir/direct" "${dds[@]}" \
    > "$dir/direct.log" 2>&1 &
  dp=$!; pids+=("$dp")
  # a controller that fails at the start (e.g. a scenario key it does not know) would leave
  # direct_sim waiting 30 s for it: stop direct_sim then
  first=""; fcode=0; wait -n -p first "$ip" "$dp" || fcode=$?
  if [ "$first" = "$ip" ] && [ "$fcode" -ne 0 ]; then
    echo "experiment_run: inverse_sim exited $fcode first (see inverse.log): direct_sim stopped" >> "$dir/direct.log"
    kill "$dp" 2>/dev/null || true; wait "$dp" 2>/dev/null || true
    code=$fcode
  elif [ "$first" = "$dp" ]; then code=$fcode
  else wait "$dp" || code=$?
  fi
  # the controller leaves by itself when direct_sim reports the end; give it 5 s
  for _ in $(seq 1 50); do kill -0 "$ip" 2>/dev/null || break; sleep 0.1; done
  kill "$ip" 2>/dev/null || true; wait "$ip" 2>/dev/null || true
  [ "$transport" = dds ] || [ "${loss:-0}" -eq 0 ] || netns_pair_dropped | sed 's/^/experiment_run: /' >> "$dir/direct.log"
fi
pids=()

row="$(row_fields "$dir")"
printf 'experiments: %-14s run %2d (seed %d, E = %s Pa): exit %d, %s\n' "$name" "$r" "$rseed" "$emod" "$code" \
  "$(echo "$row" | awk -F, '{printf "final error %s mm, amplitude %s mm", $2, $3}')"
exit "$code"
