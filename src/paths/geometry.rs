//! Per-frame path evaluation: the current path (active points plus wrap
//! tangent points), its length, lengthening speed, and the generalized force
//! a unit tension produces (OpenSim's `GeometryPath::produceForces`), from
//! which moment arms follow (opensim-semantics.md §5.2–5.4).

use nalgebra::Vector3;

use super::{BodyWrapObject, GeometryPath, PointKind};
use crate::dynamics::{jacobian, Data};
use crate::model::Model;
use crate::wrapping::{wrap_line, WrapAction};

/// What a point of the current path is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Origin {
    /// Index into `GeometryPath::points`.
    Point(usize),
    /// Tangent point of path wrap `wrap` (index into `GeometryPath::wraps`):
    /// first (`false`) or second (`true`).
    Wrap { wrap: usize, second: bool },
}

#[derive(Debug, Clone, Copy)]
pub struct CurrentPoint {
    pub origin: Origin,
    pub body: usize,
    /// Location in the body frame.
    pub local: Vector3<f64>,
    /// Location in ground as OpenSim reads it for lengths and directions. For
    /// a wrap tangent point this is where the point was when its path wrap
    /// first wrapped in this evaluation: OpenSim caches a point's ground
    /// location at Stage::Position on first read and `PathWrapPoint::
    /// setLocation` does not invalidate it, so later passes over several wrap
    /// objects move the point (`at`) but not its ground location.
    pub ground: Vector3<f64>,
    /// Where the point is now, in ground: what the next wrap computation
    /// starts from and where a tension acts (OpenSim's `getLocation`).
    pub at: Vector3<f64>,
    /// Ground velocity of the point (of `at`): the body's station velocity
    /// plus, for a moving path point, its motion along its body.
    pub velocity: Vector3<f64>,
    /// For a moving path point: its coordinate and ∂p/∂q (ground frame),
    /// the derivative taken at the unclamped coordinate value as OpenSim
    /// does.
    pub moving: Option<(usize, Vector3<f64>)>,
}

/// Reusable per-path workspace.
#[derive(Debug, Clone, Default)]
pub struct PathState {
    pub points: Vec<CurrentPoint>,
    /// Arc length over each path wrap (0 when it does not wrap).
    pub wrap_length: Vec<f64>,
    pub length: f64,
}

/// Path point `i` as a current point: location in its body, in ground, its
/// ground velocity and (moving points) its rate of motion, each computed
/// once for the path's length, speed and forces.
fn current_point(path: &GeometryPath, i: usize, data: &Data) -> CurrentPoint {
    let p = &path.points[i];
    let body = p.body;
    let (local, moving) = match &p.kind {
        PointKind::Moving {
            coordinate,
            functions,
            clamp,
        } => {
            // Location at the clamped coordinate, derivative at the
            // unclamped one; one evaluation for both when they coincide.
            let q = data.q[*coordinate];
            let qc = q.clamp(clamp[0], clamp[1]);
            let mut loc = Vector3::zeros();
            let mut d = Vector3::zeros();
            for k in 0..3 {
                (loc[k], d[k]) = if qc == q {
                    functions[k].value_and_slope(q)
                } else {
                    (functions[k].value(qc), functions[k].derivative(q, 1))
                };
            }
            let rate = data.rotation[body] * (p.frame.rotation * d);
            (p.frame.apply(&loc), Some((*coordinate, rate)))
        }
        _ => (p.body_location, None),
    };
    let r = data.rotation[body] * local;
    let ground = data.position[body] + r;
    let mut velocity = data.velocity[body] + data.omega[body].cross(&r);
    if let Some((c, rate)) = moving {
        velocity += rate * data.u[c];
    }
    CurrentPoint {
        origin: Origin::Point(i),
        body,
        local,
        ground,
        at: ground,
        velocity,
        moving,
    }
}

fn is_active(path: &GeometryPath, i: usize, data: &Data) -> bool {
    match &path.points[i].kind {
        PointKind::Conditional { coordinate, range } => {
            let q = data.q[*coordinate];
            q >= range[0] - 1e-5 && q <= range[1] + 1e-5
        }
        _ => true,
    }
}

fn length_of(points: &[CurrentPoint], wrap_length: &[f64]) -> f64 {
    let mut l = 0.0;
    for w in points.windows(2) {
        match (w[0].origin, w[1].origin) {
            (
                Origin::Wrap {
                    wrap: a,
                    second: false,
                },
                Origin::Wrap {
                    wrap: b,
                    second: true,
                },
            ) if a == b => l += wrap_length[a],
            _ => l += (w[1].ground - w[0].ground).norm(),
        }
    }
    l
}

/// Compute the current path and its length at the positions in `data`, and
/// its points' velocities (positions and velocities in `data` must be
/// current).
pub fn evaluate(path: &GeometryPath, wraps: &[BodyWrapObject], data: &Data, st: &mut PathState) {
    st.points.clear();
    st.wrap_length.clear();
    st.wrap_length.resize(path.wraps.len(), 0.0);
    for i in 0..path.points.len() {
        if is_active(path, i, data) {
            st.points.push(current_point(path, i, data));
        }
    }
    if !path.wraps.is_empty() && !st.points.is_empty() {
        apply_wrap_objects(path, wraps, data, st);
    }
    st.length = length_of(&st.points, &st.wrap_length);
}

/// GeometryPath::applyWrapObjects: insert the tangent points of each wrap.
fn apply_wrap_objects(
    path: &GeometryPath,
    wraps: &[BodyWrapObject],
    data: &Data,
    st: &mut PathState,
) {
    let n = path.wraps.len();
    let max_iter = if n < 2 { 1 } else { 8 };
    let mut order: Vec<usize> = (0..n).collect();
    let mut result = vec![WrapAction::NoWrap; n];
    let mut last_length = f64::INFINITY;
    let npts = path.points.len();
    // Ground locations of each path wrap's two tangent points as first set
    // in this evaluation (see `CurrentPoint::ground`).
    let mut latched: Vec<Option<[Vector3<f64>; 2]>> = vec![None; n];
    // OpenSim's PathWrap::previousWrap (tangent points, wrap frame): set by
    // the best wrap of a pass, reset (to −∞) when a pass ends without one. A
    // torus whose inner cylinder does not wrap still reports `wrapped`, with
    // these points as its tangent points and no length: GeometryPath ranks
    // that empty wrap by the length change through them, and if it wins, the
    // object does not wrap on this pass. Reset at the start of an evaluation,
    // as for a fresh model (results do not depend on evaluation order).
    let mut previous: Vec<Option<[Vector3<f64>; 2]>> = vec![None; n];
    for kk in 0..max_iter {
        for i in 0..n {
            let wi = order[i];
            let pw = &path.wraps[wi];
            let wo = &wraps[pw.object];
            result[i] = WrapAction::NoWrap;
            // remove this wrap's previous tangent points
            st.points
                .retain(|p| !matches!(p.origin, Origin::Wrap { wrap, .. } if wrap == wi));
            st.wrap_length[wi] = 0.0;
            if !wo.object.active {
                continue;
            }
            let (rs, re) = pw.wrap.range;
            let wrap_start = if rs < 1 { 0 } else { (rs - 1) as usize };
            let wrap_end = if re < 1 {
                npts - 1
            } else {
                ((re - 1) as usize).min(npts - 1)
            };
            let Some(jfwd) = (wrap_start..=wrap_end).find(|&j| is_active(path, j, data)) else {
                return;
            };
            let Some(jrev) = (wrap_start..=wrap_end)
                .rev()
                .find(|&j| is_active(path, j, data))
            else {
                return;
            };
            let start = st
                .points
                .iter()
                .position(|p| p.origin == Origin::Point(jfwd));
            let end = st
                .points
                .iter()
                .position(|p| p.origin == Origin::Point(jrev));
            let (Some(start), Some(end)) = (start, end) else {
                return;
            };
            // Wrap object frame in ground.
            let r_gw = data.rotation[wo.body] * wo.rotation;
            let p_gw = data.station_position(wo.body, &wo.translation);
            let to_wrap = |g: &Vector3<f64>| r_gw.transpose() * (g - p_gw);
            let mut best: Option<(usize, crate::wrapping::WrapResult)> = None;
            let mut min_change = f64::INFINITY;
            for pt1 in start..end {
                let pt2 = pt1 + 1;
                let same_other_wrap = match (st.points[pt1].origin, st.points[pt2].origin) {
                    (Origin::Wrap { wrap: a, .. }, Origin::Wrap { wrap: b, .. }) => a == b,
                    _ => false,
                };
                if same_other_wrap {
                    continue;
                }
                let p1 = to_wrap(&st.points[pt1].at);
                let p2 = to_wrap(&st.points[pt2].at);
                let wr = wrap_line(&wo.object, pw.wrap.method, p1, p2, n == 1);
                result[i] = wr.action;
                match wr.action {
                    WrapAction::MandatoryWrap => {
                        previous[wi] = Some([wr.r1, wr.r2]);
                        best = Some((pt2, wr));
                        break;
                    }
                    WrapAction::Wrapped => {
                        // An empty wrap (a torus whose cylinder missed)
                        // carries the previous tangent points; after a
                        // reset they are at −∞ and it never wins.
                        let (r1, r2) = if wr.wraps() {
                            (wr.r1, wr.r2)
                        } else {
                            match previous[wi] {
                                Some([a, b]) => (a, b),
                                None => continue,
                            }
                        };
                        // OpenSim's calcPathLengthChange reads the ends'
                        // ground locations (latched for tangent points).
                        let (g1, g2) = (
                            to_wrap(&st.points[pt1].ground),
                            to_wrap(&st.points[pt2].ground),
                        );
                        let straight = (g2 - g1).norm();
                        let change =
                            (r1 - g1).norm() + wr.wrap_path_length + (g2 - r2).norm() - straight;
                        if change < min_change {
                            min_change = change;
                            previous[wi] = Some([r1, r2]);
                            best = Some((pt2, wr));
                        }
                    }
                    _ => {}
                }
            }
            let best = best.filter(|(_, wr)| wr.wraps());
            if best.is_none() {
                previous[wi] = None;
            }
            if let Some((at, wr)) = best {
                let body = wo.body;
                let l1 = wo.rotation * wr.r1 + wo.translation;
                let l2 = wo.rotation * wr.r2 + wo.translation;
                st.wrap_length[wi] = wr.wrap_path_length;
                let (r1, r2) = (data.rotation[body] * l1, data.rotation[body] * l2);
                let (a1, a2) = (data.position[body] + r1, data.position[body] + r2);
                let velocity = |r: &Vector3<f64>| data.velocity[body] + data.omega[body].cross(r);
                let [g1, g2] = *latched[wi].get_or_insert([a1, a2]);
                let p1 = CurrentPoint {
                    origin: Origin::Wrap {
                        wrap: wi,
                        second: false,
                    },
                    body,
                    local: l1,
                    ground: g1,
                    at: a1,
                    velocity: velocity(&r1),
                    moving: None,
                };
                let p2 = CurrentPoint {
                    origin: Origin::Wrap {
                        wrap: wi,
                        second: true,
                    },
                    body,
                    local: l2,
                    ground: g2,
                    at: a2,
                    velocity: velocity(&r2),
                    moving: None,
                };
                st.points.insert(at, p1);
                st.points.insert(at + 1, p2);
            }
        }
        let length = length_of(&st.points, &st.wrap_length);
        if (length - last_length).abs() < 0.0005 {
            break;
        }
        last_length = length;
        if kk == 0
            && n > 1
            && result[0] == WrapAction::NoWrap
            && result[1] == WrapAction::InsideRadius
        {
            order.swap(0, 1);
            let w0 = 0;
            st.points
                .retain(|p| !matches!(p.origin, Origin::Wrap { wrap, .. } if wrap == w0));
            st.wrap_length[w0] = 0.0;
        }
    }
}

/// The pull of a unit tension on the path's points: at each end of every
/// segment whose points lie on different bodies, the unit vector towards the
/// other end (zero for coincident points, where OpenSim gives NaN).
fn unit_pulls(st: &PathState) -> impl Iterator<Item = (&CurrentPoint, Vector3<f64>)> {
    st.points
        .windows(2)
        .filter(|w| w[0].body != w[1].body)
        .flat_map(|w| {
            let e = unit_direction(&w[0], &w[1]);
            [(&w[0], e), (&w[1], -e)]
        })
}

/// Unit vector from `a` towards `b` (their ground locations; 0 when they
/// coincide).
fn unit_direction(a: &CurrentPoint, b: &CurrentPoint) -> Vector3<f64> {
    let d = b.ground - a.ground;
    let n = d.norm();
    if n > 0.0 {
        d / n
    } else {
        Vector3::zeros()
    }
}

/// Lengthening speed of the path [`evaluate`] made.
pub fn lengthening_speed(st: &PathState) -> f64 {
    let mut s = 0.0;
    for w in st.points.windows(2) {
        let d = w[0].ground - w[1].ground;
        let dv = w[0].velocity - w[1].velocity;
        let n = d.norm();
        s += if n < f64::EPSILON {
            dv.norm()
        } else {
            dv.dot(&d) / n
        };
    }
    s
}

/// `model.common_ancestor(a, b)`, answering the common case of a body and
/// its parent without walking to the ground.
fn segment_top(model: &Model, a: usize, b: usize) -> usize {
    if b != 0 && model.joints[b].parent_body == a {
        a
    } else if a != 0 && model.joints[a].parent_body == b {
        b
    } else {
        model.common_ancestor(a, b)
    }
}

/// Generalized force of a unit tension along the current path, added to
/// `gen` (OpenSim's `GeometryPath::produceForces`): at each point, unit
/// vectors towards its neighbours on other bodies, plus the work of moving
/// points. Moment arm about an unconstrained coordinate = this force.
pub fn add_unit_tension_force(model: &Model, data: &Data, st: &PathState, gen: &mut [f64]) {
    for w in st.points.windows(2).filter(|w| w[0].body != w[1].body) {
        let e = unit_direction(&w[0], &w[1]);
        // The segment's ends are pulled by opposite forces; the joints that
        // carry both ends get only their net moment, which vanishes when the
        // ends lie on the line of pull (`at` = `ground`; see CurrentPoint):
        // the exact 0 keeps a muscle out of the rows of coordinates it
        // cannot move (a hip muscle and the pelvis's), so those rows stay
        // independent equations for the solver.
        let top = segment_top(model, w[0].body, w[1].body);
        for (p, f) in [(&w[0], e), (&w[1], -e)] {
            jacobian::add_point_force_below(model, data, p.body, top, &p.at, &f, gen);
            if let Some((c, dp)) = p.moving {
                gen[c] += dp.dot(&f);
            }
        }
        if w[0].at != w[0].ground || w[1].at != w[1].ground {
            let moment = (w[0].at - w[1].at).cross(&e);
            jacobian::add_body_torque(model, data, top, &moment, gen);
        }
    }
}

/// The forces a tension `tension` along the current path applies, as
/// OpenSim's `GeometryPath::produceForces` applies them: a point force at
/// each end of every segment whose points lie on different bodies (added to
/// `applied`, ground frame, moments about the ground origin), and for moving
/// path points the generalized force of the point's motion on its coordinate
/// (added to `gen`, a mobility force). Their generalized-force equivalent is
/// `tension ×` [`add_unit_tension_force`]. Joint reactions need the body
/// forces themselves (opensim-semantics.md §7.2).
pub fn add_tension_forces(
    st: &PathState,
    tension: f64,
    applied: &mut [crate::dynamics::BodyForce],
    gen: &mut [f64],
) {
    for (p, e) in unit_pulls(st) {
        let f = e * tension;
        applied[p.body].add(&crate::dynamics::BodyForce::at_point(f, p.at));
        if let Some((c, dp)) = p.moving {
            gen[c] += dp.dot(&f);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segment_top_is_the_common_ancestor() {
        let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("models/leg_extension/human_seated_rajagopal.osim");
        let (_, model) = crate::tools::loading::load_model(&file).unwrap();
        let nb = model.bodies.len();
        assert!(nb > 5);
        let mut direct = 0;
        for a in 0..nb {
            for b in 0..nb {
                let top = model.common_ancestor(a, b);
                assert_eq!(segment_top(&model, a, b), top, "bodies {a} {b}");
                direct += (top == a || top == b) as usize;
            }
        }
        assert!(direct > nb);
    }
}
