#!/usr/bin/python3
"""Plots of closed-loop results (thesis fig. 5.9: distance from the needle tip to the target over
time; the final error is the mean over the steady-state window, the amplitude its peak-to-peak).

Run with Debian's python3 and matplotlib (python3-matplotlib):

  /usr/bin/python3 scripts/plot_results.py run DIR
      DIR/timeseries.csv + DIR/summary.json (direct_sim, or the merged summary of scripts/run.sh)
      -> DIR/distance.png
  /usr/bin/python3 scripts/plot_results.py compare --out OUT.png LABEL=DIR [LABEL=DIR ...]
      the distance curves of several runs on one plot (e.g. prediction on vs off)
  /usr/bin/python3 scripts/plot_results.py experiments --runs RUNS.csv --out DIR
      RUNS.csv (scripts/experiments.sh: setting,run,final_error_mm,final_error_amplitude_mm,...)
      -> DIR/final_error.png (final error and amplitude per setting, every run a dot)
  /usr/bin/python3 scripts/plot_results.py sweep --sweep SWEEP.csv --out OUT.png
      SWEEP.csv (scripts/experiments.sh --latency-steps 1,3,5,10: latency_steps,setting,runs,
      final_error_mean_mm,final_error_std_mm,final_error_worst_mm,amplitude_mean_mm,...; or
      --target-offset -6,-3,0,3: target_offset_mm in the first column)
      -> OUT.png: final error (mean +- std, worst dotted) and amplitude against the swept value
      (the first column), one line per setting
  /usr/bin/python3 scripts/plot_results.py predict-eval DIR
      DIR/marker<m>.csv + DIR/predict_eval.json (inverse_sim predict-eval, which runs this
      itself) -> DIR/marker<m>.png: the first principal component of the measurement delayed
      by the horizon, the reference and the prediction, above the 3D error with and without
      prediction (thesis figs. 5.3-5.6)

Exit code 0 on success, 2 on bad input (a message names the file), 3 without matplotlib."""

import csv
import json
import os
import sys

try:
    import matplotlib
except ImportError:
    print("plot_results: no matplotlib for " + sys.executable
          + " (apt-get install python3-matplotlib)", file=sys.stderr)
    sys.exit(3)

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def fail(message):
    print("plot_results: " + message, file=sys.stderr)
    sys.exit(2)


def read_timeseries(folder):
    path = os.path.join(folder, "timeseries.csv")
    if not os.path.isfile(path):
        fail(path + ": missing")
    t, d, phase = [], [], []
    with open(path) as f:
        reader = csv.DictReader(f)
        for key in ("t", "tip_target_distance_m", "phase"):
            if key not in (reader.fieldnames or []):
                fail(path + ": no column '" + key + "'")
        for row in reader:
            t.append(float(row["t"]))
            d.append(1e3 * float(row["tip_target_distance_m"]))
            phase.append(int(row["phase"]))
    if not t:
        fail(path + ": no rows")
    return t, d, phase


def read_summary(folder):
    path = os.path.join(folder, "summary.json")
    if not os.path.isfile(path):
        return {}
    with open(path) as f:
        return json.load(f)


def steady(summary):
    """(window, final error, amplitude) from a direct or merged summary."""
    s = summary.get("direct", summary)
    window = s.get("steady_window_s")
    return window, s.get("final_error_mm"), s.get("final_error_amplitude_mm")


def plot_run(folder):
    t, d, phase = read_timeseries(folder)
    summary = read_summary(folder)
    window, err, amp = steady(summary)
    fig, ax = plt.subplots(figsize=(8, 4.5))
    ax.plot(t, d, color="tab:blue", lw=1.5, label="tip to target")
    for p, name, color in ((1, "skin punctured", "tab:orange"), (2, "liver punctured", "tab:red")):
        times = [ti for ti, ph in zip(t, phase) if ph >= p]
        if times:
            ax.axvline(times[0], color=color, ls=":", lw=1, label=name)
    if window and err is not None:
        ax.axvspan(window[0], window[1], color="0.9", label="steady-state window")
        ax.hlines(err, window[0], window[1], color="k", lw=1.2,
                  label="final error %.2f mm (amplitude %.2f mm)" % (err, amp))
    settings = summary.get("settings", {})
    inverse = settings.get("inverse") or {}
    title = "Distance to target"
    prediction = inverse.get("prediction", settings.get("prediction"))
    if prediction is not None:
        title += " - prediction %s" % ("on" if prediction else "off")
    if "mode" in settings:
        title += ", %s" % settings["mode"]
    ax.set_title(title)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("distance (mm)")
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend(loc="upper right", fontsize=8)
    # inset: the steady-state window magnified (the breathing residual)
    if window and err is not None:
        inset = ax.inset_axes([0.45, 0.35, 0.35, 0.3])
        tw = [ti for ti in t if ti >= window[0]]
        dw = d[len(t) - len(tw):]
        inset.plot(tw, dw, color="tab:blue", lw=1)
        inset.set_title("steady state (mm)", fontsize=7)
        inset.tick_params(labelsize=6)
    out = os.path.join(folder, "distance.png")
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print("plot_results: wrote " + out)


def plot_compare(out, pairs):
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for pair in pairs:
        if "=" not in pair:
            fail("expected LABEL=DIR, got '" + pair + "'")
        label, folder = pair.split("=", 1)
        t, d, _ = read_timeseries(folder)
        _, err, amp = steady(read_summary(folder))
        if err is not None:
            label += " (final %.2f mm, amplitude %.2f mm)" % (err, amp)
        ax.plot(t, d, lw=1.2, label=label)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("distance to target (mm)")
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print("plot_results: wrote " + out)


def plot_experiments(runs_csv, out_dir):
    if not os.path.isfile(runs_csv):
        fail(runs_csv + ": missing")
    groups = {}
    with open(runs_csv) as f:
        for row in csv.DictReader(f):
            try:
                err = float(row["final_error_mm"])
                amp = float(row["final_error_amplitude_mm"])
            except (KeyError, ValueError):
                continue  # a failed run (no numbers) is counted in the table, not plotted
            groups.setdefault(row["setting"], []).append((err, amp))
    if not groups:
        fail(runs_csv + ": no run with numbers")
    names = list(groups)
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.5))
    for ax, index, ylabel in ((axes[0], 0, "final error (mm)"),
                              (axes[1], 1, "amplitude (mm)")):
        data = [[v[index] for v in groups[n]] for n in names]
        ax.boxplot(data, labels=names, showmeans=True)
        for i, values in enumerate(data):
            ax.plot([i + 1] * len(values), values, "o", ms=3, alpha=0.5, color="tab:blue")
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
        ax.tick_params(axis="x", labelsize=8, rotation=15)
    fig.suptitle("Final error over the steady-state window (%d runs per setting)"
                 % max(len(g) for g in groups.values()))
    fig.tight_layout()
    out = os.path.join(out_dir, "final_error.png")
    fig.savefig(out, dpi=110)
    print("plot_results: wrote " + out)


def plot_sweep(sweep_csv, out):
    if not os.path.isfile(sweep_csv):
        fail(sweep_csv + ": missing")
    lines = {}
    x_axes = {"latency_steps": ("latency (lockstep steps of 20 ms)", "latency"),
            "target_offset_mm": ("target moved along the planned path (mm, + deeper)",
                                 "the target's depth")}
    with open(sweep_csv) as f:
        reader = csv.DictReader(f)
        swept = (reader.fieldnames or [""])[0]
        if swept not in x_axes:
            fail(sweep_csv + ": the first column must be one of " + ", ".join(x_axes) +
                 ", got '" + swept + "'")
        for row in reader:
            try:
                values = [float(row[k]) for k in (swept, "final_error_mean_mm",
                                                  "final_error_std_mm", "final_error_worst_mm",
                                                  "amplitude_mean_mm", "amplitude_std_mm")]
            except (KeyError, TypeError, ValueError):
                fail(sweep_csv + ": expected numbers in every row")
            if int(row.get("runs", 0) or 0) > int(row.get("failed", 0) or 0):
                lines.setdefault(row["setting"], []).append(values)
    if not lines:
        fail(sweep_csv + ": no setting with numbers")
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.5))
    for i, (name, rows) in enumerate(sorted(lines.items())):
        rows.sort()
        lat = [r[0] for r in rows]
        color = "C%d" % i
        left.errorbar(lat, [r[1] for r in rows], yerr=[r[2] for r in rows], marker="o",
                      capsize=3, color=color, label=name)
        left.plot(lat, [r[3] for r in rows], ":", marker="x", color=color)
        right.errorbar(lat, [r[4] for r in rows], yerr=[r[5] for r in rows], marker="o",
                       capsize=3, color=color, label=name)
    left.set_ylabel("final error (mm): mean +- std, worst dotted")
    right.set_ylabel("amplitude (mm): mean +- std")
    for ax in (left, right):
        ax.set_xlabel(x_axes[swept][0])
        ax.set_ylim(bottom=0)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("Closed loop against " + x_axes[swept][1])
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print("plot_results: wrote " + out)


def read_columns(path, keys):
    """The float columns `keys` of a CSV file."""
    if not os.path.isfile(path):
        fail(path + ": missing")
    columns = {key: [] for key in keys}
    with open(path) as f:
        reader = csv.DictReader(f)
        for key in keys:
            if key not in (reader.fieldnames or []):
                fail(path + ": no column '" + key + "'")
        for line, row in enumerate(reader, 2):
            try:
                for key in keys:
                    columns[key].append(float(row[key]))
            except (TypeError, ValueError):
                fail("%s:%d: expected numbers" % (path, line))
    if not columns[keys[0]]:
        fail(path + ": no rows")
    return columns


def setting_label(s):
    """'lf order 2, no noise, h = 0.16 s' from a setting of predict_eval.json."""
    label = s["filter"] + (" order %d" % s["order"] if s.get("order") is not None else "")
    noise = "no noise" if s.get("snr_db") is None else "%g dB" % s["snr_db"]
    return "%s, %s, h = %g s" % (label, noise, s["horizon_s"])


def plot_predict_eval(folder):
    path = os.path.join(folder, "predict_eval.json")
    if not os.path.isfile(path):
        fail(path + ": missing")
    with open(path) as f:
        report = json.load(f)
    try:
        setting = report["settings"][report.get("plot_setting", 0)]
        markers = setting["markers"]
    except (KeyError, IndexError, TypeError):
        fail(path + ": no settings with markers")
    keys = ("t", "delayed_pc_mm", "reference_pc_mm", "predicted_pc_mm", "error_predicted_mm",
            "error_delayed_mm")
    for m, metrics in enumerate(markers):
        c = read_columns(os.path.join(folder, "marker%d.csv" % m), keys)
        fig, (top, bottom) = plt.subplots(2, 1, figsize=(10, 8), sharex=True)
        top.plot(c["t"], c["delayed_pc_mm"], color="0.65", lw=1, label="measured, delayed by h")
        top.plot(c["t"], c["reference_pc_mm"], color="0.15", lw=1.5, label="reference")
        top.plot(c["t"], c["predicted_pc_mm"], color="tab:blue", lw=1.5, label="prediction")
        top.set_title("marker %d: first principal component (%s)" % (m, setting_label(setting)))
        top.set_ylabel("PC (mm)")
        bottom.plot(c["t"], c["error_delayed_mm"], color="0.65", lw=1, label="no prediction")
        bottom.plot(c["t"], c["error_predicted_mm"], color="tab:red", lw=1, label="prediction")
        bottom.set_title("3D error: prediction RMS %.3f mm, nRMS %.1f %%; no prediction RMS "
                         "%.3f mm" % (metrics["rms_mm"], metrics["nrms_percent"],
                                      metrics["rms_delayed_mm"]))
        bottom.set_xlabel("time (s)")
        bottom.set_ylabel("error (mm)")
        bottom.set_ylim(bottom=0)
        for ax in (top, bottom):
            ax.grid(alpha=0.3)
            ax.legend(loc="upper right", fontsize=8)
        fig.tight_layout()
        out = os.path.join(folder, "marker%d.png" % m)
        fig.savefig(out, dpi=100)
        plt.close(fig)
        print("plot_results: wrote " + out)


def main(argv):
    if len(argv) < 2 or argv[1] in ("-h", "--help"):
        print(__doc__)
        return 0 if len(argv) >= 2 else 2
    cmd = argv[1]
    if cmd == "run" and len(argv) == 3:
        plot_run(argv[2])
    elif cmd == "compare" and len(argv) >= 5 and argv[2] == "--out":
        plot_compare(argv[3], argv[4:])
    elif cmd == "experiments" and len(argv) == 6 and argv[2] == "--runs" and argv[4] == "--out":
        plot_experiments(argv[3], argv[5])
    elif cmd == "sweep" and len(argv) == 6 and argv[2] == "--sweep" and argv[4] == "--out":
        plot_sweep(argv[3], argv[5])
    elif cmd == "predict-eval" and len(argv) == 3:
        plot_predict_eval(argv[2])
    else:
        fail("bad arguments; see --help")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
