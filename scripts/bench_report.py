#!/usr/bin/python3
"""Merges the Google Benchmark JSON files of scripts/bench.sh (OUT/raw/<label>__<binary>[__k].json)
into OUT/bench.json and writes OUT/bench.md: per benchmark the median over the repetitions of
the time per iteration (wall) and, for step-sequence benchmarks, of the per-step p50/p99/max
counters, beside the baselines of the same run: the floor (one solve with the double factor,
Solve/<size>) and the naive step (refactorize every step, LiverStepRefactorEveryStep/<size>),
and the baseline
build's figures when one was run. With --readme FILE, the goals table (the speed goals of the
issue tracker beside what this run measured) also replaces the text between the lines
<!-- bench:goals:begin --> and <!-- bench:goals:end --> of FILE (the README's performance
section). Standard library only."""

import argparse
import glob
import json
import math
import os
import re
import sys

TO_MS = {"ns": 1e-6, "us": 1e-3, "ms": 1.0, "s": 1e3}
LABELS = ["current", "baseline", "current-2cores", "baseline-2cores"]


def clean_name(run_name):
    """Drops Google Benchmark's suffixes (/iterations:N, /real_time, ...)."""
    return re.sub(r"/(iterations:\d+|real_time|manual_time|min_time:[^/]+|repeats:\d+)", "",
                  run_name)


def load(out):
    runs = []
    for path in sorted(glob.glob(os.path.join(out, "raw", "*.json"))):
        # <label>__<binary>.json, or <label>__<binary>__<k>__r<rep>.json for one repetition of
        # one benchmark of an interleaved run (--baseline)
        label, binary = os.path.basename(path)[:-len(".json")].split("__")[:2]
        try:
            with open(path) as f:
                data = json.load(f)
        except (OSError, ValueError) as e:
            print(f"bench_report: skipping {path}: {e}", file=sys.stderr)
            continue
        runs.append({"label": label, "binary": binary, "context": data.get("context", {}),
                     "benchmarks": data.get("benchmarks", [])})
    return runs


COUNTERS = ("p50_ms", "p99_ms", "max_ms", "over_20ms", "dofs")


def median(values):
    s = sorted(values)
    n = len(s)
    return s[n // 2] if n % 2 else 0.5 * (s[n // 2 - 1] + s[n // 2])


def medians(runs):
    """{label: {name: {"binary", "ms", "p50", "p99", "max", "reps"}}}: the median over the
    repetitions: a file's median aggregate, or its single run without repetitions; several
    files of one benchmark and build (an interleaved run writes one file a repetition) give the
    median of theirs."""
    found = {}  # (label, name) -> [(binary, entry, repetitions)]
    for run in runs:
        with_median = {x.get("run_name") for x in run["benchmarks"]
                       if x.get("aggregate_name") == "median"}
        for b in run["benchmarks"]:
            if b.get("run_type") == "aggregate":
                if b.get("aggregate_name") != "median":
                    continue
            elif b.get("run_name") in with_median:
                continue
            name = clean_name(b.get("run_name", b["name"]))
            found.setdefault((run["label"], name), []).append(
                (run["binary"], b, b.get("repetitions", 1)))
    table = {}
    for (label, name), items in found.items():
        entry = {"binary": items[0][0], "reps": sum(n for _, _, n in items),
                 "ms": median([b["real_time"] * TO_MS[b.get("time_unit", "ns")]
                               for _, b, _ in items])}
        for c in COUNTERS:
            values = [b[c] for _, b, _ in items if c in b]
            if values:
                entry[c] = median(values)
        table.setdefault(label, {})[name] = entry
    return table


def size_of(name):
    m = re.search(r"/(\d{3,6})(?=/|$)", name)
    return m.group(1) if m else None


def fmt_ms(ms):
    if ms is None:
        return "–"
    if ms < 1e-3:
        return f"{ms * 1e6:.3g} ns"
    if ms < 1.0:
        return f"{ms * 1e3:.3g} us"
    if ms < 1e3:
        return f"{ms:.3g} ms"
    return f"{ms / 1e3:.3g} s"


def fmt_ratio(x):
    return "–" if x is None else f"{x:.3g}x"


def ratio(a, b):
    return a / b if a is not None and b else None


def growth(rows, prefix):
    """[(nodes, ms)] of the benchmarks <prefix>/<size> (nodes from the dofs counter when it is
    there, else the size in the name) and the least-squares exponent p of ms ~ nodes^p
    (None with fewer than two sizes)."""
    points = []
    for name, r in rows.items():
        size = size_of(name)
        if name == f"{prefix}/{size}" and size:
            nodes = r["dofs"] / 3.0 if r.get("dofs") else float(size)
            points.append((nodes, r["ms"]))
    points.sort()
    if len(points) < 2:
        return points, None
    xs = [math.log(n) for n, _ in points]
    ys = [math.log(ms) for _, ms in points]
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    sxx = sum((x - mx) ** 2 for x in xs)
    p = sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sxx if sxx > 0 else None
    return points, p


# the speed goals, each a benchmark of this run: (what, benchmark, field, goal in ms or None
# [, run: "current" (one core, the default) or "current-2cores"]); a p99 goal also holds the
# tail to TAIL_RATIO times the same sequence's p50 (the issue's "a p99 of at most 1.5x its
# median")
TAIL_RATIO = 1.5
WHEN_READY = "DirectSceneSequence/Background/Rest/2660/WhenReady"
PACED_WHEN_READY = "DirectSceneSequence/Paced/Rest/2660/WhenReady"
PACED_FIFO = "DirectSceneSequence/Paced/Rest/2660/WhenReady/Fifo"
GOALS = [
    ("patient scene step (2660 nodes, needle in, ribs, breathing), median",
     "DirectSceneSequence/Background/Rest/2660", "p50_ms", 5.0),
    ("patient scene step, p99", "DirectSceneSequence/Background/Rest/2660", "p99_ms", 7.5),
    ("the same as realtime direct_sim runs it (refreshes adopted when ready), median",
     WHEN_READY, "p50_ms", 5.0),
    ("the same, p99", WHEN_READY, "p99_ms", 7.5),
    ("the same on two cores (the refresh on the second), median", WHEN_READY, "p50_ms", 5.0,
     "current-2cores"),
    ("the same on two cores, p99", WHEN_READY, "p99_ms", 7.5, "current-2cores"),
    ("patient scene step paced at 50 Hz (realtime), p99", "DirectSceneSequence/Paced/Rest/2660",
     "p99_ms", 7.5),
    ("paced at 50 Hz, refreshes when ready (a realtime direct_sim alone), the refresh held during "
     "each step (refactor_hold_steps), median", PACED_WHEN_READY, "p50_ms", 5.0),
    ("the same, p99", PACED_WHEN_READY, "p99_ms", 7.5),
    ("the same without the hold (refactor_hold_steps 0), p99", PACED_WHEN_READY + "/NoHold",
     "p99_ms", 7.5),
    ("paced at 50 Hz, refreshes when ready, loop thread in SCHED_FIFO (run.rt_priority), median",
     PACED_FIFO, "p50_ms", 5.0),
    ("the same, p99", PACED_FIFO, "p99_ms", 7.5),
    ("controller's control step (default scenario: 2001-node model, 12 perturbations)",
     "BM_ControlStepScenario", "ms", 5.0),
    ("the same with the markers and the flange moving with the breathing (50 Hz frames), median",
     "BM_ControlStepScenarioBreathing", "p50_ms", 5.0),
    ("the same, p99", "BM_ControlStepScenarioBreathing", "p99_ms", None),
    ("control step on the 2660-node test liver (12 perturbations)", "BM_ControlStep12", "ms", None),
    ("free liver step, 2660 nodes", "LiverStep/2660", "ms", None),
    ("free liver step, 10000 nodes", "LiverStep/10000", "ms", 30.0),
    ("floor: one solve with the liver's factor (double), 2660 nodes", "Solve/2660", "ms", None),
    ("the preconditioner's single-precision solve, 2660 nodes", "SolveSingle/2660", "ms", None),
    ("naive: refactorize every step, 2660 nodes", "LiverStepRefactorEveryStep/2660", "ms", None),
]


def goals_table(table, args):
    """Markdown lines: per goal the measured figure (one core), x floor, naive / it, the goal and
    whether it is met, and the baseline's figure when one was run."""
    current = table.get("current", {})
    base = table.get("baseline", {})
    floor = current.get("Solve/2660", {}).get("ms")
    naive = current.get("LiverStepRefactorEveryStep/2660", {}).get("ms")
    header = ["goal", "benchmark", "measured", "x floor", "naive / it", "p99 / p50", "goal", "met"]
    if base:
        header += ["baseline", "measured / baseline"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for what, name, field, goal, *run in GOALS:
        label = run[0] if run else "current"
        r = table.get(label, {}).get(name)
        if r is None or r.get(field) is None:
            continue
        ms = r[field]
        met = goal is not None and ms <= goal
        goal_cell = "–" if goal is None else f"<= {fmt_ms(goal)}"
        tail = ratio(ms, r.get("p50_ms")) if field == "p99_ms" else None
        if field == "p99_ms" and goal is not None:
            # the tail against its own median: unknown without the p50, then not met
            goal_cell += f", <= {TAIL_RATIO:g}x p50"
            met = met and tail is not None and tail <= TAIL_RATIO
        cells = [what, f"`{name}`" + ("" if field == "ms" else f" {field[:-3]}"), fmt_ms(ms),
                 fmt_ratio(ratio(ms, floor)), fmt_ratio(ratio(naive, ms)),
                 "–" if tail is None else f"{tail:.2f}x", goal_cell,
                 "–" if goal is None else ("yes" if met else "no")]
        if base:
            b = table.get(label.replace("current", "baseline"), {}).get(name, {}).get(field)
            cells += [fmt_ms(b), fmt_ratio(ratio(ms, b))]
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def write_readme(path, out, lines):
    """Replaces the block between the goals markers of `path` with `lines`."""
    begin, end = "<!-- bench:goals:begin -->", "<!-- bench:goals:end -->"
    with open(path) as f:
        text = f.read()
    if begin not in text or end not in text or text.index(begin) > text.index(end):
        sys.exit(f"bench_report: {path} has no '{begin}' ... '{end}' block")
    head, rest = text.split(begin, 1)
    _, tail = rest.split(end, 1)
    block = [begin, f"(generated by scripts/bench.sh from `{os.path.basename(os.path.normpath(out))}`, "
             "one core)", ""] + lines + [end]
    with open(path + ".tmp", "w") as f:
        f.write(head + "\n".join(block) + tail)
    os.replace(path + ".tmp", path)


def build_arch(build):
    """The instruction set a build directory was configured for: its CMakeCache's NSIM_ARCH
    ("-march=native", ...), the compiler's default when the option is empty or absent (builds
    before it existed), "?" when there is no cache to read."""
    try:
        with open(os.path.join(build, "CMakeCache.txt")) as f:
            for line in f:
                if line.startswith("NSIM_ARCH:"):
                    value = line.split("=", 1)[1].strip()
                    return f"-march={value}" if value else "the compiler's default -march"
    except OSError:
        return "?"
    return "the compiler's default -march"


def write_markdown(out, table, args, contexts):
    current = table.get("current", {})
    lines = []
    ctx = contexts[0] if contexts else {}
    lines.append(f"# Benchmarks {os.path.basename(os.path.normpath(out))}")
    lines.append("")
    lines.append(f"Host {ctx.get('host_name', '?')}, {ctx.get('num_cpus', '?')} CPUs at "
                 f"{ctx.get('mhz_per_cpu', '?')} MHz, load average "
                 f"{ctx.get('load_avg', '?')} at the start; OPENBLAS_NUM_THREADS=1 "
                 f"OMP_NUM_THREADS=1 OMP_THREAD_LIMIT=1, taskset -c {args.cpu}. Build "
                 f"`{args.build}` ({build_arch(args.build)})" +
                 (f", baseline `{args.baseline}` ({build_arch(args.baseline)})"
                  if args.baseline else "") + ".")
    lines.append("")
    lines.append("Times: median over the repetitions of the wall time per iteration (per step "
                 "for the step benchmarks). p50 / p99 / max step: medians over the repetitions "
                 "of each sequence's per-step percentiles (step-sequence benchmarks only). "
                 "`x floor` = time / one solve with the double factor (`Solve/<size>`); "
                 "`naive /` = "
                 "refactorize-every-step (`LiverStepRefactorEveryStep/<size>`) / time (speed-up "
                 "over the naive step), both measured in this run.")
    lines.append("")

    def section(title, label, baseline_label, floors_from):
        rows = table.get(label, {})
        if not rows:
            return
        base = table.get(baseline_label, {}) if baseline_label else {}
        lines.append(f"## {title}")
        lines.append("")
        header = ["benchmark", "binary", "median", "p50 step", "p99 step", "max step",
                  "x floor", "p99 x floor", "naive / median", "naive / p99"]
        if base:
            header += ["baseline median", "baseline p99", "median / baseline",
                       "p99 / baseline"]
        lines.append("| " + " | ".join(header) + " |")
        lines.append("|" + "---|" * len(header))
        for name in sorted(rows, key=lambda n: (rows[n]["binary"], n)):
            r = rows[name]
            size = size_of(name)
            floor = floors_from.get(f"Solve/{size}", {}).get("ms") if size else None
            naive = floors_from.get(f"LiverStepRefactorEveryStep/{size}", {}).get("ms") \
                if size else None
            p99 = r.get("p99_ms")
            cells = [f"`{name}`", r["binary"], fmt_ms(r["ms"]), fmt_ms(r.get("p50_ms")),
                     fmt_ms(p99), fmt_ms(r.get("max_ms")), fmt_ratio(ratio(r["ms"], floor)),
                     fmt_ratio(ratio(p99, floor)), fmt_ratio(ratio(naive, r["ms"])),
                     fmt_ratio(ratio(naive, p99))]
            if base:
                b = base.get(name, {})
                cells += [fmt_ms(b.get("ms")), fmt_ms(b.get("p99_ms")),
                          fmt_ratio(ratio(r["ms"], b.get("ms"))),
                          fmt_ratio(ratio(p99, b.get("p99_ms")))]
            lines.append("| " + " | ".join(cells) + " |")
        lines.append("")

    goals = goals_table(table, args)
    if len(goals) > 2:
        lines.append("## The speed goals (one core)")
        lines.append("")
        lines += goals
        lines.append("")
    section(f"One core (taskset -c {args.cpu})", "current",
            "baseline" if args.baseline else None, current)
    if args.two_cores != "none":
        section(f"Step sequences on two cores (taskset -c {args.two_cores}; the background "
                "refresh's worker on the second)", "current-2cores",
                "baseline-2cores" if args.baseline else None, current)
    scaling = [(prefix, *growth(current, prefix)) for prefix in ("LiverStep", "Solve",
                                                                  "Refactorize")]
    if any(len(points) >= 2 for _, points, _ in scaling):
        lines.append("## Scaling with the mesh size (one core)")
        lines.append("")
        lines.append("Median time against the number of nodes (free nodes for the steps: the "
                     "`dofs` counter / 3), and the exponent p of a least-squares fit "
                     "time ~ nodes^p over all sizes; between consecutive sizes in brackets.")
        lines.append("")
        lines.append("| benchmark | nodes: median | exponent p (consecutive) |")
        lines.append("|---|---|---|")
        for prefix, points, p in scaling:
            if len(points) < 2:
                continue
            pairs = [math.log(b[1] / a[1]) / math.log(b[0] / a[0])
                     for a, b in zip(points, points[1:])]
            lines.append(f"| `{prefix}` | " +
                         ", ".join(f"{n:.0f}: {fmt_ms(ms)}" for n, ms in points) +
                         f" | {p:.2f} (" + ", ".join(f"{x:.2f}" for x in pairs) + ") |")
        lines.append("")
    with open(os.path.join(out, "bench.md"), "w") as f:
        f.write("\n".join(lines))
    if args.readme:
        write_readme(args.readme, out, goals)


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("out")
    parser.add_argument("--cpu", default="1")
    parser.add_argument("--two-cores", default="0,1")
    parser.add_argument("--build", default="")
    parser.add_argument("--baseline", default="")
    parser.add_argument("--readme", default="",
                        help="write the goals table into this file's bench:goals block")
    args = parser.parse_args()
    runs = load(args.out)
    if not runs:
        sys.exit(f"bench_report: no results in {args.out}/raw")
    merged = {
        "context": runs[0]["context"],
        "nsim": {"cpu": args.cpu, "two_cores": args.two_cores, "build": args.build,
                 "baseline": args.baseline, "build_arch": build_arch(args.build),
                 "baseline_arch": build_arch(args.baseline) if args.baseline else "",
                 "runs": [{"label": r["label"], "binary": r["binary"], "context": r["context"]}
                          for r in runs]},
        "benchmarks": [dict(b, nsim_label=r["label"], nsim_binary=r["binary"])
                       for r in runs for b in r["benchmarks"]],
    }
    with open(os.path.join(args.out, "bench.json"), "w") as f:
        json.dump(merged, f, indent=1)
    write_markdown(args.out, medians(runs), args, [r["context"] for r in runs])


if __name__ == "__main__":
    main()
