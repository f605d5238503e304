"""Markdown tables of the speed/accuracy grids (docs/figures/speed_accuracy/*/bench_grid.csv),
written by scripts/speed_accuracy.sh to docs/figures/speed_accuracy/tables.md."""
import csv
import os
import sys

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "docs", "figures", "speed_accuracy")
CASES = [
    ("leg_extension_cam1_w0_1000", "Leg extension, cam 1, w0 = 1000 (seated gait2392-derived human, 86 muscles, 10 contacts; 101 frames)"),
    ("leg_extension_cam1_w0_1", "Leg extension, cam 1, w0 = 1"),
    ("gait10dof18musc_walk", "gait10dof18musc walk (18 muscles, 151 frames)"),
    ("gait2392", "gait2392 walk (92 muscles, 23 DOF, 151 frames)"),
    ("leg6dof9musc_stance", "leg6dof9musc stance (9 muscles, coupled patella, 30 frames)"),
    ("arm26", "arm26 (6 muscles, 121 frames)"),
]


def g(v):
    if v == "":
        return "–"
    x = float(v)
    return "0" if x == 0 else f"{x:.2g}"


out = sys.stdout
for case, title in CASES:
    path = os.path.join(ROOT, case, "bench_grid.csv")
    if not os.path.exists(path):
        continue
    rows = list(csv.DictReader(open(path)))
    cols = [("ms/frame", "ms_per_frame"), ("max Δa", "max_dactivation"), ("RMS Δa", "rms_dactivation")]
    if any(r["max_dcontact_force_N"] for r in rows):
        cols.append(("max Δcontact (N)", "max_dcontact_force_N"))
    if any(r["max_dreaction_force_N"] for r in rows):
        cols.append(("max Δknee reaction (N)", "max_dreaction_force_N"))
    if any(r["max_dactivation_vs_opensim"] for r in rows):
        cols.append(("max Δa vs OpenSim", "max_dactivation_vs_opensim"))
    out.write(f"### {title}\n\n| # | choice | " + " | ".join(c for c, _ in cols) + " | Pareto |\n")
    out.write("|---|---|" + "---|" * len(cols) + "---|\n")
    for k, r in enumerate(rows, 1):
        vals = [f"{float(r[key]):.3f}" if key == "ms_per_frame" else g(r[key]) for _, key in cols]
        front = "●" if r["pareto"] == "true" else ""
        out.write(f"| {k} | {r['choice']} | " + " | ".join(vals) + f" | {front} |\n")
    out.write(f"\n![{case}]({case}/bench_grid.png)\n\n")
