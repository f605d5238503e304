#!/usr/bin/env python3
"""The leg extension study's second human: Rajagopal et al. (2016) with the Lai et al. (2017) and
Uhlrich et al. (2022) changes (RajagopalLaiUhlrich2023.osim: knee flexion to 140 deg, patella on a
coupled patellofemoral joint, 80 Millard muscles, arms and trunk driven by coordinate actuators),
seated in the same leg extension machine.

Writes into models/leg_extension/:
  human_seated_rajagopal.osim          the model, default pose seated (see SEATED), display geometry removed
  machine_cam1_rajagopal.osim          the machine of machine_cam1.osim fitted to this person ...
  machine_cam2_rajagopal.osim          ... and with the elliptical cam 2
  contacts_rajagopal.xml               12 PointOnPlaneContacts: per side pad (a roller), 2 thigh-seat,
                                       ischium-seat, scapula-backrest, and the hand on the seat's handle
  test_knee_extension_rajagopal.mot    knees 95 -> 5 deg flexion, minimum jerk, 5 s

Needs OpenSim 4.6's Python package (forward kinematics of the walker knee) and the source model at
../shared/models/rajagopal2016/ (or give its path as the first argument). Run from anywhere:
    python scripts/make_leg_extension_rajagopal.py
The numbers below are documented in models/leg_extension/README.md.
"""
import math
import os
import sys
import xml.etree.ElementTree as ET

import opensim as osim

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import make_leg_extension_models as g  # noqa: E402  (the gait2392 study's generator)

REPO = os.path.dirname(HERE)
OUT = os.path.join(REPO, "models", "leg_extension")
DEFAULT_SRC = os.path.join(REPO, "..", "shared", "models", "rajagopal2016", "RajagopalLaiUhlrich2023.osim")
DEG = math.pi / 180.0

# ---------------------------------------------------------------------------------------------
# Seated posture. Sitting turns the pelvis backwards and flattens the lumbar spine compared with
# standing (Lord et al. 1997, Spine: lumbar lordosis markedly smaller in sitting than in standing,
# with the pelvis rotated posteriorly; 15 deg is our choice within that picture, not a measured
# value for this machine). Here: pelvis tilted
# 15 deg posteriorly (pelvis_tilt +15 deg: its anterior axis turned up), the lumbar joint flexed by
# the same 15 deg so that the trunk is upright against the vertical backrest, hips flexed 75 deg
# relative to the pelvis so that the thighs are horizontal on the seat (90 deg between trunk and
# thigh, as leg extension machines and the studies compared in docs/leg_extension_results.md
# seat their subjects: Wilk et al. 1996, Escamilla et al. 1998). The arms hang beside the trunk,
# slightly abducted and with the elbows a little flexed, the hands on handles beside the seat.
# ---------------------------------------------------------------------------------------------
PELVIS_TILT = 15.0 * DEG
KNEE_START = 95.0 * DEG  # Rajagopal's knee_angle: flexion positive
KNEE_END = 5.0 * DEG
HIP_Y = 0.5839  # hip centres at the height of the gait2392 study's seated person
SEATED = {
    "pelvis_tilt": PELVIS_TILT,
    "hip_flexion_r": 90.0 * DEG - PELVIS_TILT,
    "hip_flexion_l": 90.0 * DEG - PELVIS_TILT,
    "knee_angle_r": KNEE_START,
    "knee_angle_l": KNEE_START,
    "lumbar_extension": -PELVIS_TILT,
    "arm_add_r": -10.0 * DEG,
    "arm_add_l": -10.0 * DEG,
    "elbow_flex_r": 20.0 * DEG,
    "elbow_flex_l": 20.0 * DEG,
    "pro_sup_r": 90.0 * DEG,
    "pro_sup_l": 90.0 * DEG,
}

# Contact points, in ground at the seated pose, from landmarks of the model:
SEAT_BELOW_HIP = 0.08  # seat top 8 cm below the hip centres, as in the gait2392 study
FEMUR_POINTS = (0.10, 0.28)  # thigh points this far from the hip centre along the thigh (m)
SCAPULA_IN_TORSO = (-0.11, 0.33, 0.09)  # posterior thorax at scapula height (torso frame)
PAD_ABOVE_ANKLE = 0.07  # pad on the anterior shin, 7 cm above the ankle joint ...
SHIN_SURFACE = 0.035  # ... on the shin surface, 3.5 cm anterior of the tibia's axis
PALM_IN_HAND = (0.0, -0.08, 0.0)  # centre of the grip, 8 cm distal of the wrist (hand frame)

# The pad is a roller on an axle: what it resists along the shin is rolling resistance, a few per
# cent of the load (not the 0.8 of a pad the shin would slide on). The hands grip the handles: two
# opposing contacts per hand (the handle pushes the hand up, or holds it down) with a firm grip.
PAD = {"static_friction": "0.02", "kinetic_friction": "0.02"}
GRIP = {"static_friction": "0.8", "kinetic_friction": "0.5"}


def fk(model_path):
    model = osim.Model(model_path)
    state = model.initSystem()
    cs = model.getCoordinateSet()
    for i in range(cs.getSize()):
        c = cs.get(i)
        if c.getName() in SEATED:
            c.setValue(state, SEATED[c.getName()], False)
        elif c.getMotionType() == 1:  # rotational
            c.setValue(state, 0.0, False)
    model.assemble(state)
    model.realizePosition(state)
    bodies = model.getBodySet()
    ground = model.getGround()

    def station(body, p):
        v = bodies.get(body).findStationLocationInGround(state, osim.Vec3(*p))
        return (v[0], v[1], v[2])

    def joint_centre(joint):
        f = model.getJointSet().get(joint).getChildFrame()
        v = f.getPositionInGround(state)
        return (v[0], v[1], v[2])

    def to_body(body, p):
        v = ground.findStationLocationInAnotherFrame(state, osim.Vec3(*p), bodies.get(body))
        return (v[0], v[1], v[2])

    def axis_in_ground(body, a):
        v = bodies.get(body).expressVectorInGround(state, osim.Vec3(*a))
        return (v[0], v[1], v[2])

    def to_body_vector(body, a):
        v = ground.expressVectorInAnotherFrame(state, osim.Vec3(*a), bodies.get(body))
        return (v[0], v[1], v[2])

    beta = cs.get("knee_angle_r_beta").getValue(state)
    return dict(
        station=station,
        joint_centre=joint_centre,
        to_body=to_body,
        axis_in_ground=axis_in_ground,
        to_body_vector=to_body_vector,
        beta=beta,
    )


def norm(v):
    return math.sqrt(sum(x * x for x in v))


def make_human(src, pelvis_ty):
    tree = ET.parse(src)
    doc = tree.getroot()
    model = doc.find("Model")
    model.set("name", "seated_human_rajagopal_lai_uhlrich")
    g.strip(model, {"attached_geometry"})
    for c in model.iter("Coordinate"):
        name = c.get("name")
        v = SEATED.get(name, 0.0)
        if name == "pelvis_ty":
            v = pelvis_ty
        if c.find("default_value") is None:
            continue
        if name.endswith("_beta"):
            continue  # dependent: solved from its coupler
        c.find("default_value").text = g.fmt(v)
        rng = g.numbers(c.find("range"))
        assert rng[0] <= v <= rng[1], (name, rng, v)
    credits = model.find("credits")
    credits.text = (
        "Seated human of statopt's leg extension study, derived by scripts/make_leg_extension_rajagopal.py "
        "from RajagopalLaiUhlrich2023.osim (Rajagopal et al. 2016 with Lai et al. 2017 and Uhlrich et al. 2022): "
        "bodies, joints, muscles and actuators unchanged; display geometry removed; default pose seated. "
        "Original credits: " + (credits.text or "")
    )
    mass = sum(float(b.find("mass").text) for b in model.find("BodySet/objects"))
    doc.insert(
        0,
        ET.Comment(
            " Generated by scripts/make_leg_extension_rajagopal.py from RajagopalLaiUhlrich2023.osim: display "
            f"geometry removed, default pose seated. Total mass {mass:.4f} kg. See models/leg_extension/README.md. "
        ),
    )
    return tree, mass


def main():
    src = sys.argv[1] if len(sys.argv) > 1 else DEFAULT_SRC
    os.makedirs(OUT, exist_ok=True)
    # First pass: pelvis at 0.9 m to find where the hips are; then place the pelvis so that the hip
    # centres are at HIP_Y, x = -0.0707 (the gait2392 study's), z symmetric.
    SEATED["pelvis_ty"] = 0.9
    k = fk(src)
    hip_r = k["joint_centre"]("hip_r")
    dy = HIP_Y - hip_r[1]
    dx = -0.0707 - hip_r[0]
    SEATED["pelvis_ty"] = 0.9 + dy
    SEATED["pelvis_tx"] = dx
    human, mass = make_human(src, SEATED["pelvis_ty"])
    # pelvis_tx default too
    for c in human.getroot().iter("Coordinate"):
        if c.get("name") == "pelvis_tx":
            c.find("default_value").text = g.fmt(dx)
    path = os.path.join(OUT, "human_seated_rajagopal.osim")
    g.write(human, path)
    k = fk(path)
    geo, points = {}, {}
    for side, sign in (("r", 1.0), ("l", -1.0)):
        hip = k["joint_centre"](f"hip_{side}")
        knee = k["joint_centre"](f"walker_knee_{side}")
        ankle = k["joint_centre"](f"ankle_{side}")
        geo[f"hip_{side}"], geo[f"knee_{side}"] = hip, knee
        # pad: on the shin's anterior surface, PAD_ABOVE_ANKLE up the shin from the ankle
        shin = tuple(a - b for a, b in zip(knee, ankle))
        u = tuple(x / norm(shin) for x in shin)
        anterior = (u[1], -u[0], 0.0)  # the shin axis turned by -90 deg about z: anterior
        if anterior[0] < 0:
            anterior = tuple(-x for x in anterior)
        pad = tuple(a + PAD_ABOVE_ANKLE * b + SHIN_SURFACE * c for a, b, c in zip(ankle, u, anterior))
        geo[f"pad_{side}"] = pad
        points[f"tibia_pad_{side}"] = ("tibia_" + side, k["to_body"](f"tibia_{side}", pad))
        seat_y = hip[1] - SEAT_BELOW_HIP
        thigh = tuple(a - b for a, b in zip(knee, hip))
        for j, (tag, s) in enumerate(zip(("proximal", "distal"), FEMUR_POINTS)):
            p = (hip[0] + s * thigh[0] / norm(thigh), seat_y, hip[2])
            geo[f"femur{j}_{side}"] = p
            points[f"femur_seat_{tag}_{side}"] = ("femur_" + side, k["to_body"](f"femur_{side}", p))
        # ischial tuberosity: below the hamstrings' origin (semimembranosus, on the tuberosity)
        ischium = (hip[0] - 0.05, seat_y, hip[2] * 0.8)
        geo[f"ischium_{side}"] = ischium
        points[f"pelvis_seat_{side}"] = ("pelvis", k["to_body"]("pelvis", ischium))
        scap_local = (SCAPULA_IN_TORSO[0], SCAPULA_IN_TORSO[1], sign * SCAPULA_IN_TORSO[2])
        scap = k["station"]("torso", scap_local)
        geo[f"scapula_{side}"] = scap
        points[f"torso_backrest_{side}"] = ("torso", scap_local)
        palm = k["station"](f"hand_{side}", PALM_IN_HAND)
        geo[f"hand_{side}"] = palm
        points[f"hand_grip_{side}"] = (f"hand_{side}", PALM_IN_HAND)
    # the backrest touches the scapula points (vertical plane through the more posterior one)
    back_x = min(geo["scapula_r"][0], geo["scapula_l"][0])
    geo["scapula_r"] = (back_x, geo["scapula_r"][1], geo["scapula_r"][2])
    for side in "rl":
        body, local = points[f"torso_backrest_{side}"]
        gpt = k["station"]("torso", local)
        points[f"torso_backrest_{side}"] = ("torso", k["to_body"]("torso", (back_x, gpt[1], gpt[2])))
    print(f"human_seated_rajagopal.osim: total mass {mass:.4f} kg, pelvis_tx {dx:.5f}, pelvis_ty {SEATED['pelvis_ty']:.5f}, knee_angle_r_beta {k['beta']:.6f}")
    for key in sorted(geo):
        print(f"  {key:14s} {g.fmt(tuple(round(x, 5) for x in geo[key]))}")

    # The machine: the gait2392 study's, fitted to this person (lever axis on the knee flexion
    # axis; seat, backrest and pad where this person sits), plus handles beside the seat.
    infos = {}
    for name, cam in (("machine_cam1_rajagopal", "cam1"), ("machine_cam2_rajagopal", "cam2")):
        tree, info = g.make_machine(geo, name, cam, 0.0)
        root = tree.getroot()
        for c in list(root):
            if isinstance(c.tag, str):
                continue
            root.remove(c)
        root.insert(
            0,
            ET.Comment(
                f" Leg extension machine ({'cam 1, constant 50 N m' if cam == 'cam1' else 'cam 2, elliptical'}) fitted to "
                "human_seated_rajagopal.osim: lever axis on the knee flexion axis, seat, backrest and pad where this person "
                "sits; handles beside the seat (contacts_rajagopal.xml). Generated by scripts/make_leg_extension_rajagopal.py. "
            ),
        )
        root.find("Model/credits").text = (
            "statopt; leg extension machine after Krueger and Wartzack (2017), Figure 7. Dimensions fitted to "
            "human_seated_rajagopal.osim (Rajagopal et al. 2016; Lai et al. 2017; Uhlrich et al. 2022)."
        )
        g.write(tree, os.path.join(OUT, name + ".osim"))
        infos[name] = info
    info = infos["machine_cam1_rajagopal"]
    seat_origin = (info["backrest_x"], info["seat_top"], 0.0)

    doc = ET.Element("OpenSimDocument", Version="40000")
    doc.append(
        ET.Comment(
            " The 12 point-on-plane contacts of the leg extension study with human_seated_rajagopal.osim: per side "
            "tibia-pad (lever; a roller: friction 0.02), femur-seat (proximal thigh, seat front edge), pelvis-seat "
            "(ischial tuberosity), torso-backrest (scapula), and the hand gripping the seat's handle (two opposing "
            "contacts: the handle pushes the hand up or holds it down). Points on the human, planes on the machine, "
            "normals from the plane towards the human. Generated by scripts/make_leg_extension_rajagopal.py. "
        )
    )
    fs = g.sub_el(doc, "ForceSet", name="leg_extension_contacts_rajagopal")
    objs = g.sub_el(fs, "objects")
    base = dict(g.CONTACT)

    def contact(name, body, local, plane_body, origin, normal, extra):
        e = g.sub_el(objs, "PointOnPlaneContact", name=name)
        g.sub_el(e, "point_body", body)
        g.sub_el(e, "point_location", g.fmt(local))
        g.sub_el(e, "plane_body", plane_body)
        g.sub_el(e, "plane_origin", g.fmt(origin))
        g.sub_el(e, "plane_normal", g.fmt(normal))
        props = dict(base)
        props.update(extra)
        for kk, v in props.items():
            g.sub_el(e, kk, v)

    for side in "rl":
        b, p = points[f"tibia_pad_{side}"]
        contact(f"tibia_pad_{side}", b, p, "lever", (0, 0, 0), (-1.0, 0.0, 0.0), PAD)
        for tag in ("proximal", "distal"):
            b, p = points[f"femur_seat_{tag}_{side}"]
            contact(f"femur_seat_{tag}_{side}", b, p, "seat", (0, 0, 0), (0.0, 1.0, 0.0), {})
        b, p = points[f"pelvis_seat_{side}"]
        contact(f"pelvis_seat_{side}", b, p, "seat", (0, 0, 0), (0.0, 1.0, 0.0), {})
        b, p = points[f"torso_backrest_{side}"]
        contact(f"torso_backrest_{side}", b, p, "backrest", (0, 0, 0), (1.0, 0.0, 0.0), {})
        b, p = points[f"hand_grip_{side}"]
        handle = tuple(a - o for a, o in zip(geo[f"hand_{side}"], seat_origin))
        contact(f"handle_push_{side}", b, p, "seat", handle, (0.0, 1.0, 0.0), GRIP)
        contact(f"handle_hold_{side}", b, p, "seat", handle, (0.0, -1.0, 0.0), GRIP)
    g.sub_el(fs, "groups")
    g.write(ET.ElementTree(doc), os.path.join(OUT, "contacts_rajagopal.xml"))

    write_motion(human)

def write_motion(human):
    """The motion: every coordinate of the model; knees 95 -> 5 deg flexion, minimum jerk, 5 s.
    Rotational coordinates in degrees. The patella's knee_angle_*_beta are coupled coordinates
    (motion type not rotational): OpenSim reads their columns as they stand, so they hold the
    coupler's value (identity of the knee angle) in radians."""
    coords = [c.get("name") for c in human.getroot().iter("Coordinate")]

    def value(c, s):
        knee = KNEE_START + (KNEE_END - KNEE_START) * g.minimum_jerk(s)
        if c in ("knee_angle_r", "knee_angle_l"):
            return knee / DEG
        if c in ("knee_angle_r_beta", "knee_angle_l_beta"):
            return knee
        if c in g.TRANSLATIONAL:
            return SEATED.get(c, 0.0)
        return SEATED.get(c, 0.0) / DEG

    g.write_motion(
        os.path.join(OUT, "../../motions/leg_extension_rajagopal.mot"),
        "test_knee_extension_rajagopal",
        coords,
        [
            "Both knees 95 deg -> 5 deg flexion, minimum jerk over 5 s; other coordinates at the seated pose",
            "(human_seated_rajagopal.osim defaults; knee_angle_*_beta follow their couplers, in radians). Generated by",
            "scripts/make_leg_extension_rajagopal.py.",
        ],
        value,
    )


if __name__ == "__main__":
    main()
