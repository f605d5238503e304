"""Muscle geometry of the Rajagopal family with OpenSim 4.6, for tests/rajagopal_geometry.rs.

Run:  /work/osim-venv/bin/python tests/reference_scripts/rajagopal_geometry_reference.py
writes tests/data/rajagopal_geometry_opensim46.json.

For Rajagopal2016.osim and RajagopalLaiUhlrich2023.osim (../shared/models/rajagopal2016/): six poses,
pose k setting every free coordinate to the fraction f_k of its range (alternating ends for the left
side so that the legs differ), assembled (the patella couplers solve knee_angle_*_beta). Recorded per
pose: every coordinate's assembled value (so the test sets exactly these q), and per muscle its path
length and its moment arms about hip_flexion_r, hip_adduction_r, knee_angle_r, ankle_angle_r and
knee_angle_l.
"""
import json, os
import opensim as osim

HERE = os.path.dirname(os.path.abspath(__file__))
SHARED = os.path.join(HERE, "..", "..", "..", "shared", "models", "rajagopal2016")
MODELS = ["Rajagopal2016.osim", "RajagopalLaiUhlrich2023.osim"]
FRACTIONS = [0.1, 0.25, 0.4, 0.55, 0.7, 0.9]
MA_COORDS = ["hip_flexion_r", "hip_adduction_r", "knee_angle_r", "ankle_angle_r", "knee_angle_l"]

out = {}
for name in MODELS:
    m = osim.Model(os.path.join(SHARED, name))
    s = m.initSystem()
    cs = m.getCoordinateSet()
    muscles = m.getMuscles()
    poses = []
    for k, f in enumerate(FRACTIONS):
        for i in range(cs.getSize()):
            c = cs.get(i)
            if c.isDependent(s) or c.get_locked():
                continue
            lo, hi = c.getRangeMin(), c.getRangeMax()
            if not (abs(lo) < 1e3 and abs(hi) < 1e3):
                continue
            g = f if (c.getName().endswith("_r") or k % 2 == 0) else 1.0 - f
            # pelvis translations stay near their defaults: they do not change paths
            if c.getName().startswith("pelvis_t"):
                continue
            c.setValue(s, lo + g * (hi - lo), False)
        m.assemble(s)
        m.realizeVelocity(s)
        q = {cs.get(i).getName(): cs.get(i).getValue(s) for i in range(cs.getSize())}
        mus = {}
        for j in range(muscles.getSize()):
            mu = muscles.get(j)
            mus[mu.getName()] = {
                "length": mu.getLength(s),
                "moment_arms": {c: mu.computeMomentArm(s, cs.get(c)) for c in MA_COORDS},
            }
        poses.append({"fraction": f, "q": q, "muscles": mus})
    out[name] = poses
    print(name, len(poses), "poses,", muscles.getSize(), "muscles")

with open(os.path.join(HERE, "..", "data", "rajagopal_geometry_opensim46.json"), "w") as fh:
    json.dump(out, fh, sort_keys=True)
