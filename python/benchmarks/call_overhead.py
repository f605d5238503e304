"""Python call overhead against the CLI on one setup.

    python python/benchmarks/call_overhead.py SETUP [--rounds 15] [--tool target/release/statopt-tool]

Interleaves, per round: the CLI as a process (`statopt-tool SETUP -o TMP -q`),
`statopt.run(SETUP, results_dir=TMP, tables=False)` (the same work in-process)
and `statopt.run(SETUP)` (tables read back into DataFrames, nothing kept).
Prints the median and the best wall time of each and the overheads.
"""

import argparse
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import statopt


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("setup")
    ap.add_argument("--rounds", type=int, default=15)
    ap.add_argument("--tool", default=str(Path(__file__).resolve().parents[2] / "target/release/statopt-tool"))
    ap.add_argument("--threads", type=int, default=None)
    a = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="statopt-bench-"))
    jobs = ["-j", str(a.threads)] if a.threads else []
    times = {"cli": [], "run_files": [], "run_tables": []}

    def cli():
        subprocess.run([a.tool, a.setup, "-o", str(tmp / "cli"), "-q", *jobs], check=True)

    def run_files():
        statopt.run(a.setup, results_dir=tmp / "py", tables=False, progress=False, threads=a.threads)

    def run_tables():
        statopt.run(a.setup, progress=False, threads=a.threads)

    run_tables()  # warm-up (file cache, imports)
    cli()
    try:
        for _ in range(a.rounds):
            for name, f in (("cli", cli), ("run_files", run_files), ("run_tables", run_tables)):
                t = time.perf_counter()
                f()
                times[name].append(time.perf_counter() - t)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    med = {k: statistics.median(v) for k, v in times.items()}
    best = {k: min(v) for k, v in times.items()}
    print(f"{a.setup}: {a.rounds} rounds, interleaved")
    print(f"{'':42}{'median s':>10}{'best s':>10}{'median vs CLI':>15}")
    for k, label in (("cli", "CLI process (statopt-tool -q -o)"),
                     ("run_files", "statopt.run(results_dir=, tables=False)"),
                     ("run_tables", "statopt.run() -> DataFrames")):
        print(f"{label:42}{med[k]:10.4f}{best[k]:10.4f}{100 * (med[k] / med['cli'] - 1):+14.1f}%")
    sys.stdout.flush()


if __name__ == "__main__":
    main()
