//! Ground reactions per foot (predict-grf; docs/grf_prediction.md): the
//! foot contacts' forces summed per foot from the table a static-optimization
//! run wrote, the measured plates' loads assigned to the feet, and which
//! frames have no foot within reach of the floor.

use nalgebra::Vector3;

use crate::contacts::feet::FootContactSet;
use crate::dynamics::{kinematics, Data};
use crate::error::{Error, Result};
use crate::forces::external_loads::ExternalLoads;
use crate::storage;

/// Per frame and foot: force on the foot (N, ground), centre of pressure
/// on the floor (m) and free moment about the floor normal (N·m).
#[derive(Debug, Clone, Default)]
pub struct FootLoads {
    pub time: Vec<f64>,
    /// `[side][frame]`, side 0 right, 1 left.
    pub force: [Vec<Vector3<f64>>; 2],
    pub cop: [Vec<Vector3<f64>>; 2],
    pub free_moment: [Vec<f64>; 2],
}

/// Per row of the contacts' table (`..._ContactForces.sto`): whether every
/// foot point is farther from its floor plane than the contact band
/// (d_tol + d_trans), where its weight w(d) is nil: nothing can touch.
pub fn flight_frames(path: &std::path::Path, set: &FootContactSet) -> Result<Vec<bool>> {
    let table = storage::read(path)?;
    let reach = set.parameters.contact_tolerance + set.parameters.transition_zone;
    let cols: Vec<usize> = set
        .points
        .iter()
        .map(|p| {
            table
                .column_index(&format!("{}_distance", p.name))
                .ok_or_else(|| {
                    Error::internal(format!("{}: no column {}_distance", path.display(), p.name))
                })
        })
        .collect::<Result<_>>()?;
    Ok(table
        .rows
        .iter()
        .map(|r| cols.iter().all(|&c| r[c] > reach))
        .collect())
}

/// Per-foot loads from the contact forces a static-optimization run wrote
/// (`..._ContactExternalLoads.mot`: each contact's force on its point body
/// at the point).
pub fn foot_loads_from_contacts(path: &std::path::Path, set: &FootContactSet) -> Result<FootLoads> {
    let table = storage::read(path)?;
    let col = |name: &str| {
        table
            .column_index(name)
            .ok_or_else(|| Error::internal(format!("{}: no column {name}", path.display())))
    };
    let mut out = FootLoads {
        time: table.time.clone(),
        ..Default::default()
    };
    let mut idx: [Vec<([usize; 6], &crate::contacts::feet::FootPoint)>; 2] =
        [Vec::new(), Vec::new()];
    for p in &set.points {
        let s = usize::from(p.side == 'l');
        let mut c = [0usize; 6];
        for (k, suffix) in ["vx", "vy", "vz", "px", "py", "pz"].iter().enumerate() {
            c[k] = col(&format!("{}_point_force_{suffix}", p.name))?;
        }
        idx[s].push((c, p));
    }
    for row in &table.rows {
        for s in 0..2 {
            let mut f = Vector3::zeros();
            let mut moment_y = 0.0;
            let mut weighted = Vector3::zeros();
            for (c, p) in &idx[s] {
                let fi = Vector3::new(row[c[0]], row[c[1]], row[c[2]]);
                // The point's projection on its floor plane (level through
                // its dwell position, the floor's slope).
                let (x, z) = (row[c[3]], row[c[5]]);
                let y = set.floor_height_under(p, x, z);
                let pi = Vector3::new(x, y, z);
                f += fi;
                weighted += pi * fi.y;
                // Moment about the vertical through the origin of the floor.
                moment_y += pi.z * fi.x - pi.x * fi.z;
            }
            let cop = if f.y.abs() > 1e-9 {
                weighted / f.y
            } else {
                Vector3::new(f64::NAN, set.floor_height, f64::NAN)
            };
            // Free moment: the vertical moment left about the COP.
            let free = if f.y.abs() > 1e-9 {
                moment_y - (cop.z * f.x - cop.x * f.z)
            } else {
                0.0
            };
            out.force[s].push(f);
            out.cop[s].push(cop);
            out.free_moment[s].push(free);
        }
    }
    Ok(out)
}

/// Pose `data` at time `t`: the row of `states` at `t` (to 1e-9 s), else the
/// row `find_index` picks, and its full kinematics.
pub fn pose_at(
    model: &crate::model::Model,
    states: &crate::motion::states::States,
    t: f64,
    data: &mut Data,
) {
    let i = states
        .time
        .iter()
        .position(|&s| (s - t).abs() < 1e-9)
        .unwrap_or_else(|| crate::motion::coordinates::find_index(&states.time, t));
    data.q.copy_from_slice(&states.q[i]);
    data.u.copy_from_slice(&states.u[i]);
    kinematics::full(model, data);
}

/// The measured loads per foot at `times`: each ExternalForce is assigned
/// to the foot of the body it is applied to (`*_r` or `*_l`).
pub fn measured_foot_loads(
    loads: &ExternalLoads,
    model: &crate::model::Model,
    states: &crate::motion::states::States,
    times: &[f64],
) -> Result<FootLoads> {
    let mut data = Data::new(model);
    let mut out = FootLoads {
        time: times.to_vec(),
        ..Default::default()
    };
    for &t in times {
        pose_at(model, states, t, &mut data);
        let mut plates = Vec::with_capacity(loads.forces.len());
        for ef in &loads.forces {
            let name = &model.bodies[ef.applied_to_body].name;
            let s = usize::from(name.ends_with("_l"));
            let (fe, pe, _) = ef.evaluate(t, &data)?;
            plates.push((s, fe, pe));
        }
        let (f, cop) = per_foot(&plates);
        for s in 0..2 {
            out.force[s].push(f[s]);
            out.cop[s].push(cop[s]);
            out.free_moment[s].push(0.0);
        }
    }
    Ok(out)
}

/// Per frame of `times`: every plate of `loads` (the foot of its body,
/// force and centre of pressure, ground) and the ground positions of each
/// foot's contact `points`, for [`crate::contacts::plates::misplaced_steps`].
#[allow(clippy::type_complexity)]
pub fn plate_samples(
    loads: &ExternalLoads,
    model: &crate::model::Model,
    states: &crate::motion::states::States,
    times: &[f64],
    points: &[crate::contacts::feet::FootPoint],
) -> Result<(
    Vec<Vec<crate::contacts::plates::PlateSample>>,
    Vec<[Vec<Vector3<f64>>; 2]>,
)> {
    let mut data = Data::new(model);
    let (mut plates, mut feet) = (
        Vec::with_capacity(times.len()),
        Vec::with_capacity(times.len()),
    );
    for &t in times {
        pose_at(model, states, t, &mut data);
        let mut row = Vec::with_capacity(loads.forces.len());
        for ef in &loads.forces {
            let name = &model.bodies[ef.applied_to_body].name;
            let (force, cop, _) = ef.evaluate(t, &data)?;
            row.push(crate::contacts::plates::PlateSample {
                foot: usize::from(name.ends_with("_l")),
                force,
                cop,
            });
        }
        plates.push(row);
        let mut f: [Vec<Vector3<f64>>; 2] = [Vec::new(), Vec::new()];
        for p in points {
            f[usize::from(p.side == 'l')].push(data.station_position(p.body, &p.local));
        }
        feet.push(f);
    }
    Ok((plates, feet))
}

/// `loads` at the frames where `kept` is true.
pub fn keep_frames(loads: &FootLoads, kept: &[bool]) -> FootLoads {
    let pick = |v: &[Vector3<f64>]| -> Vec<Vector3<f64>> {
        v.iter()
            .zip(kept)
            .filter(|(_, k)| **k)
            .map(|(x, _)| *x)
            .collect()
    };
    FootLoads {
        time: loads
            .time
            .iter()
            .zip(kept)
            .filter(|(_, k)| **k)
            .map(|(t, _)| *t)
            .collect(),
        force: [pick(&loads.force[0]), pick(&loads.force[1])],
        cop: [pick(&loads.cop[0]), pick(&loads.cop[1])],
        free_moment: [0, 1].map(|s| {
            loads.free_moment[s]
                .iter()
                .zip(kept)
                .filter(|(_, k)| **k)
                .map(|(x, _)| *x)
                .collect()
        }),
    }
}

/// Plates (foot 0 right / 1 left, force, centre of pressure; ground) summed
/// per foot: the forces added, the centres of pressure weighted by the
/// plates' vertical forces (NaN without vertical force).
pub fn per_foot(
    plates: &[(usize, Vector3<f64>, Vector3<f64>)],
) -> ([Vector3<f64>; 2], [Vector3<f64>; 2]) {
    let mut f = [Vector3::zeros(); 2];
    let mut weighted = [Vector3::zeros(); 2];
    let mut fy = [0.0; 2];
    for &(s, fe, pe) in plates {
        f[s] += fe;
        if pe.iter().all(|x| x.is_finite()) && fe.y.abs() > 1e-9 {
            weighted[s] += pe * fe.y;
            fy[s] += fe.y;
        }
    }
    let cop = [0, 1].map(|s| {
        if fy[s].abs() > 1e-9 {
            weighted[s] / fy[s]
        } else {
            Vector3::repeat(f64::NAN)
        }
    });
    (f, cop)
}
/// w0 of foot contacts (predict-grf) when the setup's StaticOptimization
/// gives none. A parameter of its own, not the plan's default w0
/// (`parse::analyses::DEFAULT_CONTACT_WEIGHT` = 1000, for contacts a user
/// writes into a model, after Krüger & Wartzack):
/// with the foot contacts' optimal force of 100 N, a body weight spread over
/// a dozen points costs about as much as the muscles' activations, so the
/// contacts' weight w(d) and their sum of squares shape the split between
/// the feet (with w0 = 1000 contacts are almost free and the optimiser
/// squeezes the feet against each other in double support; see
/// docs/grf_prediction.md).
pub const FOOT_CONTACT_WEIGHT: f64 = 10.0;

/// The strength of the muscles of the models [`FOOT_CONTACT_WEIGHT`]
/// was chosen on, per coordinate (N·m per unit of control): the size of the
/// generalized forces their muscles make at full activation,
/// sqrt(Σ (r_i F_max,i)²), over the lower limb's ten coordinates of the
/// Rajagopal model (moco_walk3d, OpenSim's moment arms over the trial):
/// 57 (hip rotation) to 354 N·m (ankle), geometric mean 188, rounded to 200.
pub const MUSCLE_STRENGTH_REFERENCE: f64 = 200.0;

/// A model whose joints are carried by coordinate actuators only (no
/// muscles: torque-driven, reserves only): the geometric mean over its
/// unconstrained coordinates but the root's of the actuators' strength
/// per coordinate, sqrt(Σ F_opt²) (N·m or N per unit of control; the
/// setup's reserves included). None when the model has muscles, or no such
/// actuator.
///
/// The objective weighs an actuator's generalized force τ as (τ/S)² and a
/// contact force f as (f/F0)²/w0: to keep the balance between the feet and
/// the joints that w0 was chosen with on muscle-driven models, a model
/// whose actuators are k times weaker gets w0/k² (see
/// docs/grf_prediction.md).
pub fn torque_driven_strength(
    forces: &[crate::xml::Element],
    model: &crate::model::Model,
    reserves: Option<f64>,
) -> Option<f64> {
    if forces.iter().any(|f| f.name.contains("Muscle")) {
        return None;
    }
    let mut sum2 = vec![0.0; model.nq()];
    for f in forces.iter().filter(|f| f.name == "CoordinateActuator") {
        let applies = f
            .child_text("appliesForce")
            .map(|t| t.trim() != "false")
            .unwrap_or(true);
        let coordinate = f.child_text("coordinate").unwrap_or("").trim();
        let fo: f64 = f
            .child_text("optimal_force")
            .and_then(|t| t.trim().parse().ok())
            .unwrap_or(1.0);
        if let (true, Some(c)) = (applies, model.coordinate_index(coordinate)) {
            sum2[c] += fo * fo;
        }
    }
    let (mut log_sum, mut n) = (0.0, 0usize);
    for c in 0..model.nq() {
        if model.coordinates[c].is_constrained() || model.is_root_coordinate(c) {
            continue;
        }
        let s2 = sum2[c] + reserves.map_or(0.0, |r| r * r);
        if s2 > 0.0 {
            log_sum += 0.5 * s2.ln();
            n += 1;
        }
    }
    (n > 0).then(|| (log_sum / n as f64).exp())
}

/// Peak tension of the plantar aponeurosis in walking, as a share of body
/// weight: 96 % BW in late stance (Erdemir et al. 2004, J Bone Joint Surg
/// Am 86:546, cadaver feet loaded through a simulated stance).
pub const PLANTAR_APONEUROSIS_PEAK_BW: f64 = 0.96;

/// Moment arm of the plantar aponeurosis about the metatarsophalangeal
/// joints (m): it wraps the metatarsal heads, of about 1 cm radius (the
/// windlass, Hicks 1954, J Anat 88:25).
pub const PLANTAR_APONEUROSIS_MOMENT_ARM: f64 = 0.01;

/// The toe (metatarsophalangeal) coordinates of `model` that nothing but
/// muscles drives: unconstrained coordinates of the joints whose child is a
/// `toes_r`/`toes_l` body, with no `CoordinateActuator` of `forces` on them
/// and no reserves (`reserves` None). In pre-swing a foot rolls over its
/// toes, and the moment about those joints is carried mostly by the plantar
/// aponeurosis, tensed by the toes' dorsiflexion (the windlass, Hicks
/// 1954), which these models lack; with the toe flexors alone, a force on
/// the toes must pass close to the joint's axis, so the trailing foot's toe
/// brakes at its friction cone's edge where the plates show it pushing
/// (docs/grf_prediction.md, step 5).
pub fn undriven_toe_coordinates(
    forces: &[crate::xml::Element],
    model: &crate::model::Model,
    reserves: Option<f64>,
) -> Vec<usize> {
    if reserves.is_some() {
        return Vec::new();
    }
    (0..model.nq())
        .filter(|&c| {
            let co = &model.coordinates[c];
            let body = model.bodies[co.body].name.as_str();
            !co.is_constrained()
                && (body == "toes_r" || body == "toes_l")
                && !forces.iter().any(|f| {
                    f.name == "CoordinateActuator"
                        && f.child_text("coordinate").map(str::trim) == Some(co.name.as_str())
                })
        })
        .collect()
}

/// The optimal force (N m) of the actuator that stands for the plantar
/// aponeurosis on each toe coordinate ([`undriven_toe_coordinates`]): its
/// peak tension times its moment arm, 0.96 BW x 1 cm (7.1 N m at 75 kg), so
/// that the aponeurosis at its walking peak costs what a muscle at full
/// activation costs.
pub fn plantar_aponeurosis_strength(model: &crate::model::Model) -> f64 {
    PLANTAR_APONEUROSIS_PEAK_BW
        * model.total_mass()
        * model.gravity.norm()
        * PLANTAR_APONEUROSIS_MOMENT_ARM
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A foot of two bodies per side on pin joints: `calcn_s` on `ankle_s`
    /// from ground, `toes_s` on `mtp_angle_s` from it; the left toe joint
    /// locked. Bodies of 2 kg (8 kg in all).
    fn feet_model() -> crate::model::Model {
        let body = |n: &str| {
            format!(
                r#"<Body name="{n}"><mass>2</mass><mass_center>0 0 0</mass_center><inertia>1 1 1 0 0 0</inertia></Body>"#
            )
        };
        let pin = |j: &str, parent: &str, child: &str, c: &str, locked: bool| {
            format!(
                r#"<PinJoint name="{j}"><socket_parent_frame>{parent}</socket_parent_frame><socket_child_frame>{child}</socket_child_frame><coordinates><Coordinate name="{c}"><locked>{locked}</locked></Coordinate></coordinates></PinJoint>"#
            )
        };
        let text = format!(
            r#"<?xml version="1.0"?>
<OpenSimDocument Version="40000"><Model name="feet">
<BodySet name="bodyset"><objects>{}{}{}{}</objects></BodySet>
<JointSet name="jointset"><objects>{}{}{}{}</objects></JointSet>
</Model></OpenSimDocument>"#,
            body("calcn_r"),
            body("toes_r"),
            body("calcn_l"),
            body("toes_l"),
            pin("ankle_r", "/ground", "/bodyset/calcn_r", "ankle_r", false),
            pin(
                "mtp_r",
                "/bodyset/calcn_r",
                "/bodyset/toes_r",
                "mtp_angle_r",
                false
            ),
            pin("ankle_l", "/ground", "/bodyset/calcn_l", "ankle_l", false),
            pin(
                "mtp_l",
                "/bodyset/calcn_l",
                "/bodyset/toes_l",
                "mtp_angle_l",
                true
            ),
        );
        let path = std::path::Path::new("feet.osim");
        let root = crate::xml::parse_str(&text, path).unwrap();
        crate::model::compile(&crate::parse::osim::ModelSpec::from_document(&root, path).unwrap())
            .unwrap_or_else(|e| panic!("{e}"))
    }

    /// The plantar aponeurosis goes on a free toe joint that nothing but
    /// muscles drives: not on a locked one, not where reserves or a
    /// coordinate actuator drive it; 0.96 BW x 1 cm.
    #[test]
    fn the_plantar_aponeurosis_goes_on_free_undriven_toe_joints() {
        let model = feet_model();
        let name = |v: Vec<usize>| -> Vec<String> {
            v.into_iter()
                .map(|c| model.coordinates[c].name.clone())
                .collect()
        };
        assert_eq!(
            name(undriven_toe_coordinates(&[], &model, None)),
            vec!["mtp_angle_r"]
        );
        assert!(undriven_toe_coordinates(&[], &model, Some(10.0)).is_empty());
        let path = std::path::Path::new("forces.xml");
        let act = crate::xml::parse_str(
            "<CoordinateActuator name=\"a\"><coordinate> mtp_angle_r </coordinate><optimal_force>5</optimal_force></CoordinateActuator>",
            path,
        )
        .unwrap();
        assert!(undriven_toe_coordinates(&[act], &model, None).is_empty());
        let other = crate::xml::parse_str(
            "<CoordinateActuator name=\"b\"><coordinate>ankle_r</coordinate></CoordinateActuator>",
            path,
        )
        .unwrap();
        assert_eq!(
            name(undriven_toe_coordinates(&[other], &model, None)),
            vec!["mtp_angle_r"]
        );
        let s = plantar_aponeurosis_strength(&model);
        let expected = 0.96 * 8.0 * model.gravity.norm() * 0.01;
        assert!((s - expected).abs() < 1e-12, "{s} against {expected}");
    }

    /// Two plates under the right foot, one under the left: the foot's
    /// force is their sum and its centre of pressure the plates' weighted
    /// by their vertical forces (it was the last plate's).
    #[test]
    fn plates_under_one_foot_are_combined() {
        let plates = [
            (
                0,
                Vector3::new(10.0, 300.0, 0.0),
                Vector3::new(0.0, 0.0, 0.1),
            ),
            (
                0,
                Vector3::new(5.0, 100.0, 0.0),
                Vector3::new(0.4, 0.0, 0.1),
            ),
            (1, Vector3::new(0.0, 0.0, 0.0), Vector3::new(9.0, 0.0, 9.0)),
        ];
        let (f, cop) = per_foot(&plates);
        assert_eq!(f[0], Vector3::new(15.0, 400.0, 0.0));
        assert!(
            (cop[0] - Vector3::new(0.1, 0.0, 0.1)).norm() < 1e-12,
            "{cop:?}"
        );
        assert!(cop[1].x.is_nan(), "no load: no centre of pressure");
    }
}
