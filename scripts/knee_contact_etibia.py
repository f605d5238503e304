#!/usr/bin/env python3
"""Compare knee forces of the GC5 trial ss1 with the eTibia's (docs/knee_contact.md).

usage: knee_contact_etibia.py TABLE [TABLE ...]
TABLE: a <name>_KneeContact.sto (walker_knee_l_total_N, _medial_N, _lateral_N) or a JointReaction table
reporting walker_knee_l on tibia_l in tibia_l (total = |F|). Resampled to 0-100 % of the table's time
range (the trial is one left gait cycle); BW = 75 kg x 9.80665 (the scaled model's mass).
Prints RMSE, first peak (max over 0-50 %) and second peak (max over 40-80 %) in BW."""
import math, os, sys

GC5 = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "shared", "models", "knee_gc5")
BW = 75.0 * 9.80665


def read_sto(path):
    """Labels (time first) and rows of a table, read with statopt's reader."""
    import statopt

    df = statopt.read_table(path)
    return ["time", *df.columns], [[t, *row] for t, row in zip(df.index.tolist(), df.to_numpy().tolist())]


def interp(t, y, x):
    for i in range(1, len(t)):
        if t[i] >= x:
            w = (x - t[i - 1]) / (t[i] - t[i - 1])
            return y[i - 1] + w * (y[i] - y[i - 1])
    return y[-1]


def metrics(t, y, meas):
    t0, t1 = t[0], t[-1]
    ours = [interp(t, y, t0 + p / 100 * (t1 - t0)) for p, _ in meas]
    rmse = math.sqrt(sum((a - m) ** 2 for a, (_, m) in zip(ours, meas)) / len(meas)) / BW
    pk = lambda v, lo, hi: max(x for x, (p, _) in zip(v, meas) if lo <= p <= hi) / BW
    mv = [m for _, m in meas]
    return rmse, pk(ours, 0, 50), pk(mv, 0, 50), pk(ours, 40, 80), pk(mv, 40, 80)


def main():
    et = [list(map(float, l.split(","))) for l in open(os.path.join(GC5, "eTibia_GC5_ss1.csv")).read().splitlines()[1:]]
    for path in sys.argv[1:]:
        labels, rows = read_sto(path)
        t = [r[0] for r in rows]
        col = lambda l: [r[labels.index(l)] for r in rows]
        if "walker_knee_l_total_N" in labels:
            series = {"total": col("walker_knee_l_total_N"), "medial": col("walker_knee_l_medial_N"),
                      "lateral": col("walker_knee_l_lateral_N")}
        else:
            root = "walker_knee_l_on_tibia_l_in_tibia_l_"
            fx, fy, fz = col(root + "fx"), col(root + "fy"), col(root + "fz")
            series = {"total": [math.sqrt(a * a + b * b + c * c) for a, b, c in zip(fx, fy, fz)]}
            # The split the method's rows imply (left knee: medial +z, lateral -z, 40 mm apart).
            mx = col(root + "mx")
            med = [(m + 0.020 * -y) / 0.040 for y, m in zip(fy, mx)]
            series["medial"] = med
            series["lateral"] = [-y - a for y, a in zip(fy, med)]
        print(path)
        for name, k in (("total", 3), ("medial", 1), ("lateral", 2)):
            if name in series:
                r = metrics(t, series[name], [(e[0], e[k]) for e in et])
                print(f"  {name:8s} RMSE {r[0]:.2f} BW; first peak {r[1]:.2f} (eTibia {r[2]:.2f}) BW; second peak {r[3]:.2f} (eTibia {r[4]:.2f}) BW")


if __name__ == "__main__":
    main()
