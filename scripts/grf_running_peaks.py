#!/usr/bin/env python3
"""Running: the vertical force's peaks per stance, predicted against the
instrumented treadmill (docs/grf_prediction.md, issue 27). Reads the outputs
scripts/grf_dev_table.py left in --out (default /tmp/grf_dev_table) and the
measured files in ../shared/models/running_hamner2013. Per trial: the peak in
the first 50 ms after touchdown (the impact) and the stance's peak, measured
and predicted, as shares of body weight. Needs numpy.
"""
import argparse, os, re
import numpy as np


def read(p):
    """Labels (time first) and rows of a table, read with statopt's reader."""
    import statopt

    df = statopt.read_table(p)
    return ["time", *df.columns], np.column_stack([df.index.to_numpy(), df.to_numpy()])


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    ap = argparse.ArgumentParser()
    ap.add_argument("--shared", default=os.path.join(here, "..", "..", "shared"))
    ap.add_argument("--out", default="/tmp/grf_dev_table")
    a = ap.parse_args()
    run = os.path.join(a.shared, "models", "running_hamner2013")
    for s in sorted(os.listdir(run)):
        if not s.startswith("subject"):
            continue
        osim = open(os.path.join(run, s, "model", f"{s}_adjusted_scaled.osim")).read()
        bw = sum(float(x) for x in re.findall(r"<mass>([^<]+)</mass>", osim)) * 9.80665
        for k in [2, 3, 4, 5]:
            name = f"{s}_Run_{k}"
            pred = os.path.join(a.out, name, f"{name}_predicted_grf.sto")
            if not os.path.isfile(pred):
                continue
            pl, p = read(pred)
            gl, g = read(os.path.join(run, s, "expData", f"Run_{k}_grf.mot"))
            t, tg = p[:, 0], g[:, 0]
            imp, pimp, act, pact = [], [], [], []
            for pc, gc in [("r_force_vy", "R_ground_force_vy"), ("l_force_vy", "L_ground_force_vy")]:
                fy = g[:, gl.index(gc)]
                on = fy > 50
                edges = np.flatnonzero(np.diff(on.astype(int)))
                starts = [tg[e + 1] for e in edges if not on[e]]
                ends = [tg[e + 1] for e in edges if on[e]]
                for t0 in starts:
                    later = [e for e in ends if e > t0]
                    if not later or t0 < t[0] or later[0] > t[-1]:
                        continue
                    t1 = later[0]
                    w, wp = (tg >= t0) & (tg <= t0 + 0.05), (t >= t0) & (t <= t0 + 0.05)
                    if not wp.any():
                        continue
                    imp.append(fy[w].max() / bw)
                    pimp.append(p[wp, pl.index(pc)].max() / bw)
                    act.append(fy[(tg >= t0) & (tg <= t1)].max() / bw)
                    pact.append(p[(t >= t0) & (t <= t1), pl.index(pc)].max() / bw)
            imp, pimp, act, pact = map(np.array, (imp, pimp, act, pact))
            print(f"{name}: {len(imp)} stances; first 50 ms peak {imp.mean():.2f} BW measured, "
                  f"{pimp.mean():.2f} predicted ({100 * (pimp.mean() / imp.mean() - 1):+.0f} %); "
                  f"stance peak {act.mean():.2f} measured, {pact.mean():.2f} predicted "
                  f"({100 * (pact.mean() / act.mean() - 1):+.0f} %)")


if __name__ == "__main__":
    main()
