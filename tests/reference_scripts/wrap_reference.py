"""Reference numbers for src/wrapping/tests.rs, computed with OpenSim 4.6.

Run:  /work/venv/bin/python tests/reference_scripts/wrap_reference.py > /tmp/wrap_ref.txt

For each case a model is built with one wrap object on ground, path point P1
on ground and P2 at the origin of a body on a FreeJoint (so P2 = the free
joint's translation). A PathSpring's GeometryPath goes P1 -> P2 with a
PathWrap over the object (plus, for "multi" cases, a second PathWrap over a
far-away sphere that never wraps, which makes OpenSim's singleWrap false).
Printed per pose: path length, moment arms about the three translational
coordinates (OpenSim sign: -dL/dq), and the current path points in ground.
The Rust tests state P1, P2 in ground and the object's pose, so they also
exercise the body-to-wrap-frame transform.
"""
import opensim as osim

CASES = [
    # name, shape, params, quadrant, method, rot xyz, translation, multi, P1, [P2...]
    ("cyl_all", "cyl", (0.05, 0.5), "all", "hybrid", (0, 0, 0), (0, 0, 0), False,
     (-0.15, 0.02, -0.05), [(0.15, 0.03, 0.06), (0.2, -0.01, 0.1), (0.12, 0.04, -0.2)]),
    ("cyl_all_multi", "cyl", (0.05, 0.5), "all", "hybrid", (0, 0, 0), (0, 0, 0), True,
     (-0.15, 0.02, -0.05), [(0.15, 0.03, 0.06), (0.2, -0.01, 0.1), (0.12, 0.04, -0.2)]),
    ("cyl_py", "cyl", (0.05, 0.5), "+y", "hybrid", (0, 0, 0), (0, 0, 0), False,
     (-0.15, 0.06, -0.05), [(0.15, 0.07, 0.06), (0.15, -0.02, 0.06), (0.12, -0.1, 0.0)]),
    ("cyl_mx_far", "cyl", (0.05, 0.5), "-x", "hybrid", (0, 0, 0), (0, 0, 0), False,
     (0.12, -0.1, -0.05), [(0.1, 0.12, 0.06), (0.15, 0.03, 0.02)]),
    ("cyl_rot", "cyl", (0.03, 0.2), "all", "hybrid", (0.3, -0.5, 1.1), (0.01, -0.02, 0.03), False,
     (-0.1, 0.05, 0.0), [(0.1, 0.0, 0.05), (0.08, -0.03, 0.1)]),
    ("sph_all", "sph", (0.05,), "all", "hybrid", (0, 0, 0), (0, 0, 0), False,
     (-0.15, 0.02, -0.01), [(0.15, 0.03, 0.02), (0.1, -0.06, 0.05)]),
    ("sph_pz", "sph", (0.05,), "+z", "hybrid", (0, 0, 0), (0, 0, 0), False,
     (-0.15, 0.0, 0.02), [(0.15, 0.01, 0.01), (0.15, 0.01, -0.03)]),
    ("ell_sphere_mid", "ell", (0.05, 0.05, 0.05), "all", "midpoint", (0, 0, 0), (0, 0, 0), False,
     (-0.15, 0.02, -0.01), [(0.15, 0.03, 0.02), (0.1, -0.06, 0.05)]),
    ("ell_hybrid", "ell", (0.06, 0.03, 0.04), "all", "hybrid", (0, 0, 0), (0, 0, 0), False,
     (-0.15, 0.01, -0.01), [(0.15, 0.02, 0.015), (0.1, -0.05, 0.04), (0.02, 0.12, 0.01)]),
    ("ell_axial", "ell", (0.06, 0.03, 0.04), "all", "axial", (0, 0, 0), (0, 0, 0), False,
     (-0.15, 0.01, -0.01), [(0.15, 0.02, 0.015), (0.1, -0.05, 0.04)]),
    ("ell_midpoint", "ell", (0.06, 0.03, 0.04), "all", "midpoint", (0, 0, 0), (0, 0, 0), False,
     (-0.15, 0.01, -0.01), [(0.15, 0.02, 0.015), (0.1, -0.05, 0.04)]),
    ("ell_py_hybrid", "ell", (0.06, 0.03, 0.04), "+y", "hybrid", (0, 0, 0), (0, 0, 0), False,
     (-0.15, -0.01, -0.01), [(0.15, -0.02, 0.015), (0.1, 0.05, 0.04)]),
    ("sph_mz_far", "sph", (0.05,), "-z", "hybrid", (0, 0, 0), (0, 0, 0), False,
     (-0.15, 0.0, 0.03), [(0.15, 0.01, 0.02), (0.12, -0.02, 0.01)]),
    ("ell_mz_axial", "ell", (0.06, 0.03, 0.04), "-z", "axial", (0.2, 0.1, -0.3), (0.01, 0.0, 0.0), False,
     (-0.15, 0.01, 0.02), [(0.15, 0.02, 0.015), (0.1, -0.05, 0.04)]),
    ("ell_px_midpoint", "ell", (0.03, 0.05, 0.04), "+x", "midpoint", (0, 0, 0), (0, 0, 0), False,
     (-0.02, -0.15, 0.01), [(-0.01, 0.15, 0.02), (-0.03, 0.1, -0.03)]),
    # arm26 configurations (objects, quadrants, methods as in arm26.osim)
    ("arm26_TRI", "cyl", (0.016, 0.05), "all", "hybrid",
     (-0.14015, -0.00628319, 0.154985), (0.0028, -0.2919, -0.0069), False,
     (-0.02, -0.25, -0.01), [(-0.025, -0.33, -0.005), (0.01, -0.32, 0.0), (-0.03, -0.31, -0.02)]),
    ("arm26_TRI_multi", "cyl", (0.016, 0.05), "all", "hybrid",
     (-0.14015, -0.00628319, 0.154985), (0.0028, -0.2919, -0.0069), True,
     (-0.02, -0.25, -0.01), [(-0.025, -0.33, -0.005), (0.01, -0.32, 0.0), (-0.03, -0.31, -0.02)]),
    ("arm26_TRIlongglen_multi", "cyl", (0.003, 0.03), "x", "hybrid",
     (1.37532, -0.294612, 2.43596), (-0.043905, -0.0039, 0.1478), True,
     (-0.05, -0.01, 0.14), [(-0.04, 0.01, 0.16), (-0.035, -0.02, 0.15), (-0.05, 0.005, 0.155)]),
    ("arm26_TRIlonghh", "ell", (0.035, 0.02, 0.02), "z", "hybrid",
     (3.00162, -0.853466, 2.57419), (-0.0078, -0.0041, -0.0014), False,
     (-0.05, 0.02, -0.01), [(-0.03, -0.06, 0.0), (-0.02, -0.05, -0.02), (0.0, -0.06, 0.01)]),
    ("arm26_BIClonghh", "ell", (0.025, 0.02, 0.02), "-y", "hybrid",
     (-2.00434, -1.00164, 0.975465), (0.0033, 0.0073, 0.0003), False,
     (-0.01, 0.04, 0.02), [(0.02, -0.04, 0.01), (0.03, -0.03, -0.01), (0.0, -0.05, 0.02)]),
    ("torus_all", "tor", (0.02, 0.08), "all", "hybrid", (0, 0, 0), (0, 0, 0), False,
     (0.0, 0.0, 0.1), [(0.01, 0.0, -0.1), (0.065, 0.0, -0.1), (0.07, -0.01, -0.12)]),
    ("torus_through_tube", "tor", (0.02, 0.08), "all", "hybrid", (0, 0, 0), (0, 0, 0), False,
     (0.065, 0.0, 0.1), [(0.065, 0.01, -0.1), (0.07, -0.01, -0.12), (0.05, 0.0, -0.1)]),
    ("torus_multi", "tor", (0.02, 0.08), "all", "hybrid", (0, 0, 0), (0, 0, 0), True,
     (0.065, 0.0, 0.1), [(0.065, 0.01, -0.1), (0.07, -0.01, -0.12)]),
]


import sys
RUST = "--rust" in sys.argv


def run(case):
    name, shape, params, quad, method, rot, trans, multi, p1, p2s = case
    model = osim.Model()
    ground = model.updGround()
    body = osim.Body("b", 1.0, osim.Vec3(0), osim.Inertia(0.1, 0.1, 0.1))
    model.addBody(body)
    joint = osim.FreeJoint("j", ground, osim.Vec3(0), osim.Vec3(0), body, osim.Vec3(0), osim.Vec3(0))
    model.addJoint(joint)
    if shape == "cyl":
        wo = osim.WrapCylinder(); wo.set_radius(params[0]); wo.set_length(params[1])
    elif shape == "sph":
        wo = osim.WrapSphere(); wo.set_radius(params[0])
    elif shape == "ell":
        wo = osim.WrapEllipsoid(); wo.set_dimensions(osim.Vec3(*params))
    else:
        wo = osim.WrapTorus(); wo.set_inner_radius(params[0]); wo.set_outer_radius(params[1])
    wo.setName("wo")
    wo.set_quadrant(quad)
    wo.set_xyz_body_rotation(osim.Vec3(*rot))
    wo.set_translation(osim.Vec3(*trans))
    ground.addWrapObject(wo)
    if multi:
        far = osim.WrapSphere(); far.setName("far"); far.set_radius(0.01)
        far.set_translation(osim.Vec3(5, 5, 5))
        ground.addWrapObject(far)
    ps = osim.PathSpring("ps", 0.1, 1.0, 0.0)
    gp = ps.updGeometryPath()
    gp.appendNewPathPoint("p1", ground, osim.Vec3(*p1))
    gp.appendNewPathPoint("p2", body, osim.Vec3(0))
    gp.addPathWrap(wo)
    if multi:
        gp.addPathWrap(far)
    gp.updWrapSet().get(0).set_method(method)
    model.addForce(ps)
    state = model.initSystem()
    coords = [joint.get_coordinates(i) for i in range(6)]
    for p2 in p2s:
        for i in range(3):
            coords[3 + i].setValue(state, p2[i], False)
        model.realizePosition(state)
        L = gp.getLength(state)
        ma = [gp.computeMomentArm(state, coords[3 + i]) for i in range(3)]
        cur = gp.getCurrentPath(state)
        pts = [cur.get(k).getLocationInGround(state) for k in range(cur.getSize())]
        pts = [(v.get(0), v.get(1), v.get(2)) for v in pts]
        if RUST:
            f = lambda v: "[" + ", ".join(repr(float(x)) for x in v) + "]"
            wpts = pts[1:3] if len(pts) == 4 else []
            print(f'    RefCase {{ name: "{name}", shape: "{shape}", params: &{f(params)}, '
                  f'quadrant: "{quad}", method: "{method}", rot: {f(rot)}, trans: {f(trans)}, '
                  f'multi: {str(multi).lower()}, p1: {f(p1)}, p2: {f(p2)}, length: {L!r}, '
                  f'moment_arms: {f(ma)}, wrap_pts: &[{", ".join(f(q) for q in wpts)}] }},')
        else:
            print(f"{name} P2={p2} L={L!r} MA={[repr(x) for x in ma]} npts={len(pts)}")
            for q in pts:
                print("   pt", tuple(repr(x) for x in q))


for c in CASES:
    run(c)
