#!/usr/bin/env bash
# The closed loop on two "machines" (scripts/two_hosts.sh: a network namespace per process,
# joined by a veth pair) without and with 10 % of the packets dropped on arrival: DDS resends
# what is lost and lockstep keeps the run independent of timing, so both runs end with the same
# final error to the last digit, without a lockstep timeout or a missing frame; so does a third
# run with 10 % loss and DDS Security (--secure, credentials made by scripts/make_credentials.sh).
# A fourth run is realtime (--mode realtime) with 5 % loss: it completes, the controller answers
# frames and measures the loop's delay, and the summary says realtime. Last, a batch of two runs
# on two hosts (scripts/experiments.sh --transport two_hosts, 10 % loss) as in one process.
# Exit 77 (skipped) where network namespaces or nftables are not available.
set -u
build="$1"; src="$2"
dir="$(mktemp -d)"
trap 'rm -rf "$dir"' EXIT
. "$src/scripts/netns_pair.sh"
if ! netns_pair_up "nsimprobe$$" 2>/dev/null; then
  echo "SKIPPED: two network namespaces and a veth pair cannot be made here (needs root)"
  exit 77
fi
netns_pair_down
command -v nft > /dev/null || { echo "SKIPPED: no nft"; exit 77; }

"$src/scripts/make_credentials.sh" --out "$dir/credentials" --days 1 > /dev/null ||
  { echo "FAIL: make_credentials.sh"; exit 1; }
# "10s": 10 % loss, secured
for loss in 0 10 10s; do
  secure=()
  [ "$loss" = 10s ] && secure=(--secure "$dir/credentials")
  NSIM_BUILD_DIR="$build" NSIM_RESULTS_DIR="$dir/loss$loss" NSIM_DOMAIN=43 timeout -s INT 150 \
    "$src/scripts/two_hosts.sh" --no-build --duration 2 --prediction off --loss "${loss%s}" \
    "${secure[@]}" > "$dir/loss$loss.log" 2>&1
  code=$?
  tail -n 4 "$dir/loss$loss.log"
  [ "$code" -eq 0 ] || { cat "$dir/loss$loss.log"; echo "FAIL: two_hosts.sh --loss $loss exited $code"; exit 1; }
done
field() { jq -r "$1" "$dir/loss$2/summary.json"; }
fail=0
for loss in 0 10 10s; do
  [ "$(field .direct_exit $loss)" = completed ] || { echo "FAIL: loss $loss: direct_sim did not complete"; fail=1; }
  [ "$(field .lockstep_timeouts $loss)" = 0 ] || { echo "FAIL: loss $loss: lockstep timeouts $(field .lockstep_timeouts $loss)"; fail=1; }
  [ "$(field .inverse_frames_missing $loss)" = 0 ] || { echo "FAIL: loss $loss: frames missing $(field .inverse_frames_missing $loss)"; fail=1; }
done
dropped=$(grep -o 'packets [0-9]*' "$dir/loss10.log" | awk '{s += $2} END {print s + 0}')
[ "$dropped" -gt 0 ] || { echo "FAIL: the loss rule dropped no packet"; fail=1; }
e0=$(field .final_error_mm 0); e10=$(field .final_error_mm 10); e10s=$(field .final_error_mm 10s)
[ "$e0" = "$e10" ] || { echo "FAIL: final error $e0 mm without loss, $e10 mm with 10 % loss"; fail=1; }
[ "$e0" = "$e10s" ] || { echo "FAIL: final error $e0 mm without loss, $e10s mm secured with 10 % loss"; fail=1; }
[ "$(field .direct.dds_security.identity 10s)" = direct_sim ] &&
  [ "$(field .inverse.dds_security.identity 10s)" = inverse_sim ] ||
  { echo "FAIL: the secured run's summaries do not say DDS Security"; fail=1; }

NSIM_BUILD_DIR="$build" NSIM_RESULTS_DIR="$dir/realtime" NSIM_DOMAIN=43 timeout -s INT 150 \
  "$src/scripts/two_hosts.sh" --no-build --duration 3 --prediction off --loss 5 --mode realtime \
  > "$dir/realtime.log" 2>&1
code=$?
tail -n 4 "$dir/realtime.log"
rt() { jq -r "$1" "$dir/realtime/summary.json"; }
if [ "$code" -ne 0 ] || [ ! -f "$dir/realtime/summary.json" ]; then
  cat "$dir/realtime.log"; echo "FAIL: two_hosts.sh --mode realtime exited $code"; fail=1
else
  [ "$(rt .mode)" = realtime ] && [ "$(rt .direct.mode)" = realtime ] ||
    { echo "FAIL: realtime run: mode $(rt .mode) / $(rt .direct.mode)"; fail=1; }
  [ "$(rt .direct_exit)" = completed ] || { echo "FAIL: realtime run: direct_sim $(rt .direct_exit)"; fail=1; }
  answered=$(rt '.inverse.frames_answered // 0')
  [ "$answered" -gt 50 ] || { echo "FAIL: realtime run: the controller answered $answered frames"; fail=1; }
  [ "$(rt '.loop_latency_ms.count // 0')" -gt 50 ] || { echo "FAIL: realtime run: no loop latency measured"; fail=1; }
  awk -v d="$(rt '.inverse.measured_loop_delay_ms.median // 0')" 'BEGIN { exit !(d > 0 && d < 1000) }' ||
    { echo "FAIL: realtime run: measured loop delay $(rt '.inverse.measured_loop_delay_ms.median')"; fail=1; }
fi

# a batch's runs on two hosts (scripts/experiments.sh --transport two_hosts: a namespace pair
# per run, two runs side by side) with 10 % loss give the in-process runs' results to the last
# digit, and leave no namespace behind
coarse="$src/configs/scenarios/liver_test_coarse.yaml"
for t in in_process two_hosts; do
  loss=(); [ "$t" = two_hosts ] && loss=(--loss 10)
  NSIM_BUILD_DIR="$build" NSIM_RESULTS_DIR="$dir/batch_$t" NSIM_DOMAIN=43 timeout -s INT 150 \
    "$src/scripts/experiments.sh" --runs 2 --seed 3 --duration 2 --scenario "$coarse" \
    --settings pred_off --no-build --jobs 2 --transport "$t" "${loss[@]}" > "$dir/batch_$t.log" 2>&1 ||
    { cat "$dir/batch_$t.log"; echo "FAIL: experiments.sh --transport $t exited $?"; fail=1; }
done
results() { cut -d, -f1-7 "$dir/batch_$1/runs.csv" 2>/dev/null; }
[ "$(results two_hosts | grep -c ',completed,')" = 2 ] && [ "$(results in_process)" = "$(results two_hosts)" ] ||
  { echo "FAIL: the batch on two hosts differs from the in-process one:"; results in_process; results two_hosts; fail=1; }
batch_dropped=$(cat "$dir"/batch_two_hosts/pred_off/run_*/direct.log | grep -o 'dropped: packets [0-9]*' | awk '{s += $3} END {print s + 0}')
[ "$batch_dropped" -gt 0 ] || { echo "FAIL: the batch's loss rules dropped no packet"; fail=1; }
left=$(ip netns list | grep -c '^nx' || true)
[ "$left" = 0 ] || { echo "FAIL: the batch left $left namespaces: $(ip netns list)"; fail=1; }

[ "$fail" -eq 0 ] || exit 1
echo "PASS: final error $e0 mm with and without 10 % loss, secured too ($dropped packets dropped); realtime with 5 % loss: $(rt .inverse.frames_answered) frames answered, loop latency median $(rt .loop_latency_ms.median) ms; a batch on two hosts with 10 % loss as in process ($batch_dropped packets dropped)"
