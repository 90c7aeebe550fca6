#!/usr/bin/env bash
# The replay demo (formerly scripts/run.sh): installs missing packages, builds, then the bundled
# breathing marker stream is replayed by direct_sim and recorded by inverse_sim over DDS on
# this machine, the recording is compared with the stream, and the marker prediction filters
# are evaluated on the recording; writes results/replay_<date>/.
#
#   scripts/replay_demo.sh [MARKERS.csv]      (default: configs/markers/breathing_demo.csv)
#   NSIM_RATE_SCALE=1 scripts/replay_demo.sh  (replay at the recorded pace; default 4x faster)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/scripts/setup.sh"
"$root/scripts/build.sh" >/dev/null
bin="${NSIM_BUILD_DIR:-$root/build}/bin"

markers="${1:-$root/configs/markers/breathing_demo.csv}"
rate_scale="${NSIM_RATE_SCALE:-4}"
out="${NSIM_RESULTS_DIR:-$root/results/replay_$(date +%Y%m%d_%H%M%S)}"
mkdir -p "$out"
dds=(--dds-config "$root/configs/dds/local.xml" --domain "${NSIM_DOMAIN:-0}" --partition "run$$")

pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; }
trap cleanup EXIT INT TERM

echo "run: replaying $markers at ${rate_scale}x into inverse_sim record; results in $out"
"$bin/inverse_sim" record --out "$out/recorded.csv" --summary "$out/record_summary.json" \
  --timeout 3600 "${dds[@]}" > "$out/record.log" 2>&1 &
pids+=($!); rec=$!
"$bin/direct_sim" replay --markers "$markers" --rate-scale "$rate_scale" "${dds[@]}" \
  2>&1 | tee "$out/replay.log"
rec_code=0; wait "$rec" || rec_code=$?
echo
tail -n 3 "$out/record.log"
if [ "$rec_code" -ne 0 ]; then echo "run: the recorder failed (exit $rec_code), see $out/record.log"; exit 1; fi
if cmp -s <(tail -n +2 "$markers" | awk -F, '{for(i=1;i<=NF;i++) printf "%.17g%s", $i, (i<NF?",":"\n")}') \
          <(tail -n +2 "$out/recorded.csv" | awk -F, '{for(i=1;i<=NF;i++) printf "%.17g%s", $i, (i<NF?",":"\n")}'); then
  echo "run: the recording equals the replayed stream, value for value"
else
  echo "run: the recording differs from the replayed stream (see $out/record_summary.json)"
  exit 1
fi
echo
echo "run: marker prediction on the recording (inverse_sim predict-eval, order-2 linear filter)"
"$bin/inverse_sim" predict-eval --markers "$out/recorded.csv" --horizon 0.1,0.2,0.4 --order 2 \
  --optimize-window --snr-db 60,40,20 --seed 1 --out "$out/prediction" > "$out/prediction.log"
sed -n '/mean over markers/,/^per marker/p' "$out/prediction.log" | sed '$d'
echo "run: results in $out"
