#!/usr/bin/env python3
"""Run predict-grf on every development trial and print the table of
docs/grf_prediction.md (issue 27).

    python3 scripts/grf_dev_table.py [--tool target/release/statopt-tool]
        [--setups /work/notes/grf_setups] [--shared ../shared] [ARGS...]

The setups of running_hamner2013 and walk_schreiber2019 come from
scripts/grf_dev_setups.py (written first if absent); gait2392,
gait10dof18musc and moco_walk3d run their own setups from ../shared.
ARGS after `--` go to every predict-grf run. Per trial: exit status,
floor decision, mean over the two feet of rho / RMSE (% BW) per axis,
centre-of-pressure error (mm), heel-strike and toe-off errors (ms), the
root residual (share of frames above 25 % BW, peak % BW) and the tool's
own static-optimization time and whole-process wall time.
"""

import argparse
import csv
import os
import re
import subprocess
import sys
import time


def mean(rows, axis, key):
    v = [float(r[key]) for r in rows if r["axis"] == axis]
    return sum(v) / len(v) if v else float("nan")


def stance(rows, key):
    seen = {}
    for r in rows:
        if r[key] not in ("", "NaN", "nan") and float(r[key]) == float(r[key]):
            seen[r["foot"]] = float(r[key])
    v = list(seen.values())
    return sum(v) / len(v) if v else float("nan")


def run(tool, setup, out, extra):
    t = time.perf_counter()
    p = subprocess.run([tool, "predict-grf", setup, "-o", out] + extra,
                       capture_output=True, text=True)
    wall = time.perf_counter() - t
    err = p.stderr
    name = None
    for f in os.listdir(out):
        if f.endswith("_grf_comparison.csv"):
            name = f
    rows = list(csv.DictReader(open(os.path.join(out, name)))) if name else []
    floor = re.search(r"^floor: (\w+)", err, re.M)
    rr = re.search(r"root residual \(every actuator on the pelvis translations\): above 25 % of body weight on (\d+) of (\d+) frames with a foot on the floor \(([\d.]+) %\), at most ([\d.]+) % of body weight there; (\d+) frames in flight \(no foot point within [\d.]+ m of the floor\), where it carried at most ([\d.]+) %", err)
    so = re.search(r"static optimization: (\d+) frames in ([\d.]+) s", err)
    return {
        "rc": p.returncode,
        "floor": floor.group(1) if floor else "?",
        "rows": rows,
        "rr_share": float(rr.group(3)) if rr else float("nan"),
        "rr_peak": float(rr.group(4)) if rr else float("nan"),
        "flight": int(rr.group(5)) if rr else 0,
        "flight_peak": float(rr.group(6)) if rr else float("nan"),
        "frames": int(so.group(1)) if so else 0,
        "so_s": float(so.group(2)) if so else float("nan"),
        "wall": wall,
        "stderr": err,
    }


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    ap = argparse.ArgumentParser()
    ap.add_argument("--tool", default=os.path.join(here, "..", "target", "release", "statopt-tool"))
    ap.add_argument("--setups", default="/work/notes/grf_setups")
    ap.add_argument("--shared", default=os.path.join(here, "..", "..", "shared"))
    ap.add_argument("--out", default="/tmp/grf_dev_table")
    ap.add_argument("--only", default="")
    ap.add_argument("extra", nargs="*")
    a = ap.parse_args()
    shared = os.path.abspath(a.shared)
    if not os.path.isdir(os.path.join(shared, "models")):
        print(f"SKIP: {shared}/models is absent")
        return 0
    if not os.path.isdir(a.setups):
        subprocess.run([sys.executable, os.path.join(here, "grf_dev_setups.py"),
                        "--shared", shared, "--out", a.setups], check=True)
    trials = []
    for case, setup in [
        ("gait10dof18musc_walk", os.path.join(shared, "validation/gait10dof18musc_walk/setup_SO.xml")),
        ("moco_walk3d", os.path.join(shared, "validation/moco_walk3d/setup_SO.xml")),
        ("gait2392 subject01_walk", os.path.join(shared, "models/gait2392/subject01_walk/setup_SO.xml")),
    ]:
        if os.path.isfile(setup):
            trials.append((case, setup))
    for f in sorted(os.listdir(a.setups)):
        if f.endswith(".xml"):
            trials.append((f[:-4], os.path.join(a.setups, f)))
    print("| trial | exit | floor | vertical rho / RMSE | AP rho / RMSE | ML rho / RMSE | COP mm | HS / TO ms | root > 25 % BW (frames on the floor) / peak | flight frames / peak | frames | SO s / process s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for case, setup in trials:
        if a.only and a.only not in case:
            continue
        out = os.path.join(a.out, case.replace(" ", "_"))
        os.makedirs(out, exist_ok=True)
        r = run(a.tool, setup, out, a.extra)
        rows = r["rows"]
        cell = lambda ax: f"{mean(rows, ax, 'rho'):.3f} / {mean(rows, ax, 'rmse_percent_bw'):.1f}"
        print(f"| {case} | {r['rc']} | {r['floor']} | {cell('y')} | {cell('x')} | {cell('z')} | "
              f"{stance(rows, 'cop_error_mm'):.0f} | {stance(rows, 'heel_strike_error_ms'):.0f} / {stance(rows, 'toe_off_error_ms'):.0f} | "
              f"{r['rr_share']:.1f} % / {r['rr_peak']:.0f} % | {r['flight']} / {r['flight_peak']:.0f} % | {r['frames']} | {r['so_s']:.2f} / {r['wall']:.2f} |", flush=True)
        if not rows:
            sys.stderr.write(r["stderr"][-2000:])
    return 0


if __name__ == "__main__":
    sys.exit(main())
