#!/usr/bin/env python3
"""The trailing foot's vertical force through double support, measured on
the plates of the one-step development trials, against the published
transfer shapes (issue 36; docs/grf_prediction.md, step 8, "Examined").

Per trial, over the last double support within the kinematics (both plates
above 20 N), x = tau / T_ds from the landing foot's onset to the trailing
foot's foot-off; the trailing foot's vertical force as a share of its value
at the onset, against:
- Ren, Jones & Howard 2008: exp(-(2x)^3) (the share statopt uses);
- the linear share 1 - x (no published source found);
- Villeger, Costes, Watier & Moretto 2014 (Med Eng Phys 36:1530), as a third
  party's transcription gives it (the paper's own text was not read):
  f(u) = exp(S^2) exp(-(u - S)^2) - exp(S^2) exp(-(2 - S)^2) u / 2,
  u = 2x (time over half the double support), 1 at the onset, 0 at the
  foot-off; Ren's anteroposterior function is S = 2/3. Its shape coefficient
  S comes from a multiple regression on walking speed, T_ds and the plates'
  forces around the double support (N/kg, N/kg/s), one per axis, labelled
  X, Y and Z. Which label is the vertical is not known from what was read,
  so both are evaluated: reading A, Y vertical (the transcription's own
  axes); reading B, Z vertical.

    python3 scripts/grf_transfer_shapes.py [--setups DIR] [--shared DIR]

needs numpy and the statopt module (for its table reader); prints one row
per trial. The setups are those of scripts/grf_dev_setups.py.
"""
import argparse, os, re, subprocess, sys
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from grf_diagnose import read, tag  # noqa: E402

ONSET = 20.0  # N, a plate's onset (as the other scripts)


def villeger(s, x):
    """Villeger's transition function at x = tau / T_ds, shape s."""
    u = 2.0 * np.asarray(x)
    e = np.exp(s * s)
    return e * np.exp(-(u - s) ** 2) - 0.5 * e * np.exp(-(2.0 - s) ** 2) * u


def slope(t, y, i, half=100):
    """dy/dt at sample i: a least-squares line over 2 half + 1 samples (a
    first-derivative Savitzky-Golay filter of order one)."""
    lo, hi = max(0, i - half), min(len(y), i + half + 1)
    return np.polyfit(t[lo:hi], y[lo:hi], 1)[0]


def trial(setup_path):
    setup = open(setup_path).read()
    loads = tag(setup, "external_loads_file")
    lx = open(loads).read()
    gl, g = read(os.path.join(os.path.dirname(loads), tag(lx, "datafile")))
    ids = re.findall(r"<force_identifier>\s*([^<]*?)\s*</force_identifier>", lx)
    model = open(tag(setup, "model_file")).read()
    m = sum(float(x) for x in re.findall(r"<mass>([^<]+)</mass>", model))
    il, ik = read(tag(setup, "coordinates_file"))
    t = g[:, 0]
    F = [np.column_stack([g[:, gl.index(i + a)] for a in "xyz"]) for i in ids]
    on = [f[:, 1] > ONSET for f in F]
    tx = ik[:, il.index("pelvis_tx")]
    heading = np.sign(tx[-1] - tx[0])
    speed = abs(tx[-1] - tx[0]) / (ik[-1, 0] - ik[0, 0])
    both = np.flatnonzero(on[0] & on[1] & (t > ik[0, 0] - 0.05) & (t < ik[-1, 0]))
    runs = np.split(both, np.flatnonzero(np.diff(both) > 1) + 1)
    a, b = runs[-1][0], runs[-1][-1]
    tr = 0 if on[0][a - 5] else 1
    ld = 1 - tr
    k = a
    while k > 0 and on[tr][k - 1]:
        k -= 1
    e = b
    while e < len(t) - 1 and on[ld][e + 1]:
        e += 1
    tot = F[0] + F[1]
    tot[:, 0] *= heading
    t_ds = (b - a + 1) * (t[1] - t[0])
    # The regressors, per kilogram: the force at the onset, the slope there
    # and the peak over the two single supports around the double support.
    before, after = slice(k, a + 1), slice(b, e + 1)
    ap_i, ap_max = abs(tot[a, 0]) / m, max(abs(tot[before, 0]).max(), abs(tot[after, 0]).max()) / m
    v_i, v_max = F[tr][a, 1] / m, max(F[tr][before, 1].max(), F[ld][after, 1].max()) / m
    v_slope = abs(slope(t, F[tr][:, 1], a)) / m
    ml_i = abs(tot[a, 2]) / m
    ml_max = max(abs(tot[before, 2]).max(), abs(tot[after, 2]).max()) / m
    ml_slope = abs(slope(t, tot[:, 2], a)) / m
    # Reading A: Y vertical, Z mediolateral.
    s_a = (-0.398 + 0.149 * speed + 1.064 * t_ds + 0.043 * ap_i - 0.014 * ap_max
           + 0.036 * ml_max + 0.011 * v_i - 0.001 * v_slope - 0.026 * v_max)
    # Reading B: Z vertical, Y mediolateral.
    s_b = (0.691 - 0.313 * speed - 2.867 * t_ds - 0.121 * ap_i + 0.083 * ap_max
           + 0.007 * v_slope + 0.022 * ml_i - 0.002 * ml_slope)
    share = F[tr][a:b + 1, 1] / F[tr][a, 1]
    x = np.arange(len(share)) / len(share)
    return dict(speed=speed, t_ds=t_ds, s_a=s_a, s_b=s_b, x=x, share=share)


def main():
    ap = argparse.ArgumentParser()
    here = os.path.dirname(os.path.abspath(__file__))
    ap.add_argument("--setups", default="target/grf_dev_setups")
    ap.add_argument("--shared", default=os.path.join(here, "..", "..", "shared"))
    a = ap.parse_args()
    if not os.path.isdir(os.path.join(a.shared, "models")):
        print(f"SKIP: {a.shared}/models is absent")
        return 0
    if not os.path.isdir(a.setups):
        subprocess.run([sys.executable, os.path.join(here, "grf_dev_setups.py"),
                        "--shared", a.shared, "--out", a.setups], check=True)
    print("| trial | speed m/s | T_ds s | S, reading A / B | share at x = 1/2: plates, Ren, linear, Villeger A / B "
          "| at x = 3/4 | RMS of the share over the double support: Ren, linear, Villeger A / B |")
    print("|---|---|---|---|---|---|---|")
    for f in sorted(os.listdir(a.setups)):
        if not (f.startswith("2014") and f.endswith(".xml")):
            continue
        r = trial(os.path.join(a.setups, f))
        x, m = r["x"], r["share"]
        shapes = [np.exp(-(2 * x) ** 3), 1 - x, villeger(r["s_a"], x), villeger(r["s_b"], x)]
        at = lambda q: ", ".join(f"{v:.2f}" for v in [np.interp(q, x, m), np.exp(-(2 * q) ** 3), 1 - q,
                                                      villeger(r["s_a"], q), villeger(r["s_b"], q)])
        rms = ", ".join(f"{np.sqrt(np.mean((s - m) ** 2)):.3f}" for s in shapes)
        print(f"| {f[:-4]} | {r['speed']:.2f} | {r['t_ds']:.3f} | {r['s_a']:+.3f} / {r['s_b']:+.3f} | "
              f"{at(0.5)} | {at(0.75)} | {rms} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
