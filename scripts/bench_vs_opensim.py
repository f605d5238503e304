#!/usr/bin/env python3
"""gait2392 static optimization: statopt against OpenSim 4.6, measured in one run.

Alternates rounds: each round runs OpenSim's AnalyzeTool once (the setup's
StaticOptimization, in a Python process of its own with opensim 4.6 imported
before the clock starts: OpenSim's time is the tool's construction, which
reads the model and the motion, and its run) and then `--statopt-runs` runs
of `statopt-tool SETUP -o DIR` as whole processes (start, reading, every
frame, the tables and the log, exit). Prints every time, the medians and
their ratio, and statopt's CPU time (user + system, every thread).

Both write their results to temporary folders; statopt writes each run into
the same folder, as a user rerunning a setup does.

    scripts/bench_vs_opensim.py --opensim-python VENV/bin/python \
        [--setup ../shared/models/gait2392/subject01_walk/setup_SO.xml] \
        [--tool target/release/statopt-tool] [--rounds 3] [--statopt-runs 15]

The host's load moves wall times by a third or more (a 2-core machine shared
with builds); read the ratio with the round-to-round spread it prints.
"""

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

OPENSIM_RUN = r"""
import sys, time
import opensim
setup, out = sys.argv[1], sys.argv[2]
t = time.perf_counter()
tool = opensim.AnalyzeTool(setup)
tool.setResultsDir(out)
ok = tool.run()
dt = time.perf_counter() - t
if not ok:
    sys.exit("AnalyzeTool.run() failed")
print(f"{dt:.6f} {opensim.GetVersion()}")
"""


def run_opensim(python, setup, out):
    r = subprocess.run(
        [python, "-c", OPENSIM_RUN, os.path.abspath(setup), out],
        cwd=os.path.dirname(os.path.abspath(setup)),
        capture_output=True,
        text=True,
    )
    if r.returncode != 0:
        sys.exit(f"OpenSim run failed:\n{r.stderr[-2000:]}")
    seconds, version = r.stdout.strip().splitlines()[-1].split()
    return float(seconds), version


def run_statopt(tool, setup, out):
    """Wall and CPU seconds of one whole `statopt-tool` process."""
    t = time.perf_counter()
    p = subprocess.Popen(
        [tool, os.path.abspath(setup), "-o", out],
        cwd=os.path.dirname(os.path.abspath(setup)),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    _, status, usage = os.wait4(p.pid, 0)
    wall = time.perf_counter() - t
    err = p.stderr.read().decode(errors="replace")
    p.stderr.close()
    if os.waitstatus_to_exitcode(status) != 0:
        sys.exit(f"statopt-tool failed:\n{err[-2000:]}")
    return wall, usage.ru_utime + usage.ru_stime


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument(
        "--setup",
        default=os.path.join(
            ROOT, "..", "shared", "models", "gait2392", "subject01_walk", "setup_SO.xml"
        ),
    )
    ap.add_argument("--tool", default=os.path.join(ROOT, "target", "release", "statopt-tool"))
    ap.add_argument(
        "--opensim-python",
        default=os.environ.get("OPENSIM_PYTHON", sys.executable),
        help="a Python with opensim 4.6 installed (default: $OPENSIM_PYTHON, else this one)",
    )
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--statopt-runs", type=int, default=15)
    a = ap.parse_args()
    if not os.path.isfile(a.setup):
        print(f"SKIP: {a.setup} absent")
        return
    if not os.access(a.tool, os.X_OK):
        sys.exit(f"{a.tool}: not an executable (cargo build --release, or give --tool)")

    work = tempfile.mkdtemp(prefix="bench-vs-opensim-")
    osim_times, so_walls, so_cpus, ratios = [], [], [], []
    version = "?"
    try:
        so_out = os.path.join(work, "statopt")
        run_statopt(a.tool, a.setup, so_out)  # warm the caches once
        for r in range(a.rounds):
            osim_out = os.path.join(work, f"opensim{r}")
            t, version = run_opensim(a.opensim_python, a.setup, osim_out)
            walls, cpus = [], []
            for _ in range(a.statopt_runs):
                w, c = run_statopt(a.tool, a.setup, so_out)
                walls.append(w)
                cpus.append(c)
            m = statistics.median(walls)
            osim_times.append(t)
            so_walls += walls
            so_cpus += cpus
            ratios.append(t / m)
            print(
                f"round {r + 1}: OpenSim {version} {t:.2f} s; statopt median "
                f"{m * 1e3:.1f} ms wall (best {min(walls) * 1e3:.1f}), "
                f"{statistics.median(cpus) * 1e3:.1f} ms CPU; ratio {t / m:.0f}x",
                flush=True,
            )
    finally:
        shutil.rmtree(work, ignore_errors=True)
    mo = statistics.median(osim_times)
    ms = statistics.median(so_walls)
    print(
        f"OpenSim {version} AnalyzeTool: median {mo:.2f} s "
        f"({min(osim_times):.2f}-{max(osim_times):.2f}, {len(osim_times)} runs)"
    )
    print(
        f"statopt whole process: median {ms * 1e3:.1f} ms wall "
        f"({min(so_walls) * 1e3:.1f}-{max(so_walls) * 1e3:.1f}), "
        f"{statistics.median(so_cpus) * 1e3:.1f} ms CPU, {len(so_walls)} runs"
    )
    print(
        f"ratio of the medians: {mo / ms:.0f}x (per round "
        f"{min(ratios):.0f}-{max(ratios):.0f}x; bar 1000x)"
    )


if __name__ == "__main__":
    main()
