#!/usr/bin/python3
"""scripts/bench_report.py on made-up Google Benchmark files: the medians of the repetitions
are the table's, the ratio to the floor (Solve/<size>) is computed in the run, and the growth
exponent of the scaling section recovers the exponent the times were made with (time =
c nodes^p, nodes from the dofs counter), between consecutive sizes too. Usage:
bench_report_test.py SOURCE_DIR"""

import json
import os
import subprocess
import sys
import tempfile


def bench(name, ms_reps, dofs=None):
    """Google Benchmark entries: the repetitions' iterations and their median aggregate."""
    entries = []
    for ms in ms_reps:
        entries.append({"name": name, "run_name": name, "run_type": "iteration",
                        "real_time": ms, "time_unit": "ms"})
    median = sorted(ms_reps)[len(ms_reps) // 2]
    aggregate = {"name": name + "_median", "run_name": name, "run_type": "aggregate",
                 "aggregate_name": "median", "real_time": median, "time_unit": "ms",
                 "repetitions": len(ms_reps)}
    if dofs is not None:
        aggregate["dofs"] = dofs
    return entries + [aggregate]


def interleaved_table(source, out, files):
    """Writes OUT/raw/<stem>.json for each {stem: entries} of an interleaved run, runs
    bench_report.py with the same folder as baseline, returns bench.md."""
    for stem, entries in files.items():
        with open(os.path.join(out, "raw", stem + ".json"), "w") as f:
            json.dump({"context": {}, "benchmarks": entries}, f)
    subprocess.run([sys.executable, os.path.join(source, "scripts", "bench_report.py"),
                    "--two-cores", "none", "--baseline", out, out], check=True)
    return open(os.path.join(out, "bench.md")).read()


def main():
    source = sys.argv[1]
    failures = []

    def check(ok, what):
        if not ok:
            failures.append(what)

    with tempfile.TemporaryDirectory() as out:
        os.makedirs(os.path.join(out, "raw"))
        p = 1.3
        nodes = {"700": 685, "2660": 2656, "10000": 9991, "30000": 30097}
        benchmarks = []
        for size, n in nodes.items():
            ms = 2e-3 * n ** p
            # repetitions around the median: the median must be taken, not the mean
            benchmarks += bench(f"LiverStep/{size}", [ms, 0.5 * ms, 3.0 * ms], dofs=3 * n)
        benchmarks += bench("Solve/2660", [1.5, 1.4, 9.0])
        with open(os.path.join(out, "raw", "current__fem_bench.json"), "w") as f:
            json.dump({"context": {"host_name": "test"}, "benchmarks": benchmarks}, f)
        subprocess.run([sys.executable, os.path.join(source, "scripts", "bench_report.py"),
                        "--two-cores", "none", out], check=True)
        md = open(os.path.join(out, "bench.md")).read()
        check("## Scaling with the mesh size" in md, "a scaling section")
        row = [l for l in md.splitlines() if l.startswith("| `LiverStep` |")]
        check(len(row) == 1, "one LiverStep scaling row")
        if row:
            check("| 1.30 (1.30, 1.30, 1.30) |" in row[0], f"exponent 1.30 in {row[0]}")
            check("30097: " in row[0], f"the node count from dofs in {row[0]}")
        # the floor ratio of LiverStep/2660: median / median of Solve/2660 (1.5 ms)
        step = [l for l in md.splitlines() if l.startswith("| `LiverStep/2660` |")]
        expected = 2e-3 * 2656 ** p / 1.5
        check(step and f"{expected:.3g}x" in step[0], f"x floor {expected:.3g} in {step}")
        merged = json.load(open(os.path.join(out, "bench.json")))
        check(len(merged["benchmarks"]) == len(benchmarks), "every entry merged")

    with tempfile.TemporaryDirectory() as out:  # one size: no exponent
        os.makedirs(os.path.join(out, "raw"))
        with open(os.path.join(out, "raw", "current__fem_bench.json"), "w") as f:
            json.dump({"context": {}, "benchmarks": bench("LiverStep/2660", [9.0])}, f)
        subprocess.run([sys.executable, os.path.join(source, "scripts", "bench_report.py"),
                        "--two-cores", "none", out], check=True)
        md = open(os.path.join(out, "bench.md")).read()
        check("Scaling" not in md, "no scaling section with one size")

    with tempfile.TemporaryDirectory() as out:  # the goals table, and into a README's block
        os.makedirs(os.path.join(out, "raw"))
        entries = (bench("Solve/2660", [2.0, 2.0, 2.0]) + bench("LiverStep/10000", [40.0, 20.0, 60.0]) +
                   bench("LiverStepRefactorEveryStep/2660", [50.0]))
        seq = bench("DirectSceneSequence/Background/Rest/2660", [12.0, 12.0, 12.0])
        seq[-1].update({"p50_ms": 4.0, "p99_ms": 9.0})
        with open(os.path.join(out, "raw", "current__fem_bench.json"), "w") as f:
            json.dump({"context": {}, "benchmarks": entries + seq}, f)
        readme = os.path.join(out, "README.md")
        with open(readme, "w") as f:
            f.write("# x\nbefore\n<!-- bench:goals:begin -->\nold table\n<!-- bench:goals:end -->\nafter\n")
        subprocess.run([sys.executable, os.path.join(source, "scripts", "bench_report.py"),
                        "--two-cores", "none", "--readme", readme, out], check=True)
        text = open(readme).read()
        check("old table" not in text and text.startswith("# x\nbefore\n") and
              text.endswith("<!-- bench:goals:end -->\nafter\n"), "only the block replaced")
        lines = text.splitlines()
        median = [l for l in lines if "DirectSceneSequence/Background/Rest/2660` p50" in l]
        p99 = [l for l in lines if "DirectSceneSequence/Background/Rest/2660` p99" in l]
        big = [l for l in lines if "`LiverStep/10000`" in l]
        check(median and "| 4 ms | 2x | 12.5x | – | <= 5 ms | yes |" in median[0], f"median row {median}")
        check(p99 and "| 9 ms | 4.5x |" in p99[0] and "| 2.25x | <= 7.5 ms, <= 1.5x p50 | no |" in p99[0],
              f"p99 row {p99}")
        check(big and "| 40 ms |" in big[0] and "| no |" in big[0], f"10000 row (the median) {big}")
        md = open(os.path.join(out, "bench.md")).read()
        check("## The speed goals" in md, "the goals in bench.md too")
        for p50, p99_ms, met in ((4.0, 6.5, "no"), (4.5, 6.5, "yes")):  # 1.62x / 1.44x the median
            seq[-1].update({"p50_ms": p50, "p99_ms": p99_ms})
            with open(os.path.join(out, "raw", "current__fem_bench.json"), "w") as f:
                json.dump({"context": {}, "benchmarks": entries + seq}, f)
            subprocess.run([sys.executable, os.path.join(source, "scripts", "bench_report.py"),
                            "--two-cores", "none", "--readme", readme, out], check=True)
            row = [l for l in open(readme).read().splitlines()
                   if "DirectSceneSequence/Background/Rest/2660` p99" in l]
            check(row and row[0].endswith(f"| {met} |"), f"tail {p99_ms} / {p50}: {met} in {row}")
        with open(readme, "w") as f:
            f.write("no markers\n")
        r = subprocess.run([sys.executable, os.path.join(source, "scripts", "bench_report.py"),
                            "--two-cores", "none", "--readme", readme, out], capture_output=True)
        check(r.returncode != 0 and b"bench:goals" in r.stderr, "a README without the block refused")

    with tempfile.TemporaryDirectory() as out:  # the builds' instruction sets in the header
        os.makedirs(os.path.join(out, "raw"))
        with open(os.path.join(out, "raw", "current__fem_bench.json"), "w") as f:
            json.dump({"context": {}, "benchmarks": bench("LiverStep/2660", [9.0])}, f)
        native, old, none = (os.path.join(out, d) for d in ("native", "old", "none"))
        for d, cache in ((native, "NSIM_ARCH:STRING=native\n"), (old, "CMAKE_BUILD_TYPE:STRING=Release\n")):
            os.makedirs(d)
            with open(os.path.join(d, "CMakeCache.txt"), "w") as f:
                f.write("# cache\n" + cache)
        subprocess.run([sys.executable, os.path.join(source, "scripts", "bench_report.py"),
                        "--two-cores", "none", "--build", native, "--baseline", old, out], check=True)
        md = open(os.path.join(out, "bench.md")).read()
        check(f"`{native}` (-march=native), baseline `{old}` (the compiler's default -march)" in md,
              "the builds' -march in the header")
        nsim = json.load(open(os.path.join(out, "bench.json")))["nsim"]
        check(nsim["build_arch"] == "-march=native" and
              nsim["baseline_arch"] == "the compiler's default -march", f"arch in bench.json {nsim}")
        subprocess.run([sys.executable, os.path.join(source, "scripts", "bench_report.py"),
                        "--two-cores", "none", "--build", none, out], check=True)
        check(f"`{none}` (?)" in open(os.path.join(out, "bench.md")).read(), "no cache: unknown")

    with tempfile.TemporaryDirectory() as out:  # an interleaved run: a file per benchmark
        os.makedirs(os.path.join(out, "raw"))
        files = {"current__fem_bench__1": bench("LiverStep/2660", [9.0, 8.0, 10.0]),
                 "baseline__fem_bench__1": bench("LiverStep/2660", [12.0, 20.0, 11.0]),
                 "current__fem_bench__2": bench("Solve/2660", [1.0]),
                 "baseline__fem_bench__2": bench("Solve/2660", [2.0])}
        md = interleaved_table(source, out, files)
        step = [l for l in md.splitlines() if l.startswith("| `LiverStep/2660` |")]
        # median 9 against the baseline's median 12, binary named without the benchmark's index
        check(step and "| fem_bench | 9 ms |" in step[0] and "| 12 ms |" in step[0] and
              "0.75x" in step[0], f"interleaved baseline row {step}")
        solve = [l for l in md.splitlines() if l.startswith("| `Solve/2660` |")]
        check(solve and "0.5x" in solve[0], f"the second benchmark's baseline {solve}")

    with tempfile.TemporaryDirectory() as out:  # an interleaved run: a file per repetition
        os.makedirs(os.path.join(out, "raw"))
        name = "DirectSceneSequence/Paced/Rest/2660/iter"

        def single(ms, p99):  # Google Benchmark's file of one repetition: no aggregate
            return [{"name": name, "run_name": name, "run_type": "iteration", "real_time": ms,
                     "time_unit": "ms", "p50_ms": ms, "p99_ms": p99}]
        files = {"current__scene_bench__1__r1": single(5.0, 7.0),
                 "baseline__scene_bench__1__r1": single(4.0, 30.0),
                 "current__scene_bench__1__r2": single(9.0, 20.0),
                 "baseline__scene_bench__1__r2": single(4.5, 6.0),
                 "current__scene_bench__1__r3": single(6.0, 8.0),
                 "baseline__scene_bench__1__r3": single(30.0, 5.0)}
        md = interleaved_table(source, out, files)
        row = [l for l in md.splitlines() if l.startswith(f"| `{name}` |")]
        # the medians over the three files: 6 ms (p99 8 ms) against 4.5 ms (p99 6 ms)
        check(row and "| scene_bench | 6 ms |" in row[0] and "| 8 ms |" in row[0] and
              "| 4.5 ms | 6 ms |" in row[0] and "1.33x" in row[0],
              f"the medians of single repetitions {row}")

    for f in failures:
        print("FAILED:", f)
    print("bench_report_test:", "ok" if not failures else f"{len(failures)} failures")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
