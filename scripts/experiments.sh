#!/usr/bin/env bash
# Batch experiments (thesis §5.2): N closed-loop insertions, each with its own breathing seed and
# the patient liver's Young's modulus drawn uniformly within +-13 % of the nominal value (the
# controller's model keeps the nominal one), run in lockstep (reproducible) for every setting:
# prediction on and off, and optionally bevel on/off and 6-DoF Cartesian vs 7-DoF iiwa.
#
#   scripts/experiments.sh [--runs N] [--seed S] [--scenario S.yaml] [--duration S]
#                          [--latency-steps N] [--gain K] [--bevel] [--dof7] [--no-build]
#   scripts/experiments.sh --replay MARKERS.csv [--horizon 0.1,0.2] [--no-build]
#
# Closed loop: writes results/experiments_<date>/ (or $NSIM_RESULTS_DIR): runs.csv (one row per
# run and setting), table.txt (mean and std of the final error and its amplitude per setting,
# also printed), final_error.png and distance_<setting>.png (run 0), and every run's folders.
# The default scenario is configs/scenarios/liver_test_coarse.yaml (liver_700 both sides), the
# default duration 20 s (the steady-state window, the last 20 %, is one breathing period).
# --gain K sets the control gains k (eq. 3.9) of every setting: the scenarios' 0.1 suits a
# 1-step latency; with --latency-steps 5 use --gain 0.5 (README, Limitations).
#
# --replay: the recorded marker stream is replayed by direct_sim into inverse_sim record over
# DDS (open loop: no robot, no controller), the recording is checked against the stream, and
# the predictors are evaluated on it (inverse_sim predict-eval: LF order 2 with optimized window
# = prediction on, "none" = prediction off).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
runs=22; seed=1; scenario="$root/configs/scenarios/liver_test_coarse.yaml"; duration=20
latency=1; gain=""; bevel=0; dof7=0; build=1; replay=""; horizon="0.1,0.2,0.4"
usage() { sed -n '2,22p' "$0" | sed 's/^# \{0,1\}//'; }
while [ $# -gt 0 ]; do
  case "$1" in
    --runs) runs="$2"; shift 2 ;;
    --seed) seed="$2"; shift 2 ;;
    --scenario) scenario="$(realpath "$2")"; shift 2 ;;
    --duration) duration="$2"; shift 2 ;;
    --latency-steps) latency="$2"; shift 2 ;;
    --gain) gain="$2"; shift 2 ;;
    --bevel) bevel=1; shift ;;
    --dof7) dof7=1; shift ;;
    --replay) replay="$(realpath "$2")"; shift 2 ;;
    --horizon) horizon="$2"; shift 2 ;;
    --no-build) build=0; shift ;;
    -h|--help) usage; exit 0 ;;
    *) echo "experiments: unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
done
[[ "$runs" =~ ^[1-9][0-9]*$ ]] || { echo "experiments: --runs must be a positive integer, got '$runs'" >&2; exit 2; }
[[ "$seed" =~ ^[0-9]+$ ]] || { echo "experiments: --seed must be an integer >= 0, got '$seed'" >&2; exit 2; }
[[ "$latency" =~ ^[0-9]+$ ]] || { echo "experiments: --latency-steps must be an integer >= 0" >&2; exit 2; }
[ -f "$scenario" ] || { echo "experiments: no such scenario: $scenario" >&2; exit 2; }
[ -z "$gain" ] || [[ "$gain" =~ ^(0?\.[0-9]*[1-9][0-9]*|1(\.0*)?)$ ]] \
  || { echo "experiments: --gain must be a number in (0, 1], got '$gain'" >&2; exit 2; }

if [ "$build" = 1 ]; then
  "$root/scripts/setup.sh"
  "$root/scripts/build.sh" >/dev/null
fi
bin="${NSIM_BUILD_DIR:-$root/build}/bin"
out="${NSIM_RESULTS_DIR:-$root/results/experiments_$(date +%Y%m%d_%H%M%S)}"
mkdir -p "$out"; out="$(realpath "$out")"
# a 3 s liveliness lease: lockstep needs no fast dead-peer detection, and a shorter lease can
# expire on a loaded 2-core machine (measured: both sides declared the other dead at 0.5 s
# while a build ran)
dds=(--dds-config "$root/configs/dds/local.xml" --domain "${NSIM_DOMAIN:-0}" --lease 3)

pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  for p in "${pids[@]}"; do wait "$p" 2>/dev/null || true; done
}
trap cleanup EXIT
trap 'echo "experiments: interrupted"; exit 130' INT TERM

# ---- open-loop replay of a recorded marker stream ----
if [ -n "$replay" ]; then
  [ -f "$replay" ] || { echo "experiments: no such marker stream: $replay" >&2; exit 2; }
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
  [ "$rep_code" -eq 0 ] && [ "$rec_code" -eq 0 ] || { echo "experiments: replay exit $rep_code, record exit $rec_code" >&2; exit 1; }
  "$bin/inverse_sim" predict-eval --markers "$out/recorded.csv" --horizon "$horizon" --order 2 \
    --optimize-window --filter lf,none --seed "$seed" --out "$out/prediction" > "$out/prediction.log"
  cp "$out/prediction/table.txt" "$out/table.txt"
  cat "$out/table.txt"
  echo "experiments: results in $out"
  exit 0
fi

# ---- closed-loop batch ----
# the scenario with absolute mesh paths, and its variants (bevel, iiwa)
# --gain K replaces the controller's gains (position, angle, entry) in every variant
gain_expr=()
[ -z "$gain" ] || gain_expr=(-e "s|^\(  gains:\).*|\1 {position: $gain, angle: $gain, entry: $gain}|")
variant() {  # variant NAME SED-EXPRESSION...
  local name="$1"; shift
  local dir; dir="$(dirname "$scenario")"
  sed -e "s|\.\./meshes/|$(realpath "$dir/../meshes")/|g" "$@" "${gain_expr[@]}" "$scenario" > "$out/scenario_$name.yaml"
  if [ -n "$gain" ] && ! grep -q "^  gains: {position: $gain," "$out/scenario_$name.yaml"; then
    echo "experiments: cannot set the gains in $scenario (no '  gains:' line)" >&2; exit 2
  fi
  echo "$out/scenario_$name.yaml"
}
base="$(variant base -e 's|^\(  mode:\).*|\1 lockstep|')"
settings=("pred_on|$base|--prediction on" "pred_off|$base|--prediction off")
if [ "$bevel" = 1 ]; then
  bev="$(variant bevel -e 's|^\(  bevel: {enabled:\) false|\1 true|')"
  grep -q "bevel: {enabled: true" "$bev" || { echo "experiments: cannot turn the bevel on in $scenario" >&2; exit 2; }
  settings+=("bevel_pred_on|$bev|--prediction on" "bevel_pred_off|$bev|--prediction off")
fi
if [ "$dof7" = 1 ]; then
  iiwa="$(variant iiwa -e 's|^\(  type:\) cartesian |\1 iiwa |')"
  grep -q "^  type: iiwa" "$iiwa" || { echo "experiments: cannot switch to the iiwa in $scenario" >&2; exit 2; }
  settings+=("dof7_pred_on|$iiwa|--prediction on --dof joint7" "dof7_pred_off|$iiwa|--prediction off --dof joint7")
fi
e0=$(awk '/^  liver:/{l=1} l&&/young_modulus:/{print $2; exit}' "$scenario")
h=$(awk '/^patient:/{p=1} p&&/time_step:/{print $2; exit}' "$scenario")
delay=$(awk -v n="$latency" -v h="$h" 'BEGIN{print n*h}')
# per run: breathing seed and the patient's Young's modulus, uniform in E0 (1 +- 0.13), seeded
awk -v n="$runs" -v s="$seed" -v e0="$e0" 'BEGIN { srand(s); for (r = 0; r < n; r++)
  printf "%d %d %.1f\n", r, s + r, e0 * (1 + 0.13 * (2 * rand() - 1)) }' > "$out/draws.txt"

echo "experiments: $runs runs x ${#settings[@]} settings, lockstep (latency $latency steps), $duration s each, E0 = $e0 Pa +-13 %; results in $out"
echo "setting,run,seed,young_modulus_pa,exit,final_error_mm,final_error_amplitude_mm,min_distance_mm,direct_rate_hz,inverse_rate_hz,loop_latency_ms,nrms_mean_percent,rejected_targets" > "$out/runs.csv"
while read -r r rseed emod; do
  for s in "${settings[@]}"; do
    IFS='|' read -r name cfg inv <<< "$s"
    dir="$out/$name/run_$r"; mkdir -p "$dir"
    part=(--partition "exp$$_${name}_$r")
    # shellcheck disable=SC2086
    "$bin/inverse_sim" run --config "$cfg" --out "$dir/inverse" --mode lockstep --timeout 600 \
      --localization-delay "$delay" $inv --quiet "${dds[@]}" "${part[@]}" > "$dir/inverse.log" 2>&1 &
    ip=$!; pids=("$ip")
    timeout -s KILL 600 "$bin/direct_sim" run --config "$cfg" --out "$dir/direct" --mode lockstep \
      --latency-steps "$latency" --duration "$duration" --seed "$rseed" --young-modulus "$emod" \
      --no-video --quiet "${dds[@]}" "${part[@]}" > "$dir/direct.log" 2>&1 &
    dp=$!; pids+=("$dp")
    dcode=0; wait "$dp" || dcode=$?
    for _ in $(seq 1 50); do kill -0 "$ip" 2>/dev/null || break; sleep 0.1; done
    kill "$ip" 2>/dev/null || true; wait "$ip" 2>/dev/null || true
    pids=()
    if [ -f "$dir/direct/summary.json" ]; then
      row=$(jq -r --slurpfile i <(cat "$dir/inverse/summary.json" 2>/dev/null || echo '{}') '
        ($i[0] // {}) as $i |
        [.exit, .final_error_mm, .final_error_amplitude_mm, .min_tip_to_target_distance_mm,
         .direct_rate_hz, $i.inverse_rate_hz, .loop_latency_ms.mean,
         (($i.nrms_percent // []) | map(select(. != null)) | if length > 0 then add / length else null end),
         .targets.rejected_total] | map(if . == null then "" else tostring end) | join(",")' \
        "$dir/direct/summary.json")
    else
      row="no_summary,,,,,,,,"
    fi
    echo "$name,$r,$rseed,$emod,$row" >> "$out/runs.csv"
    printf 'experiments: %-14s run %2d (seed %d, E = %s Pa): exit %d, %s\n' "$name" "$r" "$rseed" "$emod" "$dcode" \
      "$(echo "$row" | awk -F, '{printf "final error %s mm, amplitude %s mm", $2, $3}')"
  done
done < "$out/draws.txt"

# mean and std per setting (runs with numbers; failed runs counted)
awk -F, 'NR > 1 { n[$1]++; if ($6 != "") { k[$1]++; e[$1] += $6; e2[$1] += $6 * $6; a[$1] += $7; a2[$1] += $7 * $7;
                   if ($12 != "") { m[$1]++; nr[$1] += $12 } } else bad[$1]++; if (!($1 in seen)) { seen[$1] = 1; order[++o] = $1 } }
  function sd(s, s2, c) { return c > 1 ? sqrt((s2 - s * s / c) / (c - 1)) : 0 }
  END { printf "%-16s %5s %22s %22s %12s %7s\n", "setting", "runs", "final error (mm)", "amplitude (mm)", "nRMS (%)", "failed";
        for (i = 1; i <= o; i++) { s = order[i]; c = k[s];
          printf "%-16s %5d %12.3f +- %6.3f %12.3f +- %6.3f %12s %7d\n", s, n[s], c ? e[s] / c : 0, sd(e[s], e2[s], c),
                 c ? a[s] / c : 0, sd(a[s], a2[s], c), m[s] ? sprintf("%.1f", nr[s] / m[s]) : "-", bad[s] + 0 } }' \
  "$out/runs.csv" > "$out/table.txt"
{ echo; echo "mean +- std over runs; final error = mean true tip-to-target distance over the last 20 % of each run,"
  echo "amplitude = its peak-to-peak; patient E uniform in $e0 Pa +-13 % (seed $seed), lockstep latency $latency steps"; } >> "$out/table.txt"
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
  "$out/runs.csv" >> "$out/table.txt"
echo; cat "$out/table.txt"

plot_ok=1
if [ -x /usr/bin/python3 ] && /usr/bin/python3 -c "import matplotlib" 2>/dev/null; then
  /usr/bin/python3 "$root/scripts/plot_results.py" experiments --runs "$out/runs.csv" --out "$out" || plot_ok=0
  pairs=()
  for s in "${settings[@]}"; do n="${s%%|*}"; [ -f "$out/$n/run_0/direct/timeseries.csv" ] && pairs+=("$n=$out/$n/run_0/direct"); done
  [ ${#pairs[@]} -gt 0 ] && { /usr/bin/python3 "$root/scripts/plot_results.py" compare --out "$out/distance_run0.png" "${pairs[@]}" || plot_ok=0; }
else
  echo "experiments: the plots could not be made: /usr/bin/python3 with matplotlib is missing" >&2
  plot_ok=0
fi
echo "experiments: results in $out"
[ "$plot_ok" = 1 ]
