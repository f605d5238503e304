#!/usr/bin/env python3
"""The seated leg press: a second machine for the seated Rajagopal-Lai-Uhlrich human of the leg
extension study (models/leg_extension/human_seated_rajagopal.osim, reused unchanged: its posture in
the leg press is set by the motion's coordinates).

Writes into models/leg_press/:
  machine_leg_press.osim     the machine: seat, backrest (welded), sled with the footplate on a
                             horizontal rail (SliderJoint), weight stack on a vertical rail
                             (SliderJoint) tied to the sled by its cable (CoordinateCouplerConstraint)
  contacts_leg_press.xml     16 PointOnPlaneContacts (see CONTACTS below)
  motion_command.sh          the statopt-tool motion command that makes the shipped motion
                             (motions/leg_press_rajagopal.mot), with the link constants this
                             script computes

Needs OpenSim 4.6's Python package (forward kinematics of the walker knee), like
scripts/make_leg_extension_rajagopal.py. Run from anywhere:
    python scripts/make_leg_press_models.py
then
    sh models/leg_press/motion_command.sh
Every number below is a parameter with its source or the reason it was chosen; the README of
models/leg_press repeats them.
"""
import math
import os
import sys
import xml.etree.ElementTree as ET

import opensim as osim

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import make_leg_extension_models as g  # noqa: E402  (XML helpers of the leg extension generator)

REPO = os.path.dirname(HERE)
OUT = os.path.join(REPO, "models", "leg_press")
HUMAN = os.path.join(REPO, "models", "leg_extension", "human_seated_rajagopal.osim")
DEG = math.pi / 180.0

# ---------------------------------------------------------------------------------------------
# The exercise and the posture (coordinates the motion sets; the human file is not changed)
# ---------------------------------------------------------------------------------------------
KNEE_START = 95.0  # deg of knee flexion at the bottom of the press, as in the leg extension study
KNEE_END = 5.0  # deg, near full extension without locking the knee (machine instructions)
# Tempo: 2 s down (eccentric) and 2 s up (concentric), the "controlled velocity" of Martin-Fuentes
# et al. (2020, Int J Environ Res Public Health 17:8698: 2 s eccentric - 2 s concentric), with a
# 0.5 s pause at the bottom; minimum jerk each way (Flash & Hogan 1985), as the leg extension motion.
DURATION = 2.0  # s each way
HOLD_BOTTOM = 0.5  # s
RATE = 20.0  # rows per second: 91 rows
# The seat unit reclines the person: pelvis tilted 20 deg posteriorly on a horizontal seat pan and
# the lumbar spine neutral (lumbar_extension 0), so the trunk and the backrest are reclined 20 deg
# from the vertical. Machine instructions ask for the lower back flat on the pad and a neutral spine;
# the recline angle is our choice within the adjustable range of seated leg presses (a reclined
# back keeps the hip flexion of this model within its 120 deg range at 95 deg of knee flexion:
# hip flexion = 90 - pelvis_tilt + thigh elevation).
PELVIS_TILT = 20.0  # deg, posterior
LUMBAR_EXTENSION = 0.0  # deg
# The rail is horizontal (a seated, cable-loaded leg press: the sled carries the footplate along
# the ground's x axis, away from the person as the legs extend). The feet are placed so that the
# ankles are level with the hip centres at the bottom of the press (the line hip-ankle along the
# rail); the thigh then rises above the rail by about half the knee flexion, and the motion links
# hip_flexion = 0.5 * knee_angle + C_HIP (exact for equal thigh and shank lengths, see README).
RAIL_ANGLE = 0.0  # deg above the horizontal: 0 for a seated leg press, 45 for a 45-deg sled
# The footplate leans away from the person at its top by PLATE_TILT: the foot's sole lies on the
# plate, so the ankle is dorsiflexed by about knee/2 - PLATE_TILT (32.5 deg at 95 deg of knee
# flexion, -12.5 deg at 5 deg) instead of knee/2 with a vertical plate (47.5 deg, beyond the
# ankle's usual passive dorsiflexion of about 30 deg with the knee flexed).
PLATE_TILT = 15.0  # deg
PLATE_SIZE = (0.03, 0.45, 0.70)  # m: thickness, height, width of the footplate
SLED_MASS = 15.0  # kg: carriage with footplate (our estimate; it only adds inertia along the rail)
# Load: half the body weight on the stack, the load of Castonguay-Siu & Taylor (2022, J Biomech Eng
# 144:035001, leg presses at 50 % body weight). The cable runs 1:1 from the sled to the stack, so
# the stack rises by what the sled moves and loads the sled with its weight (plus its inertia).
LOAD_FRACTION_BW = 0.5
# Seat and backrest (welded to ground): seat top 8 cm below the hip centres (the ischial
# tuberosities' depth below the hip centres used in the leg extension study); backrest through the
# posterior thorax at the scapulae, reclined with the trunk.
SEAT_BELOW_HIP = 0.08
SCAPULA_IN_TORSO = (-0.11, 0.33, 0.09)  # the leg extension study's scapula point (torso frame)
# Backrest contact heights above the seat pan, measured along the backrest: the sacrum (pelvis) at
# 0.10 m, the lumbar region at 0.19 m (where Castonguay-Siu & Taylor 2022 found the back's pressure
# on a leg press backrest to concentrate, "mid-to-lumbar region", supports 19 cm above the seat pan),
# the scapulae (thorax) where SCAPULA_IN_TORSO lies.
SACRUM_ABOVE_SEAT = 0.10
LUMBAR_ABOVE_SEAT = 0.19
BACK_HALF_WIDTH = 0.05  # m either side of the midline (the paraspinal muscles)
# Seat contacts: the ischial tuberosities (pelvis). No thigh-seat contact: with the feet at hip
# height the thighs rise off the seat as soon as the knees flex (the posterior thigh 0.10 m from the
# hip is 9 cm above the seat at 95 deg of knee flexion) and come back to it only at the top of the
# press, rotating down onto it: a contact there slides over the seat (1.3 cm/s) in the very frames it
# would load (measured with a thigh contact in an earlier version of this machine; see
# models/leg_press/README.md).
ISCHIUM_BEHIND_HIP = 0.05  # as in the leg extension study
# Foot points on the calcaneus body (calcn_*; its frame: x forward along the foot, y up): the heel
# and the forefoot under the metatarsal heads, on the sole 2 cm below the flexor tendons' path
# points at the metatarsal heads (x = 0.166-0.173 m, y = -0.005..-0.008 m in this model's calcn).
HEEL_IN_CALCN = (0.03, -0.02, 0.0)
FOREFOOT_IN_CALCN = (0.17, -0.02, 0.0)
PALM_IN_HAND = (0.0, -0.08, 0.0)  # grip centre, 8 cm distal of the wrist (leg extension study)

# ---------------------------------------------------------------------------------------------
# Contact properties per surface, with why (docs/new_machine.md repeats them)
# ---------------------------------------------------------------------------------------------
# d_tol = 5 mm and d_trans = 10 mm everywhere: the compliance of a shoe sole, a pad or the soft
# tissue over the bone is of this order, and the leg extension study uses the same values.
# v_trans = 0.01 m/s: a planted contact in this slow exercise moves relative to its surface only by
# what the motion's kinematics leave (sub-millimetre per frame); 0.01 m/s separates that from real
# sliding (the leg extension study's value).
BASE = {
    "contact_tolerance": "0.005",
    "contact_transition_zone": "0.01",
    "v_trans": "0.01",
    "optimal_force": "100",
}
# Shoe sole (rubber) on a non-skid footplate (rubber mat or grip tape on steel): dry rubber on
# textured surfaces has static coefficients of 0.6-1.0 in the slip-resistance literature
# (Chang et al. 2001, Ergonomics 44:1217); 0.8 static, 0.6 kinetic.
SOLE = {"static_friction": "0.8", "kinetic_friction": "0.6"}
# Clothing on the vinyl upholstery of seat and backrest: no measured value for gym upholstery was
# found; the contact element's defaults (0.8 / 0.5, Krueger & Wartzack's plugin), as the leg
# extension study's seat and backrest.
PAD = {"static_friction": "0.8", "kinetic_friction": "0.5"}
# The hands grip the handles: two opposing contacts (the handle pushes the hand up or holds it
# down), friction of a firm grip, as in the leg extension study.
GRIP = {"static_friction": "0.8", "kinetic_friction": "0.5"}


def fk_model():
    model = osim.Model(HUMAN)
    state = model.initSystem()
    return model, state


# Hip adduction and rotation (deg) change linearly with the knee angle from 0 at the bottom of the
# press to these values at the top, so that each foot keeps its place on the plate sideways: the
# walker knee's coupled rotations and the hip's axes move the foot medially-laterally and turn it
# as the leg extends, which a planted foot does not do. main() fits them.
SIDEWAYS = {"hip_adduction": 0.0, "hip_rotation": 0.0}


def sideways(name, knee):
    return SIDEWAYS[name] * (KNEE_START - knee) / (KNEE_START - KNEE_END)


def pose(model, state, knee, hip, ankle):
    cs = model.getCoordinateSet()
    values = {
        "hip_adduction_r": sideways("hip_adduction", knee) * DEG,
        "hip_adduction_l": sideways("hip_adduction", knee) * DEG,
        "hip_rotation_r": sideways("hip_rotation", knee) * DEG,
        "hip_rotation_l": sideways("hip_rotation", knee) * DEG,
        "pelvis_tilt": PELVIS_TILT * DEG,
        "lumbar_extension": LUMBAR_EXTENSION * DEG,
        "knee_angle_r": knee * DEG,
        "knee_angle_l": knee * DEG,
        "hip_flexion_r": hip * DEG,
        "hip_flexion_l": hip * DEG,
        "ankle_angle_r": ankle * DEG,
        "ankle_angle_l": ankle * DEG,
    }
    for name, v in values.items():
        cs.get(name).setValue(state, v, False)
    model.assemble(state)
    model.realizePosition(state)


def station(model, state, body, p):
    v = model.getBodySet().get(body).findStationLocationInGround(state, osim.Vec3(*p))
    return (v[0], v[1], v[2])


def to_body(model, state, body, p):
    v = model.getGround().findStationLocationInAnotherFrame(state, osim.Vec3(*p), model.getBodySet().get(body))
    return (v[0], v[1], v[2])


def joint_centre(model, state, joint):
    v = model.getJointSet().get(joint).getChildFrame().getPositionInGround(state)
    return (v[0], v[1], v[2])


def bisect(f, a, b, tol=1e-12):
    fa = f(a)
    assert fa * f(b) < 0, (a, b, fa, f(b))
    for _ in range(200):
        m = 0.5 * (a + b)
        fm = f(m)
        if (fm < 0) == (fa < 0):
            a, fa = m, fm
        else:
            b = m
        if b - a < tol:
            break
    return 0.5 * (a + b)


RAIL = (math.cos(RAIL_ANGLE * DEG), math.sin(RAIL_ANGLE * DEG), 0.0)
# plate normal (towards the person) and its upward tangent, in ground (and in the sled frame, whose
# axes are the rail frame's: x along the rail)
PLATE_UP_RAIL = (math.sin(PLATE_TILT * DEG), math.cos(PLATE_TILT * DEG), 0.0)
PLATE_NORMAL_RAIL = (-math.cos(PLATE_TILT * DEG), math.sin(PLATE_TILT * DEG), 0.0)


def rail_to_ground(v):
    return g.rot_z(RAIL_ANGLE * DEG, v)


def ground_to_rail(v):
    return g.rot_z(-RAIL_ANGLE * DEG, v)


def dot(a, b):
    return sum(x * y for x, y in zip(a, b))


def solve_pose(model, state, knee, c_hip, slope_hip):
    """Hip from the link; ankle so that the sole (heel -> forefoot) lies along the plate."""
    hip = c_hip + slope_hip * knee
    normal = rail_to_ground(PLATE_NORMAL_RAIL)

    def sole_off_plate(ankle):
        pose(model, state, knee, hip, ankle)
        h = station(model, state, "calcn_r", HEEL_IN_CALCN)
        f = station(model, state, "calcn_r", FOREFOOT_IN_CALCN)
        return dot(g.sub(f, h), normal)

    ankle = bisect(sole_off_plate, -50.0, 50.0)
    pose(model, state, knee, hip, ankle)
    return hip, ankle


def main():
    os.makedirs(OUT, exist_ok=True)
    model, state = fk_model()
    mass = sum(model.getBodySet().get(i).getMass() for i in range(model.getBodySet().getSize()))
    stack_mass = LOAD_FRACTION_BW * mass

    # The hip link hip_flexion = SLOPE_HIP * knee + C_HIP: the ankle centre on the rail line
    # through the hip centre at both ends of the press (at the bottom and at the top).
    def ankle_off_rail(knee, slope, c_hip):
        pose(model, state, knee, c_hip + slope * knee, 0.0)
        hip = joint_centre(model, state, "hip_r")
        ankle = joint_centre(model, state, "ankle_r")
        return ground_to_rail(g.sub(ankle, hip))[1]

    def c_for(slope):
        return bisect(lambda c: ankle_off_rail(KNEE_START, slope, c), -40.0, 120.0 - slope * KNEE_START)

    def fit_hip():
        slope = bisect(lambda a: ankle_off_rail(KNEE_END, a, c_for(a)), 0.3, 0.7, 1e-10)
        return slope, c_for(slope)

    def foot_z(knee, slope, c):
        solve_pose(model, state, knee, c, slope)
        return (
            station(model, state, "calcn_r", HEEL_IN_CALCN)[2],
            station(model, state, "calcn_r", FOREFOOT_IN_CALCN)[2],
        )

    for _ in range(4):
        slope_hip, c_hip = fit_hip()
        z0 = foot_z(KNEE_START, slope_hip, c_hip)
        # Newton on (adduction, rotation) at the top of the press: heel and forefoot sideways
        # where they were at the bottom
        for _ in range(8):
            z1 = foot_z(KNEE_END, slope_hip, c_hip)
            r = (z1[0] - z0[0], z1[1] - z0[1])
            jac = []
            for name in ("hip_adduction", "hip_rotation"):
                SIDEWAYS[name] += 1e-4
                zp = foot_z(KNEE_END, slope_hip, c_hip)
                SIDEWAYS[name] -= 1e-4
                jac.append(((zp[0] - z1[0]) / 1e-4, (zp[1] - z1[1]) / 1e-4))
            (a, c), (b, d) = jac  # columns: d(z_heel, z_fore)/d(add), d/d(rot)
            det = a * d - b * c
            SIDEWAYS["hip_adduction"] -= (d * r[0] - b * r[1]) / det
            SIDEWAYS["hip_rotation"] -= (-c * r[0] + a * r[1]) / det
    hip0, ankle0 = solve_pose(model, state, KNEE_START, c_hip, slope_hip)
    start = {
        "hip": joint_centre(model, state, "hip_r"),
        "heel_r": station(model, state, "calcn_r", HEEL_IN_CALCN),
        "forefoot_r": station(model, state, "calcn_r", FOREFOOT_IN_CALCN),
        "heel_l": station(model, state, "calcn_l", HEEL_IN_CALCN[:2] + (-HEEL_IN_CALCN[2],)),
        "forefoot_l": station(model, state, "calcn_l", FOREFOOT_IN_CALCN[:2] + (-FOREFOOT_IN_CALCN[2],)),
        "scapula_r": station(model, state, "torso", SCAPULA_IN_TORSO),
    }
    hips = {s: joint_centre(model, state, f"hip_{s}") for s in "rl"}
    hands = {s: station(model, state, f"hand_{s}", PALM_IN_HAND) for s in "rl"}
    seat_y = start["hip"][1] - SEAT_BELOW_HIP
    points = {}
    for s in "rl":
        hip = hips[s]
        ischium = (hip[0] - ISCHIUM_BEHIND_HIP, seat_y, hip[2] * 0.8)
        points[f"pelvis_seat_{s}"] = ("pelvis", to_body(model, state, "pelvis", ischium), ischium)
    # backrest: a plane through the scapula point, reclined with the trunk
    recline = (PELVIS_TILT + LUMBAR_EXTENSION) * DEG
    back_normal = (math.cos(recline), math.sin(recline), 0.0)  # towards the person
    back_up = (-math.sin(recline), math.cos(recline), 0.0)
    scap = start["scapula_r"]
    # where the backrest plane meets the seat top: its bottom edge (scap + t * back_up at y = seat_y)
    t_edge = (seat_y - scap[1]) / back_up[1]
    edge = (scap[0] + t_edge * back_up[0], seat_y, 0.0)
    lumbar_joint = joint_centre(model, state, "back")
    for s, sign in (("r", 1.0), ("l", -1.0)):
        for name, height in (("sacrum", SACRUM_ABOVE_SEAT), ("lumbar", LUMBAR_ABOVE_SEAT)):
            p = g.add(edge, g.scale(back_up, height))
            p = (p[0], p[1], sign * BACK_HALF_WIDTH)
            # the body: above the lumbar joint's height along the backrest -> torso, else pelvis
            along = dot(g.sub(p, edge), back_up)
            along_joint = dot(g.sub(lumbar_joint, edge), back_up)
            body = "torso" if along > along_joint else "pelvis"
            points[f"{name}_backrest_{s}"] = (body, to_body(model, state, body, p), p)
        sp = station(model, state, "torso", (SCAPULA_IN_TORSO[0], SCAPULA_IN_TORSO[1], sign * SCAPULA_IN_TORSO[2]))
        # onto the plane along its normal
        dist = dot(g.sub(sp, scap), back_normal)
        sp = g.sub(sp, g.scale(back_normal, dist))
        points[f"scapula_backrest_{s}"] = ("torso", to_body(model, state, "torso", sp), sp)
        points[f"hand_grip_{s}"] = (f"hand_{s}", PALM_IN_HAND, hands[s])

    # the footplate at the bottom of the press: through the right heel, normal PLATE_NORMAL
    heel = start["heel_r"]
    plate_centre = g.scale(g.add(start["heel_r"], start["forefoot_r"]), 0.5)
    plate_centre = (plate_centre[0], plate_centre[1], 0.0)
    # move the centre onto the plane through the heel along the normal
    n_g = rail_to_ground(PLATE_NORMAL_RAIL)
    plate_centre = g.sub(plate_centre, g.scale(n_g, dot(g.sub(plate_centre, heel), n_g)))

    # the end of the press: thigh points on the seat, the ankle link, the sled travel
    hip1, ankle1 = solve_pose(model, state, KNEE_END, c_hip, slope_hip)
    end_heel = station(model, state, "calcn_r", HEEL_IN_CALCN)
    travel = dot(g.sub(end_heel, heel), rail_to_ground((1.0, 0.0, 0.0)))
    # the ankle's drift off the rail line over the motion (the hip link is exact only for equal
    # segment lengths): the feet slide along the plate by this much
    drift = []
    for k in range(0, 19):
        kn = KNEE_END + (KNEE_START - KNEE_END) * k / 18
        solve_pose(model, state, kn, c_hip, slope_hip)
        drift.append(ground_to_rail(g.sub(joint_centre(model, state, "ankle_r"), joint_centre(model, state, "hip_r")))[1])
    slope_ankle = (ankle0 - ankle1) / (KNEE_START - KNEE_END)
    c_ankle = ankle0 - slope_ankle * KNEE_START

    print(f"human mass {mass:.4f} kg, stack {stack_mass:.4f} kg ({LOAD_FRACTION_BW} BW)")
    print(f"hip adduction {SIDEWAYS['hip_adduction']:.4f} deg, rotation {SIDEWAYS['hip_rotation']:.4f} deg at the top of the press")
    print(f"hip link {slope_hip:.6f} * knee + {c_hip:.6f} deg: hip flexion {hip0:.3f} deg at knee {KNEE_START}, {hip1:.3f} at {KNEE_END}")
    print(f"ankle {ankle0:.3f} deg at knee {KNEE_START}, {ankle1:.3f} at {KNEE_END}; link slope {slope_ankle:.6f}, C {c_ankle:.6f}")
    print(f"sled travel {travel:.4f} m; ankle off the rail line: {min(drift) * 1000:.2f} .. {max(drift) * 1000:.2f} mm")
    print(f"seat top y {seat_y:.5f}; backrest edge {g.fmt(tuple(round(x, 5) for x in edge))}; plate centre {g.fmt(tuple(round(x, 5) for x in plate_centre))}")
    for k, (b, local, gp) in sorted(points.items()):
        print(f"  {k:22s} {b:8s} ground {g.fmt(tuple(round(x, 4) for x in gp))}  body {g.fmt(tuple(round(x, 4) for x in local))}")

    seat_origin = (edge[0], seat_y, 0.0)
    write_machine(seat_origin, edge, recline, plate_centre, stack_mass, travel, mass)
    write_contacts(points, seat_origin, edge, back_normal, recline)
    write_command(slope_hip, c_hip, slope_ankle, c_ankle)
    for f in ("machine_leg_press.osim",):
        m = osim.Model(os.path.join(OUT, f))
        m.initSystem()
        print(f"OpenSim 4.6 loads {f}: {m.getBodySet().getSize()} bodies, {m.getCoordinateSet().getSize()} coordinates")


def write_machine(seat_origin, edge, recline, plate_centre, stack_mass, travel, human_mass):
    doc = ET.Element("OpenSimDocument", Version="40000")
    doc.append(
        ET.Comment(
            " Seated leg press: seat and backrest welded to ground; the sled (footplate) on a horizontal rail "
            "(SliderJoint sled_rail: the sled translates along the X axis of the rail frame, which is ground's x turned "
            f"by {RAIL_ANGLE:g} deg about z; sled_x = 0 at the bottom of the press, increasing as the legs extend); the weight "
            f"stack ({stack_mass:.2f} kg = {LOAD_FRACTION_BW} x the human's {human_mass:.2f} kg) on a vertical rail (SliderJoint "
            "stack_rail, its frame's X axis turned to ground's y), tied to the sled by the cable: CoordinateCouplerConstraint "
            "cable, stack_height = sled_x (1:1). Generated by scripts/make_leg_press_models.py; see models/leg_press/README.md. "
        )
    )
    model = g.sub_el(doc, "Model", name="leg_press")
    g.sub_el(model, "credits", "statopt; seated leg press fitted to human_seated_rajagopal.osim (scripts/make_leg_press_models.py).")
    g.sub_el(model, "publications", "Castonguay-Siu V., Taylor W.R. (2022) Optimizing backrest geometry to minimize interfacial pressure concentrations in the mid-to-lumbar region during leg press resistance training. J Biomech Eng 144(3):035001, doi:10.1115/1.4053133 (load 50 % body weight; backrest pressure in the lumbar region).")
    g.sub_el(model, "gravity", "0 -9.8066499999999994 0")
    bodies = g.sub_el(model, "BodySet", name="bodyset")
    objs = g.sub_el(bodies, "objects")
    # seat: origin at the bottom edge of the backrest on the seat top (midline); cushion + frame 12 kg
    g.body(objs, "seat", 12.0, (0.2, -0.05, 0.0), g.box_inertia(12.0, 0.40, 0.10, 0.40))
    # backrest: origin at the same edge, axes turned by the recline (its y along the pad)
    g.body(objs, "backrest", 8.0, (-0.04, 0.30, 0.0), g.box_inertia(8.0, 0.08, 0.60, 0.40))
    t, h, w = PLATE_SIZE
    # sled: origin at the footplate surface centre; plate 0.03 x 0.45 x 0.70 m plus carriage
    g.body(objs, "sled", SLED_MASS, (t / 2 + 0.05, 0.0, 0.0), g.box_inertia(SLED_MASS, t + 0.1, h, w))
    g.body(objs, "stack", stack_mass, (0.0, 0.0, 0.0), g.box_inertia(stack_mass, 0.10, 0.20, 0.30))
    g.sub_el(bodies, "groups")

    joints = g.sub_el(model, "JointSet", name="jointset")
    jobjs = g.sub_el(joints, "objects")
    g.weld(jobjs, "seat_weld", "seat", seat_origin)
    jb = g.sub_el(jobjs, "WeldJoint", name="backrest_weld")
    g.sub_el(jb, "socket_parent_frame", "ground_backrest")
    g.sub_el(jb, "socket_child_frame", "backrest_offset")
    fr = g.sub_el(jb, "frames")
    g.offset_frame(fr, "ground_backrest", "/ground", edge, (0.0, 0.0, recline))
    g.offset_frame(fr, "backrest_offset", "/bodyset/backrest", (0.0, 0.0, 0.0))

    def slider(name, body, coord, parent_at, parent_orientation, default, rng):
        j = g.sub_el(jobjs, "SliderJoint", name=name)
        g.sub_el(j, "socket_parent_frame", f"ground_{name}")
        g.sub_el(j, "socket_child_frame", f"{body}_offset")
        cs = g.sub_el(j, "coordinates")
        c = g.sub_el(cs, "Coordinate", name=coord)
        g.sub_el(c, "default_value", g.fmt(default))
        g.sub_el(c, "default_speed_value", "0")
        g.sub_el(c, "range", g.fmt(rng))
        g.sub_el(c, "clamped", "false")
        g.sub_el(c, "locked", "false")
        fr = g.sub_el(j, "frames")
        g.offset_frame(fr, f"ground_{name}", "/ground", parent_at, parent_orientation)
        # the child frame's axes are the parent's: undo the parent's turn for the stack (upright)
        g.offset_frame(fr, f"{body}_offset", f"/bodyset/{body}", (0.0, 0.0, 0.0), parent_orientation if body == "stack" else (0.0, 0.0, 0.0))

    slider("sled_rail", "sled", "sled_x", plate_centre, (0.0, 0.0, RAIL_ANGLE * DEG), 0.0, (-0.05, 0.6))
    # the stack hangs behind the machine, beside the seat; its rail is vertical
    stack_at = (edge[0] - 0.5, 0.3, 0.0)
    slider("stack_rail", "stack", "stack_height", stack_at, (0.0, 0.0, math.pi / 2), 0.0, (-0.05, 0.6))
    g.sub_el(joints, "groups")

    cons = g.sub_el(model, "ConstraintSet", name="constraintset")
    cobjs = g.sub_el(cons, "objects")
    cc = g.sub_el(cobjs, "CoordinateCouplerConstraint", name="cable")
    g.sub_el(cc, "isEnforced", "true")
    g.sub_el(cc, "independent_coordinate_names", "sled_x")
    g.sub_el(cc, "dependent_coordinate_name", "stack_height")
    fn = g.sub_el(cc, "coupled_coordinates_function")
    lf = g.sub_el(fn, "LinearFunction", name="function")
    g.sub_el(lf, "coefficients", "1 0")
    g.sub_el(cons, "groups")
    g.write(ET.ElementTree(doc), os.path.join(OUT, "machine_leg_press.osim"))


def write_contacts(points, seat_origin, edge, back_normal, recline):
    doc = ET.Element("OpenSimDocument", Version="40000")
    doc.append(
        ET.Comment(
            " The 16 point-on-plane contacts of the seated leg press with human_seated_rajagopal.osim: per side the heel and "
            "the forefoot on the footplate (sled), the ischial tuberosity (pelvis) on the seat, "
            "the sacrum (pelvis), the lumbar region and the scapula (torso) on the backrest, and the hand on its handle (two "
            "opposing contacts). Points on the human, planes on the machine, normals from the plane towards the human. "
            "Generated by scripts/make_leg_press_models.py. "
        )
    )
    fs = g.sub_el(doc, "ForceSet", name="leg_press_contacts")
    objs = g.sub_el(fs, "objects")

    def contact(name, body, local, plane_body, origin, normal, props):
        e = g.sub_el(objs, "PointOnPlaneContact", name=name)
        g.sub_el(e, "point_body", body)
        g.sub_el(e, "point_location", g.fmt(local))
        g.sub_el(e, "plane_body", plane_body)
        g.sub_el(e, "plane_origin", g.fmt(origin))
        g.sub_el(e, "plane_normal", g.fmt(normal))
        d = dict(props)
        d.update(BASE)
        for k in ("static_friction", "kinetic_friction", "contact_tolerance", "contact_transition_zone", "v_trans", "optimal_force"):
            g.sub_el(e, k, d[k])

    for s in "rl":
        sign = 1.0 if s == "r" else -1.0
        contact(f"heel_{s}", f"calcn_{s}", (HEEL_IN_CALCN[0], HEEL_IN_CALCN[1], sign * HEEL_IN_CALCN[2]), "sled", (0, 0, 0), PLATE_NORMAL_RAIL, SOLE)
        contact(f"forefoot_{s}", f"calcn_{s}", (FOREFOOT_IN_CALCN[0], FOREFOOT_IN_CALCN[1], sign * FOREFOOT_IN_CALCN[2]), "sled", (0, 0, 0), PLATE_NORMAL_RAIL, SOLE)
        b, local, _ = points[f"pelvis_seat_{s}"]
        contact(f"pelvis_seat_{s}", b, local, "seat", (0, 0, 0), (0.0, 1.0, 0.0), PAD)
        for name in ("sacrum", "lumbar", "scapula"):
            b, local, _ = points[f"{name}_backrest_{s}"]
            # backrest frame: x = the normal towards the person (ground's x turned by the recline)
            contact(f"{name}_backrest_{s}", b, local, "backrest", (0, 0, 0), (1.0, 0.0, 0.0), PAD)
        b, local, gp = points[f"hand_grip_{s}"]
        handle = g.sub(gp, seat_origin)
        contact(f"handle_push_{s}", b, local, "seat", handle, (0.0, 1.0, 0.0), GRIP)
        contact(f"handle_hold_{s}", b, local, "seat", handle, (0.0, -1.0, 0.0), GRIP)
    g.sub_el(fs, "groups")
    g.write(ET.ElementTree(doc), os.path.join(OUT, "contacts_leg_press.xml"))


def write_command(slope_hip, c_hip, slope_ankle, c_ankle):
    def f(x):
        return f"{x:.6f}"

    def plus(x):  # the offset of a --link, with its sign
        return f"+{x:.6f}" if x >= 0 else f"-{-x:.6f}"
    links = [
        f"pelvis_tilt=0*knee_angle_r{plus(PELVIS_TILT)}",
        f"lumbar_extension=0*knee_angle_r{plus(LUMBAR_EXTENSION)}",
        f"hip_flexion_r={f(slope_hip)}*knee_angle_r{plus(c_hip)}",
        f"hip_flexion_l={f(slope_hip)}*knee_angle_r{plus(c_hip)}",
        *[
            f"{name}_{side}={f(-SIDEWAYS[name] / (KNEE_START - KNEE_END))}*knee_angle_r{plus(SIDEWAYS[name] * KNEE_START / (KNEE_START - KNEE_END))}"
            for name in ("hip_adduction", "hip_rotation")
            for side in "rl"
        ],
        f"ankle_angle_r={f(slope_ankle)}*knee_angle_r{plus(c_ankle)}",
        f"ankle_angle_l={f(slope_ankle)}*knee_angle_r{plus(c_ankle)}",
    ]
    lines = [
        "#!/bin/sh",
        "# The shipped leg press motion, made by statopt's own motion tool. Written by",
        "# scripts/make_leg_press_models.py (the --link constants, starting values of the solve, follow",
        "# from the machine's dimensions). Run from the repository root after `cargo build --release`.",
        "# One repetition: from near full extension down to the bottom of the press (eccentric), a",
        f"# {HOLD_BOTTOM:g} s pause, and back up (concentric), {DURATION:g} s each way (minimum jerk).",
        "# Each foot is planted on the plate: heel and forefoot keep their place on it (--plant),",
        "# solved together with the sled's slide, the hips (3 each) and the ankles.",
        "set -e",
        "STATOPT=${STATOPT:-target/release/statopt-tool}",
        "$STATOPT motion --setup setups/leg_press_rajagopal.xml \\",
        f"  --coordinate knee_angle_r --also knee_angle_l --from {KNEE_END:g} --to {KNEE_START:g} --duration {DURATION:g} \\",
        f"  --hold-end {HOLD_BOTTOM:g} --return --rate {RATE:g} \\",
    ]
    lines += [f"  --link {l} \\" for l in links]
    lines += [
        "  --plant heel_r=sled_x,hip_flexion_r,hip_adduction_r,hip_rotation_r --plant forefoot_r=ankle_angle_r \\",
        "  --plant heel_l=hip_flexion_l,hip_adduction_l,hip_rotation_l --plant forefoot_l=ankle_angle_l \\",
        "  -o motions/leg_press_rajagopal.mot",
    ]
    path = os.path.join(OUT, "motion_command.sh")
    with open(path, "w") as fh:
        fh.write("\n".join(lines) + "\n")
    os.chmod(path, 0o755)


if __name__ == "__main__":
    main()
