"""Paths over two and three active wrap objects, with OpenSim 4.6, for tests/multi_wrap.rs.

Run:  /work/osim-venv/bin/python tests/reference_scripts/multi_wrap_reference.py
writes tests/data/multi_wrap/<case>.osim (the model) and tests/data/multi_wrap_opensim46.json.

Each case: a Millard muscle from P1 on ground to P2 on a body on a FreeJoint (P2 = the joint's
translation), over two or three wrap objects on ground placed along the line so that each can
engage, the PathWrapSet in the order named (every pair of kinds in both orders: cylinder, sphere,
ellipsoid, torus; and three objects). For several P2 the path length and the moment arms about
the three translations are recorded, with the number of points in the current path (how many
wraps engaged).
"""
import json, math, os
import opensim as osim

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "..", "data", "multi_wrap")
os.makedirs(OUT, exist_ok=True)

def make(kind, x, name):
    if kind == "cyl":
        w = osim.WrapCylinder(); w.set_radius(0.03); w.set_length(0.3)
        w.set_translation(osim.Vec3(x, -0.02, 0.0))
    elif kind == "sph":
        w = osim.WrapSphere(); w.set_radius(0.03)
        w.set_translation(osim.Vec3(x, -0.018, 0.005))
    elif kind == "ell":
        w = osim.WrapEllipsoid(); w.set_dimensions(osim.Vec3(0.04, 0.03, 0.035))
        w.set_translation(osim.Vec3(x, -0.02, -0.004))
    else:  # torus with its axis along x: the path runs through the tube's hole
        w = osim.WrapTorus(); w.set_inner_radius(0.02); w.set_outer_radius(0.08)
        w.set_xyz_body_rotation(osim.Vec3(0, math.pi / 2, 0))
        w.set_translation(osim.Vec3(x, 0.0, 0.065))
    w.setName(name)
    return w

KINDS = ["cyl", "sph", "ell", "tor"]
CASES = []
for i, a in enumerate(KINDS):
    for b in KINDS[i + 1:]:
        CASES.append((a, b))
        CASES.append((b, a))
CASES += [("cyl", "sph", "ell"), ("ell", "cyl", "sph")]
P2S = [(0.3, 0.0, 0.0), (0.28, -0.02, 0.03), (0.32, -0.01, -0.02), (0.25, 0.01, 0.01), (0.3, -0.04, 0.0)]
XS = [-0.12, 0.0, 0.12]

out = {}
for kinds in CASES:
    name = "_".join(kinds)
    model = osim.Model()
    model.setName(name)
    ground = model.updGround()
    body = osim.Body("b", 1.0, osim.Vec3(0), osim.Inertia(0.1, 0.1, 0.1))
    model.addBody(body)
    joint = osim.FreeJoint("j", ground, osim.Vec3(0), osim.Vec3(0), body, osim.Vec3(0), osim.Vec3(0))
    model.addJoint(joint)
    xs = XS if len(kinds) == 3 else [-0.1, 0.1]
    objs = []
    for k, (kind, x) in enumerate(zip(kinds, xs)):
        w = make(kind, x, f"w{k}_{kind}")
        ground.addWrapObject(w)
        objs.append(w)
    mus = osim.Millard2012EquilibriumMuscle("m", 1000.0, 0.1, 0.2, 0.0)
    gp = mus.updGeometryPath()
    gp.appendNewPathPoint("p1", ground, osim.Vec3(-0.3, 0.0, 0.0))
    gp.appendNewPathPoint("p2", body, osim.Vec3(0))
    # The PathWrapSet lists the objects in the case's order.
    for w in objs:
        gp.addPathWrap(w)
    model.addForce(mus)
    state = model.initSystem()
    model.printToXML(os.path.join(OUT, name + ".osim"))
    coords = [joint.get_coordinates(i) for i in range(6)]
    rows = []
    for p2 in P2S:
        for i in range(3):
            coords[3 + i].setValue(state, p2[i], False)
        model.realizePosition(state)
        L = gp.getLength(state)
        ma = [gp.computeMomentArm(state, coords[3 + i]) for i in range(3)]
        npts = gp.getCurrentPath(state).getSize()
        rows.append({"p2": list(p2), "length": L, "moment_arms": ma, "points": npts})
    out[name] = rows
    print(name, [(round(r["length"], 6), r["points"]) for r in rows])

with open(os.path.join(HERE, "..", "data", "multi_wrap_opensim46.json"), "w") as fh:
    json.dump(out, fh, sort_keys=True, indent=1)
