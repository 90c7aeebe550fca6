#!/usr/bin/env bash
# scripts/error_budget.py on two synthetic runs whose shares are known by construction: the true
# target fixed, the true tip 0.3 mm from it, the model's target offset from the true one by an
# amount that changes at the skin's and the liver's punctures, the model's tip on the true tip.
# A third run is registered to predicted markers (compared at t + horizon). Checks the window's
# shares, the registration before each puncture, the mean over runs (a run
# that never reaches the liver is left out of that stage's mean), the needle's figures of a run
# with the robot's flange (the registration along and across the axis, the arrival, the drift),
# the tip's hold in both livers where the files have it, and bad input (exit 2 naming the file
# and the column).
# Usage: error_budget_test.sh SOURCE_DIR
set -euo pipefail
src="${1:?usage: error_budget_test.sh SOURCE_DIR}"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
fails=0
fail() { echo "FAIL: $*" >&2; fails=$((fails + 1)); }

# make_run DIR SKIN_T LIVER_T: 10 s at 50 Hz; registration offset (along x) 0.001 mm before the
# skin's puncture, 0.1 mm before the liver's, 0.5 mm after it; LIVER_T > 10 never punctures it
make_run() {
  mkdir -p "$1/direct" "$1/inverse"
  /usr/bin/python3 - "$1" "$2" "$3" <<'PY'
import sys
d, skin, liver = sys.argv[1], float(sys.argv[2]), float(sys.argv[3])
with open(d + "/direct/timeseries.csv", "w") as f, open(d + "/inverse/inverse.csv", "w") as g:
    f.write("t,phase,target_x,target_y,target_z,tip_x,tip_y,tip_z\n")
    g.write("answers_seq,sim_time,valid,model_tip_x,model_tip_y,model_tip_z,"
            "model_target_x,model_target_y,model_target_z\n")
    for k in range(1, 501):
        t = round(0.02 * k, 2)
        phase = 2 if t >= liver else 1 if t >= skin else 0
        offset = 0.5e-3 if phase == 2 else 0.1e-3 if phase == 1 else 1e-6
        f.write("%.2f,%d,0.01,0.02,0.03,0.01,0.02,0.0303\n" % (t, phase))
        # every tenth frame unanswered (valid 0, garbage values): must be skipped
        valid = 0 if k % 10 == 0 else 1
        target = (0.01 + offset, 0.02, 0.03) if valid else (9, 9, 9)
        g.write("%d,%.2f,%d,0.01,0.02,0.0303,%.9f,%.9f,%.9f\n" % ((k,) + (t, valid) + target))
PY
}
make_run "$work/a" 1.02 2.02
make_run "$work/b" 3.02 20.0

out="$(/usr/bin/python3 "$src/scripts/error_budget.py" "$work/a" "$work/b")" \
  || fail "two runs: exit $?"
echo "$out"
line_a="$(echo "$out" | grep "^$work/a:")"
line_b="$(echo "$out" | grep "^$work/b:")"
mean="$(echo "$out" | grep '^mean over 2 runs:')"
# run a: final 0.3 mm; registration sqrt(0.5^2) = 0.5 mm along +x; control |(0.5, 0, -0.3)| mm
[[ "$line_a" == *"final 0.300 mm = registration 0.500 mm (model - true: +0.500 +0.000 +0.000 mm), control 0.583 mm; 90 frames"* ]] \
  || fail "run a's window: $line_a"
[[ "$line_a" == *"before the skin's puncture 0.001 mm, before the liver's 0.100 mm" ]] \
  || fail "run a's stages: $line_a"
# run b stays in the skin: 0.1 mm in the window, no liver stage
[[ "$line_b" == *"registration 0.100 mm"* && "$line_b" == *"before the skin's puncture 0.001 mm, before the liver's -" ]] \
  || fail "run b: $line_b"
[[ "$mean" == "mean over 2 runs: final 0.300 mm, registration 0.300 mm, control "*"; registration before the skin's puncture 0.001 mm, before the liver's 0.100 mm" ]] \
  || fail "mean: $mean"

# a run registered to predicted markers: the true target moves along x at 10 mm/s, the model's
# target is where it will be 0.1 s later (predicted 1, horizon 0.1): its registration error is
# 0 when compared at t + horizon (1 mm if it were compared at t); the last 0.1 s has no future
# frame and is left out of the registration, not of the final error
mkdir -p "$work/c/direct" "$work/c/inverse"
/usr/bin/python3 - "$work/c" <<'PY'
import sys
d = sys.argv[1]
with open(d + "/direct/timeseries.csv", "w") as f, open(d + "/inverse/inverse.csv", "w") as g:
    f.write("t,phase,target_x,target_y,target_z,tip_x,tip_y,tip_z\n")
    g.write("answers_seq,sim_time,valid,model_tip_x,model_tip_y,model_tip_z,"
            "model_target_x,model_target_y,model_target_z,predicted,horizon\n")
    for k in range(1, 501):
        t = round(0.02 * k, 2)
        f.write("%.2f,2,%.9f,0.02,0.03,%.9f,0.02,0.0303\n" % (t, 0.01 * t, 0.01 * t))
        g.write("%d,%.2f,1,%.9f,0.02,0.0303,%.9f,0.02,0.03,1,0.1\n"
                % (k, t, 0.01 * (t + 0.1), 0.01 * (t + 0.1)))
PY
line_c="$(/usr/bin/python3 "$src/scripts/error_budget.py" "$work/c")" || fail "predicted run: exit $?"
echo "$line_c"
[[ "$line_c" == *"final 0.300 mm = registration 0.000 mm (model - true: +0.000 +0.000 +0.000 mm), control 0.300 mm; 101 frames"* ]] \
  || fail "predicted run: $line_c"

# a run with the robot's flange: the needle's axis from the flange to the tip is -z; the tip
# reaches the target's depth (less than 0.3 mm ahead) first at t = 2.72 s, 0.2 mm off the axis
# in x; the model's target is 0.3 mm off the true one in x (across the axis) and 0.4 mm in z
# (along it); from 7 s on, the flange and the tip stand 1 mm further in y: the mean flange
# position over the last 20 % (8-10 s) is 1 mm from that over the 4 s after the arrival
mkdir -p "$work/d/direct" "$work/d/inverse"
/usr/bin/python3 - "$work/d" <<'PY'
import sys
d = sys.argv[1]
with open(d + "/direct/timeseries.csv", "w") as f, open(d + "/inverse/inverse.csv", "w") as g:
    f.write("t,phase,target_x,target_y,target_z,tip_x,tip_y,tip_z,robot_x,robot_y,robot_z\n")
    g.write("answers_seq,sim_time,valid,model_tip_x,model_tip_y,model_tip_z,"
            "model_target_x,model_target_y,model_target_z\n")
    for k in range(1, 501):
        t = round(0.02 * k, 2)
        phase = 2 if t >= 1 else 1 if t >= 0.5 else 0
        tip = (0.0102, 0.021 if t >= 7 else 0.02, 0.03 + max(0.0, 2.01 - (t - 1)) * 1e-3)
        f.write("%.2f,%d,0.01,0.02,0.03,%.9f,%.9f,%.9f,%.9f,%.9f,%.9f\n"
                % ((t, phase) + tip + (tip[0], tip[1], tip[2] + 0.13)))
        g.write("%d,%.2f,1,%.9f,%.9f,%.9f,0.0103,0.02,0.0304\n" % ((k, t) + tip))
PY
line_d="$(/usr/bin/python3 "$src/scripts/error_budget.py" "$work/d")" || fail "run with the flange: exit $?"
echo "$line_d"
[[ "$line_d" == *"final 1.020 mm = registration 0.500 mm"* && "$line_d" == *"; registration axial 0.400 mm, lateral 0.300 mm; arrival 2.72 s, 0.200 mm off the axis; drift after it 1.000 mm" ]] \
  || fail "run with the flange: $line_d"
# the same run cut at 6 s: its window (4.8-6 s) overlaps the 4 s after the arrival, no drift
/usr/bin/python3 - "$work/d" <<'PY'
import sys
for name in ("/direct/timeseries.csv", "/inverse/inverse.csv"):
    path = sys.argv[1] + name
    lines = open(path).read().splitlines()
    keep = [lines[0]] + [l for l in lines[1:] if float(l.split(",")[0 if "direct" in name else 1]) <= 6.0]
    open(path, "w").write("\n".join(keep) + "\n")
PY
line_e="$(/usr/bin/python3 "$src/scripts/error_budget.py" "$work/d")" || fail "short run: exit $?"
[[ "$line_e" == *"arrival 2.72 s, 0.200 mm off the axis; drift after it -" ]] || fail "short run: $line_e"

# the tip's hold in both livers (liver_tip_hold, model_tip_hold), added to run a's files: over
# the window (8-10 s, 90 answered frames) the model's holds 1 until 9 s, 0.4 until 9.5 s and 0.45
# after (one switch: the step of 0.05 is not one), the patient's 0.25 throughout
make_run "$work/h" 1.02 2.02
/usr/bin/python3 - "$work/h" <<'PY'
import sys
d = sys.argv[1]
def add_column(path, name, time_column, value):  # value(t) appended to each row
    lines = open(path).read().splitlines()
    rows = [l + "," + value(float(l.split(",")[time_column])) for l in lines[1:]]
    open(path, "w").write("\n".join([lines[0] + "," + name] + rows) + "\n")
add_column(d + "/direct/timeseries.csv", "liver_tip_hold", 0, lambda t: "0.25")
add_column(d + "/inverse/inverse.csv", "model_tip_hold", 1,
           lambda t: "1" if t < 9.0 else "0.4" if t < 9.5 else "0.45")
PY
cp -r "$work/h" "$work/h2"
sed -i 's/,0\.25$/,0.75/' "$work/h2/direct/timeseries.csv"
out_h="$(/usr/bin/python3 "$src/scripts/error_budget.py" "$work/h" "$work/h2")" || fail "runs with the hold: exit $?"
echo "$out_h"
line_h="$(echo "$out_h" | grep "^$work/h:")"
[[ "$line_h" == *"; tip hold model 0.71 (1 switches), patient 0.25" ]] || fail "run with the hold: $line_h"
[[ "$(echo "$out_h" | grep '^mean over 2 runs:')" == *"; tip hold model 0.71 (1 switches), patient 0.50" ]] \
  || fail "the hold's mean over runs: $out_h"
# without the columns (runs a, b) nothing is said of the hold
[[ "$out" != *"tip hold"* ]] || fail "a hold printed for runs without the columns: $out"

# bad input: a missing phase column, a missing file
sed -i '1s/phase/stage/' "$work/b/direct/timeseries.csv"
if msg="$(/usr/bin/python3 "$src/scripts/error_budget.py" "$work/b" 2>&1)"; then
  fail "no phase column: exit 0"
else
  [ $? = 2 ] && [[ "$msg" == *timeseries.csv*"no column phase"* ]] || fail "no phase column: $msg"
fi
rm "$work/a/inverse/inverse.csv"
if msg="$(/usr/bin/python3 "$src/scripts/error_budget.py" "$work/a" 2>&1)"; then
  fail "missing inverse.csv: exit 0"
else
  [ $? = 2 ] && [[ "$msg" == *"inverse.csv: missing"* ]] || fail "missing inverse.csv: $msg"
fi

[ "$fails" = 0 ] && echo "error_budget_test: passed" || { echo "error_budget_test: $fails failed" >&2; exit 1; }
