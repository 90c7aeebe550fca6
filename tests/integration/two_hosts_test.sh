#!/usr/bin/env bash
# Two "machines": direct_sim replay in one network namespace, inverse_sim record in another,
# joined by a veth pair (10.77.0.1 <-> 10.77.0.2), with the two-machine DDS configuration.
# Exit 77 (skipped) where network namespaces cannot be made here.
set -u
bin="$1"; src="$2"
tag="nsim$$"
. "$src/scripts/netns_pair.sh"
dir="$(mktemp -d)"
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill -9 "$p" 2>/dev/null; done
  netns_pair_down
  rm -rf "$dir"
}
trap cleanup EXIT

if ! netns_pair_up "$tag" 2>/dev/null; then
  echo "SKIPPED: two network namespaces and a veth pair cannot be made here (needs root and CAP_SYS_ADMIN)"
  exit 77
fi
ns1="$NETNS_A"; ns2="$NETNS_B"

# 200 frames, 2 markers, 100 Hz
awk 'BEGIN { print "t,m0_x,m0_y,m0_z,m1_x,m1_y,m1_z";
             for (k = 0; k < 200; k++) { t = k / 100; c = cos(3.14159265 * t / 4);
               printf "%.17g,%.17g,0,%.17g,0.05,%.17g,%.17g\n", t, 0.001 * k, 0.012 * c^4, 0.003 * c^2, 0.01 * c^4 } }' \
  > "$dir/in.csv"

cfg="$src/configs/dds/two_hosts.xml"
common=(--dds-config "$cfg" --domain 41 --partition "$tag")
timeout 60 ip netns exec "$ns2" "$bin/inverse_sim" record --out "$dir/out.csv" --timeout 50 "${common[@]}" \
  > "$dir/record.log" 2>&1 &
pids+=($!); rec=$!
timeout 60 ip netns exec "$ns1" "$bin/direct_sim" replay --markers "$dir/in.csv" --rate-scale 2 \
  --wait-timeout 30 "${common[@]}" > "$dir/replay.log" 2>&1 &
pids+=($!); rep=$!
wait "$rep"; rep_code=$?
wait "$rec"; rec_code=$?
cat "$dir/replay.log" "$dir/record.log"
[ "$rep_code" -eq 0 ] || { echo "FAIL: replay exited $rep_code"; exit 1; }
[ "$rec_code" -eq 0 ] || { echo "FAIL: record exited $rec_code"; exit 1; }
grep -q "received=200 written=200 missing=0 out_of_order=0 invalid=0" "$dir/record.log" \
  || { echo "FAIL: not every frame arrived"; exit 1; }
# value-for-value: both files were written with 17 significant digits
cmp -s <(tail -n +2 "$dir/in.csv" | awk -F, '{for(i=1;i<=NF;i++) printf "%.17g%s", $i, (i<NF?",":"\n")}') \
       <(tail -n +2 "$dir/out.csv" | awk -F, '{for(i=1;i<=NF;i++) printf "%.17g%s", $i, (i<NF?",":"\n")}') \
  || { echo "FAIL: recording differs from the stream"; exit 1; }
echo "PASS: 200 frames crossed the veth link between two namespaces"
