//! Passive (state-dependent, non-actuator) force elements: CoordinateLimitForce
//! (opensim-semantics.md §8.4), ExpressionBasedCoordinateForce (§8.2),
//! SpringGeneralizedForce and PointToPointSpring
//! (`OpenSim/Simulation/Model/CoordinateLimitForce.cpp`,
//! `ExpressionBasedCoordinateForce.cpp`, `OpenSim/Actuators/
//! SpringGeneralizedForce.cpp`, `OpenSim/Simulation/Model/PointToPointSpring.cpp`).
//!
//! In static optimization these enter the known part of the accelerations
//! (§6.4) and the force file (§1.5).

use nalgebra::Vector3;

use super::lepton::Expression;
use super::{applies_force, coordinate_property, find_frame};
use crate::dynamics::jacobian::add_point_force;
use crate::dynamics::Data;
use crate::error::Result;
use crate::model::{Model, MotionType};
use crate::xml::Element;

#[derive(Debug, Clone)]
pub enum PassiveForce {
    /// Smoothly engaging stiffness and damping beyond coordinate limits,
    /// stored in internal units (rad or m): q_up, q_lo, K_up, K_lo, d, Δ of §8.4.
    CoordinateLimit {
        name: String,
        coordinate: usize,
        q_up: f64,
        q_lo: f64,
        k_up: f64,
        k_lo: f64,
        damping: f64,
        transition: f64,
    },
    /// Generalized force f(q, q̇) from a Lepton expression.
    ExpressionBasedCoordinate {
        name: String,
        coordinate: usize,
        expr: Box<Expression>,
    },
    /// τ = −stiffness·(q − rest_length) − viscosity·q̇.
    SpringGeneralized {
        name: String,
        coordinate: usize,
        stiffness: f64,
        rest_length: f64,
        viscosity: f64,
    },
    /// Linear spring between two body-fixed points (Simbody TwoPointLinearSpring).
    PointToPointSpring {
        name: String,
        body1: usize,
        point1: Vector3<f64>,
        body2: usize,
        point2: Vector3<f64>,
        stiffness: f64,
        rest_length: f64,
        /// Frame names used in the record labels.
        frame_names: [String; 2],
    },
}

/// Force types that change dynamics but are not implemented here; refused
/// rather than silently dropped. (Contact forces are left to the contact
/// model's reader.)
const UNSUPPORTED_FORCES: &[&str] = &[
    "BushingForce",
    "FunctionBasedBushingForce",
    "ExpressionBasedBushingForce",
    "ExpressionBasedPointToPointForce",
    "PrescribedForce",
    "Ligament",
    "Blankevoort1991Ligament",
    "RotationalCoordinateLimitForce",
];

/// Simbody's `Function::Step`: y0 for x at or before x0, y1 at or beyond x1,
/// y0 + (y1 − y0)·t³(10 − 15t + 6t²) between, t = (x − x0)/(x1 − x0).
/// What a passive force applies at one state (ground frame).
enum PassiveLoad {
    /// A generalized force on a coordinate.
    Mobility(usize, f64),
    /// `force` on body1 at p1 and its opposite on body2 at p2.
    Pair {
        body1: usize,
        p1: Vector3<f64>,
        body2: usize,
        p2: Vector3<f64>,
        force: Vector3<f64>,
    },
}

pub fn smooth_step(x: f64, y0: f64, y1: f64, x0: f64, x1: f64) -> f64 {
    let t = (x - x0) / (x1 - x0);
    if t <= 0.0 {
        y0
    } else if t >= 1.0 {
        y1
    } else {
        y0 + (y1 - y0) * t * t * t * (10.0 + t * (-15.0 + 6.0 * t))
    }
}

impl PassiveForce {
    /// Read a passive force element. `Ok(None)` for elements of other kinds
    /// (muscles, actuators, contact) and for forces with `appliesForce`
    /// false (`isDisabled` true in 3.x), which have no effect and are not
    /// reported; such elements are still checked.
    pub fn from_xml(el: &Element, model: &Model) -> Result<Option<PassiveForce>> {
        let name = el.name_attr().to_string();
        let force = match el.name.as_str() {
            "CoordinateLimitForce" => read_limit(el, model, name)?,
            "ExpressionBasedCoordinateForce" => {
                let coordinate = coordinate_property(el, "coordinate", model)?;
                let text = el
                    .child("expression")
                    .map(|e| e.text.as_str())
                    .unwrap_or("0.0");
                let at = el.child("expression").unwrap_or(el);
                let expr = Expression::compile(text).map_err(|m| {
                    at.error(format!(
                        "ExpressionBasedCoordinateForce '{name}': expression: {m}"
                    ))
                })?;
                let name = if name.is_empty() {
                    format!(
                        "expressionCoordForce_{}",
                        model.coordinates[coordinate].name
                    )
                } else {
                    name
                };
                PassiveForce::ExpressionBasedCoordinate {
                    name,
                    coordinate,
                    expr: Box::new(expr),
                }
            }
            "SpringGeneralizedForce" => PassiveForce::SpringGeneralized {
                coordinate: coordinate_property(el, "coordinate", model)?,
                stiffness: finite(el, "stiffness", 0.0)?,
                rest_length: finite(el, "rest_length", 0.0)?,
                viscosity: finite(el, "viscosity", 0.0)?,
                name,
            },
            "PointToPointSpring" => read_p2p(el, model, name)?,
            n if UNSUPPORTED_FORCES.contains(&n) => {
                return Err(el.error(format!("force type {n} is not supported")));
            }
            _ => return Ok(None),
        };
        Ok(if applies_force(el)? {
            Some(force)
        } else {
            None
        })
    }

    pub fn name(&self) -> &str {
        match self {
            PassiveForce::CoordinateLimit { name, .. }
            | PassiveForce::ExpressionBasedCoordinate { name, .. }
            | PassiveForce::SpringGeneralized { name, .. }
            | PassiveForce::PointToPointSpring { name, .. } => name,
        }
    }

    /// What the force applies at the state in `data`, and its scalar value.
    fn load(&self, data: &Data) -> (PassiveLoad, f64) {
        match self {
            PassiveForce::PointToPointSpring {
                body1,
                point1,
                body2,
                point2,
                ..
            } => {
                let (force, tension) = self.spring_force(data);
                let load = PassiveLoad::Pair {
                    body1: *body1,
                    p1: data.station_position(*body1, point1),
                    body2: *body2,
                    p2: data.station_position(*body2, point2),
                    force,
                };
                (load, tension)
            }
            _ => {
                let (c, tau) = self.coordinate_force(data);
                (PassiveLoad::Mobility(c, tau), tau)
            }
        }
    }

    /// Add the generalized forces at the state in `data` (q, u; positions
    /// current) and time `t` to `gen`. Returns the force's scalar value: the
    /// generalized force for the coordinate forces (what the ForceReporter
    /// records in the force's own column), the spring tension for
    /// PointToPointSpring.
    pub fn add_generalized_force(
        &self,
        model: &Model,
        data: &Data,
        _t: f64,
        gen: &mut [f64],
    ) -> f64 {
        let (load, value) = self.load(data);
        match load {
            PassiveLoad::Mobility(c, tau) => gen[c] += tau,
            PassiveLoad::Pair {
                body1,
                p1,
                body2,
                p2,
                force,
            } => {
                add_point_force(model, data, body1, &p1, &force, gen);
                add_point_force(model, data, body2, &p2, &(-force), gen);
            }
        }
        value
    }

    /// Apply the force at the state in `data` as OpenSim does: coordinate
    /// forces as generalized (mobility) forces (added to `gen`), a
    /// PointToPointSpring as point forces on its two bodies (added to
    /// `applied`: ground frame, moments about the ground origin). Returns the
    /// same scalar as [`Self::add_generalized_force`].
    pub fn apply(
        &self,
        data: &Data,
        applied: &mut [crate::dynamics::BodyForce],
        gen: &mut [f64],
    ) -> f64 {
        use crate::dynamics::BodyForce;
        let (load, value) = self.load(data);
        match load {
            PassiveLoad::Mobility(c, tau) => gen[c] += tau,
            PassiveLoad::Pair {
                body1,
                p1,
                body2,
                p2,
                force,
            } => {
                applied[body1].add(&BodyForce::at_point(force, p1));
                applied[body2].add(&BodyForce::at_point(-force, p2));
            }
        }
        value
    }

    /// Coordinate index and generalized force of the coordinate forces.
    fn coordinate_force(&self, data: &Data) -> (usize, f64) {
        match self {
            PassiveForce::CoordinateLimit {
                coordinate,
                q_up,
                q_lo,
                k_up,
                k_lo,
                damping,
                transition,
                ..
            } => {
                let (q, qdot) = (data.q[*coordinate], data.u[*coordinate]);
                let ku = smooth_step(q, 0.0, *k_up, *q_up, q_up + transition);
                let kl = smooth_step(q, *k_lo, 0.0, q_lo - transition, *q_lo);
                let f_up = -ku * (q - q_up);
                let f_lo = kl * (q_lo - q);
                let f_damp = -damping * (ku / k_up + kl / k_lo) * qdot;
                (*coordinate, f_up + f_lo + f_damp)
            }
            PassiveForce::ExpressionBasedCoordinate {
                coordinate, expr, ..
            } => (
                *coordinate,
                expr.eval(data.q[*coordinate], data.u[*coordinate]),
            ),
            PassiveForce::SpringGeneralized {
                coordinate,
                stiffness,
                rest_length,
                viscosity,
                ..
            } => {
                let (q, qdot) = (data.q[*coordinate], data.u[*coordinate]);
                (
                    *coordinate,
                    -stiffness * (q - rest_length) - viscosity * qdot,
                )
            }
            PassiveForce::PointToPointSpring { .. } => (0, 0.0),
        }
    }

    /// Force on body 1 (ground frame) and tension of a PointToPointSpring.
    fn spring_force(&self, data: &Data) -> (Vector3<f64>, f64) {
        let PassiveForce::PointToPointSpring {
            body1,
            point1,
            body2,
            point2,
            stiffness,
            rest_length,
            ..
        } = self
        else {
            return (Vector3::zeros(), 0.0);
        };
        let r = data.station_position(*body2, point2) - data.station_position(*body1, point1);
        let d = r.norm();
        if d == 0.0 {
            return (Vector3::zeros(), 0.0);
        }
        let tension = stiffness * (d - rest_length);
        (r * (tension / d), tension)
    }

    /// CoordinateLimitForce's potential energy (`computePotentialEnergy`).
    fn potential_energy(&self, data: &Data) -> f64 {
        let PassiveForce::CoordinateLimit {
            coordinate,
            q_up,
            q_lo,
            k_up,
            k_lo,
            transition,
            ..
        } = self
        else {
            return 0.0;
        };
        let q = data.q[*coordinate];
        let (k, delta) = if q > *q_up {
            (*k_up, q - q_up)
        } else if q < *q_lo {
            (*k_lo, q_lo - q)
        } else {
            return 0.0;
        };
        let tr = *transition;
        if delta >= tr {
            k * ((-2.0 / 14.0) * tr * tr + 0.5 * delta * delta)
        } else {
            let x = delta / tr;
            k * x * x * x * (2.0 - 2.5 * x + (6.0 / 7.0) * x * x) * (delta * delta)
        }
    }

    /// Record labels of OpenSim's ForceReporter (§1.5).
    pub fn record_labels(&self) -> Vec<String> {
        match self {
            PassiveForce::CoordinateLimit { name, .. } => {
                vec![name.clone(), "PotentialEnergy".into()]
            }
            PassiveForce::ExpressionBasedCoordinate { name, .. } => vec![name.clone()],
            PassiveForce::SpringGeneralized { name, .. } => vec![format!("{name}_Force")],
            PassiveForce::PointToPointSpring {
                name, frame_names, ..
            } => {
                let mut v = Vec::with_capacity(12);
                for f in frame_names {
                    for what in ["force", "point"] {
                        for axis in ["X", "Y", "Z"] {
                            v.push(format!("{name}.{f}.{what}.{axis}"));
                        }
                    }
                }
                v
            }
        }
    }

    /// How many record columns the force has ([`Self::record_labels`]'s length).
    pub fn record_size(&self) -> usize {
        match self {
            PassiveForce::CoordinateLimit { .. } => 2,
            PassiveForce::PointToPointSpring { frame_names, .. } => 6 * frame_names.len(),
            PassiveForce::ExpressionBasedCoordinate { .. }
            | PassiveForce::SpringGeneralized { .. } => 1,
        }
    }

    /// Record values matching [`Self::record_labels`], at the state in `data`.
    pub fn record_values(&self, data: &Data, t: f64) -> Vec<f64> {
        let mut v = Vec::with_capacity(self.record_size());
        self.record_values_into(data, t, &mut v);
        v
    }

    /// [`Self::record_values`] appended to `out`.
    pub fn record_values_into(&self, data: &Data, _t: f64, out: &mut Vec<f64>) {
        match self {
            PassiveForce::CoordinateLimit { .. } => {
                out.extend([self.coordinate_force(data).1, self.potential_energy(data)]);
            }
            PassiveForce::PointToPointSpring {
                body1,
                point1,
                body2,
                point2,
                ..
            } => {
                let (f1, _) = self.spring_force(data);
                let p1 = data.station_position(*body1, point1);
                let p2 = data.station_position(*body2, point2);
                out.extend(f1.iter());
                out.extend(p1.iter());
                out.extend((-f1).iter());
                out.extend(p2.iter());
            }
            _ => out.push(self.coordinate_force(data).1),
        }
    }
}

fn finite(el: &Element, prop: &str, default: f64) -> Result<f64> {
    let v = el.child_f64_or(prop, default)?;
    if !v.is_finite() {
        return Err(el
            .child(prop)
            .unwrap_or(el)
            .error(format!("<{prop}> must be finite, found {v}")));
    }
    Ok(v)
}

/// CoordinateLimitForce: user units are degrees for Rotational coordinates
/// (§8.4), converted here to radians as `extendConnectToModel` does.
fn read_limit(el: &Element, model: &Model, name: String) -> Result<PassiveForce> {
    let coordinate = coordinate_property(el, "coordinate", model)?;
    let w = if model.coordinates[coordinate].motion_type == MotionType::Rotational {
        std::f64::consts::PI / 180.0
    } else {
        1.0
    };
    let upper_stiffness = finite(el, "upper_stiffness", 1.0)?;
    let lower_stiffness = finite(el, "lower_stiffness", 1.0)?;
    let transition = finite(el, "transition", 0.1)?;
    for (prop, v) in [
        ("upper_stiffness", upper_stiffness),
        ("lower_stiffness", lower_stiffness),
        ("transition", transition),
    ] {
        if v == 0.0 {
            // OpenSim divides by the stiffnesses (NaN forces) and Simbody's
            // Step needs x0 != x1.
            return Err(el.child(prop).unwrap_or(el).error(format!(
                "CoordinateLimitForce '{name}': <{prop}> must be non-zero"
            )));
        }
    }
    Ok(PassiveForce::CoordinateLimit {
        coordinate,
        q_up: w * finite(el, "upper_limit", 0.0)?,
        q_lo: w * finite(el, "lower_limit", 0.0)?,
        k_up: upper_stiffness / w,
        k_lo: lower_stiffness / w,
        damping: finite(el, "damping", 0.001)? / w,
        transition: w * transition,
        name,
    })
}

/// PointToPointSpring: 4.0 sockets `socket_body1`/`socket_body2` (frame
/// paths), 3.x properties `body1`/`body2` (body names).
fn read_p2p(el: &Element, model: &Model, name: String) -> Result<PassiveForce> {
    let frame = |k: usize| -> Result<(usize, String)> {
        let socket = format!("socket_body{k}");
        let legacy = format!("body{k}");
        let p = el
            .child(&socket)
            .filter(|c| !c.text().is_empty())
            .or_else(|| el.child(&legacy))
            .ok_or_else(|| el.error(format!("PointToPointSpring '{name}' has no <{socket}>")))?;
        let path = p.text();
        // Socket paths are relative to the force (e.g. `../../bodyset/b`);
        // resolve the part after the last `..`.
        let rel = path.rsplit("../").next().unwrap_or(path);
        let f = find_frame(model, rel).ok_or_else(|| {
            p.error(format!(
                "PointToPointSpring '{name}': unknown frame '{path}'"
            ))
        })?;
        if f.transform.rotation != nalgebra::Matrix3::identity()
            || f.transform.translation != Vector3::zeros()
        {
            return Err(p.error(format!(
                "PointToPointSpring '{name}': frame '{path}' is an offset frame; only bodies and ground are supported"
            )));
        }
        Ok((f.body, f.name.clone()))
    };
    let (body1, n1) = frame(1)?;
    let (body2, n2) = frame(2)?;
    if body1 == body2 {
        return Err(el.error(format!(
            "PointToPointSpring '{name}': body1 and body2 are the same body"
        )));
    }
    Ok(PassiveForce::PointToPointSpring {
        body1,
        point1: el.child_vec3_or("point1", [0.0; 3])?,
        body2,
        point2: el.child_vec3_or("point2", [0.0; 3])?,
        stiffness: finite(el, "stiffness", 1.0)?,
        rest_length: finite(el, "rest_length", 0.0)?,
        frame_names: [n1, n2],
        name,
    })
}
