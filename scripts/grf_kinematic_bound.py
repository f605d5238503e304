#!/usr/bin/env python3
"""What the bar's kinematics allow (issue 27; docs/grf_prediction.md,
"What the filtered kinematics allow"). Needs OpenSim 4.6 and numpy.

For each development setup of scripts/grf_dev_setups.py (the issue's bar:
12 / 6 Hz low-pass, the IK's range less 0.1 / 0.03 s at each end), OpenSim's
own InverseDynamicsTool, without external loads, gives the force the
filtered motion requires of the world on the pelvis translations
(pelvis_tx/ty_force: sum of m_i a_i - m_i g over the bodies). statopt is not
used, so the numbers do not depend on it.

Compared with the plates:
- "sum": the requirement against the plates' sum (vertical and AP);
- "oracle per foot": the requirement split between the feet exactly as the
  plates split their vertical force (zero where the plates measure nothing).
  This is a prediction that knows the plates' timing and split and meets
  the equations of motion with no residual; scored as the bar scores
  statopt: per foot over every frame, rho and RMSE (% body weight), mean
  over the two feet. A method that satisfies the equations of motion can
  only beat it where its root residual happens to carry the kinematics'
  error.

Usage: osim-venv/bin/python scripts/grf_kinematic_bound.py
       [--setups target/grf_dev_setups] [--out /tmp/grf_bound]
"""
import argparse
import glob
import os
import sys
import xml.etree.ElementTree as ET

import numpy as np

STANCE_N = 20.0  # plates' vertical force above which a foot is down
CUTOFF = None  # --cutoff: another low-pass than the setup's (Hz; -1: none)


def read_table(path):
    """Labels (time first) and rows of a table, read with statopt's reader."""
    import statopt

    df = statopt.read_table(path)
    return ["time", *df.columns], np.column_stack([df.index.to_numpy(), df.to_numpy()])


def text(root, tag):
    el = root.find(".//" + tag)
    return None if el is None or el.text is None else el.text.strip()


def measured_feet(loads_xml):
    """Per foot ('r', 'l'): force (n, 3) of every plate on it, summed, and the time."""
    root = ET.parse(loads_xml).getroot()
    datafile = text(root, "datafile")
    if not os.path.isabs(datafile):
        datafile = os.path.join(os.path.dirname(loads_xml), datafile)
    labels, data = read_table(datafile)
    t = data[:, 0]
    feet = {"r": np.zeros((len(t), 3)), "l": np.zeros((len(t), 3))}
    for ef in root.iter("ExternalForce"):
        body = ef.find("applied_to_body").text.strip()
        fid = ef.find("force_identifier").text.strip()
        side = body[-1]
        cols = [labels.index(fid + a) for a in "xyz"]
        feet[side] += data[:, cols]
    return t, feet


def required(setup, out):
    import opensim as osim

    root = ET.parse(setup).getroot()
    name = root.find(".//AnalyzeTool").get("name")
    model = osim.Model(text(root, "model_file"))
    state = model.initSystem()
    weight = model.getTotalMass(state) * 9.80665
    idt = osim.InverseDynamicsTool()
    idt.setModel(model)
    idt.setCoordinatesFileName(text(root, "coordinates_file"))
    cutoff = float(text(root, "lowpass_cutoff_frequency_for_coordinates"))
    idt.setLowpassCutoffFrequency(cutoff if CUTOFF is None else CUTOFF)
    idt.setStartTime(float(text(root, "initial_time")))
    idt.setEndTime(float(text(root, "final_time")))
    excluded = osim.ArrayStr()
    excluded.append("Muscles")
    idt.setExcludedForces(excluded)
    idt.setResultsDir(out)
    idt.setOutputGenForceFileName(name + "_id.sto")
    idt.run()
    labels, data = read_table(os.path.join(out, name + "_id.sto"))
    req = np.stack([data[:, labels.index(f"pelvis_t{a}_force")] for a in "xyz"], axis=1)
    return name, data[:, 0], req, weight, text(root, "external_loads_file")


def rho(a, b):
    return float(np.corrcoef(a, b)[0, 1])


def rmse_bw(a, b, w):
    return float(100 * np.sqrt(np.mean((a - b) ** 2)) / w)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--setups", default="target/grf_dev_setups")
    ap.add_argument("--out", default="/tmp/grf_bound")
    ap.add_argument("--only", default="", help="setups whose name contains this")
    ap.add_argument("--cutoff", type=float, default=None,
                    help="low-pass instead of the setup's (Hz; -1: none), to see what the filter does")
    args = ap.parse_args()
    global CUTOFF
    CUTOFF = args.cutoff
    os.makedirs(args.out, exist_ok=True)
    # knee_gc5's IK holds degrees in its knee_angle_*_beta columns, which
    # OpenSim reads as radians: its inverse dynamics there is no reference.
    setups = sorted(p for p in glob.glob(os.path.join(args.setups, "*.xml"))
                    if args.only in os.path.basename(p) and "knee_gc5" not in p)
    if not setups:
        sys.exit(f"no setups in {args.setups}: run scripts/grf_dev_setups.py first")
    print("| trial | sum: vertical rho / RMSE, AP rho / RMSE | oracle per foot: vertical rho / RMSE, AP rho / RMSE |")
    print("|---|---|---|")
    for s in setups:
        name, t, req, w, loads = required(s, args.out)
        tm, feet = measured_feet(loads)
        meas = {k: np.stack([np.interp(t, tm, v[:, a]) for a in range(3)], axis=1) for k, v in feet.items()}
        total = meas["r"] + meas["l"]
        down = total[:, 1] > STANCE_N
        share = {k: np.where(down, meas[k][:, 1] / np.where(down, total[:, 1], 1.0), 0.0) for k in meas}
        cells = []
        for a in (1, 0):
            cells.append(f"{rho(req[:, a], total[:, a]):.3f} / {rmse_bw(req[:, a], total[:, a], w):.1f}")
        line = ", ".join(cells)
        cells = []
        for a in (1, 0):
            r = np.mean([rho(req[:, a] * share[k], meas[k][:, a]) for k in "rl"])
            e = np.mean([rmse_bw(req[:, a] * share[k], meas[k][:, a], w) for k in "rl"])
            cells.append(f"{r:.3f} / {e:.1f}")
        print(f"| {name} | {line} | {', '.join(cells)} |", flush=True)


if __name__ == "__main__":
    main()
