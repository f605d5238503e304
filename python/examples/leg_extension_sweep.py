"""The leg extension machine of Krüger & Wartzack (2017), section 3, from
Python: both cams over a sweep of the contact weight w0, run as independent
tasks on dask (a LocalCluster here; pass a Client for a real scheduler),
and one matplotlib figure of what the cam changes.

    python python/examples/leg_extension_sweep.py [OUT.png] [--scheduler tcp://host:8786]

Writes the figure OUT.png (default output/python/leg_extension_sweep.png) and
the sweep's table beside it (OUT.csv).
"""

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import statopt  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
SETUP = REPO / "setups" / "leg_extension_cam1.xml"
CAMS = {
    "cam 1 (circular)": REPO / "models" / "leg_extension" / "machine_cam1.osim",
    "cam 2 (elliptical)": REPO / "models" / "leg_extension" / "machine_cam2.osim",
}
W0 = [0.1, 1, 10, 100, 500, 1000, 5000]


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("out", nargs="?", default=str(REPO / "output" / "python" / "leg_extension_sweep.png"))
    ap.add_argument("--scheduler", help="a dask scheduler address (default: a LocalCluster)")
    a = ap.parse_args(argv)
    client = None
    if a.scheduler:
        from dask.distributed import Client

        client = Client(a.scheduler)

    # One point per (machine, w0); the metrics are the setup's <Metric>s.
    grid = {"artifact_files": [str(p) for p in CAMS.values()], "contact_weight": W0}
    df = statopt.sweep(SETUP, grid, client=client)
    df["cam"] = df["artifact_files"].map({str(p): name for name, p in CAMS.items()})
    print(df.drop(columns=["artifact_files"]).to_string(index=False))
    if df.error.notna().any():
        raise SystemExit(f"{df.error.notna().sum()} point(s) failed")

    # The knee's shear over the movement, both cams at w0 = 500 (in-process).
    runs = {name: statopt.run(SETUP, contact_weight=500, artifact_files=p, progress=False)
            for name, p in CAMS.items()}

    fig, ax = plt.subplots(1, 3, figsize=(15, 4.2))
    for (name, g), color in zip(df.groupby("cam", sort=False), ["C0", "C1"]):
        ax[0].semilogx(g.contact_weight, g.quadriceps_work_J, "o-", color=color, label=name)
        ax[1].semilogx(g.contact_weight, g.peak_shear_N, "o-", color=color, label=name)
    ax[0].set(xlabel="contact weight w0", ylabel="quadriceps work (J)", title="Quadriceps work, both legs")
    ax[1].set(xlabel="contact weight w0", ylabel="peak |shear| (N)", title="Peak tibiofemoral shear, right knee")
    for (name, res), color in zip(runs.items(), ["C0", "C1"]):
        r = res.reactions
        ax[2].plot(r.index, r["knee_r_on_tibia_r_in_tibia_r_fx"], color=color, label=name)
    ax[2].set(xlabel="time (s)", ylabel="shear along tibia x (N)", title="Tibiofemoral shear, w0 = 500")
    for x in ax:
        x.grid(alpha=0.3)
        x.legend()
    fig.tight_layout()
    out = Path(a.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=120)
    plt.close(fig)
    df.drop(columns=["artifact_files"]).to_csv(out.with_suffix(".csv"), index=False)
    print(f"wrote {out} and {out.with_suffix('.csv')}")
    return df


if __name__ == "__main__":
    main()
