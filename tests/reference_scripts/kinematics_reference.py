# OpenSim 4.6's BodyKinematics and PointKinematics on the gait10dof18musc walk, as the reference
# of tests/validation_kinematics.rs.
#
# The setup is tests/data/kinematics/setup_walk_kinematics.xml (the walk's model, motion, times and
# 6 Hz filter; BodyKinematics of all bodies in degrees in ground, BodyKinematics of two bodies and
# the centre of mass in radians in the bodies' frames, a point on calcn_r in ground and a point on
# toes_l relative to the pelvis). OpenSim 4.6's AnalyzeTool runs it; its position and velocity
# tables are the reference as written.
#
# Accelerations: in an AnalyzeTool run from a coordinates file, OpenSim 4.6's analyses realise the
# state to the acceleration stage, i.e. forward dynamics of the model under its forces with the
# muscles' states at their defaults (activation 0.05, default fiber lengths), not the motion's
# accelerations (on this walk femur_r's centre of mass "accelerates" at 1.4e5 m/s^2). statopt writes
# the motion's accelerations instead (u' = S_u', static optimization's targets, opensim-semantics
# 6.3). Their reference is computed here with OpenSim too: at each frame the state is set to the
# AnalyzeTool's q and u, and SimbodyMatterSubsystem::calcBodyAccelerationFromUDot gives every
# body's spatial acceleration for u' = S_u' (q, u, S_u' from the case's SO_kinematic_targets.sto,
# rebuilt with OpenSim's GCVSplineSet from the AnalyzeTool states); a station's acceleration is then
# a_o + alpha x r + w x (w x r), re-expressed in a body's frame where the table is. As a check the
# script prints how far those accelerations lie from central differences of OpenSim's velocities.
#
# Stored (tests/data/kinematics/*.sto): rows 0, 1, 2, every 10th row and the last three rows of
# every table (all columns), at 17 significant digits.
#
# Usage (OpenSim 4.6 in a venv: python3 -m venv V && V/bin/pip install opensim==4.6):
#   V/bin/python tests/reference_scripts/kinematics_reference.py [--store]
import math, os, re, shutil, sys

import numpy as np
import opensim as osim

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
DATA = os.path.join(REPO, "tests", "data", "kinematics")
SETUP = os.path.join(DATA, "setup_walk_kinematics.xml")
CASE = os.path.normpath(os.path.join(REPO, "..", "shared", "validation", "gait10dof18musc_walk"))
OUT = "/tmp/kinematics_reference"


def read_sto(path):
    lines = open(path).read().splitlines()
    end = next(i for i, l in enumerate(lines) if l.strip() == "endheader")
    labels = lines[end + 1].split("\t")
    rows = np.array([[float(x) for x in l.split()] for l in lines[end + 2:] if l.strip()])
    return lines[:end], labels, rows


def write_sto(path, name, header_lines, labels, rows):
    keep = [i for i in range(len(rows)) if i < 3 or i % 10 == 0 or i >= len(rows) - 3]
    with open(path, "w") as f:
        f.write(name + "\nversion=1\n")
        f.write("nRows=%d\nnColumns=%d\n" % (len(keep), len(labels)))
        for l in header_lines:
            f.write(l + "\n")
        f.write("endheader\n" + "\t".join(labels) + "\n")
        for i in keep:
            f.write("\t".join("%.17g" % v for v in rows[i]) + "\n")


def main():
    store = "--store" in sys.argv
    if os.path.isdir(OUT):
        shutil.rmtree(OUT)
    os.makedirs(OUT)
    os.chdir(OUT)  # OpenSim's opensim.log goes here
    # The setup, run from a copy beside it so that its relative paths hold, writing to OUT.
    text = open(SETUP).read()
    text = re.sub(r"<results_directory>.*?</results_directory>",
                  "<results_directory>%s</results_directory>" % OUT, text)
    run_setup = os.path.join(DATA, ".setup_run.xml")
    open(run_setup, "w").write(text)
    try:
        osim.AnalyzeTool(run_setup).run()
    finally:
        os.remove(run_setup)

    # The motion's accelerations, by OpenSim's calcBodyAccelerationFromUDot.
    model = osim.Model(os.path.join(CASE, "inputs", "subject01.osim"))
    s = model.initSystem()
    matter = model.getMatterSubsystem()
    coords = model.getCoordinateSet()
    ncoord = coords.getSize()
    # Each coordinate's slot in the state's U vector.
    uslot = []
    for k in range(ncoord):
        for j in range(ncoord):
            coords.get(j).setSpeedValue(s, 0.0)
        coords.get(k).setSpeedValue(s, 1.0)
        u = s.getU()
        uslot.append(next(i for i in range(s.getNU()) if u.get(i) == 1.0))
    _, tl, targets = read_sto(os.path.join(CASE, "results", "gait10dof18musc_walk_SO_kinematic_targets.sto"))
    col = {l: i for i, l in enumerate(tl)}
    bodies = model.getBodySet()
    ground = model.getGround()
    nb = bodies.getSize()
    mass = [bodies.get(b).getMass() for b in range(nb)]

    def vec(v):
        return np.array([v.get(0), v.get(1), v.get(2)])

    def frame_state(row):
        s.setTime(row[0])
        for k in range(ncoord):
            c = coords.get(k)
            c.setValue(s, row[col[c.getName() + "_q"]], False)
            c.setSpeedValue(s, row[col[c.getName() + "_u"]])
        model.realizeVelocity(s)
        udot = osim.Vector(s.getNU(), 0.0)
        for k in range(ncoord):
            udot.set(uslot[k], row[col[coords.get(k).getName() + "_udot"]])
        acc = osim.VectorOfSpatialVec()
        matter.calcBodyAccelerationFromUDot(s, udot, acc)
        return acc

    def station_acc(body, acc, station):
        """Ground acceleration of `station` (body coordinates) on the Body `body`."""
        p = osim.Vec3(*station)
        a = acc.get(body.getMobilizedBodyIndex())
        alpha, a0 = vec(a.get(0)), vec(a.get(1))
        w = vec(body.getVelocityInGround(s).get(0))
        r = vec(body.expressVectorInGround(s, p))
        return a0 + np.cross(alpha, r) + np.cross(w, np.cross(w, r)), alpha

    def to_frame(frame, v):
        return vec(ground.expressVectorInAnotherFrame(s, osim.Vec3(*v), frame))

    # Which analyses, as the setup holds them.
    analyses = [
        ("BodyKinematics", "body", None, True, False),
        ("ShankLocal", "body", ["tibia_r", "center_of_mass", "calcn_l"], False, True),
        ("PointKinematics", "point", ("calcn_r", "heel_r", (0.01, 0.01, -0.005), None), None, None),
        ("ToeInPelvis", "point", ("toes_l", "toe_l", (0.05, 0.0, 0.01), "pelvis"), None, None),
    ]
    worst_fd = 0.0
    for name, kind, what, degrees, local in analyses:
        if kind == "body":
            sfx = "_bodyLocal" if local else "_global"
            files = {"pos": "walk_%s_pos_global.sto" % name, "vel": "walk_%s_vel%s.sto" % (name, sfx),
                     "acc": "walk_%s_acc%s.sto" % (name, sfx)}
        else:
            files = {k: "walk_%s_%s_%s.sto" % (name, what[1], k) for k in ("pos", "vel", "acc")}
        header, labels, vel = read_sto(os.path.join(OUT, files["vel"]))
        _, _, pos = read_sto(os.path.join(OUT, files["pos"]))
        acc_rows = []
        for row in targets:
            acc = frame_state(row)
            out = [row[0]]
            if kind == "body":
                names = [bodies.get(b).getName() for b in range(nb)] if what is None else \
                    [n for n in what if n != "center_of_mass"]
                for n in names:
                    b = bodies.get(n)
                    a, alpha = station_acc(b, acc, tuple(vec(b.get_mass_center())))
                    if local:
                        a, alpha = to_frame(b, a), to_frame(b, alpha)
                    k = 180.0 / math.pi if degrees else 1.0
                    out += list(a) + list(alpha * k)
                if what is None or "center_of_mass" in what:
                    ac = sum(mass[b] * station_acc(bodies.get(b), acc, tuple(vec(bodies.get(b).get_mass_center())))[0]
                             for b in range(nb)) / sum(mass)
                    out += list(ac)
            else:
                body, _, point, rel = what
                a, _ = station_acc(bodies.get(body), acc, point)
                if rel is not None:
                    a = to_frame(bodies.get(rel), a)
                out += list(a)
            acc_rows.append(out)
        acc_rows = np.array(acc_rows)
        assert acc_rows.shape == vel.shape, (name, acc_rows.shape, vel.shape)
        # Check: central differences of OpenSim's velocities (interior rows), relative to each
        # column's peak, where the tables are in ground (a vector re-expressed in a moving frame
        # is not the derivative of the re-expressed velocity). At 60 frames/s the differences
        # themselves err by about (2 pi 6 Hz dt)^2 / 6 = 7 % of a 6 Hz component's peak.
        t = vel[:, 0]
        if local or (kind == "point" and what[3] is not None):
            print("%-16s %d rows x %d columns (in a moving frame: no difference check)"
                  % (name, len(t), len(labels) - 1))
        else:
            fd = (vel[2:, 1:] - vel[:-2, 1:]) / (t[2:] - t[:-2])[:, None]
            peak = np.maximum(np.abs(acc_rows[:, 1:]).max(axis=0), 1e-12)
            rel_err = (np.abs(fd - acc_rows[1:-1, 1:]) / peak)[5:-5].max()
            worst_fd = max(worst_fd, rel_err)
            print("%-16s %d rows x %d columns; accelerations vs differenced velocities: %.2e of peak"
                  % (name, len(t), len(labels) - 1, rel_err))
        if store:
            hdr = [l for l in header[2:] if l.startswith("inDegrees")]
            tag = "OpenSim 4.6 AnalyzeTool %s (tests/reference_scripts/kinematics_reference.py)" % name
            write_sto(os.path.join(DATA, files["pos"]), "Positions", hdr + [tag], labels, pos)
            write_sto(os.path.join(DATA, files["vel"]), "Velocities", hdr + [tag], labels, vel)
            write_sto(os.path.join(DATA, files["acc"]), "Accelerations",
                      hdr + [tag + "; accelerations of u' = S_u' by calcBodyAccelerationFromUDot"],
                      labels, acc_rows)
    print("worst accelerations vs differenced velocities: %.2e of peak" % worst_fd)


if __name__ == "__main__":
    main()
