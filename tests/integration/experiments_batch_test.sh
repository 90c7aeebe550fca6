#!/usr/bin/env bash
# scripts/experiments.sh's batch description (--dry-run: no simulation runs): the per-run draws
# of the breathing seed and the patient's Young's modulus, --e-spread, --marker-noise, --mode
# realtime, --transport two_hosts and in_process with --loss, --target-offset, and their bad
# values; and --collect's order of a sweep's latencies and target offsets.
# Usage: experiments_batch_test.sh SOURCE_DIR
set -euo pipefail
src="${1:?usage: experiments_batch_test.sh SOURCE_DIR}"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
fails=0
fail() { echo "FAIL: $*" >&2; fails=$((fails + 1)); }

# batch DIR [options...]: a dry-run batch of 12 runs of one setting into DIR
batch() {
  local dir="$1"; shift
  NSIM_RESULTS_DIR="$dir" timeout 60 "$src/scripts/experiments.sh" --runs 12 --seed 7 \
    --settings pred_off --no-build --dry-run "$@" > "$dir.log" 2>&1
}
# column N of jobs.txt in DIR, one value a line
column() { cut -f"$2" "$1/jobs.txt"; }

batch "$work/default" || fail "default batch: exit $? ($(cat "$work/default.log"))"
batch "$work/zero" --e-spread 0 || fail "--e-spread 0: exit $?"
batch "$work/five" --e-spread 0.05 || fail "--e-spread 0.05: exit $?"

e0=$(awk '/^  liver:/{l=1} l&&/young_modulus:/{print $2; exit}' "$src/configs/scenarios/liver_breathing.yaml")
[ "$(wc -l < "$work/default/jobs.txt")" = 12 ] || fail "default: expected 12 jobs"
[ "$(column "$work/default" 3 | tr '\n' ' ')" = "7 8 9 10 11 12 13 14 15 16 17 18 " ] \
  || fail "default: the seeds are not 7..18: $(column "$work/default" 3 | tr '\n' ' ')"
grep -qx 'e_spread 0.13' "$work/default/batch.txt" || fail "default: batch.txt lacks 'e_spread 0.13'"
grep -qx 'e_spread 0' "$work/zero/batch.txt" || fail "--e-spread 0: batch.txt lacks 'e_spread 0'"

# the same seeds whatever the spread; E within E0 (1 +- spread), 0.1 Pa rounding; the same
# random numbers: (E - E0) scales with the spread
paste <(column "$work/default" 3) <(column "$work/zero" 3) <(column "$work/five" 3) \
      <(column "$work/default" 4) <(column "$work/zero" 4) <(column "$work/five" 4) > "$work/all"
awk -v e0="$e0" '
  function abs(x) { return x < 0 ? -x : x }
  $1 != $2 || $1 != $3 { printf "run %d: seeds differ: %s %s %s\n", NR, $1, $2, $3; bad = 1 }
  abs($4 - e0) > 0.13 * e0 + 0.05 { printf "run %d: E %s outside E0 +-13 %%\n", NR, $4; bad = 1 }
  $5 != e0 { printf "run %d: --e-spread 0 gave E %s, not %s\n", NR, $5, e0; bad = 1 }
  abs(($6 - e0) - ($4 - e0) * 0.05 / 0.13) > 0.1 { printf "run %d: --e-spread 0.05 gave E %s, expected %.1f\n", NR, $6, e0 + ($4 - e0) * 0.05 / 0.13; bad = 1 }
  abs($4 - e0) > 0.05 * e0 { wide++ }
  END { if (wide == 0) { print "no default draw beyond +-5 %: not a +-13 % spread"; bad = 1 }; exit bad }' \
  "$work/all" >&2 || fail "the draws (above)"

# refused_args NAMED ARGS...: a batch with ARGS exits 2 with a message that names NAMED
refused_args() {
  local named="$1" rc; shift
  if batch "$work/bad" "$@"; then
    fail "$* was accepted"
  else
    rc=$?
    [ "$rc" = 2 ] || fail "$*: exit $rc, expected 2"
    grep -q -- "$named" "$work/bad.log" || fail "$*: the message does not name $named: $(cat "$work/bad.log")"
  fi
  rm -rf "$work/bad"
}
# refused OPTION VALUE...: each bad value exits 2 with a message that names the option
refused() {
  local option="$1" v; shift
  for v in "$@"; do refused_args "$option" "$option" "$v"; done
}
refused --e-spread 1.5 1 -0.1 abc ''

# --marker-noise: the tracker's noise in the batch's scenario, recorded in batch.txt; the same
# seeds and E draws
batch "$work/noisy" --marker-noise 0.0002 || fail "--marker-noise 0.0002: exit $? ($(cat "$work/noisy.log"))"
grep -q '^  marker_noise: 0.0002 ' "$work/noisy/scenario_base.yaml" \
  || fail "--marker-noise: scenario_base.yaml has $(grep marker_noise "$work/noisy/scenario_base.yaml")"
grep -q '^  marker_noise: 0.0 ' "$work/default/scenario_base.yaml" \
  || fail "default: scenario_base.yaml has $(grep marker_noise "$work/default/scenario_base.yaml")"
grep -qx 'marker_noise 0.0002' "$work/noisy/batch.txt" || fail "--marker-noise: batch.txt lacks 'marker_noise 0.0002'"
cmp -s <(cut -f3,4 "$work/default/jobs.txt") <(cut -f3,4 "$work/noisy/jobs.txt") \
  || fail "--marker-noise changed the seeds or the E draws"
refused --marker-noise -0.001 0.02 abc ''

# --mode realtime: the scenarios' run.mode, DDS, the jobs' command, the same draws; refused with
# a latency or in_process
batch "$work/rt" --mode realtime || fail "--mode realtime: exit $? ($(cat "$work/rt.log"))"
grep -q '^  mode: realtime' "$work/rt/scenario_base.yaml" || fail "--mode realtime: scenario_base.yaml is not realtime"
grep -q '^  mode: lockstep' "$work/default/scenario_base.yaml" || fail "default: scenario_base.yaml is not lockstep"
grep -qx 'mode realtime' "$work/rt/batch.txt" || fail "--mode realtime: batch.txt lacks 'mode realtime'"
grep -qx 'transport dds' "$work/rt/batch.txt" || fail "--mode realtime: not over DDS ($(grep transport "$work/rt/batch.txt"))"
grep -q 'experiment_run.sh run .*--mode realtime' "$work/rt.log" || fail "--mode realtime: the jobs' command does not say realtime"
# run_refused MESSAGE OPTIONS...: one run (experiment_run.sh) with OPTIONS exits 2 with MESSAGE
# before it starts anything
run_refused() {
  local message="$1" rc; shift
  if timeout 20 "$src/scripts/experiment_run.sh" run --out "$work/one" --bin /nonexistent "$@" \
       pred_on 0 1 5500 "$work/rt/scenario_base.yaml" "--prediction on" > "$work/one.log" 2>&1; then
    fail "experiment_run.sh ran with $*"
  else
    rc=$?; [ "$rc" = 2 ] && grep -q -- "$message" "$work/one.log" \
      || fail "experiment_run.sh $*: exit $rc, $(cat "$work/one.log")"
  fi
}
# realtime in one process (lockstep only)
run_refused '--mode realtime needs --transport dds' --mode realtime
cmp -s <(cut -f3,4 "$work/default/jobs.txt") <(cut -f3,4 "$work/rt/jobs.txt") \
  || fail "--mode realtime changed the seeds or the E draws"
refused_args --latency-steps --mode realtime --latency-steps 3
refused_args --transport --mode realtime --transport in_process
refused --mode fast ''
# --link-delay (realtime): the jobs' command and batch.txt carry it; refused in lockstep and out
# of [0, 10] s
batch "$work/ld" --mode realtime --link-delay 0.04 || fail "--link-delay 0.04: exit $? ($(cat "$work/ld.log"))"
grep -q 'experiment_run.sh run .*--link-delay 0.04' "$work/ld.log" || fail "--link-delay: the jobs' command lacks it"
grep -qx 'link_delay_s 0.04' "$work/ld/batch.txt" || fail "--link-delay: batch.txt lacks 'link_delay_s 0.04'"
grep -qx 'link_delay_s 0' "$work/rt/batch.txt" || fail "--mode realtime: batch.txt lacks 'link_delay_s 0'"
refused_args --link-delay --link-delay 0.04
refused_args --link-delay --mode realtime --link-delay 11
refused_args --link-delay --mode realtime --link-delay abc
run_refused '--link-delay is for --mode realtime' --link-delay 0.04

# --transport two_hosts: the jobs' command carries it and the loss, batch.txt records the loss;
# refused: a loss over dds (loopback loses nothing) or out of 0..100, two_hosts with --slurm
batch "$work/th" --transport two_hosts --loss 5 --mode realtime || fail "--transport two_hosts: exit $? ($(cat "$work/th.log"))"
grep -q 'experiment_run.sh run .*--transport two_hosts .*--loss 5 ' "$work/th.log" \
  || fail "--transport two_hosts --loss 5: the jobs' command lacks them"
grep -qx 'loss_percent 5' "$work/th/batch.txt" || fail "--loss 5: batch.txt lacks 'loss_percent 5'"
grep -q '^  mode: realtime' "$work/th/scenario_base.yaml" || fail "--transport two_hosts --mode realtime: not realtime"
refused_args --loss --transport dds --loss 5
refused_args --loss --transport two_hosts --loss 101
refused_args --loss --loss -3
refused_args --slurm --transport two_hosts --slurm
run_refused '--loss needs --transport two_hosts or in_process' --transport dds --loss 5
# in one process: the seeded lockstep loss (direct_sim run --in-process --loss)
batch "$work/ip" --loss 5 || fail "--loss 5 in one process: exit $? ($(cat "$work/ip.log"))"
grep -q 'experiment_run.sh run .*--transport in_process .*--loss 5 ' "$work/ip.log" \
  || fail "--loss 5 in one process: the jobs' command lacks it"
grep -qx 'loss_percent 5' "$work/ip/batch.txt" || fail "--loss 5 in one process: batch.txt lacks 'loss_percent 5'"

# --target-offset D: shared.target moved D mm along the line from shared.entry through it (its
# distance from the old target D mm, on the line: the distance to the entry grows by D), in
# every setting's scenario and nothing else changed; the same draws; refused: out of range, at or
# before the entry, two lists at once
scen="$src/configs/scenarios/liver_breathing.yaml"
point() { awk -v k="$2" '/^shared:/ { s = 1; next } s && /^[^ #]/ { s = 0 }
  s && $1 == k":" { v = $0; sub(/^[^[]*\[/, "", v); sub(/\].*$/, "", v); gsub(/,/, " ", v); print v; exit }' "$1"; }
for d in -6.5 +2; do
  batch "$work/tgt" --target-offset "$d" || fail "--target-offset $d: exit $? ($(cat "$work/tgt.log"))"
  read -r tx ty tz <<< "$(point "$scen" target)"; read -r ex ey ez <<< "$(point "$scen" entry)"
  read -r mx my mz <<< "$(point "$work/tgt/scenario_base.yaml" target)"
  awk -v d="$d" -v tx="$tx" -v ty="$ty" -v tz="$tz" -v ex="$ex" -v ey="$ey" -v ez="$ez" -v mx="$mx" -v my="$my" -v mz="$mz" '
    function abs(x) { return x < 0 ? -x : x }
    BEGIN { moved = sqrt((mx - tx) ^ 2 + (my - ty) ^ 2 + (mz - tz) ^ 2)
            deeper = sqrt((mx - ex) ^ 2 + (my - ey) ^ 2 + (mz - ez) ^ 2) - sqrt((tx - ex) ^ 2 + (ty - ey) ^ 2 + (tz - ez) ^ 2)
            if (abs(moved - abs(d) / 1000) > 2e-6 || abs(deeper - d / 1000) > 2e-6) {
              printf "--target-offset %s: moved %.7f m, deeper by %.7f m\n", d, moved, deeper; exit 1 } }' >&2 \
    || fail "--target-offset $d: the target is not moved along the path (above)"
  grep -qx "target_offset_mm $d" "$work/tgt/batch.txt" || fail "--target-offset $d: batch.txt lacks 'target_offset_mm $d'"
  # (run.mode is the batch's: lockstep)
  cmp -s <(grep -v '^  \(target\|mode\):' "$scen" | sed 's|\.\./meshes/||') \
         <(grep -v '^  \(target\|mode\):' "$work/tgt/scenario_base.yaml" | sed 's|/[^ ]*/meshes/||') \
    || fail "--target-offset $d: the scenario changed beyond the target"
  cmp -s <(cut -f3,4 "$work/default/jobs.txt") <(cut -f3,4 "$work/tgt/jobs.txt") \
    || fail "--target-offset changed the seeds or the E draws"
  rm -rf "$work/tgt"
done
grep -qx 'target_offset_mm 0' "$work/default/batch.txt" || fail "default: batch.txt lacks 'target_offset_mm 0'"
refused --target-offset abc 101 -100.5 '' 1,,2
refused_args 'at or before the entry' --target-offset -60
refused_args 'one sweep at a time' --target-offset 1,2 --latency-steps 1,3

# --collect on a sweep folder (three one-run batches, their summaries made up here) whose own
# path holds underscores and digits: sweep.csv lists the latencies in numeric order
sweep="$work/sweep_2026_12"
for lat in 10 1 3; do
  b="$sweep/latency_$lat"
  mkdir -p "$b/pred_on/run_0/direct"
  printf 'pred_on\t0\t1\t5500\tnone.yaml\t--prediction on\n' > "$b/jobs.txt"
  printf 'e0 5500\nseed 1\ne_spread 0.13\nmode lockstep\nlatency_steps %s\n' "$lat" > "$b/batch.txt"
  echo "{\"exit\": \"completed\", \"final_error_mm\": $lat, \"final_error_amplitude_mm\": 0.1}" \
    > "$b/pred_on/run_0/direct/summary.json"
done
timeout 60 "$src/scripts/experiments.sh" --collect "$sweep" > "$work/sweep.log" 2>&1 \
  || fail "--collect on a sweep: exit $? ($(tail -3 "$work/sweep.log"))"
[ "$(tail -n +2 "$sweep/sweep.csv" 2>/dev/null | cut -d, -f1,4 | tr '\n' ' ')" = "1,1.0000 3,3.0000 10,10.0000 " ] \
  || fail "--collect: sweep.csv is not in the order of the latencies: $(cut -d, -f1,4 "$sweep/sweep.csv" | tr '\n' ' ')"

# and on a target sweep: the offsets in numeric order, signs and decimals included
sweep="$work/target_sweep_1"
for d in +2 -3 +0 -0.5; do
  b="$sweep/target_${d}mm"
  mkdir -p "$b/pred_on/run_0/direct"
  printf 'pred_on\t0\t1\t5500\tnone.yaml\t--prediction on\n' > "$b/jobs.txt"
  printf 'e0 5500\nseed 1\ne_spread 0.13\nmode lockstep\nlatency_steps 3\n' > "$b/batch.txt"
  echo "{\"exit\": \"completed\", \"final_error_mm\": ${d#+}, \"final_error_amplitude_mm\": 0.1}" \
    > "$b/pred_on/run_0/direct/summary.json"
done
timeout 60 "$src/scripts/experiments.sh" --collect "$sweep" > "$work/tsweep.log" 2>&1 \
  || fail "--collect on a target sweep: exit $? ($(tail -3 "$work/tsweep.log"))"
[ "$(head -1 "$sweep/sweep.csv" 2>/dev/null | cut -d, -f1)" = target_offset_mm ] \
  || fail "--collect: a target sweep's sweep.csv starts with $(head -1 "$sweep/sweep.csv" | cut -d, -f1)"
[ "$(tail -n +2 "$sweep/sweep.csv" 2>/dev/null | cut -d, -f1,4 | tr '\n' ' ')" = "-3,-3.0000 -0.5,-0.5000 +0,0.0000 +2,2.0000 " ] \
  || fail "--collect: sweep.csv is not in the order of the offsets: $(cut -d, -f1,4 "$sweep/sweep.csv" | tr '\n' ' ')"

if [ "$fails" -gt 0 ]; then echo "experiments_batch_test: $fails failure(s)" >&2; exit 1; fi
echo "experiments_batch_test: passed"
