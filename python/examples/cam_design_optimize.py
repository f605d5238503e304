"""Cam design for the leg extension machine of Krüger & Wartzack (2017),
section 3, by optimisation rather than a grid: the resistance torque is a
monotone spline over knee flexion (5 control points, at most 50 N m), and
scipy's SLSQP finds the profile with the lowest peak tibiofemoral
compression whose quadriceps work stays at least 90 % of the circular
cam's at every contact weight w0 of the band (robust to how the load is
shared between muscles and contacts).

    python python/examples/cam_design_optimize.py [--out DIR] [--w0 1 500 1000]
        [--min-work 0.9] [--ratios N] [--knee-contact]

Which load is optimised: without --knee-contact, the peak over the movement
of the plain joint reaction's tibiofemoral compression of the right knee
(``peak_tf_compression_N``, KneeLoads ``tf_compression_r``); with
--knee-contact the setup is solved with the knee contact method
(setups/leg_extension_rajagopal_cam2_kc.xml, docs/knee_contact.md) and the
goal is the peak of its total tibiofemoral force (``peak_tf_total_N``,
KneeContact ``walker_knee_r_total_N``), for the grid and the optimum alike.

The profile: torque values v_0 >= v_1 >= ... >= v_4 >= 0 at knee flexion 5,
27.5, 50, 72.5 and 95 deg, v_0 <= 50 N m, joined by a monotone cubic
(PCHIP) and written as the Lepton expression of the machine file's
``cam_torque`` (knee flexion = -lever_angle, within 2 deg; constant beyond
the end points). Parameters z in [0, 1]^5: v_0 = 50 z_0, v_k = v_(k-1) z_k,
so every z is a monotone profile. The setup is compiled and every frame
assembled once (statopt.Scene); each iterate is then one batch of solves,
the iterate and its five finite-difference neighbours at every w0 of the
band at once.

The grid it is compared with: the elliptical cams b/a = 0.3 ... 1.0
(cam_design_sweep.py's family, one force sweep), whose best shape meeting
the same constraint at every w0 is the one to beat.

Writes to the output folder (default output/cam_design/, with --knee-contact
output/cam_design_kc/): cam_optimum.csv
(one row per w0: w0, peak_tf_compression_N, work_vs_circular, the other
metrics and the profile's parameters) and cam_optimum.png (torque
profiles, knee compression over flexion, the grid's Pareto front of work
against peak compression with the optimum on it).
"""

import argparse
import sys
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from scipy.interpolate import PchipInterpolator  # noqa: E402
from scipy.optimize import minimize  # noqa: E402

import statopt  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from cam_design_sweep import (  # noqa: E402
    SETUP, SETUP_KC, cam_expression, compression_curves, goal_of, machine_expression, torque)

REPO = Path(__file__).resolve().parents[2]
W0 = [1.0, 500.0, 1000.0]
PEAK = 50.0  # N m: the weight stack's torque on the circular cam
KNOTS_DEG = np.linspace(5.0, 95.0, 5)  # knee flexion of the control points
GOAL = "peak_tf_compression_N"  # without --knee-contact (goal_of)
WORK = "quadriceps_work_J"


def profile_values(z):
    """Torque at the knots (N m), from extension to deep flexion."""
    z = np.clip(np.asarray(z, dtype=float), 0.0, 1.0)
    return PEAK * np.cumprod(z)


def spline_expression(values) -> str:
    """The profile as a Lepton expression of q (the lever angle): -f(x),
    x = knee flexion (rad) clamped to the knots, f the PCHIP of ``values``."""
    p = PchipInterpolator(np.radians(KNOTS_DEG), values)
    x = [float(v) for v in np.radians(KNOTS_DEG)]
    xs = f"min(max(-q,{x[0]!r}),{x[-1]!r})"
    terms = []
    for k in range(len(x) - 1):
        c3, c2, c1, c0 = (float(c) for c in p.c[:, k])
        t = f"(({xs})-{x[k]!r})"
        poly = f"({c0!r}+{t}*({c1!r}+{t}*({c2!r}+{t}*{c3!r})))"
        if k == 0 and len(x) == 2:
            gate = "1"
        elif k == 0:
            gate = f"(1-step(({xs})-{x[1]!r}))"
        elif k == len(x) - 2:
            gate = f"step(({xs})-{x[k]!r})"
        else:
            gate = f"step(({xs})-{x[k]!r})*(1-step(({xs})-{x[k + 1]!r}))"
        terms.append(f"{gate}*{poly}")
    return "-(" + "+".join(terms) + ")"


def profile_torque(values, flexion_rad):
    """The resistance (N m, positive) of a profile at knee flexion angles."""
    x = np.radians(KNOTS_DEG)
    return PchipInterpolator(x, values)(np.clip(flexion_rad, x[0], x[-1]))


class Evaluator:
    """Metrics of profiles at every w0, one force sweep per batch, cached."""

    def __init__(self, w0s, work_circular, setup=SETUP, goal=GOAL):
        # The setup compiled and every frame assembled once: each batch
        # only solves.
        self.scene = statopt.Scene(setup)
        self.goal = goal
        self.w0s = w0s
        self.work_circular = work_circular  # per w0
        self.cache = {}
        self.sweeps = 0

    def batch(self, zs):
        todo = [tuple(np.round(z, 12)) for z in zs if tuple(np.round(z, 12)) not in self.cache]
        if todo:
            cands = [{"w0": w, "expressions": {"cam_torque": spline_expression(profile_values(z))}}
                     for z in todo for w in self.w0s]
            rows = self.scene.run(cands)
            self.sweeps += 1
            for i, z in enumerate(todo):
                per = rows[i * len(self.w0s):(i + 1) * len(self.w0s)]
                if any(r["failed"] for r in per):
                    raise RuntimeError(f"profile {z}: frames not solved")
                self.cache[z] = (np.array([r[self.goal] for r in per]),
                                 np.array([r[WORK] / self.work_circular[w] for r, w in zip(per, self.w0s)]),
                                 per)
        return [self.cache[tuple(np.round(z, 12))] for z in zs]

    def best_feasible(self, min_work):
        """The profile evaluated so far (iterates and their neighbours) with
        the lowest worst-case goal among those meeting the work requirement
        at every w0, or None."""
        best = None
        for z, (peaks, works, _) in self.cache.items():
            if (works >= min_work).all() and (best is None or peaks.max() < best[0]):
                best = (peaks.max(), z)
        return None if best is None else np.array(best[1])

    def with_gradient(self, z, h=1e-4):
        """(peaks, works) at z and their forward-difference Jacobians."""
        z = np.asarray(z, dtype=float)
        steps = []
        for i in range(len(z)):
            zi = z.copy()
            # step inwards at the upper bound
            zi[i] += h if z[i] + h <= 1.0 else -h
            steps.append(zi)
        out = self.batch([z, *steps])
        peak0, work0, _ = out[0]
        jp = np.zeros((len(self.w0s), len(z)))
        jw = np.zeros_like(jp)
        for i, (p, w, _) in enumerate(out[1:]):
            d = steps[i][i] - z[i]
            jp[:, i] = (p - peak0) / d
            jw[:, i] = (w - work0) / d
        return peak0, work0, jp, jw


def ellipse_grid(ratios, w0s, setup=SETUP):
    """The elliptical cams of cam_design_sweep.py at every w0 (one force sweep)."""
    template = machine_expression()
    expr = {r: cam_expression(r, template) for r in ratios}
    grid = {"contact_weight": w0s, "model_properties": [{"cam_torque/expression": expr[r]} for r in ratios]}
    df = statopt.sweep(setup, grid, progress=False)
    if df.error.notna().any():
        raise SystemExit(df.error.dropna().iloc[0])
    df.insert(0, "b_over_a", [ratios[i % len(ratios)] for i in range(len(df))])
    df = df.rename(columns={"contact_weight": "w0"})
    circ = df[df.b_over_a == 1.0].set_index("w0")[WORK]
    df["work_vs_circular"] = df[WORK] / df.w0.map(circ)
    return df, expr, circ.to_dict()


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", help="output folder (default output/cam_design, with --knee-contact "
                    "output/cam_design_kc)")
    ap.add_argument("--w0", type=float, nargs="+", default=W0, help="contact weights (default 1 500 1000)")
    ap.add_argument("--min-work", type=float, default=0.9,
                    help="required quadriceps work at every w0, a fraction of the circular cam's (default 0.9)")
    ap.add_argument("--ratios", type=int, default=71, help="ellipses of the comparison grid (b/a 0.3 to 1.0)")
    ap.add_argument("--knee-contact", action="store_true",
                    help="solve with the knee contact method (setups/leg_extension_rajagopal_cam2_kc.xml) and "
                    "minimise the peak of its total tibiofemoral force (peak_tf_total_N) instead of the plain "
                    "reaction's tibiofemoral compression (peak_tf_compression_N)")
    a = ap.parse_args(argv)
    setup = SETUP_KC if a.knee_contact else SETUP
    goal = goal_of(a.knee_contact)
    what = "total tibiofemoral force (knee contact)" if a.knee_contact else "tibiofemoral compression"
    if a.out is None:
        a.out = str(REPO / "output" / ("cam_design_kc" if a.knee_contact else "cam_design"))
    start = time.perf_counter()
    w0s = sorted(set(a.w0))

    # The grid: every ellipse at every w0; its best shape meeting the work
    # requirement at every w0 (lowest worst-case peak over the band).
    ratios = sorted({float(r) for r in np.round(np.linspace(0.3, 1.0, a.ratios), 6)} | {1.0})
    grid, ellipse_expr, work_circ = ellipse_grid(ratios, w0s, setup)
    band = grid.groupby("b_over_a").agg(worst=(goal, "max"), least_work=("work_vs_circular", "min"))
    feasible = band[band.least_work >= a.min_work]
    best_ratio = float(feasible.worst.idxmin())
    best_ellipse = float(feasible.worst.min())

    # Start from the best ellipse's profile (feasible), read at the knots.
    ev = Evaluator(w0s, work_circ, setup, goal)
    knots = np.radians(KNOTS_DEG)
    v = -torque(ellipse_expr[best_ratio], -knots)
    z0 = np.clip(np.r_[v[0] / PEAK, v[1:] / np.maximum(v[:-1], 1e-9)], 0, 1)
    margin = 1e-4  # the constraint with room for rounding: met, not grazed

    def objective(y):
        return y[-1]

    def objective_grad(y):
        g = np.zeros_like(y)
        g[-1] = 1.0
        return g

    def cons(y):
        p, w, _, _ = ev.with_gradient(y[:-1])
        return np.r_[y[-1] - p, w - a.min_work - margin]

    def cons_jac(y):
        _, _, jp, jw = ev.with_gradient(y[:-1])
        n = len(w0s)
        j = np.zeros((2 * n, len(y)))
        j[:n, :-1] = -jp
        j[:n, -1] = 1.0
        j[n:, :-1] = jw
        return j

    p0, w0v, _, _ = ev.with_gradient(z0)
    y0 = np.r_[z0, p0.max()]
    res = minimize(objective, y0, jac=objective_grad, method="SLSQP",
                   bounds=[(0.0, 1.0)] * len(z0) + [(0.0, None)],
                   constraints=[{"type": "ineq", "fun": cons, "jac": cons_jac}],
                   options={"maxiter": 60, "ftol": 1e-3})
    z = np.clip(res.x[:-1], 0, 1)
    # SLSQP may stop at an iterate that grazes the work constraint (with the
    # knee contact method the loads are not smooth in the profile: the
    # compartments' l >= 0 and activation bounds switch on and off): then
    # the answer is the best feasible profile it evaluated.
    fallback = False
    if not (ev.batch([z])[0][1] >= a.min_work).all():
        zb = ev.best_feasible(a.min_work)
        if zb is not None:
            z, fallback = zb, True
    values = profile_values(z)
    expr = spline_expression(values)
    # The optimum, evaluated on its own (a force sweep of one profile).
    rows = ev.scene.run([{"w0": w, "expressions": {"cam_torque": expr}} for w in w0s])
    opt = pd.DataFrame(rows)
    opt.insert(0, "w0", w0s)
    opt.insert(1, "work_vs_circular", [r[WORK] / work_circ[w] for r, w in zip(rows, w0s)])
    first = ["w0", GOAL, "work_vs_circular"] + ([goal] if goal != GOAL else [])
    cols = first + [c for c in opt.columns if c not in first]
    opt = opt[cols]
    for k, (deg, val) in enumerate(zip(KNOTS_DEG, values)):
        opt[f"knot{k}_flexion_deg"] = deg
        opt[f"knot{k}_torque_Nm"] = val
    opt["expression"] = expr
    meets = bool((opt.work_vs_circular >= a.min_work).all())
    worst = float(opt[goal].max())

    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    opt.to_csv(out / "cam_optimum.csv", index=False)
    print(f"SLSQP: {res.message} ({res.nit} iterations, {ev.sweeps} force sweeps of up to "
          f"{(len(z0) + 1) * len(w0s)} candidates)")
    if fallback:
        print("SLSQP's last iterate misses the work constraint: the best feasible profile it evaluated is taken")
    print("profile (knee flexion deg: resistance N m): "
          + ", ".join(f"{d:g}: {t:.2f}" for d, t in zip(KNOTS_DEG, values)))
    print(opt[[*first, WORK, "peak_pf_compression_N"]].to_string(
        index=False, float_format=lambda x: f"{x:.4f}"))
    print(f"work constraint (>= {a.min_work:.0%} of circular at every w0): {'met' if meets else 'NOT met'}")
    print(f"worst-case peak {what}: optimum {worst:.1f} N, best feasible ellipse "
          f"(b/a = {best_ratio:g}) {best_ellipse:.1f} N, circular {band.loc[1.0].worst:.1f} N")

    # Figure: profiles; compression over flexion (band over w0); Pareto front.
    runs = {name: statopt.run(setup, contact_weight=w0s, progress=False,
                              model_properties={"cam_torque/expression": e})
            for name, e in (("optimum", expr), (f"best ellipse b/a = {best_ratio:g}", ellipse_expr[best_ratio]),
                            ("circular", ellipse_expr[1.0]))}
    fig, ax = plt.subplots(1, 3, figsize=(17, 5))
    q = np.radians(np.linspace(5, 95, 181))
    ax[0].plot(np.degrees(q), profile_torque(values, q), color="C3", lw=2.5, label="optimum (spline)")
    ax[0].plot(KNOTS_DEG, values, "o", color="C3", label="control points")
    ax[0].plot(np.degrees(q), -torque(ellipse_expr[best_ratio], -q), color="C0",
               label=f"best ellipse, b/a = {best_ratio:g}")
    ax[0].plot(np.degrees(q), -torque(ellipse_expr[1.0], -q), color="C7", label="circular")
    ax[0].set(xlabel="knee flexion (deg)", ylabel="resistance torque (N m)", title="Cam torque profiles",
              ylim=(0, PEAK * 1.08))
    ax[0].invert_xaxis()
    for (name, r), c in zip(runs.items(), ["C3", "C0", "C7"]):
        _, _, flex, v = compression_curves(r, a.knee_contact)[0]
        ax[1].fill_between(flex, v.min(axis=1), v.max(axis=1), color=c, alpha=0.2)
        ax[1].plot(flex, np.median(v, axis=1), color=c, label=f"{name} (band over w0)")
    ax[1].set(xlabel="knee flexion (deg)", ylabel=f"{what}, right knee (N)",
              title="Knee loads")
    ax[1].invert_xaxis()
    pts = band.reset_index()
    ax[2].scatter(pts.least_work * 100, pts.worst, s=12, c=pts.b_over_a, cmap="viridis",
                  label="ellipses b/a 0.3-1.0")
    order = pts.sort_values("least_work", ascending=False)
    # non-dominated: no shape with as much work or more has as low a peak
    front = order[order.worst < order.worst.cummin().shift(fill_value=np.inf)]
    ax[2].plot(front.least_work * 100, front.worst, "k-", lw=1, label="Pareto front of the grid")
    ax[2].plot([band.loc[best_ratio].least_work * 100], [best_ellipse], "s", color="C0", ms=9,
               label=f"best feasible ellipse b/a = {best_ratio:g}")
    ax[2].plot([opt.work_vs_circular.min() * 100], [worst], "*", color="C3", ms=16, label="optimum (spline)")
    ax[2].axvline(a.min_work * 100, color="k", ls=":", label=f"required work {a.min_work:.0%}")
    ax[2].set(xlabel="quadriceps work, least over w0 (% of circular)",
              ylabel=f"peak {what}, worst over w0 (N)", title=f"Work against peak {what}")
    for x in ax:
        x.grid(alpha=0.3)
        x.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "cam_optimum.png", dpi=110)
    plt.close(fig)
    print(f"wrote {out / 'cam_optimum.csv'} and {out / 'cam_optimum.png'} in {time.perf_counter() - start:.1f} s")
    return opt, best_ellipse, meets


if __name__ == "__main__":
    main()
