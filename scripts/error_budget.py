#!/usr/bin/python3
"""The final error of closed-loop runs split into its two shares, over the steady-state window
(the last 20 % of the run, as the final error of summary.json):

  registration  |model target - true target|: where the controller's model places the target
                 against where it is in the patient (the model's registration to the markers,
                 its mesh, its missing boundary conditions and friction)
  control       |model target - model tip|: what the controller leaves of its own objective
  final         |true target - true tip| (the model's tip is the true tip: the rigid needle is
                 placed at the measured flange pose)

Each share is the mean of its distance over the window's answered frames; the mean vector of
the registration error (model - true, mm) shows its direction.

Where the patient's timeseries has the robot's flange (robot_x/y/z, as direct_sim writes it),
the needle's axis at each frame is taken as the direction from the flange to the tip (exact
for a rigid needle whose tool offset lies on its axis, the default scenario's), and three more
figures are printed:

  axial / lateral  the registration error's mean component along the needle's axis (its
                   absolute value) and across it, over the window
  arrival          the first frame in the liver (phase 2) at which the true target is less
                   than 0.3 mm ahead of the tip along the axis: its time and the true target's
                   distance from the axis then (the lateral error the needle arrives with)
  drift            how far the robot's mean flange position moves after the arrival: the mean
                   over the window against the mean over the 4 s from the arrival (a breathing
                   cycle, so the breathing's own motion averages out; "-" when the two
                   overlap); a needle that drags the liver toward an error it cannot remove
                   keeps moving

A frame registered to predicted markers (inverse.csv's `predicted` 1) places the model's target
where the true one will be at t + `horizon`: its registration error compares it with the true
target of the frame at t + horizon (the nearest frame; frames whose t + horizon is past the run
are left out). Without these columns (older runs) every frame compares at t.

Where both files have the tip's lateral hold (direct_sim's `liver_tip_hold`, the controller's
`model_tip_hold`: the fraction of a rigid hold each liver gives its needle's tip, 0 free, 1
rigid; the hold switches on a quarter point spacing past the last trajectory point with
`tip_hold: quarter`), the hold over the window: its mean in the model and in the patient, and
how often the model's switched (consecutive answered frames whose holds differ by 0.5 or more).
A model that holds its tip while the patient's is free (or the other way) places the tissue at
the tip, where the target is, differently from the patient.

Where the registration error comes from in time: the registration error at the last answered
frame before the needle punctures the skin (breathing alone: the markers drive both livers the
same way) and before it punctures the liver (the skin's pull on the liver added), from the
patient's `phase` column (0 outside, 1 in skin, 2 in liver). A run whose needle never reached a
stage prints "-" for it, and the mean over runs takes the runs that did.

usage: scripts/error_budget.py RUN_DIR [RUN_DIR ...]
  RUN_DIR holds direct/timeseries.csv and inverse/inverse.csv (scripts/experiments.sh's
  SETTING/run_R, or the --out / --controller-out folders of direct_sim run --in-process given as
  DIRECT_DIR:INVERSE_DIR). Prints one line per run and the mean over the runs.
Exit code 0, or 2 on bad input (the message names the file)."""

import csv
import math
import os
import sys


def fail(message):
    print("error_budget: " + message, file=sys.stderr)
    sys.exit(2)


def rows(path, keys, optional=()):
    if not os.path.isfile(path):
        fail(path + ": missing")
    with open(path) as f:
        reader = csv.DictReader(f)
        missing = [k for k in keys if k not in (reader.fieldnames or [])]
        if missing:
            fail("%s: no column %s" % (path, ", ".join(missing)))
        keys = list(keys) + [k for k in optional if k in (reader.fieldnames or [])]
        out = []
        for line, row in enumerate(reader, 2):
            try:
                out.append({k: float(row[k]) for k in keys})
            except (TypeError, ValueError):
                fail("%s:%d: expected numbers" % (path, line))
    if not out:
        fail(path + ": no rows")
    return out


def budget(direct_csv, inverse_csv):
    xyz = lambda p: [p + "_" + a for a in "xyz"]
    truth = rows(direct_csv, ["t", "phase"] + xyz("target") + xyz("tip"),
                 optional=xyz("robot") + ["liver_tip_hold"])
    model = rows(inverse_csv, ["sim_time", "valid"] + xyz("model_tip") + xyz("model_target"),
                 optional=("predicted", "horizon", "model_tip_hold"))
    by_time = {round(r["t"], 9): r for r in truth}
    times = [r["t"] for r in truth]
    step = (times[-1] - times[0]) / (len(times) - 1) if len(times) > 1 else 0.0

    def truth_at(t):  # the frame nearest to t on the run's time grid, None past the run
        if step <= 0:
            return by_time.get(round(t, 9))
        k = round((t - times[0]) / step)
        return truth[k] if 0 <= k < len(truth) else None

    has_robot = all(k in truth[0] for k in xyz("robot"))

    def axis(d):  # the needle's unit axis at a patient frame: flange -> tip
        a = [d[k] - d[r] for k, r in zip(xyz("tip"), xyz("robot"))]
        n = math.sqrt(sum(v * v for v in a))
        return [v / n for v in a] if n > 0 else None

    def split(v, n):  # |component along n|, component across n
        along = sum(a * b for a, b in zip(v, n))
        return abs(along), math.sqrt(max(0.0, sum(a * a for a in v) - along * along))

    start = 0.8 * truth[-1]["t"]
    final, registration, control, vector = [], [], [], [0.0, 0.0, 0.0]
    axial, lateral = [], []
    model_hold = []  # the model's tip hold at the window's answered frames
    # the first time the patient's needle is in the skin (phase >= 1) and in the liver (2)
    punctures = [next((r["t"] for r in truth if r["phase"] >= stage), None) for stage in (1, 2)]
    before = [None, None]  # registration error at the last answered frame before each
    for m in model:
        t = round(m["sim_time"], 9)
        if m["valid"] != 1 or t not in by_time:
            continue
        d = by_time[t]
        target = [d[k] for k in xyz("target")]
        model_target = [m[k] for k in xyz("model_target")]
        # the true target where the model's target is meant to be: at t, or at t + horizon
        ahead = d
        if m.get("predicted", 0) == 1 and m.get("horizon", 0) > 0:
            ahead = truth_at(t + m["horizon"])
        registered = None
        if ahead is not None:
            target_then = [ahead[k] for k in xyz("target")]
            registered = 1e3 * math.dist(model_target, target_then)
            for i, when in enumerate(punctures):
                if when is not None and t < when:
                    before[i] = registered
        if t < start:
            continue
        tip = [d[k] for k in xyz("tip")]
        model_tip = [m[k] for k in xyz("model_tip")]
        final.append(1e3 * math.dist(target, tip))
        if "model_tip_hold" in m:
            model_hold.append(m["model_tip_hold"])
        control.append(1e3 * math.dist(model_target, model_tip))
        if registered is not None:
            registration.append(registered)
            for i in range(3):
                vector[i] += 1e3 * (model_target[i] - target_then[i])
            n = axis(ahead) if has_robot else None
            if n is not None:
                a, l = split([1e3 * (m_ - t_) for m_, t_ in zip(model_target, target_then)], n)
                axial.append(a)
                lateral.append(l)
    if not final or not registration:
        fail("%s and %s: no answered frame in the last 20 %% of the run" % (direct_csv, inverse_csv))
    n = len(registration)
    mean = lambda v: sum(v) / len(v)
    needle = None  # (axial, lateral, arrival time, lateral error then, drift), mm and s
    if has_robot and axial:
        arrival = None
        for k, d in enumerate(truth):
            n_ = axis(d)
            if d["phase"] < 2 or n_ is None:
                continue
            e = [1e3 * (d[a] - d[b]) for a, b in zip(xyz("target"), xyz("tip"))]
            if sum(a * b for a, b in zip(e, n_)) < ARRIVAL_AHEAD_MM:
                arrival = (k, d["t"], split(e, n_)[1])
                break
        drift = None
        if arrival is not None:
            cycle = [d for d in truth[arrival[0]:] if d["t"] < arrival[1] + DRIFT_CYCLE_S]
            window = [d for d in truth if d["t"] >= start]
            if window and cycle and cycle[-1]["t"] < start:
                centre = lambda ds: [mean([d[k] for d in ds]) for k in xyz("robot")]
                drift = 1e3 * math.dist(centre(cycle), centre(window))
        needle = (mean(axial), mean(lateral), arrival[1] if arrival else None,
                  arrival[2] if arrival else None, drift)
    hold = None  # (model's mean, patient's mean, the model's switches)
    patient_hold = [d["liver_tip_hold"] for d in truth if d["t"] >= start and "liver_tip_hold" in d]
    if model_hold and patient_hold:
        switches = sum(abs(b - a) >= HOLD_SWITCH for a, b in zip(model_hold, model_hold[1:]))
        hold = (mean(model_hold), mean(patient_hold), switches)
    return (mean(final), mean(registration), mean(control), [v / n for v in vector], len(final),
            before, needle, hold)


ARRIVAL_AHEAD_MM = 0.3  # the target less than this ahead of the tip along the axis: arrived
DRIFT_CYCLE_S = 4.0  # the mean flange position after the arrival: over a breathing cycle
HOLD_SWITCH = 0.5  # consecutive holds that differ by this much: the hold switched


def mm(value):
    return "-" if value is None else "%.3f mm" % value


def needle_text(needle):
    if needle is None:
        return ""
    axial, lateral, when, off, drift = needle
    return ("; registration axial %.3f mm, lateral %.3f mm; arrival %s, %s off the axis; "
            "drift after it %s" % (axial, lateral, "-" if when is None else "%.2f s" % when,
                                   mm(off), mm(drift)))


def hold_text(hold):
    if hold is None:
        return ""
    return "; tip hold model %.2f (%g switches), patient %.2f" % (hold[0], round(hold[2], 1),
                                                                   hold[1])


def main(argv):
    if len(argv) < 2 or argv[1] in ("-h", "--help"):
        print(__doc__)
        return 0 if len(argv) >= 2 else 2
    totals = []
    for arg in argv[1:]:
        if ":" in arg:
            direct_dir, inverse_dir = arg.split(":", 1)
        else:
            direct_dir, inverse_dir = os.path.join(arg, "direct"), os.path.join(arg, "inverse")
        f, r, c, v, n, before, needle, hold = budget(
            os.path.join(direct_dir, "timeseries.csv"), os.path.join(inverse_dir, "inverse.csv"))
        totals.append((f, r, c, before, needle, hold))
        print("%s: final %.3f mm = registration %.3f mm (model - true: %+.3f %+.3f %+.3f mm), "
              "control %.3f mm; %d frames; registration before the skin's puncture %s, "
              "before the liver's %s%s%s" % (arg, f, r, v[0], v[1], v[2], c, n, mm(before[0]),
                                             mm(before[1]), needle_text(needle), hold_text(hold)))
    if len(totals) > 1:
        m = [sum(t[i] for t in totals) / len(totals) for i in range(3)]
        stage = []
        for i in range(2):  # each stage over the runs that reached it
            reached = [t[3][i] for t in totals if t[3][i] is not None]
            stage.append(mm(sum(reached) / len(reached) if reached else None))
        needles = [t[4] for t in totals if t[4] is not None]
        needle = None
        if needles:  # each figure over the runs that have it
            def over(i):
                have = [x[i] for x in needles if x[i] is not None]
                return sum(have) / len(have) if have else None
            needle = tuple(over(i) for i in range(5))
        holds = [t[5] for t in totals if t[5] is not None]
        hold = tuple(sum(h[i] for h in holds) / len(holds) for i in range(3)) if holds else None
        print("mean over %d runs: final %.3f mm, registration %.3f mm, control %.3f mm; "
              "registration before the skin's puncture %s, before the liver's %s%s%s"
              % (len(totals), m[0], m[1], m[2], stage[0], stage[1], needle_text(needle),
                 hold_text(hold)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
