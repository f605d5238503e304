//! Non-muscle scalar actuators: CoordinateActuator, PointActuator and
//! TorqueActuator (opensim-semantics.md §8.3; `OpenSim/Actuators/
//! CoordinateActuator.cpp`, `PointActuator.cpp`, `TorqueActuator.cpp`).
//!
//! Each produces actuation = control × `optimal_force` along a fixed
//! generalized direction; static optimization needs only the generalized
//! force of unit actuation ([`Actuator::add_unit_generalized_force`]).

use nalgebra::{Matrix3, Vector3};

use super::{applies_force, coordinate_property, find_frame};
use crate::dynamics::jacobian::{add_body_torque, add_point_force};
use crate::dynamics::Data;
use crate::error::Result;
use crate::model::Model;
use crate::xml::Element;

#[derive(Debug, Clone, PartialEq)]
pub enum ActuatorKind {
    /// Generalized force on one coordinate.
    Coordinate { coordinate: usize },
    /// A force of unit `direction` at `point` on `body`.
    Point {
        body: usize,
        /// In the body frame, or in ground when `point_is_global`.
        point: Vector3<f64>,
        point_is_global: bool,
        /// Unit vector, in the body frame or in ground when `force_is_global`.
        direction: Vector3<f64>,
        force_is_global: bool,
    },
    /// A torque of unit `axis` on `body_a` and its opposite on `body_b`
    /// (bodies may be ground).
    Torque {
        body_a: usize,
        body_b: usize,
        /// Unit vector, in ground when `torque_is_global`, otherwise in the
        /// frame of body A's base body (an offset frame's rotation already
        /// applied). +axis acts on A and −axis on B, as in OpenSim's
        /// `TorqueActuator::implProduceForces`.
        axis: Vector3<f64>,
        torque_is_global: bool,
    },
}

#[derive(Debug, Clone, PartialEq)]
pub struct Actuator {
    pub name: String,
    /// Element tag, e.g. `CoordinateActuator`.
    pub type_name: String,
    pub kind: ActuatorKind,
    pub optimal_force: f64,
    pub min_control: f64,
    pub max_control: f64,
    pub applies_force: bool,
}

/// Actuator types that exist in OpenSim but are not implemented here; a model
/// using one is refused rather than silently analysed without it.
const UNSUPPORTED_ACTUATORS: &[&str] = &[
    "PointToPointActuator",
    "BodyActuator",
    "McKibbenActuator",
    "ClutchedPathSpring",
    "PathActuator",
    "SpringGeneralizedForceActuator",
];

impl Actuator {
    /// Read an actuator element (4.0 or 3.x spelling). `Ok(None)` for
    /// elements that are not non-muscle actuators (muscles, passive forces, ...).
    pub fn from_xml(el: &Element, model: &Model) -> Result<Option<Actuator>> {
        let kind = match el.name.as_str() {
            "CoordinateActuator" | "ActivationCoordinateActuator" => ActuatorKind::Coordinate {
                coordinate: coordinate_property(el, "coordinate", model)?,
            },
            "PointActuator" => read_point(el, model)?,
            "TorqueActuator" => read_torque(el, model)?,
            n if UNSUPPORTED_ACTUATORS.contains(&n) => {
                return Err(el.error(format!("actuator type {n} is not supported")));
            }
            _ => return Ok(None),
        };
        let optimal_force = el.child_f64_or("optimal_force", 1.0)?;
        if !optimal_force.is_finite() || optimal_force == 0.0 {
            return Err(el.error(format!(
                "optimal_force must be finite and non-zero, found {optimal_force}"
            )));
        }
        let min_control = el.child_f64_or_inf("min_control", f64::NEG_INFINITY)?;
        let max_control = el.child_f64_or_inf("max_control", f64::INFINITY)?;
        if min_control.is_nan() || max_control.is_nan() || min_control > max_control {
            return Err(el.error(format!(
                "min_control ({min_control}) must not exceed max_control ({max_control})"
            )));
        }
        Ok(Some(Actuator {
            name: el.name_attr().to_string(),
            type_name: el.name.to_string(),
            kind,
            optimal_force,
            min_control,
            max_control,
            applies_force: applies_force(el)?,
        }))
    }

    /// What an actuation of 1 applies at the current pose (ground frame).
    fn unit_load(&self, data: &Data) -> UnitLoad {
        match &self.kind {
            ActuatorKind::Coordinate { coordinate } => UnitLoad::Mobility(*coordinate),
            ActuatorKind::Point {
                body,
                point,
                point_is_global,
                direction,
                force_is_global,
            } => UnitLoad::Point {
                body: *body,
                at: if *point_is_global {
                    *point
                } else {
                    data.station_position(*body, point)
                },
                force: if *force_is_global {
                    *direction
                } else {
                    data.rotation[*body] * direction
                },
            },
            ActuatorKind::Torque {
                body_a,
                body_b,
                axis,
                torque_is_global,
            } => UnitLoad::Torque {
                body_a: *body_a,
                body_b: *body_b,
                torque: if *torque_is_global {
                    *axis
                } else {
                    data.rotation[*body_a] * axis
                },
            },
        }
    }

    /// Generalized force produced by actuation = 1 (control × optimal_force
    /// = 1 N or N·m), added to `gen` (length nq). Positions in `data` must be
    /// current ([`crate::dynamics::kinematics::positions`]). A TorqueActuator
    /// applies +axis on body A and −axis on body B, as OpenSim does.
    pub fn add_unit_generalized_force(&self, model: &Model, data: &Data, gen: &mut [f64]) {
        match self.unit_load(data) {
            UnitLoad::Mobility(c) => gen[c] += 1.0,
            UnitLoad::Point { body, at, force } => {
                add_point_force(model, data, body, &at, &force, gen)
            }
            UnitLoad::Torque {
                body_a,
                body_b,
                torque,
            } => {
                add_body_torque(model, data, body_a, &torque, gen);
                add_body_torque(model, data, body_b, &(-torque), gen);
            }
        }
    }

    /// Apply actuation `actuation` (N or N·m) as OpenSim does: a CoordinateActuator
    /// as a generalized (mobility) force on its coordinate (added to `gen`), a
    /// PointActuator as a point force and a TorqueActuator as body torques
    /// (added to `applied`: ground frame, moments about the ground origin).
    /// Positions in `data` must be current. The generalized equivalent is
    /// `actuation ×` [`Self::add_unit_generalized_force`].
    pub fn apply(
        &self,
        data: &Data,
        actuation: f64,
        applied: &mut [crate::dynamics::BodyForce],
        gen: &mut [f64],
    ) {
        use crate::dynamics::BodyForce;
        match self.unit_load(data) {
            UnitLoad::Mobility(c) => gen[c] += actuation,
            UnitLoad::Point { body, at, force } => {
                applied[body].add(&BodyForce::at_point(force * actuation, at))
            }
            UnitLoad::Torque {
                body_a,
                body_b,
                torque,
            } => {
                applied[body_a].add(&BodyForce::torque(torque * actuation));
                applied[body_b].add(&BodyForce::torque(-torque * actuation));
            }
        }
    }

    /// The record label OpenSim's ForceReporter writes (§1.5): the name.
    pub fn record_labels(&self) -> Vec<String> {
        vec![self.name.clone()]
    }
}

/// The load of a unit actuation, in ground.
enum UnitLoad {
    Mobility(usize),
    Point {
        body: usize,
        at: Vector3<f64>,
        force: Vector3<f64>,
    },
    Torque {
        body_a: usize,
        body_b: usize,
        torque: Vector3<f64>,
    },
}

fn unit(el: &Element, prop: &str, default: [f64; 3]) -> Result<Vector3<f64>> {
    let v = el.child_vec3_or(prop, default)?;
    let n = v.norm();
    if !n.is_finite() || n == 0.0 {
        let at = el.child(prop).unwrap_or(el);
        return Err(at.error(format!("<{prop}> must be a finite, non-zero vector")));
    }
    Ok(v / n)
}

fn read_point(el: &Element, model: &Model) -> Result<ActuatorKind> {
    // PointActuator names a body of the BodySet (`extendConnectToModel`).
    let p = el.req("body")?;
    let name = p.text();
    let body = model.body_index(name).filter(|&b| b != 0).ok_or_else(|| {
        p.error(format!(
            "PointActuator '{}': unknown body '{name}'",
            el.name_attr()
        ))
    })?;
    Ok(ActuatorKind::Point {
        body,
        point: el.child_vec3_or("point", [0.0; 3])?,
        point_is_global: el.child_bool_or("point_is_global", false)?,
        direction: unit(el, "direction", [1.0, 0.0, 0.0])?,
        force_is_global: el.child_bool_or("force_is_global", false)?,
    })
}

fn read_torque(el: &Element, model: &Model) -> Result<ActuatorKind> {
    // bodyA / bodyB are physical frames, found as paths or as `bodyset/<name>`.
    let frame = |prop: &str| -> Result<(usize, Matrix3<f64>)> {
        let p = el.req(prop)?;
        let name = p.text();
        if name.is_empty() {
            return Err(p.error(format!(
                "TorqueActuator '{}' has an empty <{prop}>",
                el.name_attr()
            )));
        }
        let f = find_frame(model, name).ok_or_else(|| {
            p.error(format!(
                "TorqueActuator '{}': unknown body or frame '{name}'",
                el.name_attr()
            ))
        })?;
        Ok((f.body, f.transform.rotation))
    };
    let (body_a, r_a) = frame("bodyA")?;
    let (body_b, _) = frame("bodyB")?;
    let torque_is_global = el.child_bool_or("torque_is_global", true)?;
    let axis = unit(el, "axis", [0.0, 0.0, 1.0])?;
    // A body-A-fixed axis is given in frame A; store it in A's base body.
    let axis = if torque_is_global { axis } else { r_a * axis };
    Ok(ActuatorKind::Torque {
        body_a,
        body_b,
        axis,
        torque_is_global,
    })
}
