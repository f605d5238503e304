//! OpenSim's BodyKinematics and PointKinematics of one frame: where bodies'
//! mass centres and a point fixed on a body are, how fast they move and
//! accelerate, from the frame's kinematics (`kinematics::full` at q, u, u̇).
//!
//! As OpenSim 4.6 (`OpenSim/Analyses/BodyKinematics.cpp`, `PointKinematics.cpp`):
//! - a body's row holds its mass centre in ground (`_X`, `_Y`, `_Z`) and its
//!   orientation as body-fixed X-Y-Z Euler angles of its rotation in ground
//!   (`_Ox`, `_Oy`, `_Oz`; Simbody's `convertRotationToBodyFixedXYZ`); in the
//!   velocity and acceleration tables the mass centre's velocity and
//!   acceleration and the body's angular velocity and acceleration, in ground
//!   or, with `express_results_in_body_local_frame`, in the body's frame
//!   (positions always in ground); angles in degrees when `in_degrees`;
//! - `center_of_mass_X/_Y/_Z`: the whole model's mass centre (every body of
//!   the BodySet), always in ground;
//! - a point's position relative to `relative_to_body_name` is its position
//!   in that frame; its velocity and acceleration are the ground ones
//!   re-expressed in that frame (not the velocity relative to the frame).
//!
//! Accelerations are the motion's: the body accelerations of u̇ (the
//! frame's `data.udot`). OpenSim 4.6's AnalyzeTool instead realises forward
//! dynamics of the model's forces with the muscle states at their defaults
//! (docs/kinematics_analyses.md).

use nalgebra::{Matrix3, Rotation3, Vector3};

use super::Data;
use crate::error::{Error, Result};
use crate::model::{Model, Transform};
use crate::parse::kinematics::{BodyKinematicsSetup, PointKinematicsSetup, CENTER_OF_MASS};

/// Body-fixed X-Y-Z Euler angles (radians) of the rotation `r`:
/// r = Rx(a)·Ry(b)·Rz(c) (`model::body_fixed_xyz`'s inverse; b in
/// [−π/2, π/2]).
pub fn body_fixed_xyz_angles(r: &Matrix3<f64>) -> Vector3<f64> {
    let rot = Rotation3::from_matrix_unchecked(*r);
    let (angles, _) = rot.euler_angles_ordered(
        [Vector3::x_axis(), Vector3::y_axis(), Vector3::z_axis()],
        false,
    );
    Vector3::from(angles)
}

/// The bodies a BodyKinematics analysis records, resolved on a model.
#[derive(Debug, Clone)]
pub struct BodySelection {
    /// Model indices of the recorded bodies, in OpenSim's order (`all`: the
    /// BodySet's; else as listed).
    pub bodies: Vec<usize>,
    /// Whether the whole model's centre of mass is recorded.
    pub center_of_mass: bool,
    /// Every body of the BodySet, for the centre of mass.
    every_body: Vec<usize>,
    total_mass: f64,
    pub in_degrees: bool,
    /// Velocities and accelerations in the bodies' frames.
    pub body_frame: bool,
}

impl BodySelection {
    /// Resolve `setup`'s `<bodies>` on `model`, whose BodySet holds the
    /// bodies `body_set` (model indices, in the file's order). A name that
    /// is not a body of the BodySet is an error at `<bodies>` (OpenSim:
    /// "Could not find body named").
    pub fn compile(model: &Model, body_set: &[usize], setup: &BodyKinematicsSetup) -> Result<Self> {
        let at = setup.element.child("bodies").unwrap_or(&setup.element);
        let mut bodies = Vec::new();
        let mut center_of_mass = false;
        for name in &setup.bodies {
            if name == "all" {
                bodies = body_set.to_vec();
                center_of_mass = true;
                break;
            }
            if name == CENTER_OF_MASS {
                center_of_mass = true;
                continue;
            }
            match body_set.iter().find(|&&b| model.bodies[b].name == *name) {
                Some(&b) => bodies.push(b),
                None => {
                    let mut known: Vec<&str> = body_set
                        .iter()
                        .map(|&b| model.bodies[b].name.as_str())
                        .collect();
                    known.extend(["all", CENTER_OF_MASS]);
                    let ground = if model.bodies[0].name == *name {
                        " (ground is not a body of the BodySet; OpenSim refuses it too)"
                    } else {
                        ""
                    };
                    return Err(at.error(format!(
                        "{}: no body named '{name}' in the model {}{ground}; {}",
                        setup.common.name,
                        model.file.display(),
                        crate::parse::known::suggestion(name, &known)
                    )));
                }
            }
        }
        let total_mass = body_set.iter().map(|&b| model.bodies[b].mass).sum::<f64>();
        if center_of_mass && total_mass <= 0.0 {
            return Err(at.error(format!(
                "{}: the model's bodies have no mass, so it has no centre of mass to record",
                setup.common.name
            )));
        }
        Ok(BodySelection {
            bodies,
            center_of_mass,
            every_body: body_set.to_vec(),
            total_mass,
            in_degrees: setup.common.in_degrees,
            body_frame: setup.express_in_body_frame,
        })
    }

    /// The tables' column labels (without time): `<body>_X, _Y, _Z, _Ox,
    /// _Oy, _Oz` per body, then `center_of_mass_X, _Y, _Z`.
    pub fn labels(&self, model: &Model) -> Vec<String> {
        let mut out = Vec::new();
        for &b in &self.bodies {
            for s in ["X", "Y", "Z", "Ox", "Oy", "Oz"] {
                out.push(format!("{}_{s}", model.bodies[b].name));
            }
        }
        if self.center_of_mass {
            for s in ["X", "Y", "Z"] {
                out.push(format!("{CENTER_OF_MASS}_{s}"));
            }
        }
        out
    }

    /// One frame's rows of the position, velocity and acceleration tables
    /// (`data` after `kinematics::full`), each cleared and filled in the
    /// order of [`BodySelection::labels`].
    pub fn rows(
        &self,
        model: &Model,
        data: &Data,
        pos: &mut Vec<f64>,
        vel: &mut Vec<f64>,
        acc: &mut Vec<f64>,
    ) {
        let k = if self.in_degrees {
            180.0 / std::f64::consts::PI
        } else {
            1.0
        };
        pos.clear();
        vel.clear();
        acc.clear();
        for &b in &self.bodies {
            let c = &model.bodies[b].mass_center;
            let r = &data.rotation[b];
            // In the body's frame when asked: Rᵀ v.
            let frame = |v: Vector3<f64>| {
                if self.body_frame {
                    r.transpose() * v
                } else {
                    v
                }
            };
            pos.extend(data.station_position(b, c).iter());
            pos.extend((body_fixed_xyz_angles(r) * k).iter());
            vel.extend(frame(data.station_velocity(b, c)).iter());
            vel.extend((frame(data.omega[b]) * k).iter());
            acc.extend(frame(data.station_acceleration(b, c)).iter());
            acc.extend((frame(data.alpha[b]) * k).iter());
        }
        if self.center_of_mass {
            let (mut p, mut v, mut a) = (Vector3::zeros(), Vector3::zeros(), Vector3::zeros());
            for &b in &self.every_body {
                let (m, c) = (model.bodies[b].mass, &model.bodies[b].mass_center);
                p += m * data.station_position(b, c);
                v += m * data.station_velocity(b, c);
                a += m * data.station_acceleration(b, c);
            }
            pos.extend((p / self.total_mass).iter());
            vel.extend((v / self.total_mass).iter());
            acc.extend((a / self.total_mass).iter());
        }
    }
}

/// A physical frame of the model by name or path (`ground`, a body, an
/// offset frame; a bare body name also as `/bodyset/<name>`, as OpenSim's
/// PointKinematics looks it up): its body and its pose in that body.
fn physical_frame(model: &Model, name: &str) -> Option<(usize, Transform)> {
    model
        .frame(name)
        .or_else(|| model.frame(&format!("/bodyset/{name}")))
        .map(|f| (f.body, f.transform))
}

/// The point a PointKinematics analysis records, resolved on a model.
#[derive(Debug, Clone)]
pub struct PointSelection {
    /// The body the point is fixed on and the point in that body's frame.
    pub body: usize,
    pub station: Vector3<f64>,
    /// `relative_to_body_name`: its body and its pose in that body.
    pub relative_to: Option<(usize, Transform)>,
    /// The column labels: OpenSim 4.6's, `state_0, state_1, state_2` (the
    /// X, Y and Z of the point; OpenSim labels PointKinematics' tables
    /// before the point is known, and statopt writes what OpenSim writes so
    /// that its tables load where OpenSim's do).
    pub labels: Vec<String>,
}

impl PointSelection {
    /// Resolve `setup`'s `<body_name>` and `<relative_to_body_name>` on
    /// `model`. A name that is no frame of the model is an error at its
    /// element (OpenSim 4.6 crashes on an unknown `body_name` and silently
    /// ignores an unknown `relative_to_body_name`).
    pub fn compile(model: &Model, setup: &PointKinematicsSetup) -> Result<Self> {
        let resolve = |property: &str, name: &str| -> Result<(usize, Transform)> {
            physical_frame(model, name).ok_or_else(|| {
                let at = setup.element.child(property).unwrap_or(&setup.element);
                let mut known: Vec<&str> = model.bodies.iter().map(|b| b.name.as_str()).collect();
                if property == "relative_to_body_name" {
                    known.push("none");
                }
                at.error(format!(
                    "{}: no body or frame named '{name}' in the model {}; {}",
                    setup.common.name,
                    model.file.display(),
                    crate::parse::known::suggestion(name, &known)
                ))
            })
        };
        let (body, x) = resolve("body_name", &setup.body_name)?;
        let relative_to = match &setup.relative_to {
            Some(name) => Some(resolve("relative_to_body_name", name)?),
            None => None,
        };
        Ok(PointSelection {
            body,
            station: x.apply(&setup.point),
            relative_to,
            labels: (0..3).map(|i| format!("state_{i}")).collect(),
        })
    }

    /// One frame's position, velocity and acceleration of the point
    /// (`data` after `kinematics::full`).
    pub fn rows(&self, data: &Data) -> [Vector3<f64>; 3] {
        let (b, s) = (self.body, &self.station);
        let (p, v, a) = (
            data.station_position(b, s),
            data.station_velocity(b, s),
            data.station_acceleration(b, s),
        );
        match &self.relative_to {
            None => [p, v, a],
            Some((f, x)) => {
                // The frame's orientation and origin in ground.
                let r = data.rotation[*f] * x.rotation;
                let o = data.station_position(*f, &x.translation);
                let rt = r.transpose();
                [rt * (p - o), rt * v, rt * a]
            }
        }
    }
}

/// The BodySet's bodies as model indices, in the order of `names` (the
/// model document's BodySet, `ModelSpec::bodies`).
pub fn body_set<'a>(model: &Model, names: impl IntoIterator<Item = &'a str>) -> Result<Vec<usize>> {
    names
        .into_iter()
        .map(|n| {
            model.body_index(n).ok_or_else(|| {
                Error::internal(format!(
                    "the BodySet's body '{n}' is not in the compiled model"
                ))
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn euler_angles_invert_body_fixed_xyz() {
        for a in [
            Vector3::new(0.3, -0.4, 1.2),
            Vector3::new(-2.5, 1.1, -3.0),
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(3.0, -1.5, 0.2),
        ] {
            let r = crate::model::body_fixed_xyz(&a);
            let back = body_fixed_xyz_angles(&r);
            assert!(
                (crate::model::body_fixed_xyz(&back) - r).norm() < 1e-12,
                "{a:?} -> {back:?}"
            );
            assert!((back - a).norm() < 1e-12, "{a:?} -> {back:?}");
        }
    }
}
