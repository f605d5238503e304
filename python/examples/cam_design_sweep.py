"""Cam design for the leg extension machine of Krüger & Wartzack (2017),
section 3, from Python: sweep the elliptical cam's axis ratio b/a on a dask
LocalCluster (or a real scheduler), and pick the shape with the lowest peak
tibiofemoral compression among those that still demand enough quadriceps
work.

    python python/examples/cam_design_sweep.py [--out DIR] [--ratios 0.3 0.4 ... 1.0]
        [--min-work 0.9] [--w0 1 500 1000] [--knee-contact] [--scheduler tcp://host:8786]

The cam torque is the ExpressionBasedCoordinateForce ``cam_torque`` of the
machine file (models/leg_extension/README.md, "Cam torques"):

    tau(q) = -W a sqrt(1 - (1 - (b/a)^2) sin^2(q + phase)),   W a = 50 N m,

so b/a = 1 is the circular cam (a constant 50 N m) and a smaller b/a resists
less in deep flexion (W b at -95 deg) and the same 50 N m near extension.
Each point overrides the expression with ``model_properties={"cam_torque/
expression": ...}``: the machine file is edited in a scratch folder, never
in place. The human is Rajagopal's (with a patella), so the knee loads are
tibiofemoral and patellofemoral (setups/leg_extension_rajagopal_cam2.xml and
its <Metric>s), at every contact weight w0 of the band (default 1, 500,
1000: the paper's, the indeterminacy of how the load is shared between
muscles and contacts).

Which load is optimised: without --knee-contact, the peak over the movement
of the plain joint reaction's tibiofemoral compression (``tf_compression_r``
of the KneeLoads table: the compression along the tibial axis, the metric
``peak_tf_compression_N``); with --knee-contact, the setup is
setups/leg_extension_rajagopal_cam2_kc.xml (static optimization with the knee
contact method, docs/knee_contact.md: the knees' compartments are unknown
contact forces of the same optimisation) and the goal is the peak of the
method's total tibiofemoral force (``walker_knee_r_total_N`` of its
KneeContact table, |F| of the reaction on the right tibia, the metric
``peak_tf_total_N``); the plain reaction's compression is still reported.

The shapes differ only in a force, so statopt.sweep runs them as one force
sweep: the scene is compiled and each frame assembled once, and solved for
every (b/a, w0) (docs/python.md, "Force sweeps"); 1000 shapes x 3 w0 take a
few seconds. With --scheduler the candidates are split over the cluster's
workers.

Writes to the output folder (default output/cam_design/, with --knee-contact
output/cam_design_kc/):
cam_design.csv (one row per (b/a, w0)) and cam_design.png (torque
profiles, work and peak loads against b/a, compression over knee flexion;
every curve with its band over w0).
"""

import argparse
import re
from pathlib import Path

import numpy as np
import xml.etree.ElementTree as ET

import statopt

REPO = Path(__file__).resolve().parents[2]
SETUP = REPO / "setups" / "leg_extension_rajagopal_cam2.xml"
# The same with the knee contact method (<knee_contact>all</knee_contact> and
# the KneeContact table's metrics): --knee-contact.
SETUP_KC = REPO / "setups" / "leg_extension_rajagopal_cam2_kc.xml"
MACHINE = REPO / "models" / "leg_extension" / "machine_cam2_rajagopal.osim"
RATIOS = [0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 1.0]
W0 = [1.0, 500.0, 1000.0]
# The knee loads compared; the design goal is the first.
LOADS = {
    "peak_tf_compression_N": "peak tibiofemoral compression",
    "peak_pf_compression_N": "peak patellofemoral compression",
    "peak_pcl_shear_N": "peak PCL-type shear",
}
# With the knee contact method: its total tibiofemoral force first (the goal).
LOADS_KC = {"peak_tf_total_N": "peak total tibiofemoral force (knee contact method)", **LOADS}


def goal_of(knee_contact: bool) -> str:
    """The metric a design minimises: the knee contact method's total
    tibiofemoral force, or the plain reaction's compression."""
    return "peak_tf_total_N" if knee_contact else "peak_tf_compression_N"


def compression_curves(res, knee_contact: bool):
    """(label, line style, knee flexion (deg), values per frame and w0) of
    the right knee's compression over the movement of a run: the goal's
    tibiofemoral load, and the patellofemoral compression."""
    kl = res.table("KneeLoads")  # indexed by (w0, time)
    flex = kl.knee_flexion_r.unstack(0).iloc[:, 0].to_numpy()
    if knee_contact:
        kc = res.table("KneeContact")
        tf = ("tibiofemoral total (knee contact)", kc.walker_knee_r_total_N.unstack(0).to_numpy())
    else:
        tf = ("tibiofemoral", kl.tf_compression_r.unstack(0).to_numpy())
    return [(tf[0], "-", flex, tf[1]),
            ("patellofemoral", "--", flex, kl.pf_compression_r.unstack(0).to_numpy())]
# -W a * sqrt(1 - K * sin(q + phase)^2): the machine file's cam 2 expression
# (K = 0.75, b/a = 0.5); only K changes with the design.
_CAM = re.compile(r"^(?P<head>-?[0-9.]+\*sqrt\(1-)(?P<k>[0-9.eE+-]+)(?P<tail>\*sin\(q\+[0-9.eE+-]+\)\^2\))$")


def cam_expression(ratio: float, template: str) -> str:
    """The cam torque of an ellipse of axis ratio b/a, as Lepton text: the
    machine file's expression with K = 1 - (b/a)^2."""
    m = _CAM.match(template.replace(" ", ""))
    if not m:
        raise ValueError(f"{MACHINE.name}: cam_torque is not of the form -Wa*sqrt(1-K*sin(q+phase)^2): {template}")
    if not 0 < ratio <= 1:
        raise ValueError(f"axis ratio b/a must be in (0, 1], got {ratio}")
    k = float(round(1.0 - float(ratio) ** 2, 12))
    return f"{m['head']}{k!r}{m['tail']}"


def machine_expression() -> str:
    """The expression of ``cam_torque`` in the machine file."""
    root = ET.parse(MACHINE).getroot()
    for el in root.iter("ExpressionBasedCoordinateForce"):
        if el.get("name") == "cam_torque":
            return el.findtext("expression").strip()
    raise ValueError(f"{MACHINE}: no ExpressionBasedCoordinateForce 'cam_torque'")


def torque(expr: str, q: np.ndarray) -> np.ndarray:
    """The expression evaluated in numpy (the form cam_expression writes)."""
    m = _CAM.match(expr)
    wa = float(m["head"][: m["head"].index("*")])
    k = float(m["k"])
    phase = float(re.search(r"q\+([0-9.eE+-]+)\)", m["tail"]).group(1))
    return wa * np.sqrt(1 - k * np.sin(q + phase) ** 2)


def add_work_vs_circular(df):
    """``work_vs_circular``: the quadriceps work over the circular cam's at
    the same w0."""
    circ = df[df.b_over_a == 1.0].set_index("w0").quadriceps_work_J
    if circ.empty:
        raise ValueError("the sweep needs the circular cam (b/a = 1) as reference")
    return df.quadriceps_work_J / df.w0.map(circ)


def choose(df, min_work_fraction: float, goal: str = "peak_tf_compression_N"):
    """The shape with the lowest worst-case ``goal`` over the w0 band among
    those whose quadriceps work is at least ``min_work_fraction`` of the
    circular cam's at every w0 (of equal ones, the one with the most work).
    Returns (per-shape table of the band's worst case, the chosen row)."""
    ok = df[df.error.isna()] if "error" in df else df
    band = ok.groupby("b_over_a").agg(
        worst=(goal, "max"), least_work=("work_vs_circular", "min"),
        work=("quadriceps_work_J", "mean"))
    feasible = band[band.least_work >= min_work_fraction - 1e-12]
    if feasible.empty:
        raise ValueError(f"no shape demands {min_work_fraction:.0%} of the circular cam's work at every w0")
    best = feasible.sort_values(["worst", "work"], ascending=[True, False]).iloc[0]
    return band, best.name


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", help="output folder (default output/cam_design, with --knee-contact "
                    "output/cam_design_kc)")
    ap.add_argument("--ratios", type=float, nargs="+", default=RATIOS, help="axis ratios b/a (1 = circular)")
    ap.add_argument("--min-work", type=float, default=0.9,
                    help="required quadriceps work, as a fraction of the circular cam's (default 0.9)")
    ap.add_argument("--w0", type=float, nargs="+", default=W0, help="contact weights (default 1 500 1000)")
    ap.add_argument("--knee-contact", action="store_true",
                    help="solve with the knee contact method (setups/leg_extension_rajagopal_cam2_kc.xml) and "
                    "minimise the peak of its total tibiofemoral force (peak_tf_total_N) instead of the plain "
                    "reaction's tibiofemoral compression (peak_tf_compression_N)")
    ap.add_argument("--scheduler", help="a dask scheduler address (default: this process)")
    ap.add_argument("--no-figure", action="store_true", help="write the table only")
    a = ap.parse_args(argv)
    setup = SETUP_KC if a.knee_contact else SETUP
    goal = goal_of(a.knee_contact)
    loads = LOADS_KC if a.knee_contact else LOADS
    if a.out is None:
        a.out = str(REPO / "output" / ("cam_design_kc" if a.knee_contact else "cam_design"))
    ratios = sorted(set(a.ratios) | {1.0})  # the circular cam is the reference
    w0s = sorted(set(a.w0))
    template = machine_expression()
    expr = {r: cam_expression(r, template) for r in ratios}

    client = None
    if a.scheduler:
        from dask.distributed import Client

        client = Client(a.scheduler)
    try:
        # One point per (b/a, w0): a force sweep (the setup's <Metric>s).
        grid = {"contact_weight": w0s,
                "model_properties": [{"cam_torque/expression": expr[r]} for r in ratios]}
        df = statopt.sweep(setup, grid, client=client, progress=False)
    finally:
        if client is not None:
            client.close()
    if df.error.notna().any():
        print(df[["error"]].to_string())
        raise SystemExit(f"{df.error.notna().sum()} point(s) failed")
    df.insert(0, "b_over_a", [ratios[i % len(ratios)] for i in range(len(df))])
    df = df.rename(columns={"contact_weight": "w0"})
    df.insert(2, "expression", df.model_properties.map(lambda m: m["cam_torque/expression"]))
    df = df.drop(columns=["model_properties"])
    df.insert(3, "work_vs_circular", add_work_vs_circular(df))
    df = df.sort_values(["b_over_a", "w0"], kind="stable").reset_index(drop=True)
    band, best = choose(df, a.min_work, goal)

    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    df.to_csv(out / "cam_design.csv", index=False)
    cols = ["b_over_a", "w0", "quadriceps_work_J", "work_vs_circular", *loads, "peak_acl_shear_N", "failed"]
    shown = df if len(ratios) <= 12 else df[df.b_over_a.isin(np.unique(np.r_[
        ratios[:: max(1, len(ratios) // 8)], 1.0, best]))]
    print(f"w0 = {', '.join(f'{w:g}' for w in w0s)}, Rajagopal human, right knee"
          f"{', knee contact method' if a.knee_contact else ''} "
          f"({len(df)} rows, {len(ratios)} shapes):")
    print(shown[cols].to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    circ = band.loc[1.0]
    chosen = band.loc[best]
    print(f"required quadriceps work: >= {a.min_work:.0%} of the circular cam's at every w0")
    print(f"choice: b/a = {best:g} (lowest worst-case {loads[goal]} over w0 among those): "
          f"{chosen.worst:.0f} N against {circ.worst:.0f} N circular, "
          f"quadriceps work >= {chosen.least_work:.1%} of the circular cam's")
    if a.no_figure:
        print(f"wrote {out / 'cam_design.csv'}")
        return df, best

    # The chosen and the circular cam over the movement, every w0 (in-process).
    runs = {r: statopt.run(setup, contact_weight=w0s, progress=False,
                           model_properties={"cam_torque/expression": expr[r]})
            for r in sorted({1.0, float(best)})}

    # matplotlib only when a figure is drawn: importing pyplot costs about
    # 0.4 s, an eighth of a 1000-cam sweep with --no-figure.
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(2, 2, figsize=(12, 8.5))
    ax = ax.ravel()
    q = np.radians(np.linspace(-95, -5, 91))
    drawn = ratios if len(ratios) <= 12 else sorted({*ratios[:: max(1, len(ratios) // 8)], 1.0, best})
    for r in drawn:
        chosen_r = r == best
        ax[0].plot(-np.degrees(q), -torque(expr[r], q), lw=2.8 if chosen_r else 1.2,
                   label=f"b/a = {r:g}" + (" (chosen)" if chosen_r else ""))
    ax[0].set(xlabel="knee flexion = -lever angle (deg, within 2 deg)", ylabel="resistance torque (N m)",
              title="Cam torque on the lever, both legs (the same at every w0)")
    ax[0].invert_xaxis()
    per = df.groupby("b_over_a")
    lo, hi, mid = per.min(numeric_only=True), per.max(numeric_only=True), per.median(numeric_only=True)
    x = lo.index.to_numpy()
    mark = "o-" if len(x) <= 12 else "-"
    ax[1].fill_between(x, lo.quadriceps_work_J, hi.quadriceps_work_J, color="k", alpha=0.15,
                       label=f"min-max over w0 = {', '.join(f'{w:g}' for w in w0s)}")
    ax[1].plot(x, mid.quadriceps_work_J, mark, color="k", ms=4, label="quadriceps work, both legs (median w0)")
    req = a.min_work * df[df.b_over_a == 1.0].quadriceps_work_J
    ax[1].axhspan(req.min(), req.max(), color="k", alpha=0.08, hatch="//", lw=0)
    ax[1].axhline(req.max(), color="k", ls=":", lw=1, label=f"required: {a.min_work:.0%} of circular (band over w0)")
    ax[1].set(xlabel="axis ratio b/a", ylabel="quadriceps work (J)", title="Quadriceps work, band over w0")
    for (k, label), c in zip(loads.items(), ["C3", "C1", "C2", "C0"][-len(loads):]):
        ax[2].fill_between(x, lo[k], hi[k], color=c, alpha=0.2)
        ax[2].plot(x, mid[k], mark.replace("o", "s"), color=c, ms=4, label=f"{label} (band over w0)")
    ax[2].set(xlabel="axis ratio b/a", ylabel="peak load, right knee (N)", title="Peak knee loads, band over w0")
    for xx in ax[1:3]:
        xx.axvline(best, color="C3", lw=8, alpha=0.15, label=f"chosen b/a = {best:g}")
    for r, res in runs.items():
        name = "circular" if r == 1.0 else f"b/a = {r:g}"
        c = "C7" if r == 1.0 else "C3"
        for what, ls, flex, v in compression_curves(res, a.knee_contact):
            ax[3].fill_between(flex, v.min(axis=1), v.max(axis=1), color=c, alpha=0.2)
            ax[3].plot(flex, np.median(v, axis=1), color=c, ls=ls, label=f"{what}, {name} (band over w0)")
    ax[3].set(xlabel="knee flexion (deg)", ylabel="compression, right knee (N)",
              title="Knee compression: chosen vs circular cam")
    ax[3].invert_xaxis()
    for xx in ax:
        xx.grid(alpha=0.3)
        xx.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "cam_design.png", dpi=110)
    plt.close(fig)
    print(f"wrote {out / 'cam_design.csv'} and {out / 'cam_design.png'}")
    return df, best


if __name__ == "__main__":
    main()
