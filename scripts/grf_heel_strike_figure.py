#!/usr/bin/env python3
"""Draw the heel-strike split of a one-step trial before and after issue 36's
step-to-step transition (docs/figures/grf_prediction/heel_strike_<trial>.png).

    python3 scripts/grf_heel_strike_figure.py --before DIR --after DIR \
        --trial 2014004_C4_02 --plates ../shared/.../2014004_C4_02_grf.mot \
        --right ground_force_1 --left ground_force_2 --out PNG

DIR: a predict-grf results folder of the trial (scripts/grf_dev_table.py's
--out, the "before" one run with the release build of 560d239, the commit
before issue 36's transition). Plots per foot the vertical (or, with
--component ap, the anteroposterior) force of the prediction before and
after, and the plates', around the landing, with the strike found on the
raw kinematics (read from the run's contacts file, `off_intervals`).
Needs matplotlib.
"""

import argparse
import os
import re

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def read_sto(path):
    """Every column of a table (time included) as a list, read with statopt's reader."""
    import statopt

    df = statopt.read_table(path)
    return {"time": df.index.tolist(), **{c: df[c].tolist() for c in df.columns}}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--before", required=True)
    ap.add_argument("--after", required=True)
    ap.add_argument("--trial", required=True)
    ap.add_argument("--plates", required=True)
    ap.add_argument("--right", default="ground_force_1")
    ap.add_argument("--left", default="ground_force_2")
    ap.add_argument("--out", required=True)
    ap.add_argument("--component", choices=["vertical", "ap"], default="vertical",
                    help="the vertical force (vy) or the anteroposterior one (vx)")
    ap.add_argument("--labels", default="before,after",
                    help="the legend's names of the two runs, comma-separated")
    a = ap.parse_args()
    b = read_sto(os.path.join(a.before, f"{a.trial}_predicted_grf.sto"))
    n = read_sto(os.path.join(a.after, f"{a.trial}_predicted_grf.sto"))
    m = read_sto(a.plates)
    contacts = open(os.path.join(a.after, f"{a.trial}_foot_contacts.xml")).read()
    # A landing foot's strike ends the swing its contacts are off over; its
    # heel's contacts have no other off interval (the others are also off
    # while it lands on its heel).
    heels = re.findall(r'<PointOnPlaneContact name="[^"]*heel[^"]*">(.*?)</PointOnPlaneContact>', contacts, re.S)
    strikes = sorted({float(x.split()[1]) for h in heels for x in re.findall(r"<off_intervals>([^<]*)</off_intervals>", h)})
    t0, t1 = n["time"][0], n["time"][-1]
    lo = max(t0, (strikes[0] - 0.12) if strikes else t0)
    fig, ax = plt.subplots(figsize=(7.5, 4.2))
    c = "vy" if a.component == "vertical" else "vx"
    before, after = a.labels.split(",")
    for side, col, plate in [("r", "tab:red", a.right), ("l", "tab:blue", a.left)]:
        mt = [(t, f) for t, f in zip(m["time"], m[f"{plate}_{c}"]) if lo <= t <= t1]
        ax.plot([x[0] for x in mt], [x[1] for x in mt], color=col, lw=1.2, ls="--", label=f"{side}: plates")
        ax.plot(b["time"], b[f"{side}_force_{c}"], color=col, lw=1.0, alpha=0.45, marker=".", label=f"{side}: {before}")
        ax.plot(n["time"], n[f"{side}_force_{c}"], color=col, lw=1.8, marker="o", ms=3, label=f"{side}: {after}")
    for s in strikes:
        ax.axvline(s, color="k", lw=0.8, ls=":")
        ax.text(s, ax.get_ylim()[1] * 0.97, " strike (raw kinematics)", fontsize=8, va="top")
    ax.set_xlim(lo, t1)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("vertical force (N)" if c == "vy" else "anteroposterior force (N)")
    ax.set_title(f"{a.trial}: heel strike, {before} and {after}")
    ax.legend(fontsize=7, ncol=3, loc="center left")
    fig.tight_layout()
    fig.savefig(a.out, dpi=110)
    print(a.out)


if __name__ == "__main__":
    main()
