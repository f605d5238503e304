# OpenSim 4.6 check of the leg extension study's model files, and the inverse-dynamics reference
# tests/data/opensim46_leg_extension_human_ID.sto.
#
#   /work/venv/bin/python tests/reference_scripts/leg_extension_opensim.py
#
# 1. loads models/leg_extension/human_seated.osim and the three machine files with
#    opensim.Model(path) + initSystem() and prints bodies, coordinates, masses, forces;
# 2. evaluates, with OpenSim's own kinematics in the default (seated) poses, each contact of
#    contacts.xml: the point on the human body and the plane on the machine body, both in ground,
#    and prints the signed distance (independent of statopt and of the generator's kinematics);
# 3. prints the cam torques by realizing the machine models at lever angles -95..-5 deg;
# 4. runs OpenSim's InverseDynamicsTool on human_seated.osim with test_knee_extension.mot
#    (muscles excluded, no filtering) and writes tests/data/opensim46_leg_extension_human_ID.sto
#    (precision 10).
import math
import os
import shutil
import tempfile
import xml.etree.ElementTree as ET

import opensim as osim

osim.Logger.removeFileSink()  # no opensim.log beside the models

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
DIR = os.path.join(REPO, "models", "leg_extension")


def vec(v):
    return [v.get(i) for i in range(3)]


def load(name):
    m = osim.Model(os.path.join(DIR, name))
    s = m.initSystem()
    mass = sum(m.getBodySet().get(i).getMass() for i in range(m.getBodySet().getSize()))
    print(f"{name}: OK, {m.getBodySet().getSize()} bodies, {m.getCoordinateSet().getSize()} coordinates, "
          f"{m.getForceSet().getSize()} forces ({m.getMuscles().getSize()} muscles), total mass {mass:.4f} kg")
    return m, s


human, hs = load("human_seated.osim")
machines = {n: load(n) for n in ("machine_cam1.osim", "machine_cam2.osim", "machine_cam1_axis_offset.osim")}
print("human COM (seated):", [round(x, 4) for x in vec(human.calcMassCenterPosition(hs))])

human.realizePosition(hs)
contacts = ET.parse(os.path.join(DIR, "contacts.xml")).getroot().find("ForceSet/objects")
for mname, (mach, ms) in machines.items():
    mach.realizePosition(ms)
    worst = 0.0
    for c in contacts:
        pb = human.getBodySet().get(c.find("point_body").text)
        p = [float(x) for x in c.find("point_location").text.split()]
        pg = vec(pb.findStationLocationInGround(hs, osim.Vec3(*p)))
        plb = mach.getBodySet().get(c.find("plane_body").text)
        o = [float(x) for x in c.find("plane_origin").text.split()]
        n = [float(x) for x in c.find("plane_normal").text.split()]
        og = vec(plb.findStationLocationInGround(ms, osim.Vec3(*o)))
        ng = vec(plb.expressVectorInGround(ms, osim.Vec3(*n)))
        d = sum((a - b) * k for a, b, k in zip(pg, og, ng))
        worst = max(worst, abs(d))
        print(f"  {mname} {c.get('name'):24s} point {[round(x, 5) for x in pg]} d = {d:+.3e} m")
    print(f"{mname}: largest |d| in the seated pose {worst:.3e} m")

for mname, (mach, ms) in machines.items():
    coord = mach.getCoordinateSet().get("lever_angle")
    f = osim.ExpressionBasedCoordinateForce.safeDownCast(mach.getForceSet().get("cam_torque"))
    vals = []
    for deg in (-95, -65, -35, -5):
        coord.setValue(ms, deg * math.pi / 180)
        mach.realizeDynamics(ms)
        vals.append(f"{deg}:{f.getForceMagnitude(ms):.4f}")
    print(f"{mname}: cam torque {vals}")

# Inverse dynamics reference
tmp = tempfile.mkdtemp()
idt = osim.InverseDynamicsTool()
idt.setName("leg_extension_human")
idt.setModelFileName(os.path.join(DIR, "human_seated.osim"))
idt.setCoordinatesFileName(os.path.join(DIR, "test_knee_extension.mot"))
idt.setLowpassCutoffFrequency(-1)
idt.setStartTime(0)
idt.setEndTime(5)
excl = osim.ArrayStr()
excl.append("Muscles")
idt.setExcludedForces(excl)
idt.setResultsDir(tmp)
idt.setOutputGenForceFileName("id.sto")
idt.setModel(human)
# precision 10 through the global IO default used by Storage::print
osim.IO.SetPrecision(10)
ok = idt.run()
print("InverseDynamicsTool.run():", ok)
dst = os.path.join(REPO, "tests", "data", "opensim46_leg_extension_human_ID.sto")
os.makedirs(os.path.dirname(dst), exist_ok=True)
shutil.copy(os.path.join(tmp, "id.sto"), dst)
print("wrote", dst)
