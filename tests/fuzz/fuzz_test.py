#!/usr/bin/env python3
"""Seeded fuzz suite of the executables' input handling (DESIGN.md "Bad input and faults").

Generates mutated scenario YAML files, meshes, marker CSVs and command lines from the committed
ones, runs each case in the cheapest mode that still reads the input, and fails on any crash
(a signal), hang (the per-case timeout), exit code other than 0/1/2, or an exit 2 whose message
names no key, file or option. Prints the counts by outcome.

The message cases: seeded DDS sessions, each a realtime direct_sim on the coarse scenario with
two injectors (tests/fuzz/target_fuzzer.cpp): one that takes the robot at the start handshake
and answers every frame with raw RobotTarget samples of a random kind (NaN, infinite, huge,
zero and long quaternions, unknown modes, joint targets of any length, stale, duplicate and
future sequence numbers, jumps, far positions, bad stamps, good ones), and a stranger that
answers every frame 45 mm off. A session fails unless direct_sim completes, every value it
logged is finite, the robot never moved faster than its speed limit nor left its workspace, and
the stranger's targets were all rejected as foreign. Every injected sample counts as a case.

usage: fuzz_test.py BIN_DIR SOURCE_DIR [--seed N] [--cases N] [--jobs N] [--timeout S]
environment: NSIM_FUZZ_SEED, NSIM_FUZZ_CASES override the defaults (seed 1, 1050 cases).
"""

import argparse
import collections
import concurrent.futures
import os
import random
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time

# values that replace a YAML scalar: out of range, wrong type, NaN/inf spellings, huge numbers
BAD_VALUES = [
    "-1", "0", "-0.0", "1e308", "-1e308", "1e-300", "1e-9", "1e6", "1e12", "nan", ".nan", "NaN",
    "inf", ".inf", "-.inf", "abc", "[1, 2]", "[]", "{a: 1}", "{}", "''", "~", "null",
    "99999999999999999999", "2147483648", "-2147483649", "0x10", "true", "yes", "1.5.3", "'1'",
    "[nan, 0, 0]", "[1e308, 1e308, 1e308]", "[0, 0, -1.0e6]", "[.inf, 0, 0]", "*undefined",
    "&a 1", "!!binary AAAA", "[[[[[[1]]]]]]",
]
UNKNOWN_KEYS = ["typo_key", "youngs_modulus", "gravityy", "shared2", "x", "durations"]
BAD_CELLS = ["nan", "inf", "-inf", "abc", "", "1e400", "0x1p3", "1,2", " ", "--1", "1e-400"]


# ---- generators -----------------------------------------------------------------------------

def mutate_yaml(rng, text):
    """One to three text-level mutations of a scenario (what a careless edit or a bad tool does)."""
    lines = text.split("\n")
    kinds = []
    for _ in range(rng.choice([1, 1, 1, 2, 3])):
        kind = rng.choice(["value", "value", "value", "scale", "delete", "duplicate", "unknown",
                           "truncate", "indent", "swap", "huge", "garbage"])
        kinds.append(kind)
        keyed = [i for i, l in enumerate(lines) if re.match(r"^\s*[A-Za-z_]+:\s*\S", l)
                 and not l.lstrip().startswith("#")]
        any_key = [i for i, l in enumerate(lines) if re.match(r"^\s*[A-Za-z_]+:", l)]
        if kind == "value" and keyed:
            i = rng.choice(keyed)
            key = lines[i].split(":", 1)[0]
            lines[i] = key + ": " + rng.choice(BAD_VALUES)
        elif kind == "scale" and keyed:
            # every number of a line multiplied by 10^k: values just or far out of range
            i = rng.choice(keyed)
            k = rng.choice([-12, -9, -6, -3, -1, 1, 2, 3, 6, 9, 12])
            lines[i] = re.sub(r"(?<![\w.])(\d+\.?\d*(e-?\d+)?)",
                              lambda m: repr(float(m.group(1)) * 10.0 ** k), lines[i])
        elif kind == "delete" and any_key:
            del lines[rng.choice(any_key)]
        elif kind == "duplicate" and keyed:
            i = rng.choice(keyed)
            lines.insert(i + 1, lines[i])
        elif kind == "unknown" and any_key:
            i = rng.choice(any_key)
            indent = lines[i][: len(lines[i]) - len(lines[i].lstrip())]
            lines.insert(i, indent + rng.choice(UNKNOWN_KEYS) + ": 1")
        elif kind == "truncate":
            joined = "\n".join(lines)
            lines = joined[: rng.randrange(len(joined) + 1)].split("\n")
        elif kind == "indent" and any_key:
            i = rng.choice(any_key)
            lines[i] = rng.choice(["\t", "   ", " "]) + lines[i]
        elif kind == "swap" and len(any_key) > 1:
            i, j = rng.sample(any_key, 2)
            lines[i], lines[j] = lines[j], lines[i]
        elif kind == "huge" and keyed:
            i = rng.choice(keyed)
            key = lines[i].split(":", 1)[0]
            lines[i] = key + ": " + rng.choice(["x" * 70000, "9" * 400, "[" + "0, " * 20000 + "0]"])
        elif kind == "garbage":
            i = rng.randrange(len(lines) + 1)
            lines.insert(i, "".join(chr(rng.randrange(1, 127)) for _ in range(rng.randrange(1, 40))))
    return "\n".join(lines), "+".join(kinds)


def mutate_mesh(rng, text):
    """A mutation of a Gmsh 4.1 mesh: truncation, huge counts, bad indices, NaN coordinates."""
    lines = text.split("\n")
    kind = rng.choice(["truncate", "count", "count", "coordinate", "coordinate", "index", "index",
                       "delete", "duplicate", "garbage", "version", "empty"])
    def section_line(name):
        return lines.index(name) + 1 if name in lines else 1
    if kind == "truncate":
        return text[: rng.randrange(len(text))], kind
    if kind == "count":
        i = section_line(rng.choice(["$Nodes", "$Elements"]))
        parts = lines[i].split()
        if parts:
            parts[rng.randrange(len(parts))] = rng.choice(
                ["1000000000000", "-1", "0", "2147483648", "9223372036854775808", "abc", "1e6",
                 "18446744073709551615"])
            lines[i] = " ".join(parts)
    elif kind in ("coordinate", "index"):
        start = section_line("$Nodes" if kind == "coordinate" else "$Elements")
        end = lines.index("$EndNodes" if kind == "coordinate" else "$EndElements") \
            if ("$EndNodes" if kind == "coordinate" else "$EndElements") in lines else len(lines)
        candidates = [i for i in range(start + 1, end) if len(lines[i].split()) >= 3]
        if candidates:
            i = rng.choice(candidates)
            parts = lines[i].split()
            parts[rng.randrange(len(parts))] = rng.choice(
                ["nan", "inf", "-inf", "1e308", "abc", "0", "-5", "99999999", "1e400"]
                if kind == "coordinate" else
                ["0", "-1", "99999999", "2147483648", "abc", "1.5", parts[0]])
            lines[i] = " ".join(parts)
    elif kind == "delete":
        for _ in range(rng.randrange(1, 5)):
            del lines[rng.randrange(len(lines))]
    elif kind == "duplicate":
        i = rng.randrange(len(lines))
        lines.insert(i, lines[i])
    elif kind == "garbage":
        i = rng.randrange(len(lines))
        lines[i] = "".join(chr(rng.randrange(1, 256)) for _ in range(rng.randrange(1, 60)))
    elif kind == "version":
        lines[1] = rng.choice(["4.1 1 8", "3.0 0 8", "2.2 0 4", "4.1 0", "", "4.1 0 16"])
    elif kind == "empty":
        return "", kind
    return "\n".join(lines), kind


def mutate_csv(rng, rows):
    """A mutation of a marker CSV (header + rows): bad headers, gaps, non-monotone times, NaN."""
    rows = [list(r) for r in rows]
    kind = rng.choice(["header", "gap", "gap", "order", "cell", "cell", "columns", "truncate",
                       "blank", "huge_time", "duplicate", "ok"])
    if kind == "header":
        h = rows[0]
        what = rng.randrange(4)
        if what == 0:
            h[rng.randrange(len(h))] = rng.choice(["x", "", "m9_q", "T"])
        elif what == 1:
            h.pop()
        elif what == 2:
            h.append("m99_x")
        else:
            rows[0] = ["t"] + ["m%d_%s" % (m, a) for m in range(1100) for a in "xyz"]
    elif kind == "gap":
        k = rng.randrange(2, len(rows))
        shift = rng.choice([1e6, 100.0, 11.0, 9.0, 3.0, 0.5])
        for r in rows[k:]:
            r[0] = repr(float(r[0]) + shift)
    elif kind == "order":
        i, j = rng.sample(range(1, len(rows)), 2)
        rows[i], rows[j] = rows[j], rows[i]
    elif kind == "cell":
        r = rows[rng.randrange(1, len(rows))]
        r[rng.randrange(len(r))] = rng.choice(BAD_CELLS)
    elif kind == "columns":
        r = rows[rng.randrange(1, len(rows))]
        if rng.random() < 0.5:
            r.pop()
        else:
            r.append("0")
    elif kind == "duplicate":
        i = rng.randrange(1, len(rows))
        rows.insert(i, list(rows[i]))
    elif kind == "huge_time":
        r = rows[rng.randrange(2, len(rows))]
        r[0] = rng.choice(["1e300", "1e9", "-1e9"])
    text = "\n".join(",".join(r) for r in rows) + "\n"
    if kind == "truncate":
        text = text[: rng.randrange(len(text))]
    elif kind == "blank":
        lines = text.split("\n")
        lines.insert(rng.randrange(1, len(lines) - 1), "")
        text = "\n".join(lines)
    return text, kind


def random_partition(rng):
    n = rng.choice([0, 1, 8, 63, 64, 65, 200, 65535, 70000])
    chars = rng.choice(["abcXYZ019_-", "abc*?/ .\t", "\u00e9\u00fc", "p"])
    return "".join(rng.choice(chars) for _ in range(n))


# ---- running --------------------------------------------------------------------------------

Case = collections.namedtuple("Case", "name args files")

# what an exit-2 message must name: a file used by the case, an option, or a key path
KEY_RE = re.compile(r"\b[a-z_]+(\[\d+\])?\.[a-z_]+|\bduplicate key \S+|: [a-z_]+: |^\S+:\d+")
OPTION_RE = re.compile(r"--[a-z][a-z-]+|usage:|unknown command")


def names_something(message, files):
    if OPTION_RE.search(message) or KEY_RE.search(message):
        return True
    return any(os.path.basename(f) in message for f in files)


def run_case(case, timeout, env):
    start = time.monotonic()
    try:
        p = subprocess.run(case.args, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, timeout=timeout, env=env)
    except subprocess.TimeoutExpired as e:
        return case, "hang", None, (e.stderr or b"").decode("utf-8", "replace"), timeout
    took = time.monotonic() - start
    err = p.stderr.decode("utf-8", "replace")
    if p.returncode < 0:
        return case, "crash", p.returncode, err, took
    if p.returncode not in (0, 1, 2):
        return case, "bad_exit", p.returncode, err, took
    if p.returncode == 2:
        message = "\n".join(l for l in err.splitlines() if "error" in l) or err
        if not message.strip() or not names_something(message, case.files):
            return case, "unnamed", 2, err, took
        return case, "exit_2", 2, err, took
    return case, "exit_%d" % p.returncode, p.returncode, err, took


def dds_session(index, seed, direct, fuzzer, scenario_path, work, dds, env, duration=5.0):
    """One DDS session; returns (failure text or None, owner counts, foreign counts, summary)."""
    out = os.path.join(work, "dds%d" % index)
    part = ["--partition", "fuzzdds%d_%d" % (os.getpid(), index)]
    dds = [x for x in dds] + part
    procs = []
    try:
        procs.append(subprocess.Popen(
            [direct, "run", "--config", scenario_path, "--mode", "realtime", "--duration",
             str(duration), "--out", out, "--no-video", "--quiet"] + dds,
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env))
        procs.append(subprocess.Popen(
            [fuzzer, "run", "--role", "owner", "--seed", str(seed), "--per-frame", "2",
             "--duration", str(duration + 25)] + dds,
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env))
        time.sleep(1.0)  # the owner's handshake first: the stranger arrives mid-run
        procs.append(subprocess.Popen(
            [fuzzer, "run", "--role", "foreign", "--seed", str(seed + 1), "--per-frame", "1",
             "--duration", str(duration + 25)] + dds,
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env))
        outputs = []
        for p in procs:
            try:
                o, e = p.communicate(timeout=duration + 40)
            except subprocess.TimeoutExpired:
                return "hang", None, None, None
            outputs.append((p.returncode, o.decode(), e.decode()))
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
                p.wait()
    (dcode, _, derr), (ocode, oout, oerr), (fcode, fout, ferr) = outputs
    if dcode < 0 or ocode < 0 or fcode < 0:
        return "crash (exit %s %s %s): %s %s %s" % (dcode, ocode, fcode, derr, oerr, ferr), \
            None, None, None
    if dcode != 0 or ocode != 0 or fcode != 0:
        return "exit %d/%d/%d: %s %s %s" % (dcode, ocode, fcode, derr[-400:], oerr, ferr), \
            None, None, None
    import json
    owner, foreign = json.loads(oout), json.loads(fout)
    with open(os.path.join(out, "summary.json")) as f:
        summary = json.load(f)
    t = summary["targets"]
    problems = []
    if summary["exit"] != "completed":
        problems.append("exit %s" % summary["exit"])
    if t["foreign"] < 1 or len(t["foreign_by_writer"]) != 1:
        problems.append("the stranger's targets were not all rejected as foreign: %s" % t)
    if t["received"] + t["transport_invalid"] + t["foreign"] > owner["sent"] + foreign["sent"]:
        problems.append("more targets counted than sent")
    if t["received"] + t["transport_invalid"] + t["foreign"] < 0.8 * (owner["sent"] +
                                                                       foreign["sent"]):
        problems.append("fewer than 80 %% of the targets sent were checked: %s" % t)
    # the robot: finite, at most its speed per step, inside its workspace
    text = open(scenario_path).read()
    speed = float(re.search(r"max_linear_speed: *([0-9.e-]+)", text).group(1))
    lo = [float(v) for v in re.search(r"workspace_min: *\[([^]]*)\]", text).group(1).split(",")]
    hi = [float(v) for v in re.search(r"workspace_max: *\[([^]]*)\]", text).group(1).split(",")]
    h = 0.02
    with open(os.path.join(out, "timeseries.csv")) as f:
        header = f.readline().strip().split(",")
        ix = [header.index("robot_" + a) for a in "xyz"]
        prev = None
        for n, line in enumerate(f):
            row = [float(v) for v in line.strip().split(",")]
            if not all(v == v and abs(v) != float("inf") for v in row):
                problems.append("a non-finite value in timeseries.csv row %d" % (n + 1))
                break
            p = [row[i] for i in ix]
            if any(p[k] < lo[k] - 1e-9 or p[k] > hi[k] + 1e-9 for k in range(3)):
                problems.append("the robot left its workspace at row %d: %s" % (n + 1, p))
                break
            if prev is not None:
                step = sum((p[k] - prev[k]) ** 2 for k in range(3)) ** 0.5
                if step > speed * h * (1 + 1e-6) + 1e-12:
                    problems.append("the robot moved %.6f m in one step at row %d" % (step, n + 1))
                    break
            prev = p
    return ("; ".join(problems) or None), owner, foreign, summary


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("bin_dir")
    ap.add_argument("source_dir")
    ap.add_argument("--seed", type=int, default=int(os.environ.get("NSIM_FUZZ_SEED", "1")))
    ap.add_argument("--cases", type=int, default=int(os.environ.get("NSIM_FUZZ_CASES", "1050")))
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--timeout", type=float, default=20.0)
    ap.add_argument("--dds-sessions", type=int,
                    default=int(os.environ.get("NSIM_FUZZ_DDS_SESSIONS", "2")))
    a = ap.parse_args()
    rng = random.Random(a.seed)
    direct = os.path.join(os.path.abspath(a.bin_dir), "direct_sim")
    inverse = os.path.join(os.path.abspath(a.bin_dir), "inverse_sim")
    src = os.path.abspath(a.source_dir)  # the scenarios name their meshes by absolute path
    work = tempfile.mkdtemp(prefix="nsim_fuzz_%d_" % os.getpid())
    # all three set: the programs do not re-execute themselves to set them
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", OMP_THREAD_LIMIT="1",
               DISPLAY="")
    dds = ["--dds-config", os.path.join(src, "configs/dds/local.xml"), "--domain", "47"]

    with open(os.path.join(src, "configs/scenarios/liver_test_coarse.yaml")) as f:
        scenario = f.read().replace("../meshes/", os.path.join(src, "configs/meshes") + "/")
    with open(os.path.join(src, "configs/meshes/liver_700.msh")) as f:
        mesh = f.read()
    with open(os.path.join(src, "configs/markers/breathing_demo.csv")) as f:
        csv_rows = [l.split(",") for l in f.read().split("\n")[:151]]  # 5 s at 30 Hz
    good_csv = os.path.join(work, "good.csv")
    with open(good_csv, "w") as f:
        f.write("\n".join(",".join(r) for r in csv_rows) + "\n")
    good_yaml = os.path.join(work, "good.yaml")
    with open(good_yaml, "w") as f:
        f.write(scenario)

    # the share of each family in the cases
    n = a.cases
    n_yaml, n_mesh, n_csv = int(n * 0.42), int(n * 0.2), int(n * 0.25)
    n_cli = n - n_yaml - n_mesh - n_csv
    cases = []
    fifo = os.path.join(work, "fifo")
    os.mkfifo(fifo)
    for path in ["/dev/zero", fifo, work, "/nonexistent.yaml"]:  # the hangs, and friends
        cases.append(Case("special_config", [direct, "run", "--config", path, "--check"], [path]))
        cases.append(Case("special_csv", [inverse, "predict-eval", "--markers", path, "--out",
                                          os.path.join(work, "pe_special"), "--no-plots"], [path]))
    for i in range(n_yaml):
        text, kind = mutate_yaml(rng, scenario)
        path = os.path.join(work, "s%04d.yaml" % i)
        with open(path, "w") as f:
            f.write(text)
        r = rng.random()
        if r < 0.4:  # direct_sim starts slower (OpenCV's GUI libraries): fewer of these
            args = [direct, "run", "--config", path, "--check", "--quiet"]
        elif r < 0.985:
            args = [inverse, "run", "--config", path, "--check", "--quiet"]
        else:  # a few run the physics: 2 steps without a controller
            args = [direct, "run", "--config", path, "--no-controller", "--duration", "0.04",
                    "--no-video", "--quiet", "--out", os.path.join(work, "out%04d" % i),
                    "--partition", "fuzz%d_%d" % (os.getpid(), i)] + dds
        cases.append(Case("config:" + kind, args, [path]))
    for i in range(n_mesh):
        text, kind = mutate_mesh(rng, mesh)
        path = os.path.join(work, "m%04d.msh" % i)
        with open(path, "w", encoding="utf-8", errors="replace") as f:
            f.write(text)
        config = os.path.join(work, "m%04d.yaml" % i)
        with open(config, "w") as f:  # the controller's mesh only: inverse_sim reads just that
            f.write(scenario.replace(os.path.join(src, "configs/meshes/liver_700.msh  # coarser"),
                                     path + "  # coarser"))
        cases.append(Case("mesh:" + kind, [inverse, "run", "--config", config, "--check",
                                           "--quiet"], [path, config]))
    for i in range(n_csv):
        text, kind = mutate_csv(rng, csv_rows)
        path = os.path.join(work, "c%04d.csv" % i)
        with open(path, "w") as f:
            f.write(text)
        if rng.random() < 0.6:
            args = [inverse, "predict-eval", "--markers", path, "--out",
                    os.path.join(work, "pe%04d" % i), "--no-plots", "--horizon", "0.1",
                    "--pca-window", "60", "--window-max", "20"]
        else:
            args = [direct, "replay", "--markers", path, "--wait-readers", "0", "--rate-scale",
                    "10000", "--quiet", "--partition", "fuzzr%d_%d" % (os.getpid(), i)] + dds
        cases.append(Case("csv:" + kind, args, [path]))
    for i in range(n_cli):
        kind = rng.choice(["partition", "replay_opts", "run_opts", "record_opts", "eval_opts"])
        value = lambda: rng.choice(BAD_VALUES[:30] + ["1", "0.5", "20", "-5"])
        if kind == "partition":
            program = rng.choice([[direct, "replay", "--markers", good_csv, "--wait-readers", "0",
                                   "--rate-scale", "10000", "--quiet"],
                                  [inverse, "record", "--out", os.path.join(work, "r%d.csv" % i),
                                   "--start-timeout", "0.3", "--timeout", "0.5", "--quiet"]])
            args = program + dds + ["--partition", random_partition(rng)]
        elif kind == "replay_opts":
            opt = rng.choice(["--rate-scale", "--wait-readers", "--wait-timeout", "--lease",
                              "--deadline", "--domain"])
            # waiting for readers that never come is legitimate: at most 2 s of it
            args = [direct, "replay", "--markers", good_csv, "--rate-scale", "10000", "--quiet",
                    "--partition", "fuzzc%d_%d" % (os.getpid(), i)] + dds + [opt, value()]
            args += [] if opt == "--wait-readers" else ["--wait-readers", "0"]
            args += [] if opt == "--wait-timeout" else ["--wait-timeout", "2"]
        elif kind == "run_opts":
            opt = rng.choice(["--duration", "--latency-steps", "--seed", "--young-modulus",
                              "--vtk-every", "--mode", "--domain", "--lease"])
            args = [direct, "run", "--config", good_yaml, "--check", "--quiet", opt, value()]
        elif kind == "record_opts":
            opt = rng.choice(["--timeout", "--start-timeout", "--end-grace", "--lease"])
            args = [inverse, "record", "--out", os.path.join(work, "r%d.csv" % i), "--quiet",
                    "--start-timeout", "0.3", "--timeout", "0.5",
                    "--partition", "fuzzo%d_%d" % (os.getpid(), i)] + dds + [opt, value()]
        else:
            opt = rng.choice(["--horizon", "--order", "--snr-db", "--filter", "--window",
                              "--window-max", "--pca-window", "--seed", "--search-lead"])
            args = [inverse, "predict-eval", "--markers", good_csv, "--out",
                    os.path.join(work, "pev%d" % i), "--no-plots", "--pca-window", "60",
                    "--window-max", "20", opt, value()]
        cases.append(Case("cli:" + kind, args, [good_csv, good_yaml]))

    start = time.monotonic()
    counts = collections.Counter()
    by_family = collections.defaultdict(collections.Counter)
    failures = []

    # the message cases first: realtime sessions want the machine to themselves
    fuzzer = os.path.join(os.path.abspath(a.bin_dir), "target_fuzzer")
    dds_kinds, dds_gate = collections.Counter(), collections.Counter()
    for i in range(a.dds_sessions):
        failure, owner, foreign, summary = dds_session(i, a.seed * 1000 + 2 * i, direct, fuzzer,
                                                       good_yaml, work, dds, env)
        if failure:
            failures.append((Case("dds:session%d" % i, [direct, fuzzer], []), "dds", None,
                             failure))
            counts["dds_failed"] += 1
            continue
        dds_kinds.update({"owner_" + k: v for k, v in owner["by_kind"].items()})
        dds_kinds["foreign_jump"] += foreign["sent"]
        t = summary["targets"]
        dds_gate.update({"accepted": t["accepted"], "transport_invalid": t["transport_invalid"],
                         "foreign": t["foreign"]})
        dds_gate.update({"rejected_" + k: v for k, v in t["rejected"].items()})
        dds_gate.update({"clamped_" + k: v for k, v in t["clamped"].items()})
        n_sent = owner["sent"] + foreign["sent"]
        counts["message"] += n_sent
        by_family["message"]["sent"] += n_sent
        # sent after direct_sim stopped taking them, or dropped by DDS
        by_family["message"]["unchecked"] += n_sent - t["received"] - t["transport_invalid"] \
            - t["foreign"]
    slowest = (0.0, None)
    with concurrent.futures.ThreadPoolExecutor(max_workers=a.jobs) as pool:
        for case, outcome, code, err, took in pool.map(lambda c: run_case(c, a.timeout, env),
                                                       cases):
            counts[outcome] += 1
            by_family[case.name.split(":")[0]][outcome] += 1
            slowest = max(slowest, (took, case.name))
            if outcome in ("crash", "hang", "bad_exit", "unnamed"):
                failures.append((case, outcome, code, err))
    elapsed = time.monotonic() - start

    for case, outcome, code, err in failures[:30]:
        shown = [x if len(x) < 200 else x[:60] + "...(%d chars)" % len(x) for x in case.args]
        print("FAIL %s (%s, exit %s): %s\n  %s" % (outcome, case.name, code, " ".join(shown),
                                                  err.strip()[-600:].replace("\n", "\n  ")))
    print("fuzz: seed %d, %d cases in %.1f s (%d at a time), slowest %.2f s (%s)" %
          (a.seed, len(cases), elapsed, a.jobs, slowest[0], slowest[1]))
    for family in sorted(by_family):
        print("fuzz: %-8s %s" % (family, ", ".join("%s %d" % kv for kv in
                                                   sorted(by_family[family].items()))))
    print("fuzz: outcomes: " + ", ".join("%s %d" % kv for kv in sorted(counts.items())))
    print("fuzz: dds sessions %d, injected: %s" % (a.dds_sessions, ", ".join(
        "%s %d" % kv for kv in sorted(dds_kinds.items()))))
    print("fuzz: dds outcomes at direct_sim: %s" % ", ".join(
        "%s %d" % kv for kv in sorted(dds_gate.items()) if kv[1]))
    if failures:
        print("fuzz: %d failing cases (kept in %s)" % (len(failures), work))
        return 1
    shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
