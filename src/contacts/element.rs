//! The point-on-plane contact element as read from a ForceSet
//! (Krüger & Wartzack 2017, §2.1 and §2.3).
//!
//! # XML
//!
//! The element is `PointOnPlaneContact`; the original OpenSim plugin's name
//! `ContactPointOnPlane` (statopt-contact, D. Krüger and F. Laufer,
//! `ContactPointOnPlane.h`) is accepted as a synonym. The property names are
//! the plugin's, with the plugin's defaults:
//!
//! | property | default | meaning |
//! |---|---|---|
//! | `point_body` | required | body (or frame path) carrying the point |
//! | `point_location` | `0 0 0` | point p in that frame |
//! | `plane_body` | `ground` | body (or frame path) carrying the plane |
//! | `plane_origin` | `0 0 0` | a point of the plane, in that frame |
//! | `plane_normal` | `0 1 0` | plane normal in that frame (normalised; zero is an error) |
//! | `static_friction` | 0.8 | μs |
//! | `kinetic_friction` | 0.5 | μk |
//! | `contact_tolerance` | −1 | d_tol; negative: distance has no effect (w = 1) |
//! | `contact_transition_zone` | 0.01 | d_trans (m) |
//! | `v_trans` | 0.1 | static/kinetic transition speed (m/s) |
//! | `optimal_force` | 100 | F0 (N): force per unit multiplier |
//! | `regime_blend` | 0 | statopt: slip-speed width (m/s) of a smooth static/kinetic transition centred on v_trans (0: the paper's hard switch; at most 2 v_trans); see [`super::kinematics`] |
//! | `plane_velocity` | `0 0 0` | statopt: velocity (m/s, plane body frame) of the plane's surface relative to its body, e.g. a treadmill belt `-1.2 0 0`; slip is taken against the moving surface. 0: the paper's rigid plane |
//! | `speed_weight` | off | statopt: two slip speeds `s_full s_zero` (m/s): the contact weakens with the slip speed of its point over the plane, full strength up to `s_full`, none from `s_zero` (a C¹ smoothstep between), multiplying w(d); AnyBody's ground-reaction prediction uses about `0.12 0.8`. Off (absent) by default, so the paper's model is unchanged |
//! | `off_intervals` | none | statopt: pairs of times `t0 t1 ...` (s, ascending, t0 < t1): the contact carries nothing for t0 <= t < t1 (its weight is multiplied by `off_weight`); predict-grf writes a landing foot's swing before its kinematic foot strike, and its points but the heel's over the double support it lands into (docs/grf_prediction.md, "The step-to-step transition"). Absent: always on |
//! | `held_intervals` | none | statopt: pairs of times `t0 t1 ...` (s, ascending, t0 < t1): for t0 <= t < t1 the contact's point is on the floor whatever its slip: its slip-speed gate (`speed_weight`) is not applied and its regime is static; predict-grf writes a trailing foot's double support, where the model's rigid toe point moves as the real foot rolls over its toes (docs/grf_prediction.md, step 8). Absent: never |
//! | `off_weight` | 0 | statopt: the factor on the contact's weight within `off_intervals`, in [0, 1) (0: off) |
//! | `time_weight` | none | statopt: knots `t0 f0 t1 f1 ...` (times ascending, factors in [0, 1]): the contact's weight is multiplied by f, linear between the knots and the end knots' values before and after them; predict-grf writes the smooth transition of double support (docs/grf_prediction.md) |
//! | `force_target_group` | none | statopt: a name shared by the contacts whose summed force on their point bodies is held to `force_target` (a soft equality, [`super::targets`]); predict-grf writes the trailing foot's share of double support (a smooth transition, after Ren et al. 2008) and each foot's force along its leg |
//! | `force_target_rows` | none | statopt: m, the number of axes (1–3) along which the group's force is targeted |
//! | `force_target` | none | statopt: knots `t on ax ay az f ...` (s; 1 or 0; then m times a unit axis in ground and the force in N along it, or 0 0 0 0, a row that holds nothing at that knot; times ascending): linear between two knots that are both on (the axis renormalised); no target elsewhere |
//! | `force_target_optimal_force` | 1 | statopt: S (N), one for all rows or one per row: a departure e from the target costs (e/S)², what an actuator of optimal force S costs |
//! | `appliesForce` / `isDisabled` | true / false | as for every OpenSim force |
//!
//! The bodies may also be given as OpenSim-4 style sockets
//! `socket_point_frame` / `socket_plane_frame` (paths such as
//! `/bodyset/tibia` or an offset frame's path); giving both spellings of one
//! property is an error. Names are resolved as paths, then as body names
//! (the plugin meant to accept a path by keeping its last segment).
//!
//! Differences from the plugin, all deliberate:
//! - the plugin's `point_body` defaults to `ground` and then fails to connect
//!   (it searches only the BodySet); here `point_body` is required, and it
//!   may be ground when the plane body is not (a fixed point touching a moving
//!   plane);
//! - point and plane on the same body is refused (the force pair would cancel);
//! - μk > μs is accepted (Coulomb's law does not forbid it and the plugin
//!   does not check); negative coefficients are refused.

use nalgebra::Vector3;

use crate::error::Result;
use crate::forces::{applies_force, find_frame};
use crate::model::{Frame, Model};
use crate::xml::Element;

/// Element names read as a point-on-plane contact.
pub const CONTACT_TYPE_NAMES: &[&str] = &["PointOnPlaneContact", "ContactPointOnPlane"];

/// A point-on-plane contact (Krüger & Wartzack 2017, §2.1). Body-fixed
/// quantities are in the frame of the body (an offset frame given in the XML
/// is already resolved into its base body).
#[derive(Debug, Clone, PartialEq)]
pub struct Contact {
    pub name: String,
    /// Element tag, e.g. `PointOnPlaneContact`.
    pub type_name: String,
    /// Body A, carrying the point p.
    pub point_body: usize,
    /// p in body A.
    pub point: Vector3<f64>,
    /// Body B, carrying the plane.
    pub plane_body: usize,
    /// A point of the plane, in body B.
    pub origin: Vector3<f64>,
    /// Unit plane normal n, in body B; the distance is positive on this side.
    pub normal: Vector3<f64>,
    /// In-plane unit axes e1, e2 in body B, fixed on the body so that the shear
    /// multipliers keep their meaning as the body moves. Choice: let k be the
    /// body axis most nearly parallel to n (largest |n_k|, lowest index on
    /// ties), a the next axis cyclically (x→y→z→x); e1 is a made orthogonal
    /// to n and normalised, e2 = n × e1. Then (e1, e2, n) is right-handed
    /// (e1 × e2 = n); for n = +y: e1 = +z, e2 = +x; for n = +z: e1 = +x,
    /// e2 = +y. (The plugin uses `UnitVec3::perp()` of the ground-frame
    /// normal, which is not body-fixed.)
    pub e1: Vector3<f64>,
    pub e2: Vector3<f64>,
    /// Static and kinetic friction coefficients μs, μk.
    pub mu_s: f64,
    pub mu_k: f64,
    /// d_tol (m); negative: the distance has no effect (w = 1).
    pub d_tol: f64,
    /// d_trans (m), > 0 when d_tol ≥ 0.
    pub d_trans: f64,
    /// Transition speed (m/s), > 0: static iff slip speed ≤ v_trans.
    pub v_trans: f64,
    /// F0 (N): the force of a unit multiplier at w = 1.
    pub optimal_force: f64,
    /// Slip-speed width (m/s) of the smooth static/kinetic transition
    /// (`regime_blend`, statopt); 0: the paper's hard switch at v_trans.
    pub regime_blend: f64,
    /// `speed_weight` (statopt): slip speeds (m/s) at which the contact
    /// starts to weaken and is off; None: the weight does not depend on the
    /// slip speed (the paper's model).
    pub speed_weight: Option<(f64, f64)>,
    /// `plane_velocity` (statopt): velocity of the plane's surface relative
    /// to its body (a treadmill belt), given in the plane's frame like
    /// `plane_normal` and kept in the body's; zero for the paper's rigid plane.
    pub surface_velocity: Vector3<f64>,
    /// `off_intervals` (statopt): times [t0, t1) over which the contact
    /// carries nothing; empty: always on.
    pub off_intervals: Vec<(f64, f64)>,
    /// `off_weight` (statopt): the factor on the weight within the off
    /// intervals, in [0, 1).
    pub off_weight: f64,
    /// `held_intervals` (statopt): times [t0, t1) over which the contact's
    /// slip-speed gate is not applied and its regime is static; empty:
    /// never.
    pub held_intervals: Vec<(f64, f64)>,
    /// `time_weight` (statopt): knots (t, factor) of a piecewise-linear
    /// factor on the weight; empty: 1.
    pub time_weight: Vec<(f64, f64)>,
    /// `force_target_*` (statopt): the group force target this contact
    /// belongs to ([`super::targets`]); None: no target.
    pub force_target: Option<super::targets::TargetSpec>,
    pub applies_force: bool,
    /// Where the element is: file, line, element (for messages such as
    /// `--check`'s plane facing away from the point's body).
    pub loc: crate::error::Location,
}

/// In-plane axes (e1, e2) for the unit normal `n`: see [`Contact::e1`].
pub fn plane_axes(n: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let mut k = 0;
    for i in 1..3 {
        if n[i].abs() > n[k].abs() {
            k = i;
        }
    }
    let mut a = Vector3::zeros();
    a[(k + 1) % 3] = 1.0;
    // |a·n| ≤ sqrt(1 − n_k²) ≤ sqrt(2/3), so the projection is never small.
    let e1 = (a - n * a.dot(n)).normalize();
    let e2 = n.cross(&e1);
    (e1, e2)
}

impl Contact {
    /// Read a contact element. `Ok(None)` for elements of other types.
    pub fn from_xml(el: &Element, model: &Model) -> Result<Option<Contact>> {
        if !CONTACT_TYPE_NAMES.contains(&el.name.as_str()) {
            return Ok(None);
        }
        let name = el.name_attr().to_string();
        let point_frame = frame_property(el, model, "point_body", "socket_point_frame", None)?;
        let plane_frame = frame_property(
            el,
            model,
            "plane_body",
            "socket_plane_frame",
            Some("ground"),
        )?;
        if point_frame.body == plane_frame.body {
            return Err(el.error(format!(
                "{} '{name}': point and plane are on the same body '{}' (the contact force pair would cancel)",
                el.name, model.bodies[point_frame.body].name
            )));
        }

        let point = point_frame
            .transform
            .apply(&finite_vec3(el, "point_location", [0.0; 3])?);
        let origin = plane_frame
            .transform
            .apply(&finite_vec3(el, "plane_origin", [0.0; 3])?);
        let n = finite_vec3(el, "plane_normal", [0.0, 1.0, 0.0])?;
        let len = n.norm();
        if len == 0.0 {
            let at = el.child("plane_normal").unwrap_or(el);
            return Err(at.error(format!(
                "{} '{name}': <plane_normal> must be a non-zero vector",
                el.name
            )));
        }
        let normal = plane_frame.transform.rotation * (n / len);
        let (e1, e2) = plane_axes(&normal);

        let mu_s = number(el, "static_friction", 0.8)?;
        let mu_k = number(el, "kinetic_friction", 0.5)?;
        for (prop, mu) in [("static_friction", mu_s), ("kinetic_friction", mu_k)] {
            if mu < 0.0 {
                return Err(at(el, prop).error(format!(
                    "{} '{name}': <{prop}> must not be negative, found {mu}",
                    el.name
                )));
            }
        }
        let d_tol = number(el, "contact_tolerance", -1.0)?;
        let d_trans = number(el, "contact_transition_zone", 0.01)?;
        if d_tol >= 0.0 && d_trans <= 0.0 {
            return Err(at(el, "contact_transition_zone").error(format!(
                "{} '{name}': <contact_transition_zone> must be positive when <contact_tolerance> ({d_tol}) is not negative, found {d_trans}",
                el.name
            )));
        }
        let v_trans = el.child_f64_or("v_trans", 0.1)?;
        // +inf is allowed: the contact then always stays in the static regime.
        if v_trans.is_nan() || v_trans <= 0.0 {
            return Err(at(el, "v_trans").error(format!(
                "{} '{name}': <v_trans> must be positive, found {v_trans}",
                el.name
            )));
        }
        let optimal_force = number(el, "optimal_force", 100.0)?;
        if optimal_force <= 0.0 {
            return Err(at(el, "optimal_force").error(format!(
                "{} '{name}': <optimal_force> must be positive, found {optimal_force}",
                el.name
            )));
        }
        let regime_blend = number(el, "regime_blend", 0.0)?;
        // A blend reaching below zero slip would take static friction away
        // from a contact at rest (β(0) > 0).
        if regime_blend < 0.0 || regime_blend > 2.0 * v_trans {
            return Err(at(el, "regime_blend").error(format!(
                "{} '{name}': <regime_blend> is a slip-speed width in m/s and must lie in [0, 2 v_trans] = [0, {}], found {regime_blend}",
                el.name,
                2.0 * v_trans
            )));
        }
        // Given in the plane's frame, like plane_normal; kept in the body's.
        let surface_velocity =
            plane_frame.transform.rotation * finite_vec3(el, "plane_velocity", [0.0; 3])?;
        if surface_velocity.dot(&normal).abs() > 1e-9 * (1.0 + surface_velocity.norm()) {
            return Err(at(el, "plane_velocity").error(format!(
                "{} '{name}': <plane_velocity> is the velocity of the plane's surface and must lie in the plane (its component along the normal is {})",
                el.name,
                surface_velocity.dot(&normal)
            )));
        }
        let speed_weight = match el.child("speed_weight") {
            Some(w) if !w.text().trim().is_empty() => {
                let v = w.numbers_n(2)?;
                if !(v[0] >= 0.0 && v[1] > v[0] && v[1].is_finite()) {
                    return Err(w.error(format!(
                        "{} '{name}': <speed_weight> takes two slip speeds in m/s, full strength up to the first and none from the second (0 <= first < second), found {} {}",
                        el.name, v[0], v[1]
                    )));
                }
                Some((v[0], v[1]))
            }
            _ => None,
        };
        let off_intervals = intervals(el, &name, "off_intervals", "the contact carries nothing")?;
        let held_intervals = intervals(
            el,
            &name,
            "held_intervals",
            "the contact is on the floor whatever its slip",
        )?;
        let off_weight = number(el, "off_weight", 0.0)?;
        if !(0.0..1.0).contains(&off_weight) {
            return Err(at(el, "off_weight").error(format!(
                "{} '{name}': <off_weight> is the factor on the contact's weight within <off_intervals> and must lie in [0, 1), found {off_weight}",
                el.name
            )));
        }
        let time_weight = match el.child("time_weight") {
            Some(w) if !w.text().trim().is_empty() => {
                let v = w.numbers()?;
                let ok = v.len() % 2 == 0
                    && v.chunks(2).all(|p| (0.0..=1.0).contains(&p[1]))
                    && v.chunks(2)
                        .zip(v.chunks(2).skip(1))
                        .all(|(a, b)| a[0] < b[0]);
                if !ok {
                    return Err(w.error(format!(
                        "{} '{name}': <time_weight> takes knots t f (s, factor in [0, 1]) with the times ascending, found '{}'",
                        el.name,
                        w.text().trim()
                    )));
                }
                v.chunks(2).map(|p| (p[0], p[1])).collect()
            }
            _ => Vec::new(),
        };
        let force_target = super::targets::TargetSpec::from_xml(el, &name)?;
        Ok(Some(Contact {
            loc: el.loc(),
            name,
            type_name: el.name.to_string(),
            point_body: point_frame.body,
            point,
            plane_body: plane_frame.body,
            origin,
            normal,
            e1,
            e2,
            mu_s,
            mu_k,
            d_tol,
            d_trans,
            v_trans,
            optimal_force,
            regime_blend,
            speed_weight,
            surface_velocity,
            off_intervals,
            off_weight,
            held_intervals,
            time_weight,
            force_target,
            applies_force: applies_force(el)?,
        }))
    }
}

/// The element to blame for a bad property: the property if present.
fn at<'a>(el: &'a Element, prop: &str) -> &'a Element {
    el.child(prop).unwrap_or(el)
}

/// Optional pairs of times `t0 t1 ...` (s; t0 < t1, ascending) of
/// property `prop`; `meaning` says what holds for t0 <= t < t1.
fn intervals(el: &Element, name: &str, prop: &str, meaning: &str) -> Result<Vec<(f64, f64)>> {
    match el.child(prop) {
        Some(w) if !w.text().trim().is_empty() => {
            let v = w.numbers()?;
            let ok = v.len() % 2 == 0
                && v.chunks(2).all(|p| p[0] < p[1])
                && v.windows(2).all(|p| p[0] <= p[1]);
            if !ok {
                return Err(w.error(format!(
                    "{} '{name}': <{prop}> takes pairs of times in s, t0 t1 with t0 < t1, in ascending order ({meaning} for t0 <= t < t1), found '{}'",
                    el.name,
                    w.text().trim()
                )));
            }
            Ok(v.chunks(2).map(|p| (p[0], p[1])).collect())
        }
        _ => Ok(Vec::new()),
    }
}

/// An optional finite number.
fn number(el: &Element, prop: &str, default: f64) -> Result<f64> {
    let v = el.child_f64_or(prop, default)?;
    if !v.is_finite() {
        return Err(at(el, prop).error(format!(
            "{} '{}': <{prop}> must be finite, found {v}",
            el.name,
            el.name_attr()
        )));
    }
    Ok(v)
}

fn finite_vec3(el: &Element, prop: &str, default: [f64; 3]) -> Result<Vector3<f64>> {
    let v = el.child_vec3_or(prop, default)?;
    if !v.iter().all(|x| x.is_finite()) {
        return Err(at(el, prop).error(format!(
            "{} '{}': <{prop}> must be finite",
            el.name,
            el.name_attr()
        )));
    }
    Ok(v)
}

/// Resolve the frame named by `prop` or by its socket spelling `socket`.
fn frame_property<'m>(
    el: &Element,
    model: &'m Model,
    prop: &str,
    socket: &str,
    default: Option<&str>,
) -> Result<&'m Frame> {
    let given = |p: &str| el.child(p).filter(|c| !c.text().is_empty());
    let (holder, text) = match (given(prop), given(socket)) {
        (Some(_), Some(s)) => {
            return Err(s.error(format!(
                "{} '{}': give either <{prop}> or <{socket}>, not both",
                el.name,
                el.name_attr()
            )))
        }
        (Some(c), None) | (None, Some(c)) => (c, c.text()),
        (None, None) => match default {
            Some(d) => (el, d),
            None => {
                return Err(el.error(format!(
                    "{} '{}': missing property <{prop}>",
                    el.name,
                    el.name_attr()
                )))
            }
        },
    };
    let last = text.rsplit('/').next().unwrap_or(text);
    find_frame(model, text)
        .or_else(|| {
            model
                .body_index(last)
                .and_then(|b| model.frame(&model.bodies[b].name))
        })
        .ok_or_else(|| {
            holder.error(format!(
                "{} '{}': unknown body or frame '{text}'",
                el.name,
                el.name_attr()
            ))
        })
}
