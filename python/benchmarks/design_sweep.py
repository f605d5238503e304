"""Bench of the design workflow (docs/python.md, "A design sweep" and "An
optimiser"): wall and CPU time (user + system, children included) of

- ``cam_design_sweep.py`` with N ratios from 0.3 to 1.0 and the w0 band
  1, 500, 1000 (N x 3 rows), as a user runs it (a process, the figure
  included unless --no-figure);
- ``cam_design_optimize.py`` (default settings);
- both again with ``--knee-contact`` (the knee contact method's setup,
  its total tibiofemoral force the goal);
- the engine alone: ``statopt.force_sweep`` of the same N x 3 candidates
  (one thread and all), and ``statopt.Scene`` (compile once, then one
  batch);
- for scale, ``statopt.run`` of one point (one shape at one w0).

    python python/benchmarks/design_sweep.py [--ratios 1000] [--rounds 3] [--examples-only]

Prints one line per measurement (median and best of the rounds) and the
load average before and after, since other work on the machine inflates
wall times (CPU times far less).
"""

import argparse
import atexit
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import statopt

REPO = Path(__file__).resolve().parents[2]
SETUP = REPO / "setups" / "leg_extension_rajagopal_cam2.xml"
EXAMPLES = REPO / "python" / "examples"


def cpu() -> float:
    s, c = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return s.ru_utime + s.ru_stime + c.ru_utime + c.ru_stime


def measure(label, f, rounds):
    walls, cpus = [], []
    for _ in range(rounds):
        c0, t0 = cpu(), time.perf_counter()
        f()
        walls.append(time.perf_counter() - t0)
        cpus.append(cpu() - c0)
    print(f"{label:58s} wall median {statistics.median(walls):7.2f} s  best {min(walls):7.2f} s   "
          f"CPU median {statistics.median(cpus):7.2f} s")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--ratios", type=int, default=1000)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--examples-only", action="store_true", help="time the two examples only")
    a = ap.parse_args()
    print(f"load average before: {os.getloadavg()}; {os.cpu_count()} cores")
    ratios = [f"{r:.6f}" for r in np.linspace(0.3, 1.0, a.ratios)]
    out = Path(tempfile.mkdtemp(prefix="statopt-bench-"))
    atexit.register(shutil.rmtree, out, True)

    def example(*args):
        subprocess.run([sys.executable, str(EXAMPLES / args[0]), "--out", str(out), *args[1:]],
                       check=True, capture_output=True)

    measure(f"cam_design_sweep.py, {a.ratios} ratios x 3 w0, with figure",
            lambda: example("cam_design_sweep.py", "--ratios", *ratios, "--w0", "1", "500", "1000"), a.rounds)
    measure(f"cam_design_sweep.py, {a.ratios} ratios x 3 w0, --no-figure",
            lambda: example("cam_design_sweep.py", "--ratios", *ratios, "--w0", "1", "500", "1000",
                            "--no-figure"), a.rounds)
    measure("cam_design_optimize.py (defaults)", lambda: example("cam_design_optimize.py"), a.rounds)
    measure(f"cam_design_sweep.py, {a.ratios} ratios x 3 w0, --knee-contact",
            lambda: example("cam_design_sweep.py", "--ratios", *ratios, "--w0", "1", "500", "1000",
                            "--knee-contact"), a.rounds)
    measure("cam_design_optimize.py --knee-contact", lambda: example("cam_design_optimize.py", "--knee-contact"),
            a.rounds)
    if a.examples_only:
        print(f"load average after: {os.getloadavg()}")
        return

    expr = lambda r: f"-50*sqrt(1-{float(1 - float(r) ** 2)!r}*sin(q+0.08726646259971647)^2)"  # noqa: E731
    cands = [{"w0": w, "expressions": {"cam_torque": expr(r)}} for w in (1, 500, 1000) for r in ratios]
    for threads in (1, None):
        measure(f"force_sweep, {len(cands)} candidates, threads={threads or 'all'}",
                lambda: statopt.force_sweep(SETUP, cands, threads=threads), a.rounds)
    scene = {}
    measure("Scene(setup): compile, every frame assembled",
            lambda: scene.__setitem__("s", statopt.Scene(SETUP)), a.rounds)
    measure(f"Scene.run, {len(cands)} candidates", lambda: scene["s"].run(cands), a.rounds)
    measure("Scene.run, 18 candidates (an optimiser's iterate)", lambda: scene["s"].run(cands[:18]), a.rounds)
    measure("statopt.run, one shape at one w0 (tables=False)",
            lambda: statopt.run(SETUP, contact_weight=500, progress=False, tables=False,
                                model_properties={"cam_torque/expression": expr(0.7)}), a.rounds)
    print(f"load average after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
