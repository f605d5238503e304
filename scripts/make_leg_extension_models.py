#!/usr/bin/env python3
"""Derive the model files of the leg extension machine study (Krueger & Wartzack 2017, section 3).

Plain Python 3 and the standard library; OpenSim is not needed. This script documents how the
committed files in models/leg_extension/ were made; the repository does not need it (nor
../shared) to run. Run from anywhere:

    python3 scripts/make_leg_extension_models.py [path/to/gait2392_thelen2003muscle.osim]

Writes into models/leg_extension/:

- human_seated.osim      gait2392 (Delp et al. 1990; Anderson & Pandy 1999) without the trunk
                         muscles, geometry and markers, default pose = seated on the machine;
- machine_cam1.osim      seat, backrest, lever (pad) on a pin joint whose axis is the knee axis;
                         circular cam: constant 50 N m resisting extension;
- machine_cam2.osim      the same machine with the elliptical cam (torque rising to 50 N m);
- machine_cam1_axis_offset.osim  cam 1 with the lever axis 3 cm anterior-superior of the knee axis;
- contacts.xml           the 10 PointOnPlaneContact elements of the paper's Figure 7;
- test_knee_extension.mot  both knees -95 deg -> -5 deg, minimum jerk over 5 s, 101 rows
                         (the reference motion of tests/leg_extension_models.rs).

Conventions (gait2392, OpenSim): ground x anterior, y up, z right. knee_angle is negative in
flexion; hip_flexion positive in flexion. All the machine geometry is computed from the human's
seated pose by the forward kinematics below (hip and knee CustomJoints, including the
Yamaguchi-Zajac knee translations, evaluated with OpenSim's SimmSpline).
"""

import math
import os
import sys
import xml.etree.ElementTree as ET

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
OUT = os.path.join(REPO, "models", "leg_extension")
DEFAULT_SRC = os.path.join(REPO, "..", "shared", "models", "gait2392", "gait2392_thelen2003muscle.osim")

DEG = math.pi / 180.0

# ---------------------------------------------------------------------------------------------
# The seated pose (radians / metres). Pelvis upright (tilt 0), thighs horizontal (hip flexion
# 90 deg), knees at the start of the exercise (-95 deg), torso upright (lumbar 0), feet neutral.
# ---------------------------------------------------------------------------------------------
PELVIS_TX, PELVIS_TY, PELVIS_TZ = 0.0, 0.65, 0.0
HIP_FLEXION = 90.0 * DEG
KNEE_START = -95.0 * DEG
KNEE_END = -5.0 * DEG
SEATED = {
    "pelvis_tx": PELVIS_TX,
    "pelvis_ty": PELVIS_TY,
    "pelvis_tz": PELVIS_TZ,
    "hip_flexion_r": HIP_FLEXION,
    "hip_flexion_l": HIP_FLEXION,
    "knee_angle_r": KNEE_START,
    "knee_angle_l": KNEE_START,
}  # every other coordinate: 0

# Trunk muscles of gait2392 (they cross the lumbar joint only); dropped.
DROPPED_MUSCLES = ["ercspn_r", "ercspn_l", "intobl_r", "intobl_l", "extobl_r", "extobl_l"]

# gait2392 geometry used below (copied from the model file, checked on read).
HIP_IN_PELVIS = {"r": (-0.0707, -0.0661, 0.0835), "l": (-0.0707, -0.0661, -0.0835)}
BACK_IN_PELVIS = (-0.1007, 0.0815, 0.0)

# ---------------------------------------------------------------------------------------------
# Contact points on the human (body frames of gait2392). Soft tissue under the ischial
# tuberosity and the thigh, compressed on the seat: 8 cm between the hip centre height and the
# seat top (the hamstring origins on the ischial tuberosity lie 3.5 cm below the hip centre in
# gait2392, plus about 4.5 cm of compressed tissue; the thigh's posterior surface lies 8 cm
# below the femur's hip-knee axis).
# ---------------------------------------------------------------------------------------------
SEAT_BELOW_HIP = 0.08
ISCHIUM_X, ISCHIUM_Z = -0.12, 0.065  # pelvis frame; hamstring origins are at x -0.12, |z| 0.067
FEMUR_POINTS_Y = (-0.12, -0.30)  # femur frame: proximal and distal (seat front edge) thigh points
SCAPULA_IN_TORSO = (-0.12, 0.35, 0.09)  # posterior thorax at scapula height (torso frame)
PAD_ON_TIBIA = (0.03, -0.36, 0.0)  # anterior surface of the distal shin, 7 cm above the ankle
AXIS_OFFSET = 0.03  # variant: lever axis 3 cm from the knee axis ...
AXIS_OFFSET_DIR = (math.cos(45 * DEG), math.sin(45 * DEG), 0.0)  # ... anterior-superior (ground)

# Cams (section 3.2 and Figure 8 of the paper): peak 50 N m.
PEAK_TORQUE = 50.0
ELLIPSE_AXIS_RATIO = 0.5  # b/a of the elliptical cam 2
CAM2_PEAK_ANGLE = KNEE_END  # cam 2 reaches its peak (major semi-axis a) at the end of the motion

# Contact parameters: the brief's tolerance and transition zone; v_trans see README.
CONTACT = {
    "static_friction": "0.8",
    "kinetic_friction": "0.5",
    "contact_tolerance": "0.005",
    "contact_transition_zone": "0.01",
    "v_trans": "0.01",
    "optimal_force": "100",
}


# The pad is a roller turning on an axle: along the shin it resists only by rolling resistance, a
# few per cent of its load, not with the 0.8 of a pad the shin would slide on (which pushed 54-75 N
# along the shin towards the knee and added 29 % to the knee compression at -95 deg).
PAD_ROLLER = {"static_friction": "0.02", "kinetic_friction": "0.02"}

# ---------------------------------------------------------------------------------------------
# Small math helpers
# ---------------------------------------------------------------------------------------------
def rot_z(a, v):
    c, s = math.cos(a), math.sin(a)
    return (c * v[0] - s * v[1], s * v[0] + c * v[1], v[2])


def add(a, b):
    return tuple(x + y for x, y in zip(a, b))


def sub(a, b):
    return tuple(x - y for x, y in zip(a, b))


def scale(a, k):
    return tuple(x * k for x in a)


def fmt(v):
    """Numbers as OpenSim writes them back (repr round-trips doubles)."""
    if isinstance(v, (tuple, list)):
        return " ".join(fmt(x) for x in v)
    r = repr(float(v))
    if r.endswith(".0"):
        r = r[:-2]
    return "0" if r == "-0" else r


class SimmSpline:
    """OpenSim's SimmSpline (Forsythe-Malcolm-Moler natural cubic spline with third-divided-
    difference end conditions, linear beyond the ends); opensim-semantics.md section 3.1."""

    def __init__(self, x, y):
        n = len(x)
        self.x, self.y = list(x), list(y)
        h = [max(1e-7, x[i + 1] - x[i]) for i in range(n - 1)]
        b, c, d = [0.0] * n, [0.0] * n, [0.0] * n
        if n == 2:
            s = (y[1] - y[0]) / h[0]
            self.b, self.c, self.d = [s, s], c, d
            return
        last = n - 1
        slope = [(y[i + 1] - y[i]) / h[i] for i in range(last)]
        diag = [0.0] * n
        for i in range(1, last):
            diag[i] = 2.0 * (h[i - 1] + h[i])
            c[i] = slope[i] - slope[i - 1]
        diag[0], diag[last] = -h[0], -h[last - 1]
        if n > 3:
            span = lambda i, j: max(1e-7, x[j] - x[i])
            dd0 = c[2] / span(1, 3) - c[1] / span(0, 2)
            dd1 = c[last - 1] / span(n - 3, last) - c[n - 3] / span(n - 4, last - 1)
            c[0] = dd0 * h[0] * h[0] / span(0, 3)
            c[last] = -dd1 * h[last - 1] * h[last - 1] / span(n - 4, last)
        for i in range(1, n):
            t = h[i - 1] / diag[i - 1]
            diag[i] -= t * h[i - 1]
            c[i] -= t * c[i - 1]
        c[last] /= diag[last]
        for i in range(last - 1, -1, -1):
            c[i] = (c[i] - h[i] * c[i + 1]) / diag[i]
        b[last] = slope[last - 1] + h[last - 1] * (c[last - 1] + 2.0 * c[last])
        for i in range(last):
            b[i] = slope[i] - h[i] * (c[i + 1] + 2.0 * c[i])
            d[i] = (c[i + 1] - c[i]) / h[i]
            c[i] *= 3.0
        c[last] *= 3.0
        self.b, self.c, self.d = b, c, d

    def __call__(self, v):
        x = self.x
        if v < x[0]:
            return self.y[0] + (v - x[0]) * self.b[0]
        if v > x[-1]:
            return self.y[-1] + (v - x[-1]) * self.b[-1]
        k = 0
        while k < len(x) - 2 and x[k + 1] <= v:
            k += 1
        t = v - x[k]
        return self.y[k] + t * (self.b[k] + t * (self.c[k] + t * self.d[k]))


# ---------------------------------------------------------------------------------------------
# The human model
# ---------------------------------------------------------------------------------------------
def numbers(el):
    return [float(t) for t in el.text.split()]


def find_joint(model, name):
    for j in model.find("JointSet/objects"):
        if j.get("name") == name:
            return j
    raise SystemExit(f"gait2392 has no joint {name}")


def knee_translation_splines(model, side):
    st = find_joint(model, f"knee_{side}").find("SpatialTransform")
    out = {}
    for ax in st.findall("TransformAxis"):
        if ax.get("name") in ("translation1", "translation2"):
            sp = ax.find("SimmSpline")
            out[ax.get("name")] = SimmSpline(numbers(sp.find("x")), numbers(sp.find("y")))
    return out["translation1"], out["translation2"]


def check_offsets(model):
    """The geometry constants above must match the source model."""
    def frame_translation(joint, frame):
        for f in find_joint(model, joint).find("frames"):
            if f.get("name") == frame:
                return tuple(numbers(f.find("translation")))
        raise SystemExit(f"{joint} has no frame {frame}")

    for side in "rl":
        got = frame_translation(f"hip_{side}", "pelvis_offset")
        assert max(abs(a - b) for a, b in zip(got, HIP_IN_PELVIS[side])) < 1e-12, got
    got = frame_translation("back", "pelvis_offset")
    assert max(abs(a - b) for a, b in zip(got, BACK_IN_PELVIS)) < 1e-12, got


def seated_kinematics(model):
    """Ground positions in the seated pose (pelvis tilt/list/rotation 0, hip adduction and
    rotation 0, so only z rotations act): hip and knee centres, contact points."""
    tx, ty = knee_translation_splines(model, "r")
    pelvis = (PELVIS_TX, PELVIS_TY, PELVIS_TZ)
    out = {}
    for side, sign in (("r", 1.0), ("l", -1.0)):
        hip = add(pelvis, HIP_IN_PELVIS[side])
        # knee CustomJoint: translations in the femur (parent) frame, rotation about z.
        knee = add(hip, rot_z(HIP_FLEXION, (tx(KNEE_START), ty(KNEE_START), 0.0)))
        tibia_rot = HIP_FLEXION + KNEE_START
        out[f"hip_{side}"] = hip
        out[f"knee_{side}"] = knee
        out[f"pad_{side}"] = add(knee, rot_z(tibia_rot, PAD_ON_TIBIA))
        for k, y in enumerate(FEMUR_POINTS_Y):
            out[f"femur{k}_{side}"] = add(hip, rot_z(HIP_FLEXION, (-SEAT_BELOW_HIP, y, 0.0)))
        out[f"ischium_{side}"] = add(pelvis, (ISCHIUM_X, HIP_IN_PELVIS["r"][1] - SEAT_BELOW_HIP, sign * ISCHIUM_Z))
        torso = add(pelvis, BACK_IN_PELVIS)
        out[f"scapula_{side}"] = add(torso, (SCAPULA_IN_TORSO[0], SCAPULA_IN_TORSO[1], sign * SCAPULA_IN_TORSO[2]))
    # the two knee splines are equal for left and right in gait2392; check it
    txl, tyl = knee_translation_splines(model, "l")
    assert abs(txl(KNEE_START) - tx(KNEE_START)) < 1e-15 and abs(tyl(KNEE_START) - ty(KNEE_START)) < 1e-15
    return out


def strip(parent, tags):
    for child in list(parent):
        if child.tag in tags:
            parent.remove(child)
        else:
            strip(child, tags)


CREDITS = (
    "Seated human model of the leg extension machine study (Krueger and Wartzack 2017, section 3), "
    "derived by statopt's scripts/make_leg_extension_models.py from OpenSim's gait2392 model "
    "(gait2392_thelen2003muscle.osim, OpenSim 4 version): the 23 degrees of freedom (pelvis 6, hips, "
    "knees, ankles, subtalar, mtp, lumbar) and all body segment parameters unchanged; the 86 "
    "Thelen2003 muscles that cross the hip, knee or ankle kept unchanged; the six trunk muscles "
    "(ercspn_r/l, intobl_r/l, extobl_r/l) removed, so the lumbar joint has no muscles (the backrest "
    "contacts or reserve actuators carry it); display geometry and markers removed; default pose = "
    "seated (hip flexion 90 deg, knee -95 deg, pelvis_ty 0.65 m). "
    "Original credits of gait2392: Delp S.L., Loan J.P., Hoy M.G., Zajac F.E., Topp E.L., Rosen J.M., "
    "Thelen D.G., Anderson F.C., Seth A. 3D, 23 DOF gait model created by D.G. Thelen, Univ. of "
    "Wisconsin-Madison, and Ajay Seth, Frank C. Anderson, and Scott L. Delp, Stanford University. "
    "Lower extremity joint definitions based on Delp et al. (1990). Low back joint and anthropometry "
    "based on Anderson and Pandy (1999, 2001). Planar knee model of Yamaguchi and Zajac (1989). "
    "License: Creative Commons (CC BY 3.0), http://creativecommons.org/licenses/by/3.0/ ; this "
    "derived model is distributed under the same licence, crediting the original authors."
)
PUBLICATIONS = (
    "Delp S.L., Loan J.P., Hoy M.G., Zajac F.E., Topp E.L., Rosen J.M.: An interactive graphics-based "
    "model of the lower extremity to study orthopaedic surgical procedures. IEEE Transactions on "
    "Biomedical Engineering 37:757-767, 1990. "
    "Yamaguchi G.T., Zajac F.E.: A planar model of the knee joint to characterize the knee extensor "
    "mechanism. Journal of Biomechanics 22:1-10, 1989. "
    "Anderson F.C., Pandy M.G.: A dynamic optimization solution for vertical jumping in three "
    "dimensions. Computer Methods in Biomechanics and Biomedical Engineering 2:201-231, 1999. "
    "Anderson F.C., Pandy M.G.: Dynamic optimization of human walking. Journal of Biomechanical "
    "Engineering 123:381-390, 2001. "
    "Thelen D.G.: Adjustment of muscle mechanics model parameters to simulate dynamic contractions "
    "in older adults. Journal of Biomechanical Engineering 125:70-77, 2003. "
    "Delp S.L., Anderson F.C., Arnold A.S., Loan P., Habib A., John C.T., Guendelman E., Thelen D.G.: "
    "OpenSim: open-source software to create and analyze dynamic simulations of movement. IEEE "
    "Transactions on Biomedical Engineering 54:1940-1950, 2007. "
    "Krueger D., Wartzack S.: A contact model to simulate human-artifact interaction based on force "
    "optimization: implementation and application to the analysis of a training machine. Computer "
    "Methods in Biomechanics and Biomedical Engineering, 2017, doi:10.1080/10255842.2017.1393804."
)


def make_human(src):
    tree = ET.parse(src)  # comments are dropped by the parser
    doc = tree.getroot()
    assert doc.get("Version") == "40000", doc.get("Version")
    model = doc.find("Model")
    check_offsets(model)
    geo = seated_kinematics(model)
    model.set("name", "seated_human_gait2392")
    model.find("credits").text = CREDITS
    model.find("publications").text = PUBLICATIONS
    strip(model, {"attached_geometry", "FrameGeometry", "Appearance"})
    for m in model.find("MarkerSet/objects").findall("*"):
        model.find("MarkerSet/objects").remove(m)

    forces = model.find("ForceSet/objects")
    kept, dropped = [], []
    for f in list(forces):
        if f.get("name") in DROPPED_MUSCLES:
            forces.remove(f)
            dropped.append(f.get("name"))
        else:
            kept.append(f.get("name"))
    assert sorted(dropped) == sorted(DROPPED_MUSCLES), dropped
    groups = model.find("ForceSet/groups")
    for g in list(groups):
        members = [m for m in g.find("members").text.split() if m not in DROPPED_MUSCLES]
        if members:
            g.find("members").text = " " + " ".join(members)
        else:
            groups.remove(g)

    names = set()
    for c in model.iter("Coordinate"):
        names.add(c.get("name"))
        c.find("default_value").text = fmt(SEATED.get(c.get("name"), 0.0))
        rng = numbers(c.find("range"))
        v = SEATED.get(c.get("name"), 0.0)
        assert rng[0] <= v <= rng[1], (c.get("name"), rng, v)
    assert set(SEATED) <= names

    mass = sum(float(b.find("mass").text) for b in model.find("BodySet/objects"))
    doc.insert(
        0,
        ET.Comment(
            " Generated by scripts/make_leg_extension_models.py from OpenSim's gait2392 "
            "(gait2392_thelen2003muscle.osim): trunk muscles, geometry and markers removed, "
            f"default pose seated. Total mass {mass:.4f} kg. See models/leg_extension/README.md. "
        ),
    )
    return tree, geo, kept, dropped, mass


# ---------------------------------------------------------------------------------------------
# The machine models
# ---------------------------------------------------------------------------------------------
def sub_el(parent, tag, text=None, **attrs):
    e = ET.SubElement(parent, tag, attrs)
    if text is not None:
        e.text = text
    return e


def body(parent, name, mass, com, inertia):
    b = sub_el(parent, "Body", name=name)
    sub_el(b, "mass", fmt(mass))
    sub_el(b, "mass_center", fmt(com))
    sub_el(b, "inertia", fmt(inertia))
    return b


def offset_frame(parent, name, socket_parent, translation, orientation=(0.0, 0.0, 0.0)):
    f = sub_el(parent, "PhysicalOffsetFrame", name=name)
    sub_el(f, "socket_parent", socket_parent)
    sub_el(f, "translation", fmt(translation))
    sub_el(f, "orientation", fmt(orientation))
    return f


def weld(parent, name, body_name, at):
    j = sub_el(parent, "WeldJoint", name=name)
    sub_el(j, "socket_parent_frame", f"ground_{body_name}")
    sub_el(j, "socket_child_frame", f"{body_name}_offset")
    fr = sub_el(j, "frames")
    offset_frame(fr, f"ground_{body_name}", "/ground", at)
    offset_frame(fr, f"{body_name}_offset", f"/bodyset/{body_name}", (0.0, 0.0, 0.0))


def box_inertia(m, dx, dy, dz):
    return (m * (dy * dy + dz * dz) / 12, m * (dx * dx + dz * dz) / 12, m * (dx * dx + dy * dy) / 12, 0.0, 0.0, 0.0)


def lever_mass_properties(pivot_in_lever):
    """Lever body, origin at the pad surface centre, axes as the lever frame (x anterior to the
    shin, y along the lever towards the pivot, z right). Side arm: 1.8 kg steel tube from the pivot
    down to the pad, 0.30 m lateral of the midline (outside the right knee); pad: 1.2 kg foam
    roller of radius 0.04 m and length 0.55 m whose axis lies 0.04 m in front of the pad surface.
    Returns (mass, centre of mass, [Ixx Iyy Izz Ixy Ixz Iyz] about the centre of mass)."""
    px, py, _ = pivot_in_lever
    arm_m, arm_z = 1.8, 0.30
    arm_a, arm_b = (0.0, 0.0, arm_z), (px, py, arm_z)
    arm_c = scale(add(arm_a, arm_b), 0.5)
    arm_len = math.dist(arm_a, arm_b)
    pad_m, pad_r, pad_len, pad_c = 1.2, 0.04, 0.55, (0.04, 0.0, 0.025)
    m = arm_m + pad_m
    com = scale(add(scale(arm_c, arm_m), scale(pad_c, pad_m)), 1 / m)
    # arm: thin rod; its direction in the x-y plane
    ux, uy = (arm_b[0] - arm_a[0]) / arm_len, (arm_b[1] - arm_a[1]) / arm_len
    i_rod = arm_m * arm_len ** 2 / 12
    # rod inertia I = i_rod (1 - u u^T) on the x-y block, i_rod about z
    arm_i = [[i_rod * (1 - ux * ux), -i_rod * ux * uy, 0.0], [-i_rod * ux * uy, i_rod * (1 - uy * uy), 0.0], [0.0, 0.0, i_rod]]
    i_cyl_t = pad_m * (3 * pad_r ** 2 + pad_len ** 2) / 12
    pad_i = [[i_cyl_t, 0.0, 0.0], [0.0, i_cyl_t, 0.0], [0.0, 0.0, pad_m * pad_r ** 2 / 2]]
    total = [[0.0] * 3 for _ in range(3)]
    for mi, ci, ii in ((arm_m, arm_c, arm_i), (pad_m, pad_c, pad_i)):
        r = sub(ci, com)
        rr = sum(x * x for x in r)
        for a in range(3):
            for b in range(3):
                total[a][b] += ii[a][b] + mi * ((rr if a == b else 0.0) - r[a] * r[b])
    inertia = (total[0][0], total[1][1], total[2][2], total[0][1], total[0][2], total[1][2])
    return m, com, inertia


def cam2_expression():
    """Elliptical cam: tau = -W * h(psi), h the ellipse's support function (see README)."""
    k2 = ELLIPSE_AXIS_RATIO ** 2
    return f"-{fmt(PEAK_TORQUE)}*sqrt(1-{fmt(1 - k2)}*sin(q+{fmt(-CAM2_PEAK_ANGLE)})^2)"


def cam2_torque(q):
    psi = q - CAM2_PEAK_ANGLE
    return -PEAK_TORQUE * math.sqrt(math.cos(psi) ** 2 + (ELLIPSE_AXIS_RATIO * math.sin(psi)) ** 2)


def make_machine(geo, name, cam, offset):
    knee = geo["knee_r"]
    knee_axis = (knee[0], knee[1], 0.0)  # the knee flexion axis (z) at the midline
    pivot = add(knee_axis, scale(AXIS_OFFSET_DIR, offset))
    # lever frame in ground at lever_angle q: R_z(pi/2 + q) (parent frame turned by 90 deg), so
    # that lever_angle = knee_angle when the lever follows the shin (hip flexion 90 deg).
    lever_rot = math.pi / 2 + KNEE_START
    pad_ground = (geo["pad_r"][0], geo["pad_r"][1], 0.0)
    # pivot in the lever body frame (origin at the pad surface centre, axes = lever frame)
    pivot_in_lever = rot_z(-lever_rot, sub(pivot, pad_ground))
    seat_top = geo["ischium_r"][1]
    backrest_x = geo["scapula_r"][0]
    seat_front = geo["femur1_r"][0] + 0.03

    doc = ET.Element("OpenSimDocument", Version="40000")
    cam_text = {
        "cam1": "cam 1 (circular disc): constant resistance torque of 50 N m",
        "cam2": (
            f"cam 2 (elliptical, axis ratio b/a = {ELLIPSE_AXIS_RATIO}): torque "
            f"-50 sqrt(cos^2 psi + (b/a)^2 sin^2 psi), psi = lever_angle - ({CAM2_PEAK_ANGLE / DEG:g} deg), "
            f"rising from {abs(cam2_torque(KNEE_START)):.1f} N m at -95 deg to the 50 N m peak at -5 deg"
        ),
    }[cam]
    where = (
        "lever axis on the knee flexion axis of the seated pose"
        if offset == 0
        else f"lever axis {offset * 100:g} cm anterior-superior (45 deg) of the knee flexion axis of the seated pose"
    )
    doc.append(
        ET.Comment(
            f" Leg extension machine ({cam_text}; {where}). Generated by "
            "scripts/make_leg_extension_models.py; see models/leg_extension/README.md. Merged into "
            "human_seated.osim by the study's setup (artifact_files); contacts in contacts.xml. "
        )
    )
    model = sub_el(doc, "Model", name=name)
    sub_el(model, "credits", "statopt; leg extension machine after Krueger and Wartzack (2017), Figure 7. Dimensions fitted to human_seated.osim (gait2392, Delp et al. 1990).")
    sub_el(model, "publications", "Krueger D., Wartzack S.: A contact model to simulate human-artifact interaction based on force optimization: implementation and application to the analysis of a training machine. Computer Methods in Biomechanics and Biomedical Engineering, 2017, doi:10.1080/10255842.2017.1393804.")
    sub_el(model, "gravity", "0 -9.8066499999999994 0")
    bodies = sub_el(model, "BodySet", name="bodyset")
    objs = sub_el(bodies, "objects")
    depth = seat_front - backrest_x
    # seat: origin at the centre of the rear edge of the top surface; cushion + frame 12 kg
    body(objs, "seat", 12.0, (depth / 2, -0.05, 0.0), box_inertia(12.0, depth, 0.10, 0.40))
    # backrest: origin at the front surface, seat height, midline; 8 kg
    body(objs, "backrest", 8.0, (-0.04, 0.30, 0.0), box_inertia(8.0, 0.08, 0.60, 0.40))
    lm, lcom, linertia = lever_mass_properties(pivot_in_lever)
    body(objs, "lever", lm, lcom, linertia)
    sub_el(bodies, "groups")

    joints = sub_el(model, "JointSet", name="jointset")
    jobjs = sub_el(joints, "objects")
    weld(jobjs, "seat_weld", "seat", (backrest_x, seat_top, 0.0))
    weld(jobjs, "backrest_weld", "backrest", (backrest_x, seat_top, 0.0))
    pin = sub_el(jobjs, "PinJoint", name="lever_pivot")
    sub_el(pin, "socket_parent_frame", "ground_lever_pivot")
    sub_el(pin, "socket_child_frame", "lever_offset")
    coords = sub_el(pin, "coordinates")
    c = sub_el(coords, "Coordinate", name="lever_angle")
    sub_el(c, "default_value", fmt(KNEE_START))
    sub_el(c, "default_speed_value", "0")
    sub_el(c, "range", fmt((-120 * DEG, 10 * DEG)))
    sub_el(c, "clamped", "false")
    sub_el(c, "locked", "false")
    fr = sub_el(pin, "frames")
    offset_frame(fr, "ground_lever_pivot", "/ground", pivot, (0.0, 0.0, math.pi / 2))
    offset_frame(fr, "lever_offset", "/bodyset/lever", pivot_in_lever)
    sub_el(joints, "groups")

    fs = sub_el(model, "ForceSet", name="forceset")
    fobjs = sub_el(fs, "objects")
    if cam == "cam1":
        expr = f"-{fmt(PEAK_TORQUE)}"
        fobjs.append(ET.Comment(" Circular cam: the weight stack's cable leaves the disc at a constant moment arm r, so tau = -W r = -50 N m on lever_angle (negative: against the extension, in which lever_angle increases). "))
    else:
        expr = cam2_expression()
        fobjs.append(
            ET.Comment(
                " Elliptical cam (semi-axes a, b; b/a = 0.5) turning with the lever about its centre. The cable, pulled by the weight "
                "stack W, leaves the cam tangentially in a fixed direction, so its moment arm is the ellipse's support function "
                "h(psi) = sqrt(a^2 cos^2 psi + b^2 sin^2 psi), psi the angle between the cable's normal and the major axis. The major "
                "axis is normal to the cable at lever_angle = -5 deg (0.0872665 rad short of full extension): psi = q + 0.0872665. "
                "tau = -W h = -W a sqrt(1 - (1 - (b/a)^2) sin^2 psi), W a = 50 N m: -50*sqrt(1-0.75*sin(q+0.0872665)^2); "
                "25 N m at -95 deg, 50 N m at -5 deg. "
            )
        )
    f = sub_el(fobjs, "ExpressionBasedCoordinateForce", name="cam_torque")
    sub_el(f, "appliesForce", "true")
    sub_el(f, "coordinate", "lever_angle")
    sub_el(f, "expression", expr)
    sub_el(fs, "groups")
    info = {
        "pivot": pivot,
        "pivot_in_lever": pivot_in_lever,
        "lever_mass": lm,
        "lever_com": lcom,
        "seat_top": seat_top,
        "backrest_x": backrest_x,
        "seat_front": seat_front,
        "expression": expr,
    }
    return ET.ElementTree(doc), info


# ---------------------------------------------------------------------------------------------
# Contacts (Figure 7): per side tibia-pad, femur-seat (2), pelvis-seat, scapula-backrest = 10
# ---------------------------------------------------------------------------------------------
def make_contacts(geo):
    doc = ET.Element("OpenSimDocument", Version="40000")
    doc.append(
        ET.Comment(
            " The 10 point-on-plane contacts of the leg extension study (Krueger and Wartzack 2017, Figure 7): "
            "per side tibia-pad (lever), femur-seat (2 points: proximal thigh and the seat's front edge), "
            "pelvis-seat (ischial tuberosity), torso-backrest (scapula). Points on the human bodies of "
            "human_seated.osim, planes on the machine bodies, normals from the plane towards the human; "
            "every point lies on its plane in the seated default pose. Kept out of the model files because "
            "OpenSim 4.6 refuses unknown element types. The pad is a roller: friction 0.02 (rolling resistance), not the 0.8 of a pad the shin would slide on. v_trans 0.01 m/s: see models/leg_extension/README.md. "
        )
    )
    fs = sub_el(doc, "ForceSet", name="leg_extension_contacts")
    objs = sub_el(fs, "objects")
    rows = []
    for side, sign in (("r", 1.0), ("l", -1.0)):
        rows.append((f"tibia_pad_{side}", f"tibia_{side}", PAD_ON_TIBIA, "lever", (-1.0, 0.0, 0.0)))
        for k, y in enumerate(FEMUR_POINTS_Y):
            tag = ("proximal", "distal")[k]
            rows.append((f"femur_seat_{tag}_{side}", f"femur_{side}", (-SEAT_BELOW_HIP, y, 0.0), "seat", (0.0, 1.0, 0.0)))
        rows.append((f"pelvis_seat_{side}", "pelvis", (ISCHIUM_X, HIP_IN_PELVIS["r"][1] - SEAT_BELOW_HIP, sign * ISCHIUM_Z), "seat", (0.0, 1.0, 0.0)))
        rows.append((f"torso_backrest_{side}", "torso", (SCAPULA_IN_TORSO[0], SCAPULA_IN_TORSO[1], sign * SCAPULA_IN_TORSO[2]), "backrest", (1.0, 0.0, 0.0)))
    for name, pb, p, plb, n in rows:
        props = dict(CONTACT)
        if name.startswith("tibia_pad_"):
            props.update(PAD_ROLLER)
        e = sub_el(objs, "PointOnPlaneContact", name=name)
        sub_el(e, "point_body", pb)
        sub_el(e, "point_location", fmt(p))
        sub_el(e, "plane_body", plb)
        sub_el(e, "plane_origin", "0 0 0")
        sub_el(e, "plane_normal", fmt(n))
        for k, v in props.items():
            sub_el(e, k, v)
    sub_el(fs, "groups")
    assert len(rows) == 10
    return ET.ElementTree(doc)


# ---------------------------------------------------------------------------------------------
# The reference motion
# ---------------------------------------------------------------------------------------------
def minimum_jerk(s):
    return s ** 3 * (10 - 15 * s + 6 * s * s)


def write_motion(path, name, coords, description, value, n=101, duration=5.0):
    """A .mot in degrees: `value(coordinate, t)` for every coordinate at n rows over `duration`."""
    lines = [
        name,
        "version=1",
        f"nRows={n}",
        f"nColumns={len(coords) + 1}",
        "inDegrees=yes",
        "",
        *description,
        "endheader",
        "\t".join(["time"] + coords),
    ]
    for i in range(n):
        t = duration * i / (n - 1)
        lines.append("\t".join([f"{t:.4f}"] + [f"{value(c, t / duration):.12f}" for c in coords]))
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


TRANSLATIONAL = {"pelvis_tx", "pelvis_ty", "pelvis_tz"}


def make_motion(model_tree, path):
    coords = [c.get("name") for c in model_tree.getroot().iter("Coordinate")]

    def value(c, s):
        if c in ("knee_angle_r", "knee_angle_l"):
            return (KNEE_START + (KNEE_END - KNEE_START) * minimum_jerk(s)) / DEG
        if c in TRANSLATIONAL:
            return SEATED.get(c, 0.0)
        return SEATED.get(c, 0.0) / DEG

    write_motion(
        path,
        "test_knee_extension",
        coords,
        [
            "Both knees -95 deg -> -5 deg, minimum jerk over 5 s; other coordinates at the seated pose",
            "(human_seated.osim defaults). Generated by scripts/make_leg_extension_models.py.",
        ],
        value,
    )


def write(tree, path):
    ET.indent(tree, space="\t")
    tree.write(path, encoding="UTF-8", xml_declaration=True)
    with open(path, "a") as f:
        f.write("\n")


def main():
    src = sys.argv[1] if len(sys.argv) > 1 else DEFAULT_SRC
    os.makedirs(OUT, exist_ok=True)
    human, geo, kept, dropped, mass = make_human(src)
    write(human, os.path.join(OUT, "human_seated.osim"))
    print(f"human_seated.osim: {len(kept)} muscles kept, dropped {dropped}; total mass {mass:.4f} kg")
    for k in sorted(geo):
        print(f"  {k:18s} {fmt(tuple(round(x, 6) for x in geo[k]))}")
    for name, cam, offset in (
        ("machine_cam1", "cam1", 0.0),
        ("machine_cam2", "cam2", 0.0),
        ("machine_cam1_axis_offset", "cam1", AXIS_OFFSET),
    ):
        tree, info = make_machine(geo, name, cam, offset)
        write(tree, os.path.join(OUT, name + ".osim"))
        print(f"{name}.osim: " + ", ".join(f"{k} {fmt(v) if not isinstance(v, str) else v}" for k, v in info.items()))
    write(make_contacts(geo), os.path.join(OUT, "contacts.xml"))
    make_motion(human, os.path.join(OUT, "test_knee_extension.mot"))
    for deg in (-95, -80, -65, -50, -35, -20, -5):
        print(f"  cam2 torque at {deg:4d} deg: {cam2_torque(deg * DEG):8.3f} N m")


if __name__ == "__main__":
    main()
