"""Cam design for the leg extension machine of Krüger & Wartzack (2017),
section 3, from Python: sweep the elliptical cam's axis ratio b/a on a dask
LocalCluster (or a real scheduler), and pick the shape with the lowest peak
tibiofemoral compression among those that still demand enough quadriceps
work.

    python python/examples/cam_design_sweep.py [--out DIR] [--ratios 0.3 0.4 ... 1.0]
        [--min-work 0.9] [--w0 500] [--scheduler tcp://host:8786]

The cam torque is the ExpressionBasedCoordinateForce ``cam_torque`` of the
machine file (models/leg_extension/README.md, "Cam torques"):

    tau(q) = -W a sqrt(1 - (1 - (b/a)^2) sin^2(q + phase)),   W a = 50 N m,

so b/a = 1 is the circular cam (a constant 50 N m) and a smaller b/a resists
less in deep flexion (W b at -95 deg) and the same 50 N m near extension.
Each point overrides the expression with ``model_properties={"cam_torque/
expression": ...}``: the machine file is edited in a scratch folder, never
in place. The human is Rajagopal's (with a patella), so the knee loads are
tibiofemoral and patellofemoral (setups/leg_extension_rajagopal_cam2.xml and
its <Metric>s), at one contact weight w0.

Writes to the output folder (default output/cam_design/):
cam_design.csv (one row per b/a) and cam_design.png (torque profiles, work
and peak loads against b/a, compression over knee flexion).
"""

import argparse
import re
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xml.etree.ElementTree as ET  # noqa: E402

import statopt  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
SETUP = REPO / "setups" / "leg_extension_rajagopal_cam2.xml"
MACHINE = REPO / "models" / "leg_extension" / "machine_cam2_rajagopal.osim"
RATIOS = [0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 1.0]
# The knee loads compared; the design goal is the first.
LOADS = {
    "peak_tf_compression_N": "peak tibiofemoral compression",
    "peak_pf_compression_N": "peak patellofemoral compression",
    "peak_pcl_shear_N": "peak PCL-type shear",
}
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
    k = round(1.0 - ratio * ratio, 12)
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


def choose(df, min_work_fraction: float, goal: str = "peak_tf_compression_N"):
    """The row with the lowest ``goal`` among the designs whose quadriceps
    work is at least ``min_work_fraction`` of the circular cam's (of equal
    ones, the one with the most work)."""
    circular = df.loc[df.b_over_a == 1.0, "quadriceps_work_J"]
    if circular.empty:
        raise ValueError("the sweep needs the circular cam (b/a = 1) as reference")
    required = min_work_fraction * float(circular.iloc[0])
    ok = df[df.error.isna() & (df.quadriceps_work_J >= required)]
    # equal peaks (the peak may come near extension, where every cam resists
    # with W a): the one that demands the most work
    return required, ok.sort_values([goal, "quadriceps_work_J"], ascending=[True, False]).iloc[0]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=str(REPO / "output" / "cam_design"), help="output folder")
    ap.add_argument("--ratios", type=float, nargs="+", default=RATIOS, help="axis ratios b/a (1 = circular)")
    ap.add_argument("--min-work", type=float, default=0.9,
                    help="required quadriceps work, as a fraction of the circular cam's (default 0.9)")
    ap.add_argument("--w0", type=float, default=500, help="contact weight (default 500)")
    ap.add_argument("--scheduler", help="a dask scheduler address (default: a LocalCluster of 2 workers)")
    a = ap.parse_args(argv)
    ratios = sorted(set(a.ratios) | {1.0})  # the circular cam is the reference
    template = machine_expression()
    expr = {r: cam_expression(r, template) for r in ratios}

    from dask.distributed import Client, LocalCluster

    cluster = None
    if a.scheduler:
        client = Client(a.scheduler)
    else:
        cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
        client = Client(cluster)
    try:
        # One point per b/a; the metrics are the setup's <Metric>s.
        grid = [{"model_properties": {"cam_torque/expression": expr[r]}} for r in ratios]
        df = statopt.sweep(SETUP, grid, client=client, threads=1, contact_weight=a.w0, progress=False)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    if df.error.notna().any():
        print(df[["error"]].to_string())
        raise SystemExit(f"{df.error.notna().sum()} point(s) failed")
    df.insert(0, "b_over_a", ratios)
    df.insert(1, "expression", [expr[r] for r in ratios])
    df = df.drop(columns=["setup", "model_properties"])
    work0 = float(df.loc[df.b_over_a == 1.0, "quadriceps_work_J"].iloc[0])
    df.insert(3, "work_vs_circular", df.quadriceps_work_J / work0)
    required, best = choose(df, a.min_work)

    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    df.to_csv(out / "cam_design.csv", index=False)
    cols = ["b_over_a", "quadriceps_work_J", "work_vs_circular", *LOADS, "peak_acl_shear_N", "failed", "seconds"]
    print(f"w0 = {a.w0:g}, Rajagopal human, right knee:")
    print(df[cols].to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    print(f"required quadriceps work: >= {a.min_work:.0%} of the circular cam's {work0:.1f} J = {required:.1f} J")
    print(f"choice: b/a = {best.b_over_a:g} (lowest peak tibiofemoral compression among those): "
          f"{best.peak_tf_compression_N:.0f} N against {df.peak_tf_compression_N.iloc[-1]:.0f} N circular, "
          f"quadriceps work {best.quadriceps_work_J:.1f} J ({best.work_vs_circular:.1%})")

    # The chosen and the circular cam over the movement (in-process).
    runs = {r: statopt.run(SETUP, contact_weight=a.w0, progress=False, threads=1,
                           model_properties={"cam_torque/expression": expr[r]})
            for r in sorted({1.0, float(best.b_over_a)})}

    fig, ax = plt.subplots(2, 2, figsize=(12, 8.5))
    ax = ax.ravel()
    q = np.radians(np.linspace(-95, -5, 91))
    for r in ratios:
        chosen = r == best.b_over_a
        ax[0].plot(-np.degrees(q), -torque(expr[r], q), lw=2.8 if chosen else 1.2,
                   label=f"b/a = {r:g}" + (" (chosen)" if chosen else ""))
    ax[0].set(xlabel="knee flexion = -lever angle (deg, within 2 deg)", ylabel="resistance torque (N m)",
              title="Cam torque on the lever, both legs")
    ax[0].invert_xaxis()
    ax[1].plot(df.b_over_a, df.quadriceps_work_J, "o-", color="k", label="quadriceps work, both legs")
    ax[1].axhline(required, color="k", ls=":", lw=1, label=f"required: {a.min_work:.0%} of circular")
    ax[1].set(xlabel="axis ratio b/a", ylabel="quadriceps work (J)", title=f"Quadriceps work, w0 = {a.w0:g}")
    for (k, label), c in zip(LOADS.items(), ["C3", "C2", "C0"]):
        ax[2].plot(df.b_over_a, df[k], "s-", color=c, label=label)
    ax[2].set(xlabel="axis ratio b/a", ylabel="peak load, right knee (N)", title=f"Peak knee loads, w0 = {a.w0:g}")
    for x in ax[1:3]:
        x.axvline(best.b_over_a, color="C3", lw=8, alpha=0.15, label=f"chosen b/a = {best.b_over_a:g}")
    for r, res in runs.items():
        kl = res.table("KneeLoads")
        name = "circular" if r == 1.0 else f"b/a = {r:g}"
        c = "C7" if r == 1.0 else "C3"
        ax[3].plot(kl.knee_flexion_r, kl.tf_compression_r, color=c, label=f"tibiofemoral, {name}")
        ax[3].plot(kl.knee_flexion_r, kl.pf_compression_r, color=c, ls="--", label=f"patellofemoral, {name}")
    ax[3].set(xlabel="knee flexion (deg)", ylabel="compression, right knee (N)",
              title="Knee compression: chosen vs circular cam")
    ax[3].invert_xaxis()
    for x in ax:
        x.grid(alpha=0.3)
        x.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "cam_design.png", dpi=110)
    plt.close(fig)
    print(f"wrote {out / 'cam_design.csv'} and {out / 'cam_design.png'}")
    return df, best


if __name__ == "__main__":
    main()
