#!/usr/bin/env python3
"""Where predict-grf's errors come from, per development trial (issue 27;
docs/grf_prediction.md, "Diagnosis"). Reads the outputs that
scripts/grf_dev_table.py left in --out (default /tmp/grf_dev_table) and the
measured plates named by each setup in --setups. Needs numpy.

Per trial:
- kinematics: the force the filtered motion requires of the world on the
  pelvis translations (`pelvis_tx/ty_required` of
  GeneralizedForcesBySource: m a_COM, plus m g vertically) against the sum of
  the plates, rho and RMSE (% BW). No contact model can do better than this
  on the sum of the feet; in single support (running) the sum is the foot;
- the same with the requirement set to zero where the plates measure
  nothing (flight): what feet that carry exactly what the motion requires
  whenever one is down would score;
- the prediction's sum of the feet against the plates' sum, and the mean
  over the feet (the bar's figure): the gap between the sum and the feet is
  the split between the feet (double support);
- frames with a root residual above 25 % BW: in flight (plates < 20 N),
  within 30 ms of a measured touchdown or toe-off, or in mid-stance; and
  among the on-floor ones, those where a foot point is within the contact
  band (w(d) >= 0.5) but its slip speed gate (speed_weight) is below 0.5;
- friction: the share of stance frames (plates' Fy > 10 % BW) where the
  plates' |shear| / Fy exceeds the contacts' static coefficient 0.35.
"""
import argparse, os, re, sys
import numpy as np

D_TOL, D_TRANS, SW = 0.005, 0.03, (0.3, 1.2)


def read(p):
    """Labels (time first) and rows of a table, read with statopt's reader."""
    import statopt

    df = statopt.read_table(p)
    return ["time", *df.columns], np.column_stack([df.index.to_numpy(), df.to_numpy()])


def tag(xml, t):
    m = re.search(rf"<{t}>\s*([^<]*?)\s*</{t}>", xml)
    return m.group(1) if m else None


def rho_rmse(a, b, bw):
    return np.corrcoef(a, b)[0, 1], 100 * np.sqrt(np.mean((a - b) ** 2)) / bw


def wd(d):
    w = 0.5 * (1 + np.tanh(-np.pi * (2 * (d - D_TOL) - D_TRANS) / D_TRANS))
    return np.where(d > D_TOL + D_TRANS, 0.0, w)


def gate(s):
    x = np.clip((s - SW[0]) / (SW[1] - SW[0]), 0, 1)
    return 1 - x * x * (3 - 2 * x)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default="/tmp/grf_dev_table")
    ap.add_argument("--setups", default="target/grf_dev_setups")
    ap.add_argument("--only", default="")
    ap.add_argument("--walk-ap", action="store_true",
                    help="the AP error of the muscle-model walking trials, phase by phase")
    ap.add_argument("--frames", default="",
                    help="with --walk-ap: T0:T1, print every frame in [T0, T1] s (forces, contacts, plantarflexors)")
    ap.add_argument("--shared", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "shared"))
    a = ap.parse_args()
    if a.walk_ap:
        return walk_ap(a)
    if not os.path.isdir(a.setups):
        print(f"SKIP: {a.setups} is absent (run scripts/grf_dev_setups.py)")
        return 0
    print("| trial | required vs plates: vertical rho / RMSE, AP rho / RMSE | required, zero in flight | feet summed: vertical, AP | per foot (mean): vertical, AP | root > 25 % BW: flight / touchdown / toe-off / mid-stance (in band but speed-gated) | stance frames with plates' shear/Fy > 0.35 |")
    print("|---|---|---|---|---|---|---|")
    for f in sorted(os.listdir(a.setups)):
        if not f.endswith(".xml") or (a.only and a.only not in f):
            continue
        name = f[:-4]
        out = os.path.join(a.out, name)
        gen = os.path.join(out, f"{name}_StaticOptimization_GeneralizedForcesBySource.sto")
        if not os.path.isfile(gen):
            continue
        setup = open(os.path.join(a.setups, f)).read()
        model = open(tag(setup, "model_file")).read()
        bw = sum(float(x) for x in re.findall(r"<mass>([^<]+)</mass>", model)) * 9.80665
        loads_xml = tag(setup, "external_loads_file")
        lx = open(loads_xml).read()
        mot = os.path.join(os.path.dirname(loads_xml), tag(lx, "datafile"))
        ids = re.findall(r"<force_identifier>\s*([^<]*?)\s*</force_identifier>", lx)
        bodies = re.findall(r"<applied_to_body>\s*([^<]*?)\s*</applied_to_body>", lx)
        gl, g = read(mot)
        gl_, gen_ = read(gen)
        t = gen_[:, 0]
        meas = {}
        for ax in "xy":
            meas[ax] = sum(np.interp(t, g[:, 0], g[:, gl.index(i + ax)]) for i in ids)
        feet_meas = {}
        for i, b in zip(ids, bodies):
            s = b[-1]
            for ax in "xy":
                feet_meas[(s, ax)] = feet_meas.get((s, ax), 0) + np.interp(t, g[:, 0], g[:, gl.index(i + ax)])
        req = {"x": gen_[:, gl_.index("pelvis_tx_required")], "y": gen_[:, gl_.index("pelvis_ty_required")]}
        pl, p = read(os.path.join(out, f"{name}_predicted_grf.sto"))
        pred = {ax: p[:, pl.index(f"r_force_v{ax}")] + p[:, pl.index(f"l_force_v{ax}")] for ax in "xy"}
        cells = []
        cells.append(" , ".join("%.3f / %.1f" % rho_rmse(req[ax], meas[ax], bw) for ax in "yx"))
        # The same, but zero where the plates measure nothing (flight): what
        # feet that carry exactly the required force whenever one is down
        # would give.
        down = meas["y"] > 20
        cells.append(" , ".join("%.3f / %.1f" % rho_rmse(np.where(down, req[ax], 0), meas[ax], bw) for ax in "yx"))
        cells.append(" , ".join("%.3f / %.1f" % rho_rmse(pred[ax], meas[ax], bw) for ax in "yx"))
        per = []
        for ax in "yx":
            v = [rho_rmse(p[:, pl.index(f"{s}_force_v{ax}")], feet_meas[(s, ax)], bw) for s in "rl"]
            per.append("%.3f / %.1f" % (np.mean([x[0] for x in v]), np.mean([x[1] for x in v])))
        cells.append(" , ".join(per))
        # Root residual frames over 25 % BW, classified.
        rl, rr = read(os.path.join(out, f"{name}_root_residual.sto"))
        over = rr[:, 2] > 25.0
        cl, c = read(os.path.join(out, f"{name}_StaticOptimization_ContactForces.sto"))
        kinds = {"flight": 0, "touchdown": 0, "toe-off": 0, "mid": 0, "gated": 0}
        for k in np.flatnonzero(over):
            tk = t[k]
            if meas["y"][k] < 20:
                kinds["flight"] += 1
                continue
            near = None
            for s in "rl":
                fy = np.interp(g[:, 0], g[:, 0], sum(g[:, gl.index(i + "y")] for i, b in zip(ids, bodies) if b[-1] == s))
                on = fy > 20
                e = np.flatnonzero(np.diff(on.astype(int)))
                for j in e:
                    te = g[j + 1, 0]
                    if abs(te - tk) <= 0.03:
                        near = "touchdown" if not on[j] else "toe-off"
            kinds[near or "mid"] += 1
            pts = [x[:-len("_distance")] for x in cl if x.endswith("_distance")]
            gated = any(wd(c[k, cl.index(q + "_distance")]) >= 0.5 and gate(c[k, cl.index(q + "_slip_speed")]) < 0.5 for q in pts)
            kinds["gated"] += gated
        cells.append(f"{kinds['flight']} / {kinds['touchdown']} / {kinds['toe-off']} / {kinds['mid']} ({kinds['gated']})")
        st = meas["y"] > 0.1 * bw
        ratio = np.abs(meas["x"][st]) / meas["y"][st]
        cells.append("%.0f %% (max %.2f)" % (100 * np.mean(ratio > 0.35), ratio.max()))
        print(f"| {name} | " + " | ".join(cells) + " |", flush=True)
    return 0


def plates(setup_path):
    """Per foot (r, l) and axis (x, y): the plates' force, as (time, value)."""
    setup = open(setup_path).read()
    here = os.path.dirname(setup_path)
    loads_xml = os.path.join(here, tag(setup, "external_loads_file"))
    lx = open(loads_xml).read()
    mot = os.path.join(os.path.dirname(loads_xml), tag(lx, "datafile"))
    ids = re.findall(r"<force_identifier>\s*([^<]*?)\s*</force_identifier>", lx)
    bodies = re.findall(r"<applied_to_body>\s*([^<]*?)\s*</applied_to_body>", lx)
    gl, g = read(mot)
    feet = {}
    for i, b in zip(ids, bodies):
        for ax in "xy":
            feet[(b[-1], ax)] = feet.get((b[-1], ax), 0) + g[:, gl.index(i + ax)]
    model = open(os.path.join(here, tag(setup, "model_file"))).read()
    bw = sum(float(x) for x in re.findall(r"<mass>([^<]+)</mass>", model)) * 9.80665
    return g[:, 0], feet, bw


def walk_ap(a):
    """Where the AP error of walking with muscle models sits (issue 36).

    Per foot e = predicted - measured AP force. Over both feet the squared
    error splits exactly into a part from the feet's sum, E = e_r + e_l
    (E^2 / 2 per frame), and a part from the split between them,
    d = (e_r - e_l) / 2 (2 d^2 per frame). E itself is the kinematics'
    (the requirement less the plates' sum) plus the prediction's (its sum
    less the requirement: the root residual's AP part). Counterfactuals of
    the bar's figure (mean over the feet of rho): the prediction's sum
    split as the plates split their vertical force ("split right"), the
    plates' sum split as the prediction splits it ("sum right"); and per
    double-support half and single support, the bar's figure with that
    phase alone set right (and with its split alone right). With
    --frames T0:T1, every frame in that window (see frames()).
    """
    shared = os.path.abspath(a.shared)
    trials = [
        ("gait10dof18musc_walk", os.path.join(shared, "validation/gait10dof18musc_walk/setup_SO.xml")),
        ("moco_walk3d", os.path.join(shared, "validation/moco_walk3d/setup_SO.xml")),
        ("gait2392_subject01_walk", os.path.join(shared, "models/gait2392/subject01_walk/setup_SO.xml")),
        ("knee_gc5_ss1", os.path.join(a.setups, "knee_gc5_ss1.xml")),
    ]
    # The torque-driven one-step trials too (their landing heel, issue 36).
    if os.path.isdir(a.setups):
        trials += [(f[:-4], os.path.join(a.setups, f)) for f in sorted(os.listdir(a.setups))
                   if f.startswith("2014") and f.endswith(".xml")]
    for name, setup in trials:
        out = os.path.join(a.out, name)
        if not os.path.isfile(setup) or not os.path.isdir(out) or (a.only and a.only not in name):
            continue
        pre = [f for f in os.listdir(out) if f.endswith("_predicted_grf.sto")][0][: -len("_predicted_grf.sto")]
        pl, p = read(os.path.join(out, pre + "_predicted_grf.sto"))
        t = p[:, 0]
        gl_, gen_ = read(os.path.join(out, pre + "_StaticOptimization_GeneralizedForcesBySource.sto"))
        req = np.interp(t, gen_[:, 0], gen_[:, gl_.index("pelvis_tx_required")])
        tg, feet, bw = plates(setup)
        m = {k: np.interp(t, tg, v) for k, v in feet.items()}
        pr = {(s, ax): p[:, pl.index(f"{s}_force_v{ax}")] for s in "rl" for ax in "xy"}
        e = {s: pr[(s, "x")] - m[(s, "x")] for s in "rl"}
        E = e["r"] + e["l"]
        d = (e["r"] - e["l"]) / 2
        M = m[("r", "x")] + m[("l", "x")]
        on = {s: m[(s, "y")] > 20 for s in "rl"}
        ds = on["r"] & on["l"]
        ss = on["r"] ^ on["l"]
        tot = np.sum(E ** 2 / 2 + 2 * d ** 2)
        bar = np.mean([np.corrcoef(pr[(s, "x")], m[(s, "x")])[0, 1] for s in "rl"])
        vy = m[("r", "y")] + m[("l", "y")]
        w = {s: np.where(vy > 20, m[(s, "y")] / np.maximum(vy, 1e-9), 0.5) for s in "rl"}
        split_right = np.mean([np.corrcoef(m[(s, "x")] + E * w[s], m[(s, "x")])[0, 1] for s in "rl"])
        sum_right = np.mean([np.corrcoef(pr[(s, "x")] - E * w[s], m[(s, "x")])[0, 1] for s in "rl"])
        kin = np.mean([np.corrcoef(m[(s, "x")] + (req - M) * w[s], m[(s, "x")])[0, 1] for s in "rl"])
        print(f"## {name}: AP rho (mean of feet) {bar:.3f}; split right {split_right:.3f}; sum right {sum_right:.3f}; "
              f"requirement split as the plates {kin:.3f}")
        r_req, rm_req = rho_rmse(req, M, bw)
        r_sum, rm_sum = rho_rmse(pr[("r", "x")] + pr[("l", "x")], M, bw)
        print(f"  sum: requirement vs plates rho {r_req:.3f} / {rm_req:.1f} % BW; predicted sum vs plates {r_sum:.3f} / {rm_sum:.1f}; "
              f"predicted sum - requirement RMS {100*np.sqrt(np.mean((pr[('r','x')]+pr[('l','x')]-req)**2))/bw:.1f} % BW")
        for ph, sel in (("double support", ds), ("single support", ss), ("neither", ~(ds | ss))):
            if not sel.any():
                continue
            se = np.sum(E[sel] ** 2 / 2)
            sd = np.sum(2 * d[sel] ** 2)
            ek = (req - M)[sel]
            print(f"  {ph}: {sel.sum()} frames, {100*(se+sd)/tot:.0f} % of the squared error "
                  f"(sum {100*se/tot:.0f} %, split {100*sd/tot:.0f} %); mean sum error {E[sel].mean():+.0f} N "
                  f"(kinematics {ek.mean():+.0f} N, RMS {np.sqrt(np.mean(ek**2)):.0f}; prediction vs requirement "
                  f"{(E[sel]-ek).mean():+.0f} N, RMS {np.sqrt(np.mean((E[sel]-ek)**2)):.0f})")
        # Double support's first and second half: the squeeze after the
        # strike, the trailing foot's pre-swing.
        k = np.flatnonzero(ds)
        half = np.zeros_like(ds)
        for rr in np.split(k, np.flatnonzero(np.diff(k) > 1) + 1) if len(k) else []:
            half[rr[len(rr) // 2:]] = True
        for ph, sel in (("first half of double support", ds & ~half), ("second half", ds & half)):
            print(f"    {ph}: split {100*np.sum(2*d[sel]**2)/tot:.0f} % of the squared error")
        # Double support, per foot: the leading (braking) and trailing (pushing) foot.
        for s, o in (("r", "l"), ("l", "r")):
            k = np.flatnonzero(ds)
            if not len(k):
                continue
            # runs of double support
            runs = np.split(k, np.flatnonzero(np.diff(k) > 1) + 1)
            for rr in runs:
                if len(rr) < 2:
                    continue
                # the trailing foot is the one loaded before the run began
                pre_ = rr[0] - 1
                trailing = s if pre_ >= 0 and on[s][pre_] else None
                if trailing is None:
                    continue
                lead = o
                print(f"    DS {t[rr[0]]:.3f}-{t[rr[-1]]:.3f} s, trailing {s}: trailing AP pred - meas mean {e[s][rr].mean():+.0f} N "
                      f"(max {e[s][rr].max():+.0f}), leading {e[lead][rr].mean():+.0f} N (min {e[lead][rr].min():+.0f}); "
                      f"sum error {E[rr].mean():+.0f}, kinematics {(req - M)[rr].mean():+.0f}")
        # Each phase set right (the plates' AP there, the prediction
        # elsewhere): what the bar's figure would gain from that phase alone,
        # and from its split alone (the prediction's sum shared equally).
        S = pr[("r", "x")] + pr[("l", "x")]
        phases = []
        for lab, sel in (("double support", ds), ("single support", ss)):
            k = np.flatnonzero(sel)
            for rr in np.split(k, np.flatnonzero(np.diff(k) > 1) + 1) if len(k) else []:
                if lab == "double support" and len(rr) >= 4:
                    phases.append((f"{lab} {t[rr[0]]:.3f}-{t[rr[-1]]:.3f} s, first half", rr[: len(rr) // 2]))
                    phases.append((f"{lab} {t[rr[0]]:.3f}-{t[rr[-1]]:.3f} s, second half", rr[len(rr) // 2:]))
                else:
                    phases.append((f"{lab} {t[rr[0]]:.3f}-{t[rr[-1]]:.3f} s", rr))
        for lab, rr in phases:
            q = {s_: pr[(s_, "x")].copy() for s_ in "rl"}
            q2 = {s_: pr[(s_, "x")].copy() for s_ in "rl"}
            for s_ in "rl":
                q[s_][rr] = m[(s_, "x")][rr]
                q2[s_][rr] = m[(s_, "x")][rr] + (S - M)[rr] / 2
            right = np.mean([np.corrcoef(q[s_], m[(s_, "x")])[0, 1] for s_ in "rl"])
            split = np.mean([np.corrcoef(q2[s_], m[(s_, "x")])[0, 1] for s_ in "rl"])
            print(f"    set right: {lab}: AP rho {bar:.3f} -> {right:.3f} (its split alone {split:.3f})")
        # The vertical force the filtered motion requires against the
        # plates' sum, per phase: the model's weight and the collision's peak
        # (a 6 Hz filter smooths it) fall on whichever foot the effort
        # minimum unloads.
        ry = np.interp(t, gen_[:, 0], gen_[:, gl_.index("pelvis_ty_required")])
        vd = ry - vy
        print(f"  vertical: required - plates' sum mean {vd.mean():+.0f} N (model weight {bw:.0f} N, plates' mean {vy.mean():.0f} N); "
              f"double support mean {vd[ds].mean() if ds.any() else float('nan'):+.0f}, min {vd[ds].min() if ds.any() else float('nan'):+.0f} N; "
              f"single support mean {vd[ss].mean() if ss.any() else float('nan'):+.0f} N")
        if a.frames:
            frames(a, out, pre, t, p, pl, m, req, ry)
        # Peaks per stance: braking (min) and propulsion (max).
        for s in "rl":
            k = np.flatnonzero(on[s])
            if not len(k):
                continue
            for rr in np.split(k, np.flatnonzero(np.diff(k) > 1) + 1):
                if len(rr) < 10:
                    continue
                mm, pp = m[(s, "x")][rr], pr[(s, "x")][rr]
                i, j = np.argmin(mm), np.argmin(pp)
                I, J = np.argmax(mm), np.argmax(pp)
                print(f"    stance {s} {t[rr[0]]:.3f}-{t[rr[-1]]:.3f}: braking {mm[i]:.0f} N at {t[rr[i]]:.3f} vs pred {pp[j]:.0f} at {t[rr[j]]:.3f}; "
                      f"push-off {mm[I]:.0f} at {t[rr[I]]:.3f} vs {pp[J]:.0f} at {t[rr[J]]:.3f}")
    return 0


def frames(a, out, pre, t, p, pl, m, req, ry):
    """Every frame in --frames T0:T1: the requirement and the plates' sum
    (AP / vertical), per foot the plates and the prediction (AP / vertical),
    the contact points that carry or are within reach (fx / fy N, weight,
    slip speed m/s, shear / normal), and the plantarflexors' activation and
    strength (force / activation, N: what a full activation would give at
    that frame's fibre length and speed)."""
    t0, t1 = (float(x) for x in a.frames.split(":"))
    cl, c = read(os.path.join(out, pre + "_StaticOptimization_ContactForces.sto"))
    al, act = read(os.path.join(out, pre + "_StaticOptimization_activation.sto"))
    fl, frc = read(os.path.join(out, pre + "_StaticOptimization_force.sto"))
    pts = sorted({x[:-3] for x in cl if x.endswith("_fx")}, key=lambda q: (q[-1], q))
    pf = [n for n in al if re.match(r"(soleus|gas|med_gas|lat_gas|gastroc)", n)]
    ci = np.searchsorted(c[:, 0], t - 1e-9)
    for i in np.flatnonzero((t >= t0 - 1e-9) & (t <= t1 + 1e-9)):
        j = min(ci[i], len(c) - 1)
        print(f"    {t[i]:.3f} s: required AP {req[i]:+.0f} / vertical {ry[i]:.0f} N, plates' sum "
              f"{m[('r', 'x')][i] + m[('l', 'x')][i]:+.0f} / {m[('r', 'y')][i] + m[('l', 'y')][i]:.0f}; "
              + "; ".join(f"{s} plates {m[(s, 'x')][i]:+.0f} / {m[(s, 'y')][i]:.0f}, predicted "
                          f"{p[i, pl.index(s + '_force_vx')]:+.0f} / {p[i, pl.index(s + '_force_vy')]:.0f}" for s in "rl"))
        row = []
        for q in pts:
            fx, fy, w = c[j, cl.index(q + "_fx")], c[j, cl.index(q + "_fy")], c[j, cl.index(q + "_weight")]
            if fy > 1 or w > 0.05:
                row.append(f"{q[5:] if q.startswith('foot_') else q} {fx:+.0f}/{fy:.0f} w {w:.2f} v {c[j, cl.index(q + '_slip_speed')]:.2f}"
                           + (f" ({abs(fx) / fy:.2f})" if fy > 10 else ""))
        print("      " + ", ".join(row))
        if pf:
            k = min(np.searchsorted(act[:, 0], t[i] - 1e-9), len(act) - 1)
            print("      " + ", ".join(f"{n} {act[k, al.index(n)]:.2f} ({frc[k, fl.index(n)] / max(act[k, al.index(n)], 1e-3):.0f} N)" for n in pf))


if __name__ == "__main__":
    sys.exit(main())
