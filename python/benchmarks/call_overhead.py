"""Python call overhead against the CLI on one setup.

    python python/benchmarks/call_overhead.py SETUP [--rounds 15] [--tool target/release/statopt-tool]

Interleaves, per round: the CLI as a process (`statopt-tool SETUP -o TMP -q`),
`statopt.run(SETUP, results_dir=TMP, tables=False)` (the same work in-process),
`statopt.run(SETUP)` (nothing kept; tables are read when first used) and
`statopt.run(SETUP).tables` (every table read into a DataFrame).
Prints the median and the best wall time of each and the overheads.
"""

import argparse
import logging
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import statopt


def cpu_seconds():
    """CPU time (user + system) of this process and its finished children."""
    me = resource.getrusage(resource.RUSAGE_SELF)
    ch = resource.getrusage(resource.RUSAGE_CHILDREN)
    return me.ru_utime + me.ru_stime + ch.ru_utime + ch.ru_stime


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("setup")
    ap.add_argument("--rounds", type=int, default=15)
    ap.add_argument("--tool", default=str(Path(__file__).resolve().parents[2] / "target/release/statopt-tool"))
    ap.add_argument("--threads", type=int, default=None)
    a = ap.parse_args()
    logging.getLogger("statopt").setLevel(logging.ERROR)  # the CLI runs with -q
    tmp = Path(tempfile.mkdtemp(prefix="statopt-bench-"))
    jobs = ["-j", str(a.threads)] if a.threads else []
    times = {"cli": [], "run_files": [], "run": [], "run_tables": []}
    cpu = {k: [] for k in times}

    def cli():
        subprocess.run([a.tool, a.setup, "-o", str(tmp / "cli"), "-q", *jobs], check=True)

    def run_files():
        statopt.run(a.setup, results_dir=tmp / "py", tables=False, progress=False, threads=a.threads)

    def run():
        statopt.run(a.setup, progress=False, threads=a.threads)

    def run_tables():
        res = statopt.run(a.setup, progress=False, threads=a.threads)
        assert res.tables  # every table read into a DataFrame

    run_tables()  # warm-up (file cache, imports)
    cli()
    try:
        for _ in range(a.rounds):
            for name, f in (("cli", cli), ("run_files", run_files), ("run", run), ("run_tables", run_tables)):
                c0 = cpu_seconds()
                t = time.perf_counter()
                f()
                times[name].append(time.perf_counter() - t)
                cpu[name].append(cpu_seconds() - c0)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    med = {k: statistics.median(v) for k, v in times.items()}
    best = {k: min(v) for k, v in times.items()}
    cmed = {k: statistics.median(v) for k, v in cpu.items()}
    print(f"{a.setup}: {a.rounds} rounds, interleaved, threads: {a.threads or 'all cores'}")
    print(f"{'':42}{'wall median':>12}{'wall best':>10}{'vs CLI':>8}{'CPU median':>12}{'vs CLI':>8}")
    for k, label in (("cli", "CLI process (statopt-tool -q -o)"),
                     ("run_files", "statopt.run(results_dir=, tables=False)"),
                     ("run", "statopt.run() (tables read when used)"),
                     ("run_tables", "statopt.run().tables (all read)")):
        print(f"{label:42}{med[k]:12.4f}{best[k]:10.4f}{100 * (med[k] / med['cli'] - 1):+7.1f}%"
              f"{cmed[k]:12.4f}{100 * (cmed[k] / cmed['cli'] - 1):+7.1f}%")
    sys.stdout.flush()


if __name__ == "__main__":
    main()
