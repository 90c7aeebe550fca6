#!/usr/bin/env bash
# Batch experiments (thesis §5.2): N closed-loop insertions, each with its own breathing seed and
# the patient liver's Young's modulus drawn uniformly within +-13 % of the nominal value (the
# controller's model keeps the nominal one), run in lockstep (reproducible) for every setting:
# prediction on and off, and optionally bevel on/off, 6-DoF Cartesian vs 7-DoF iiwa, the bevel in
# the controller's model too, and the flexible needle (patient and model).
#
#   scripts/experiments.sh [--runs N] [--seed S] [--scenario S.yaml] [--duration S]
#                          [--latency-steps N[,N...] | --mode realtime] [--gain K] [--e-spread F]
#                          [--target-offset D[,D...]]
#                          [--marker-noise S]
#                          [--bevel] [--dof7]
#                          [--model-bevel] [--flexible]
#                          [--settings REGEX] [--no-build] [--transport in_process|dds|two_hosts]
#                          [--loss PCT] [--link-delay S] [--jobs N] [--timeout S]
#                          [--hosts H1,H2,... | --slurm] [--dry-run]
#   scripts/experiments.sh --collect DIR
#   scripts/experiments.sh --replay MARKERS.csv [--horizon 0.1,0.2] [--no-build]
#
# Closed loop: writes results/experiments_<date>/ (or $NSIM_RESULTS_DIR): runs.csv (one row per
# run and setting, ordered by setting, then run), table.txt (mean and std of the final error
# and its amplitude per setting, the paired prediction on - off differences; also printed),
# final_error.png and distance_run0.png, every run's folder SETTING/run_R/, and the batch's
# description: jobs.txt (one job a line: setting, run, seed, E, scenario, controller flags, tab
# separated), batch.txt, scenario_*.yaml, joblog.txt (GNU parallel's, one line per job).
# The default scenario is configs/scenarios/liver_breathing.yaml (the 2656-node patient liver;
# liver_test_coarse.yaml is the 685-node one, faster), the default duration 26 s (the default
# scenario's: its insertion starts at ~8 s, after the exhale-gated preparation; the
# steady-state window, the last 20 %, is 5.2 s, 1.3 breathing periods).
# --latency-steps 1,3,5,10 (a list) is a latency sweep: one batch per latency, in
# DIR/latency_<N>/ (each as above), then DIR/sweep.csv (one row per latency and setting: runs,
# mean, std and worst final error, mean amplitude, failed runs), DIR/sweep.txt (the same as a
# table, with the paired prediction on - off lines of every latency; also printed) and
# DIR/sweep.png (final error and amplitude against latency, one line per setting: prediction on
# and off, 6-DoF and, with --dof7, 7-DoF). `--collect DIR` on a sweep folder rebuilds them.
# --target-offset D moves the scenario's target (shared.target) D mm along the planned path (the
# line from shared.entry through the target; D > 0 deeper), in every setting: how the results
# depend on where the target falls between the needle's trajectory points (spaced
# needle.liver.point_spacing, 13 mm in the default scenario; README, "Where the target falls").
# A list (--target-offset -6,-3,0,3) is a target sweep: one batch per offset in
# DIR/target_<D>mm/, then DIR/sweep.csv, sweep.txt and sweep.png as for a latency sweep, with the
# offset in place of the latency (one list at a time: a latency list or an offset list).
# --mode realtime: every run in realtime mode (both loops on the wall clock, over DDS: --transport
# dds, or two_hosts when given) instead of lockstep: the latency is whatever the machine makes it
# (the controller measures it; no --latency-steps) and runs are not reproducible to the bit.
# --link-delay S (realtime): each controller takes its frames up and writes its targets S
# seconds late (inverse_sim run --link-delay): a slower network, the latency measured all the same.
# Each run is two processes that want a core each: --jobs defaults to one run per two cores. table.txt
# adds per setting what the runs got: the controller's measured frame-to-applied delay (median),
# direct_sim's rate, its step p99 and its steps over the step budget (runs.csv's loop_latency_ms
# is the mean time from a frame's publication to its target's arrival at direct_sim).
# --settings REGEX keeps only the settings whose names match (bash regex, anchored: e.g.
# 'dof7_.*' for the 7-DoF cells alone, 'pred_off' for one setting); the names are pred_on,
# pred_off, bevel_pred_on/off (--bevel), dof7_pred_on/off (--dof7), mbevel_pred_on/off
# (--model-bevel: the patient's bevel on and the controller's model with the same bevel,
# inverse.bevel: patient), flex_pred_on/off (--flexible: the patient's needle flexible and the
# model's the same, inverse.needle: patient) and, with --bevel as well, flex_bevel_pred_on/off
# (both flexible, both beveled).
# --e-spread F: the patient's E is drawn uniformly within E0 (1 +- F), F in [0, 1) (default
# 0.13, the thesis's +-13 %); 0 gives every run the model's nominal E, with the same breathing
# seeds (the draws consume the same random numbers), to take the stiffness error out of a batch.
# --marker-noise S: the tracker's noise on the markers direct_sim publishes, S metres of standard
# deviation per coordinate (tracker.marker_noise in every setting's scenario; default: the
# scenario's, 0 in the default one), seeded by each run's seed.
# --gain K sets the control gains k (eq. 3.9 / A.3) of every setting (the scenarios' default,
# 0.2, serves every latency with controller.compensate_in_flight: README, "Control under
# latency").
#
# How the runs are run: every run is one command, scripts/experiment_run.sh, on one core, and
# GNU parallel (Debian `parallel`, installed by scripts/setup.sh) runs the job list side by side:
#   --transport in_process  (default) direct_sim run --in-process: both loops in one process, no
#                           DDS; the same results as the two-process lockstep run. --loss PCT:
#                           each frame and each target lost with probability PCT % (seeded by
#                           the run's seed; lockstep loss, reproducible to the bit)
#   --transport dds         inverse_sim run + direct_sim run over DDS, each run on its own
#                           partition exp<pid>_<setting>_<run>
#   --transport two_hosts   the same two processes on two "machines" (scripts/two_hosts.sh): each
#                           in a network namespace of its own, joined by a veth pair, one pair
#                           per run; --loss PCT drops PCT % of the packets arriving in each
#                           namespace (default 0). Needs root; this machine only (no --hosts or
#                           --slurm). With --mode realtime: the two-machine realtime cell
#   --jobs N                runs at a time (default: the number of cores, `nproc`; with --hosts:
#                           per host, default one per core of each host)
#   --timeout S             a run still going after S seconds is killed and counted as failed
#                           (default 600); a failed run does not stop the batch
#   --hosts H1,H2           the same jobs over ssh (parallel's --sshlogin; ':' is this machine,
#                           "4/H" runs 4 at a time on H). Every host must reach the others'
#                           paths: the repository, the build ($NSIM_BUILD_DIR) and the results
#                           folder at the same absolute path on every host (a shared file system,
#                           e.g. NFS); nothing is copied. ssh must log in without a prompt.
#                           The build is for its machine's CPU (-march=native): for hosts with
#                           other CPUs configure it with -DNSIM_ARCH=x86-64-v2 (README).
#   --slurm                 runs nothing: writes DIR/experiments.sbatch, a Slurm job array with
#                           one task per line of DIR/jobs.txt (same paths on every node, as for
#                           --hosts; --jobs N limits the tasks running at once), to submit with
#                           `sbatch DIR/experiments.sbatch`; when the array has finished,
#                           `scripts/experiments.sh --collect DIR` makes runs.csv, table.txt, plots
#   --dry-run               writes the batch folder (scenarios, jobs.txt) and prints the parallel
#                           command and the command of every job, without running any
#   --collect DIR           (re)builds runs.csv, table.txt and the plots of DIR from its run folders
#
# --replay: the recorded marker stream is replayed by direct_sim into inverse_sim record over
# DDS (open loop: no robot, no controller), the recording is checked against the stream, and
# the predictors are evaluated on it (inverse_sim predict-eval: LF order 2 with optimized window
# = prediction on, "none" = prediction off).
#
# Exit codes: 0 success (failed runs are counted in table.txt and named at the end), 2 a bad
# option (the message names it), 1 anything else (e.g. GNU parallel or a plot missing).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
runs=22; seed=1; scenario="$root/configs/scenarios/liver_breathing.yaml"; duration=26
latency=1; gain=""; noise=""; noise_given=0; espread=0.13; bevel=0; dof7=0; only=""; build=1; replay=""; horizon="0.1,0.2,0.4"
model_bevel=0; flexible=0; target_offset=""; target_given=0
transport=in_process; transport_given=0; loss=""; link_delay=""; mode=lockstep; latency_given=0; jobs=""; timeout=600; hosts=""; slurm=0; dry_run=0; collect=""
usage() { awk 'NR > 1 && !/^#/ { exit } NR > 1 { sub(/^# ?/, ""); print }' "$0"; }
die() { echo "experiments: $*" >&2; exit 2; }
while [ $# -gt 0 ]; do
  # the options that take a value must have one
  case "$1" in
    --runs|--seed|--scenario|--duration|--latency-steps|--target-offset|--mode|--gain|--e-spread|--marker-noise|--settings|--transport|--loss|--link-delay|--jobs|--timeout|--hosts|--collect|--replay|--horizon)
      [ $# -ge 2 ] || die "option '$1' needs a value (see --help)" ;;
  esac
  case "$1" in
    --runs) runs="$2"; shift 2 ;;
    --seed) seed="$2"; shift 2 ;;
    --scenario) scenario="$(realpath -m "$2")"; shift 2 ;;
    --duration) duration="$2"; shift 2 ;;
    --latency-steps) latency="$2"; latency_given=1; shift 2 ;;
    --target-offset) target_offset="$2"; target_given=1; shift 2 ;;
    --mode) mode="$2"; shift 2 ;;
    --gain) gain="$2"; shift 2 ;;
    --e-spread) espread="$2"; shift 2 ;;
    --marker-noise) noise="$2"; noise_given=1; shift 2 ;;
    --bevel) bevel=1; shift ;;
    --dof7) dof7=1; shift ;;
    --model-bevel) model_bevel=1; shift ;;
    --flexible) flexible=1; shift ;;
    --settings) only="$2"; shift 2 ;;
    --transport) transport="$2"; transport_given=1; shift 2 ;;
    --loss) loss="$2"; shift 2 ;;
    --link-delay) link_delay="$2"; shift 2 ;;
    --jobs) jobs="$2"; shift 2 ;;
    --timeout) timeout="$2"; shift 2 ;;
    --hosts) hosts="$2"; shift 2 ;;
    --slurm) slurm=1; shift ;;
    --dry-run) dry_run=1; shift ;;
    --collect) collect="$(realpath -m "$2")"; shift 2 ;;
    --replay) replay="$(realpath -m "$2")"; shift 2 ;;
    --horizon) horizon="$2"; shift 2 ;;
    --no-build) build=0; shift ;;
    -h|--help) usage; exit 0 ;;
    *) die "unknown option '$1' (see --help)" ;;
  esac
done
[[ "$runs" =~ ^[1-9][0-9]*$ ]] || die "--runs must be a positive integer, got '$runs'"
[[ "$seed" =~ ^[0-9]+$ ]] || die "--seed must be an integer >= 0, got '$seed'"
[[ "$latency" =~ ^[0-9]+(,[0-9]+)*$ ]] \
  || die "--latency-steps must be an integer >= 0 or a comma-separated list of them, got '$latency'"
if ! [[ "$duration" =~ ^([0-9]+\.?[0-9]*|\.[0-9]+)$ ]] || ! awk -v d="$duration" 'BEGIN { exit !(d > 0) }'; then
  die "--duration must be a number of seconds > 0, got '$duration'"
fi
[ -f "$scenario" ] || die "--scenario: no such file: $scenario"
offset_re='[+-]?([0-9]+\.?[0-9]*|\.[0-9]+)'
[ "$target_given" = 0 ] || { [[ "$target_offset" =~ ^$offset_re(,$offset_re)*$ ]] &&
  awk -v l="$target_offset" 'BEGIN { n = split(l, d, ","); for (i = 1; i <= n; i++) if (d[i] < -100 || d[i] > 100) exit 1 }'; } \
  || die "--target-offset must be a number of mm in [-100, 100] or a comma-separated list of them, got '$target_offset'"
[[ "$latency" != *,* || "$target_offset" != *,* ]] \
  || die "one sweep at a time: --latency-steps '$latency' and --target-offset '$target_offset' are both lists"
[ -z "$gain" ] || [[ "$gain" =~ ^(0?\.[0-9]*[1-9][0-9]*|1(\.0*)?)$ ]] \
  || die "--gain must be a number in (0, 1], got '$gain'"
[ "$noise_given" = 0 ] || { [[ "$noise" =~ ^([0-9]+\.?[0-9]*|\.[0-9]+)([eE]-?[0-9]+)?$ ]] &&
  awk -v n="$noise" 'BEGIN { exit !(n <= 0.01) }'; } \
  || die "--marker-noise must be a standard deviation in [0, 0.01] m, got '$noise'"
[[ "$espread" =~ ^(0(\.[0-9]*)?|\.[0-9]+)$ ]] \
  || die "--e-spread must be a fraction in [0, 1), got '$espread'"
case "$transport" in in_process|dds|two_hosts) ;; *) die "--transport must be in_process, dds or two_hosts, got '$transport'" ;; esac
case "$mode" in lockstep|realtime) ;; *) die "--mode must be lockstep or realtime, got '$mode'" ;; esac
if [ "$mode" = realtime ]; then
  [ "$latency_given" = 0 ] || die "--mode realtime measures its latency: no --latency-steps"
  [ "$transport_given" = 0 ] || [ "$transport" != in_process ] || die "--mode realtime runs over DDS: no --transport in_process"
  [ "$transport_given" = 1 ] || transport=dds
  # two processes a run, a core each
  [ -n "$jobs" ] || [ -n "$hosts" ] || jobs=$(( $(nproc) / 2 > 0 ? $(nproc) / 2 : 1 ))
fi
if [ -n "$link_delay" ]; then
  [ "$mode" = realtime ] || die "--link-delay is for --mode realtime (lockstep: --latency-steps)"
  [[ "$link_delay" =~ ^([0-9]+\.?[0-9]*|\.[0-9]+)$ ]] && awk -v d="$link_delay" 'BEGIN { exit !(d <= 10) }' \
    || die "--link-delay must be a number of seconds in [0, 10], got '$link_delay'"
fi
[ -z "$jobs" ] || [[ "$jobs" =~ ^[1-9][0-9]*$ ]] || die "--jobs must be a positive integer, got '$jobs'"
[[ "$timeout" =~ ^[1-9][0-9]*$ ]] || die "--timeout must be a positive integer (seconds), got '$timeout'"
# --hosts: a comma-separated list of parallel sshlogins ([N/][user@]host[:port] or ':')
ssh_logins=()
if [ -n "$hosts" ]; then
  IFS=',' read -ra hl <<< "$hosts"
  [ ${#hl[@]} -gt 0 ] || die "--hosts must list at least one host, got '$hosts'"
  for h in "${hl[@]}"; do
    [[ "$h" =~ ^[^[:space:]\'\"]+$ ]] || die "--hosts: bad host '$h' in '$hosts'"
    ssh_logins+=(--sshlogin "$h")
  done
fi
[ -z "$hosts" ] || [ "$slurm" = 0 ] || die "--hosts and --slurm exclude each other"
if [ -n "$loss" ]; then
  [ "$transport" != dds ] || die "--loss needs --transport two_hosts or in_process (over dds on this machine nothing is lost)"
  [[ "$loss" =~ ^[0-9]+$ ]] && [ "$loss" -le 100 ] || die "--loss must be 0..100 (percent), got '$loss'"
fi
if [ "$transport" = two_hosts ]; then
  [ -z "$hosts" ] && [ "$slurm" = 0 ] || die "--transport two_hosts makes network namespaces on this machine: no --hosts or --slurm"
  [ "$dry_run" = 1 ] || [ "$(id -u)" -eq 0 ] || die "--transport two_hosts needs root (ip netns, nft)"
fi

# ---- the batch's table and plots, from its folder (after the local runs, or --collect) ----
# runs.csv in the order of jobs.txt (setting, then run) whatever order the runs ended in; a run
# without a summary (failed to start, killed by the timeout) is a row "no_summary"
collect_batch() {  # collect_batch DIR
  local dir="$1" e0 espread_pct bseed blatency bmode latency_text
  [[ -f "$dir/jobs.txt" && -f "$dir/batch.txt" ]] \
    || die "--collect: $dir is not a batch folder (no jobs.txt and batch.txt)"
  command -v jq > /dev/null || { echo "experiments: jq is missing: run scripts/setup.sh" >&2; exit 1; }
  meta() { awk -v k="$1" '$1 == k { print $2; exit }' "$dir/batch.txt"; }
  e0="$(meta e0)"; bseed="$(meta seed)"; blatency="$(meta latency_steps)"; bmode="$(meta mode)"
  # batches from before --e-spread have no e_spread line: they used 0.13
  espread_pct="$(awk -v f="$(meta e_spread)" 'BEGIN { printf "%g", 100 * (f == "" ? 0.13 : f) }')"
  echo "setting,run,seed,young_modulus_pa,exit,final_error_mm,final_error_amplitude_mm,min_distance_mm,direct_rate_hz,inverse_rate_hz,loop_latency_ms,nrms_mean_percent,rejected_targets" > "$dir/runs.csv"
  local name r rseed emod _
  while IFS=$'\t' read -r name r rseed emod _; do
    "$root/scripts/experiment_run.sh" row "$dir/$name/run_$r" "$name" "$r" "$rseed" "$emod" >> "$dir/runs.csv"
  done < "$dir/jobs.txt"

  # mean and std per setting over the runs with numbers (a run stopped early, e.g. by the
  # physics watchdog, keeps the final error of its last 20 %); failed = the runs whose exit
  # is not "completed"
  awk -F, 'NR > 1 { n[$1]++; if ($6 != "") { k[$1]++; e[$1] += $6; e2[$1] += $6 * $6; a[$1] += $7; a2[$1] += $7 * $7;
                     if ($12 != "") { m[$1]++; nr[$1] += $12 } } if ($5 != "completed") bad[$1]++; if (!($1 in seen)) { seen[$1] = 1; order[++o] = $1 } }
    function sd(s, s2, c) { return c > 1 ? sqrt((s2 - s * s / c) / (c - 1)) : 0 }
    END { printf "%-16s %5s %22s %22s %12s %7s\n", "setting", "runs", "final error (mm)", "amplitude (mm)", "nRMS (%)", "failed";
          for (i = 1; i <= o; i++) { s = order[i]; c = k[s];
            printf "%-16s %5d %12.3f +- %6.3f %12.3f +- %6.3f %12s %7d\n", s, n[s], c ? e[s] / c : 0, sd(e[s], e2[s], c),
                   c ? a[s] / c : 0, sd(a[s], a2[s], c), m[s] ? sprintf("%.1f", nr[s] / m[s]) : "-", bad[s] + 0 } }' \
    "$dir/runs.csv" > "$dir/table.txt"
  latency_text="lockstep latency $blatency steps"
  [ "$bmode" != realtime ] || latency_text="realtime (latency measured)"
  { echo; echo "mean +- std over runs; final error = mean true tip-to-target distance over the last 20 % of each run,"
    echo "amplitude = its peak-to-peak; patient E uniform in $e0 Pa +-$espread_pct % (seed $bseed), $latency_text"; } >> "$dir/table.txt"
  # realtime: what the runs got from the machine, per setting: the controller's measured
  # frame-to-applied delay, direct_sim's rate and step p99 (summaries), the steps over the step
  # budget (direct/step_times.csv)
  if [ "$bmode" = realtime ]; then
    local name r _ run_dir budget over
    { echo; echo "realtime, per setting, mean over runs [min, max]: measured delay (controller, median ms),"
      echo "direct rate (Hz), direct step p99 (ms), direct steps over the step budget"
      while IFS=$'\t' read -r name r _; do
        run_dir="$dir/$name/run_$r"
        [[ -f "$run_dir/direct/summary.json" && -f "$run_dir/direct/step_times.csv" ]] || continue
        budget=$(jq -r '1e3 * .time_step_s' "$run_dir/direct/summary.json")
        over=$(awk -F, -v b="$budget" 'NR > 1 && $3 > b { n++ } END { print n + 0 }' "$run_dir/direct/step_times.csv")
        jq -r --arg s "$name" --arg over "$over" --slurpfile i <(cat "$run_dir/inverse/summary.json" 2>/dev/null || echo '{}') \
          '[$s, ($i[0].measured_loop_delay_ms.median // "nan"), .direct_rate_hz, .step_time_ms.p99, $over] | map(tostring) | join(" ")' \
          "$run_dir/direct/summary.json"
      done < "$dir/jobs.txt" | awk '{ if (!($1 in n)) order[++o] = $1; n[$1]++
          for (j = 2; j <= 5; j++) { v = $j + 0; s[$1, j] += v; if (n[$1] == 1 || v < lo[$1, j]) lo[$1, j] = v; if (n[$1] == 1 || v > hi[$1, j]) hi[$1, j] = v } }
        END { for (i = 1; i <= o; i++) { k = order[i]; printf "%-16s", k
                for (j = 2; j <= 5; j++) printf "  %.1f [%.1f, %.1f]", s[k, j] / n[k], lo[k, j], hi[k, j]; printf "\n" } }'
    } >> "$dir/table.txt"
  fi
  # prediction on against off, paired by run (same seed and E): mean +- std of the differences,
  # the paired t statistic (|t| > 2.08 is significant at 5 % for 22 runs), the runs where
  # prediction was better, and the change of the mean amplitude
  awk -F, 'NR > 1 && $6 != "" { key = $1; sub(/_?pred_(on|off)$/, "", key); if (key == "") key = "base"; side = ($1 ~ /pred_on$/) ? "on" : "off";
                                e[key, side, $2] = $6; a[key, side, $2] = $7; runs[key, $2] = 1; if (!(key in seen)) { seen[key] = 1; order[++o] = key } }
    function stats(v, c,   i, s, s2) { s = 0; s2 = 0; for (i = 1; i <= c; i++) { s += v[i]; s2 += v[i] * v[i] }
      mean = s / c; sdev = c > 1 ? sqrt((s2 - s * s / c) / (c - 1)) : 0; t = sdev > 0 ? mean / (sdev / sqrt(c)) : 0 }
    END { for (i = 1; i <= o; i++) { k = order[i]; c = 0; better = 0; son = 0; soff = 0
            for (kr in runs) { split(kr, p, SUBSEP); if (p[1] != k || !((k, "on", p[2]) in e) || !((k, "off", p[2]) in e)) continue
              c++; de[c] = e[k, "on", p[2]] - e[k, "off", p[2]]; da[c] = a[k, "on", p[2]] - a[k, "off", p[2]]
              son += a[k, "on", p[2]]; soff += a[k, "off", p[2]]; if (da[c] < 0) better++ }
            if (c < 2) continue
            if (!header++) printf "\nprediction on - off, paired by run:\n%-16s %5s %26s %26s %14s %10s\n", "setting", "pairs", "final error diff (mm), t", "amplitude diff (mm), t", "amp. smaller", "mean amp."
            stats(de, c); fe = sprintf("%+.3f +- %.3f, %+.2f", mean, sdev, t)
            stats(da, c); fa = sprintf("%+.3f +- %.3f, %+.2f", mean, sdev, t)
            printf "%-16s %5d %26s %26s %8d of %2d %+9.1f%%\n", k, c, fe, fa, better, c, (soff > 0 ? 100 * (son - soff) / soff : 0) } }' \
    "$dir/runs.csv" >> "$dir/table.txt"
  # the final error split into the model's registration error and the control residual, and
  # the registration error before the skin's and the liver's punctures, along and across the
  # needle, the lateral error the needle arrives with and the robot's drift after it
  # (scripts/error_budget.py), per setting, over the runs that completed
  if [ -x /usr/bin/python3 ]; then
    local budget_lines="" runs_ok
    while read -r n; do
      runs_ok=()
      for r in "$dir/$n"/run_*; do
        [[ -f "$r/direct/timeseries.csv" && -f "$r/inverse/inverse.csv" ]] && runs_ok+=("$r")
      done
      [ ${#runs_ok[@]} -gt 0 ] || continue
      budget_lines+="$(printf '%-16s ' "$n")$(/usr/bin/python3 "$root/scripts/error_budget.py" "${runs_ok[@]}" 2>/dev/null | tail -n 1)"$'\n'
    done < <(cut -f1 "$dir/jobs.txt" | awk '!seen[$0]++')
    [ -z "$budget_lines" ] || printf '\nerror budget (scripts/error_budget.py: shares over the last 20 %% of each run; registration before each puncture; along and across the needle; the arrival and the drift after it):\n%s' "$budget_lines" >> "$dir/table.txt"
  fi
  echo; cat "$dir/table.txt"

  # the final errors of every run, and the distance curves of run 0 of every setting
  local plot_ok=1 n pairs=()
  if [ -x /usr/bin/python3 ] && /usr/bin/python3 -c "import matplotlib" 2>/dev/null; then
    /usr/bin/python3 "$root/scripts/plot_results.py" experiments --runs "$dir/runs.csv" --out "$dir" || plot_ok=0
    while read -r n; do
      [ -f "$dir/$n/run_0/direct/timeseries.csv" ] && pairs+=("$n=$dir/$n/run_0/direct")
    done < <(cut -f1 "$dir/jobs.txt" | awk '!seen[$0]++')
    [ ${#pairs[@]} -eq 0 ] || /usr/bin/python3 "$root/scripts/plot_results.py" compare --out "$dir/distance_run0.png" "${pairs[@]}" || plot_ok=0
  else
    echo "experiments: the plots could not be made: /usr/bin/python3 with matplotlib is missing" >&2
    plot_ok=0
  fi
  local failed
  failed=$(awk -F, 'NR > 1 && $5 != "completed" { printf "%s%s/run_%s (%s)", sep, $1, $2, $5; sep = ", " }' "$dir/runs.csv")
  [ -z "$failed" ] || echo "experiments: runs that did not complete: $failed (their logs: DIR/SETTING/run_R/*.log)"
  echo "experiments: results in $dir"
  [ "$plot_ok" = 1 ]
}

# ---- a sweep: its table and plot, from the batches DIR/latency_<N>/ or DIR/target_<D>mm/ ----
collect_sweep() {  # collect_sweep DIR
  local dir="$1" d v prefix suffix column label unit heading footnote
  if compgen -G "$dir/latency_*" > /dev/null; then
    prefix=latency_; suffix=""; column=latency_steps; label=latency; unit=steps
    heading=latency; footnote="latency in lockstep steps"
  else
    prefix=target_; suffix=mm; column=target_offset_mm; label="target offset"; unit=mm
    heading=offset; footnote="offset = the target moved along the planned path (mm, + deeper)"
  fi
  echo "$column,setting,runs,final_error_mean_mm,final_error_std_mm,final_error_worst_mm,amplitude_mean_mm,amplitude_std_mm,failed" > "$dir/sweep.csv"
  : > "$dir/sweep_pairs.txt"
  # in numeric order of the values (the folder's own path may hold underscores and digits)
  for v in $(ls -d "$dir/$prefix"*"$suffix" | sed "s|.*/$prefix||; s|$suffix\$||" | sort -g); do
    d="$dir/$prefix$v$suffix"
    [ -f "$d/runs.csv" ] || { echo "experiments: $d has no runs.csv (collect it first)" >&2; return 1; }
    awk -F, -v L="$v" 'NR > 1 { n[$1]++; if (!($1 in seen)) { seen[$1] = 1; order[++o] = $1 }
        if ($5 != "completed") bad[$1]++
        if ($6 == "") next
        k[$1]++; e[$1] += $6; e2[$1] += $6 * $6; a[$1] += $7; a2[$1] += $7 * $7
        if (!($1 in w) || $6 > w[$1]) w[$1] = $6 }
      function sd(s, s2, c) { return c > 1 ? sqrt((s2 - s * s / c) / (c - 1)) : 0 }
      END { for (i = 1; i <= o; i++) { s = order[i]; c = k[s]
              printf "%s,%s,%d,%.4f,%.4f,%.4f,%.4f,%.4f,%d\n", L, s, n[s], c ? e[s] / c : 0, sd(e[s], e2[s], c),
                     c ? w[s] : 0, c ? a[s] / c : 0, sd(a[s], a2[s], c), bad[s] + 0 } }' "$d/runs.csv" >> "$dir/sweep.csv"
    if grep -q "^prediction on - off" "$d/table.txt" 2>/dev/null; then
      { echo "$label $v $unit:"; sed -n '/^prediction on - off/,$p' "$d/table.txt" | tail -n +2; } >> "$dir/sweep_pairs.txt"
    fi
  done
  {
    awk -F, 'NR == 1 { next } { printf "%7s  %-16s %4d  %7.3f +- %5.3f  %7.3f  %7.3f +- %5.3f  %6d\n", $1, $2, $3, $4, $5, $6, $7, $8, $9 }' \
      "$dir/sweep.csv" | sed "1i $(printf '%-7s' "$heading")  setting          runs  final error (mm)  worst (mm)  amplitude (mm)  failed"
    echo
    echo "final error = mean true tip-to-target distance over the last 20 % of each run, amplitude = its"
    echo "peak-to-peak; mean +- std over runs; worst = the largest final error; $footnote"
    echo
    echo "prediction on - off, paired by run (|t| > 2.08: significant at 5 % for 22 runs):"
    cat "$dir/sweep_pairs.txt"
  } > "$dir/sweep.txt"
  rm -f "$dir/sweep_pairs.txt"
  echo; cat "$dir/sweep.txt"
  if [ -x /usr/bin/python3 ] && /usr/bin/python3 -c "import matplotlib" 2>/dev/null; then
    /usr/bin/python3 "$root/scripts/plot_results.py" sweep --sweep "$dir/sweep.csv" --out "$dir/sweep.png"
  else
    echo "experiments: the sweep plot could not be made: /usr/bin/python3 with matplotlib is missing" >&2
    return 1
  fi
  echo "experiments: sweep results in $dir"
}

if [ -n "$collect" ]; then
  [ -d "$collect" ] || die "--collect: no such folder: $collect"
  if compgen -G "$collect/latency_*" > /dev/null || compgen -G "$collect/target_*mm" > /dev/null \
      && [ ! -f "$collect/jobs.txt" ]; then
    for d in "$collect"/latency_* "$collect"/target_*mm; do
      [ -d "$d" ] || continue
      collect_batch "$d" > /dev/null || true
    done
    collect_sweep "$collect"
  else
    collect_batch "$collect"
  fi
  exit
fi

if [ "$build" = 1 ]; then
  "$root/scripts/setup.sh"
  "$root/scripts/build.sh" >/dev/null
fi
bin="${NSIM_BUILD_DIR:-$root/build}/bin"
bin="$(realpath -m "$bin")"
out="${NSIM_RESULTS_DIR:-$root/results/experiments_$(date +%Y%m%d_%H%M%S)}"
mkdir -p "$out"; out="$(realpath "$out")"

# ---- a sweep (latencies or target offsets): this script once per value, then the sweep's table
# and plot ----
if [[ "$latency" == *,* || "$target_offset" == *,* ]]; then
  [ -z "$replay" ] || die "--replay takes no latency or target-offset list"
  [ "$slurm" = 0 ] && [ "$dry_run" = 0 ] || die "a sweep runs its batches here: no --slurm or --dry-run (run one batch per value instead)"
  sub=(--runs "$runs" --seed "$seed" --scenario "$scenario" --duration "$duration" --e-spread "$espread"
       --transport "$transport" --timeout "$timeout" --no-build)
  [ -z "$loss" ] || sub+=(--loss "$loss")
  [ -z "$gain" ] || sub+=(--gain "$gain")
  [ -z "$noise" ] || sub+=(--marker-noise "$noise")
  [ "$bevel" = 0 ] || sub+=(--bevel)
  [ "$dof7" = 0 ] || sub+=(--dof7)
  [ "$model_bevel" = 0 ] || sub+=(--model-bevel)
  [ "$flexible" = 0 ] || sub+=(--flexible)
  [ -z "$only" ] || sub+=(--settings "$only")
  [ -z "$jobs" ] || sub+=(--jobs "$jobs")
  [ -z "$hosts" ] || sub+=(--hosts "$hosts")
  # the swept option, its values, and each value's folder
  if [[ "$latency" == *,* ]]; then
    [ -z "$target_offset" ] || sub+=(--target-offset "$target_offset")
    swept=--latency-steps; IFS=',' read -ra values <<< "$latency"
    folder() { echo "$out/latency_$1"; }
    echo "experiments: latency sweep over ${values[*]} steps; results in $out"
  else
    if [ "$mode" = lockstep ]; then sub+=(--latency-steps "$latency"); else sub+=(--mode "$mode"); fi
    [ -z "$link_delay" ] || sub+=(--link-delay "$link_delay")
    swept=--target-offset; IFS=',' read -ra values <<< "$target_offset"
    folder() { echo "$out/target_$(awk -v v="$1" 'BEGIN { printf "%+g", v }')mm"; }
    echo "experiments: target sweep over ${values[*]} mm along the planned path; results in $out"
  fi
  for v in "${values[@]}"; do
    d="$(folder "$v")"
    NSIM_RESULTS_DIR="$d" "$0" "${sub[@]}" "$swept" "$v" \
      || echo "experiments: the batch in $d ended with an error" >&2
  done
  collect_sweep "$out"
  exit
fi

pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  for p in "${pids[@]}"; do wait "$p" 2>/dev/null || true; done
}
trap cleanup EXIT
trap 'echo "experiments: interrupted"; exit 130' INT TERM

# ---- open-loop replay of a recorded marker stream ----
if [ -n "$replay" ]; then
  [ -f "$replay" ] || die "--replay: no such marker stream: $replay"
  # a 3 s liveliness lease, as in scripts/experiment_run.sh (a loaded machine)
  dds=(--dds-config "$root/configs/dds/local.xml" --domain "${NSIM_DOMAIN:-0}" --lease 3)
  echo "experiments: replaying $replay into inverse_sim record (open loop); results in $out"
  part=(--partition "exp$$")
  "$bin/inverse_sim" record --out "$out/recorded.csv" --summary "$out/record_summary.json" \
    --timeout 900 "${dds[@]}" "${part[@]}" > "$out/record.log" 2>&1 &
  rec=$!; pids+=("$rec")
  timeout -s KILL 900 "$bin/direct_sim" replay --markers "$replay" --rate-scale "${NSIM_RATE_SCALE:-4}" \
    "${dds[@]}" "${part[@]}" > "$out/replay.log" 2>&1 &
  rep=$!; pids+=("$rep")
  rep_code=0; wait "$rep" || rep_code=$?
  rec_code=0; wait "$rec" || rec_code=$?
  pids=()
  tail -n 1 "$out/replay.log"; tail -n 1 "$out/record.log"
  [[ "$rep_code" -eq 0 && "$rec_code" -eq 0 ]] || { echo "experiments: replay exit $rep_code, record exit $rec_code" >&2; exit 1; }
  "$bin/inverse_sim" predict-eval --markers "$out/recorded.csv" --horizon "$horizon" --order 2 \
    --optimize-window --filter lf,none --seed "$seed" --out "$out/prediction" > "$out/prediction.log"
  cp "$out/prediction/table.txt" "$out/table.txt"
  cat "$out/table.txt"
  echo "experiments: results in $out"
  exit 0
fi

# ---- closed-loop batch: the settings and the job list ----
# the scenario with absolute mesh paths, and its variants (bevel, iiwa)
# --gain K replaces the controller's gains (position, angle, entry) in every variant
gain_expr=()
[ -z "$gain" ] || gain_expr=(-e "s|^\(  gains:\).*|\1 {position: $gain, angle: $gain, entry: $gain}|")
# --marker-noise S replaces tracker.marker_noise in every variant
[ -z "$noise" ] || gain_expr+=(-e "s|^\(  marker_noise:\) *[^ #]*|\1 $noise|")
# and every variant runs in the batch's mode (run.mode)
gain_expr+=(-e "s|^\(  mode:\).*|\1 $mode|")
# --target-offset D moves shared.target D mm along the line from shared.entry through it
moved_target=""
if [ -n "$target_offset" ]; then
  moved_target=$(awk -v d="$target_offset" '
    /^shared:/ { s = 1; next } s && /^[^ #]/ { s = 0 }
    s && /^  (target|entry):/ { k = $1; sub(/:$/, "", k); v = $0; sub(/^[^[]*\[/, "", v); sub(/\].*$/, "", v)
                                if (split(v, c, ",") == 3) { p[k, 1] = c[1] + 0; p[k, 2] = c[2] + 0; p[k, 3] = c[3] + 0; got[k] = 1 } }
    END { if (!got["target"] || !got["entry"]) exit 1
          n = 0; for (i = 1; i <= 3; i++) { u[i] = p["target", i] - p["entry", i]; n += u[i] * u[i] }
          if (n <= 0) exit 1
          n = sqrt(n); if (d / 1000 <= -n) { printf "%.1f", 1000 * n; exit 2 }
          printf "[%.6f, %.6f, %.6f]", p["target", 1] + d / 1000 * u[1] / n,
                              p["target", 2] + d / 1000 * u[2] / n, p["target", 3] + d / 1000 * u[3] / n }' "$scenario") \
    || { [ $? = 2 ] && die "--target-offset $target_offset puts the target at or before the entry (the entry is $moved_target mm before the target)"
         die "--target-offset: cannot read shared.target and shared.entry (two different points, '  target: [x, y, z]') from $scenario"; }
  gain_expr+=(-e "/^shared:/,/^[^ #]/ s|^  target:.*|  target: $moved_target   # moved $target_offset mm along the planned path (m)|")
fi
variant() {  # variant NAME SED-EXPRESSION...
  local name="$1"; shift
  local dir; dir="$(dirname "$scenario")"
  sed -e "s|\.\./meshes/|$(realpath "$dir/../meshes")/|g" "$@" "${gain_expr[@]}" "$scenario" > "$out/scenario_$name.yaml"
  if [ -n "$gain" ] && ! grep -q "^  gains: {position: $gain," "$out/scenario_$name.yaml"; then
    die "cannot set the gains in $scenario (no '  gains:' line)"
  fi
  if [ -n "$moved_target" ] && ! grep -qF "  target: $moved_target " "$out/scenario_$name.yaml"; then
    die "cannot move the target in $scenario (no '  target:' line under 'shared:')"
  fi
  if [ -n "$noise" ] && ! grep -q "^  marker_noise: $noise\( \|$\)" "$out/scenario_$name.yaml"; then
    die "cannot set the marker noise in $scenario (no '  marker_noise:' line under 'tracker:')"
  fi
  echo "$out/scenario_$name.yaml"
}
base="$(variant base)"
grep -q "^  mode: $mode" "$base" || die "cannot set run.mode to $mode in $scenario (no '  mode:' line)"
settings=("pred_on|$base|--prediction on" "pred_off|$base|--prediction off")
if [ "$bevel" = 1 ]; then
  bev="$(variant bevel -e 's|^\(  bevel: {enabled:\) false|\1 true|')"
  grep -q "bevel: {enabled: true" "$bev" || die "cannot turn the bevel on in $scenario"
  settings+=("bevel_pred_on|$bev|--prediction on" "bevel_pred_off|$bev|--prediction off")
fi
# the controller's model: the patient's bevel and needle (a line after `inverse:`)
model_bevel_expr=(-e 's|^inverse:.*$|&\n  bevel: patient|')
model_needle_expr=(-e 's|^inverse:.*$|&\n  needle: patient|')
flexible_expr=(-e 's|^\(  type:\) rigid |\1 flexible |')
if [ "$model_bevel" = 1 ]; then
  mbev="$(variant mbevel -e 's|^\(  bevel: {enabled:\) false|\1 true|' \
    "${model_bevel_expr[@]}")"
  grep -q "^  bevel: patient" "$mbev" || die "cannot give the model the bevel in $scenario (no 'inverse:' line)"
  settings+=("mbevel_pred_on|$mbev|--prediction on" "mbevel_pred_off|$mbev|--prediction off")
fi
if [ "$flexible" = 1 ]; then
  flex="$(variant flex "${flexible_expr[@]}" "${model_needle_expr[@]}")"
  grep -q "^  type: flexible" "$flex" || die "cannot make the needle flexible in $scenario (no '  type: rigid' line)"
  settings+=("flex_pred_on|$flex|--prediction on" "flex_pred_off|$flex|--prediction off")
  if [ "$bevel" = 1 ]; then
    fbev="$(variant flex_bevel -e 's|^\(  bevel: {enabled:\) false|\1 true|' \
      "${flexible_expr[@]}" "${model_needle_expr[@]}" "${model_bevel_expr[@]}")"
    settings+=("flex_bevel_pred_on|$fbev|--prediction on" "flex_bevel_pred_off|$fbev|--prediction off")
  fi
fi
if [ "$dof7" = 1 ]; then
  iiwa="$(variant iiwa -e 's|^\(  type:\) cartesian |\1 iiwa |')"
  grep -q "^  type: iiwa" "$iiwa" || die "cannot switch to the iiwa in $scenario"
  settings+=("dof7_pred_on|$iiwa|--prediction on --dof joint7" "dof7_pred_off|$iiwa|--prediction off --dof joint7")
fi
if [ -n "$only" ]; then
  kept=()
  for s in "${settings[@]}"; do [[ "${s%%|*}" =~ ^($only)$ ]] && kept+=("$s"); done
  [ ${#kept[@]} -gt 0 ] || die "--settings '$only' matches none of: $(for s in "${settings[@]}"; do printf '%s ' "${s%%|*}"; done)"
  settings=("${kept[@]}")
fi
e0=$(awk '/^  liver:/{l=1} l&&/young_modulus:/{print $2; exit}' "$scenario")
h=$(awk '/^patient:/{p=1} p&&/time_step:/{print $2; exit}' "$scenario")
[[ -n "$e0" && -n "$h" ]] || die "cannot read patient.liver.young_modulus and patient.time_step from $scenario"
# the controller's localization delay: the lockstep latency (steps x h), unless the scenario
# has the controller measure the loop latency itself (prediction.measure_latency: true; its
# localization_delay is then a tracker's own delay, on top of the measured one)
# realtime has no step latency: the scenario's localization delay, or its measurement
delay=$(awk -v n="$latency" -v h="$h" 'BEGIN{print n*h}')
if awk '/^prediction:/{p=1; next} /^[^ #]/{p=0} p && /^  measure_latency: *true/{f=1} END{exit !f}' "$scenario"; then
  delay=""
elif [ "$mode" = realtime ]; then
  delay=""
  echo "experiments: $scenario does not measure the loop latency (prediction.measure_latency): the controller predicts over its prediction.localization_delay" >&2
fi
# per run: breathing seed and the patient's Young's modulus, uniform in E0 (1 +- e-spread), seeded
awk -v n="$runs" -v s="$seed" -v e0="$e0" -v f="$espread" 'BEGIN { srand(s); for (r = 0; r < n; r++)
  printf "%d %d %.1f\n", r, s + r, e0 * (1 + f * (2 * rand() - 1)) }' > "$out/draws.txt"
# the job list, one run a line: setting, run, seed, E, scenario, controller flags (tab separated)
for s in "${settings[@]}"; do
  IFS='|' read -r name cfg inv <<< "$s"
  while read -r r rseed emod; do
    printf '%s\t%s\t%s\t%s\t%s\t%s\n' "$name" "$r" "$rseed" "$emod" "$cfg" "$inv"
  done < "$out/draws.txt"
done > "$out/jobs.txt"
njobs=$(wc -l < "$out/jobs.txt")
# what --collect needs besides jobs.txt (the table's footer), and a record of the batch
batch_latency="$latency"; [ "$mode" = lockstep ] || batch_latency=measured
printf '%s %s\n' scenario "$scenario" runs "$runs" seed "$seed" e0 "$e0" e_spread "$espread" mode "$mode" latency_steps "$batch_latency" \
  marker_noise "${noise:-scenario}" target_offset_mm "${target_offset:-0}" \
  duration_s "$duration" transport "$transport" loss_percent "${loss:-0}" link_delay_s "${link_delay:-0}" \
  timeout_s "$timeout" > "$out/batch.txt"

# the one-run command shared by every job (parallel adds the job's six fields as {1}..{6},
# a Slurm task reads them from its line of jobs.txt)
run_cmd=("$root/scripts/experiment_run.sh" run --out "$out" --bin "$bin" --transport "$transport"
         --mode "$mode" --latency-steps "$latency" --duration "$duration" --timeout "$timeout"
         --partition-prefix "exp$$" --domain "${NSIM_DOMAIN:-0}")
[ -z "$delay" ] || run_cmd+=(--localization-delay "$delay")
[ -z "$loss" ] || run_cmd+=(--loss "$loss")
[ -z "$link_delay" ] || run_cmd+=(--link-delay "$link_delay")
[ "$dry_run" = 1 ] || [ -x "$bin/direct_sim" ] || { echo "experiments: no $bin/direct_sim: build first (scripts/build.sh) or set NSIM_BUILD_DIR" >&2; exit 1; }

# ---- --slurm: a job array over jobs.txt, nothing run here ----
if [ "$slurm" = 1 ]; then
  mkdir -p "$out/slurm"
  sb="$out/experiments.sbatch"
  {
    echo "#!/bin/bash"
    echo "# nsim batch ($njobs runs): task i runs line i+1 of jobs.txt with scripts/experiment_run.sh."
    echo "# Submit: sbatch $(printf '%q' "$sb")"
    echo "# When every task has ended: $(printf '%q' "$root/scripts/experiments.sh") --collect $(printf '%q' "$out")"
    echo "#SBATCH --job-name=nsim_experiments"
    echo "#SBATCH --array=0-$((njobs - 1))${jobs:+%$jobs}"
    echo "#SBATCH --cpus-per-task=$([ "$mode" = realtime ] && echo 2 || echo 1)"  # realtime: two processes
    echo "#SBATCH --time=$(( (timeout + 59) / 60 ))"
    echo "#SBATCH --output=$out/slurm/%A_%a.out"
    printf 'job_list=%q\n' "$out/jobs.txt"
    printf 'run_cmd=('; printf ' %q' "${run_cmd[@]}"; printf ' )\n'
    cat <<'EOF'
set -euo pipefail
# this task's job: line SLURM_ARRAY_TASK_ID + 1 of jobs.txt (setting, run, seed, E, scenario, flags)
IFS=$'\t' read -r setting run seed emod config flags < <(sed -n "$((SLURM_ARRAY_TASK_ID + 1))p" "$job_list")
exec "${run_cmd[@]}" "$setting" "$run" "$seed" "$emod" "$config" "$flags"
EOF
  } > "$sb"
  chmod +x "$sb"
  echo "experiments: wrote $sb ($njobs array tasks, one run each, $transport, timeout $timeout s) and $out/jobs.txt"
  echo "experiments: submit it with   sbatch $sb"
  echo "experiments: when it has ended, make the table and plots with   $root/scripts/experiments.sh --collect $out"
  exit 0
fi

# ---- local (or --hosts) batch with GNU parallel ----
command -v parallel > /dev/null \
  || { echo "experiments: GNU parallel is missing: run scripts/setup.sh (it installs Debian's parallel)" >&2; exit 1; }
if [ -z "$jobs" ] && [ -z "$hosts" ]; then jobs="$(nproc)"; fi
par=(parallel --will-cite --halt never --timeout "$timeout" --joblog "$out/joblog.txt" --colsep '\t')
[ -z "$jobs" ] || par+=(--jobs "$jobs")
par+=("${ssh_logins[@]}")
cmd="$(printf '%q ' "${run_cmd[@]}"){1} {2} {3} {4} {5} {6}"
if [ "$dry_run" = 1 ]; then
  echo "experiments: dry run, nothing run; the batch folder is $out"
  echo "parallel command:"
  printf ' %q' "${par[@]}"; printf ' %s :::: %q\n' "${cmd@Q}" "$out/jobs.txt"
  # parallel --dry-run prints them without the ssh part, so ask it on this machine only (with
  # --hosts it would log in to count the cores)
  echo "the jobs' commands ($njobs, from parallel --dry-run${hosts:+; each run through ssh on one of the hosts}):"
  parallel --will-cite --dry-run --colsep '\t' "$cmd" :::: "$out/jobs.txt"
  exit 0
fi
if [ -n "$hosts" ]; then
  # every host must see the build, the scripts and this results folder at the same paths
  # (parallel --nonall runs the test once on every host, --tag prefixes its answer with the host)
  missing=$(parallel --will-cite --nonall --tag "${ssh_logins[@]}" \
            "test -x $(printf %q "$bin/direct_sim") && test -x $(printf %q "${run_cmd[0]}") && test -f $(printf %q "$out/jobs.txt") || echo missing" 2>&1 || true)
  [ -z "$missing" ] || { echo "experiments: --hosts: a host does not see $bin, the scripts or $out at the same path:" >&2; echo "$missing" >&2; exit 1; }
fi

mode_text="lockstep (latency $latency steps)"; [ "$mode" = lockstep ] || mode_text="realtime (latency measured)"
echo "experiments: $runs runs x ${#settings[@]} settings, $mode_text, $duration s each, E0 = $e0 Pa +-$(awk -v f="$espread" 'BEGIN { printf "%g", 100 * f }') %, $transport${loss:+ ($loss % loss)}${link_delay:+ (link delay $link_delay s each way)}, ${jobs:-one per core} at a time${hosts:+ on $hosts}; results in $out"
start=$(date +%s.%N)
pcode=0
"${par[@]}" "$cmd" :::: "$out/jobs.txt" || pcode=$?
# parallel exits with the number of failed runs (101: more than 100), 255 when it was stopped
# (Ctrl-C: it ends the running jobs itself, so bash's INT trap does not fire) or failed itself
if [ "$pcode" -gt 101 ]; then
  echo "experiments: GNU parallel stopped (exit $pcode: interrupted, or its error above); the runs that ended can be tabulated with: $0 --collect $out" >&2
  exit 130
fi
echo "experiments: $njobs runs in $(awk -v a="$start" -v b="$(date +%s.%N)" 'BEGIN { printf "%.1f", b - a }') s wall; parallel exit $pcode (the number of failed runs; joblog.txt)"
collect_batch "$out"
