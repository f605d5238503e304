//! `WrapCylinder::wrapLine` (opensim-semantics §5.4, WrapCylinder.cpp):
//! cylinder of radius r along the local z axis, centred at the origin.
//!
//! The steps, tolerances and quirks follow OpenSim: tangent candidates in
//! the planes perpendicular to the axis through each endpoint, quadrant
//! logic with "far side" / "long wrap" flags, sliding of the tangent points
//! along the axis into the plane through P1, P2 and an apex point, the
//! length cut-off (both tangent points beyond ±L/2 → no wrap), a helical
//! surface path of length √((rθ)² + Δz²), and — only when the path has more
//! than one wrap object — the iterative tangency adjustment
//! (`_adjust_tangent_point`, threshold 0.1°, factor 1.5, ≤ 100 restarts).

use super::math::*;
use super::types::{Quadrant, WrapAction, WrapResult};

const MAX_ITERATIONS: usize = 100;
/// `TANGENCY_THRESHOLD` = 0.1 degree.
const TANGENCY_THRESHOLD: f64 = 0.1 * std::f64::consts::PI / 180.0;

fn p0() -> V3 {
    V3::new(0.0, 0.0, -1.0)
}
fn dn() -> V3 {
    V3::new(0.0, 0.0, 1.0)
}

/// Wrap segment p1→p2 (cylinder frame) over the cylinder.
#[allow(
    clippy::if_same_then_else,
    reason = "the branches follow OpenSim's WrapCylinder case by case"
)]
pub fn wrap_cylinder(
    radius: f64,
    length: f64,
    quadrant: Quadrant,
    p1: V3,
    p2: V3,
    single_wrap: bool,
) -> WrapResult {
    let (p0, dn) = (p0(), dn());
    let r_squared = radius * radius;
    let wrap_sign = quadrant.wrap_sign();
    let wrap_axis = quadrant.wrap_axis();
    let constrained = wrap_sign != 0;
    let mut far_side_wrap = false;
    let mut long_wrap = false;
    let mut return_code = WrapAction::Wrapped;

    if dist_sq_point_to_line(&p1, &p0, &dn) < r_squared
        || dist_sq_point_to_line(&p2, &p0, &dn) < r_squared
    {
        return WrapResult::no_wrap(WrapAction::InsideRadius, p1, p2);
    }

    // Closest points between the muscle line and the axis segment.
    let cyl_start = V3::new(0.0, 0.0, -0.5 * length);
    let cyl_end = V3::new(0.0, 0.0, 0.5 * length);
    let nan3 = V3::repeat(f64::NAN);
    let (near12, t12, near00) = match intersect_lines(&p1, &p2, &cyl_start, &cyl_end) {
        Some((a, s, b, _)) => (a, s, b),
        None => (nan3, f64::NAN, nan3),
    };
    let line_hits = (near12 - near00).norm_squared() < r_squared && t12 > 0.0 && t12 < 1.0;

    if !constrained {
        if line_hits {
            return_code = WrapAction::MandatoryWrap;
        } else {
            return WrapResult::no_wrap(WrapAction::NoWrap, p1, p2);
        }
    }

    // Closest axis points to P1 and P2, and tangent candidates.
    let (p11, _) = closest_point_on_line(&p1, &p0, &dn);
    let (p22, _) = closest_point_on_line(&p2, &p0, &dn);
    let candidates = |p: &V3, pa: &V3| -> (V3, V3, f64) {
        let (vv, p_dist) = normalize_or_zero(&(p - pa));
        let sin_theta = radius / p_dist;
        let dist = radius * sin_theta;
        let pp = pa + dist * vv;
        let dist = (r_squared - dist * dist).sqrt();
        let uu = dn.cross(&vv);
        (pp + dist * uu, pp - dist * uu, p_dist)
    };
    let (r1a, r1b, p11_dist) = candidates(&p1, &p11);
    let (r2a, r2b, p22_dist) = candidates(&p2, &p22);

    let (mut r1, mut r2);
    if constrained {
        let ax = wrap_axis;
        let s = wrap_sign;
        if dsign(p1[ax]) == s || dsign(p2[ax]) == s {
            if line_hits {
                return_code = WrapAction::MandatoryWrap;
            } else if dsign(p1[ax]) != dsign(p2[ax]) && dsign(near12[ax]) != s {
                return_code = WrapAction::Wrapped;
            } else {
                return WrapResult::no_wrap(WrapAction::NoWrap, p1, p2);
            }
        }
        let r1am = r1a - p11;
        let r1bm = r1b - p11;
        let r2am = r2a - p22;
        let r2bm = r2b - p22;
        let alpha = (r1am.dot(&r2bm) / (r1am.norm() * r2bm.norm())).acos();
        let beta = (r1bm.dot(&r2am) / (r1bm.norm() * r2am.norm())).acos();
        let on = |v: &V3| dsign(v[ax]) == s;
        // Comparisons are written as in OpenSim so NaN behaves the same.
        // (r1b, r2a) pairs use far side iff alpha <= beta;
        // (r1a, r2b) pairs use far side iff alpha > beta.
        let pick_b_a = |far: &mut bool| {
            *far = !(alpha > beta);
            (r1b, r2a)
        };
        let pick_a_b = |far: &mut bool| {
            *far = alpha > beta;
            (r1a, r2b)
        };
        let (a1, a2) = if on(&r1a) && on(&r1b) {
            if on(&r2a) {
                pick_b_a(&mut far_side_wrap)
            } else {
                pick_a_b(&mut far_side_wrap)
            }
        } else if on(&r1a) && !on(&r1b) {
            pick_a_b(&mut far_side_wrap)
        } else if !on(&r1a) && on(&r1b) {
            pick_b_a(&mut far_side_wrap)
        } else if on(&r2a) {
            pick_b_a(&mut far_side_wrap)
        } else if on(&r2b) {
            pick_a_b(&mut far_side_wrap)
        } else {
            // None of the four candidates is on the active side.
            far_side_wrap = true;
            if alpha > beta {
                (r1a, r2b)
            } else {
                (r1b, r2a)
            }
        };
        r1 = a1;
        r2 = a2;
        // Short or long wrap?
        let sum_musc = (r1 - p1) + (r2 - p2);
        let sum_r = (r1 - p11) + (r2 - p22);
        if sum_r.dot(&sum_musc) < 0.0 {
            long_wrap = true;
        }
    } else {
        let r1am = unit_or_zero(&(r1a - p11));
        let r1bm = unit_or_zero(&(r1b - p11));
        let r2am = unit_or_zero(&(r2a - p22));
        let r2bm = unit_or_zero(&(r2b - p22));
        let dot1 = r1am.dot(&r2am);
        let dot2 = r1am.dot(&r2bm);
        let dot3 = r1bm.dot(&r2am);
        let dot4 = r1bm.dot(&r2bm);
        (r1, r2) = if dot1 > dot2 && dot1 > dot3 && dot1 > dot4 {
            (r1a, r2a)
        } else if dot2 > dot3 && dot2 > dot4 {
            (r1a, r2b)
        } else if dot3 > dot4 {
            (r1b, r2a)
        } else {
            (r1b, r2b)
        };
    }

    // Apex point: a point on the cylinder in the plane through P1, P2 and
    // the axis point closest to the line point at ratio t.
    let t = p11_dist / (p11_dist + p22_dist);
    let mpt = p1 + t * (p2 - p1);
    let (axispt, _) = closest_point_on_line(&mpt, &p0, &dn);
    let l1 = unit_or_zero(&(p1 - axispt));
    let l2 = unit_or_zero(&(p2 - axispt));
    let plane_normal = unit_or_zero(&unit_vec(&l1.cross(&l2)));
    let vert1 = unit_or_zero(&dn.cross(&plane_normal));
    let vert2 = unit_or_zero(&plane_normal.cross(&dn));
    let apex1 = axispt + radius * vert1;
    let apex2 = axispt + radius * vert2;
    let dist1 = (mpt - apex1).norm_squared();
    let dist2 = (mpt - apex2).norm_squared();
    let apex = if far_side_wrap {
        if dist1 < dist2 {
            apex2
        } else {
            apex1
        }
    } else if dist1 < dist2 {
        apex1
    } else {
        apex2
    };

    // Slide r1, r2 along the axis into the plane (P1, P2, apex).
    let uu = unit_or_zero(&(p1 - apex));
    let vv = unit_or_zero(&(p2 - apex));
    let plane_normal = unit_vec(&uu.cross(&vv));
    let d = -p1.dot(&plane_normal);
    let r1p = intersect_line_seg_plane(&(r1 - 10.0 * dn), &(r1 + 10.0 * dn), &plane_normal, d);
    let r2p = intersect_line_seg_plane(&(r2 - 10.0 * dn), &(r2 + 10.0 * dn), &plane_normal, d);
    // OpenSim passes p22 (a point) as the line direction here; reproduced.
    if let Some(r1p) = r1p {
        let (q, _) = closest_point_on_line(&r1p, &p11, &p22);
        if (q - p22).norm_squared() < (p11 - p22).norm_squared() {
            r1 = r1p;
        }
    }
    if let Some(r2p) = r2p {
        let (q, _) = closest_point_on_line(&r2p, &p11, &p22);
        if (q - p11).norm_squared() < (p22 - p11).norm_squared() {
            r2 = r2p;
        }
    }

    // Length cut-off: both tangent points beyond the ends → no wrap.
    let half_l = length / 2.0;
    if (r1[2] < -half_l || r1[2] > half_l) && (r2[2] < -half_l || r2[2] > half_l) {
        return WrapResult::no_wrap(WrapAction::NoWrap, p1, p2);
    }

    let (wrap_path_length, wrap_points) =
        make_spiral_path(radius, &p1, &p2, long_wrap, &mut r1, &mut r2, single_wrap);
    WrapResult {
        action: return_code,
        r1,
        r2,
        wrap_path_length,
        wrap_points,
        c1: V3::zeros(),
        sv: V3::zeros(),
    }
}

/// `WrapCylinder::_make_spiral_path`: helix from r1 to r2; with several
/// wrap objects on the path the tangent points are adjusted iteratively.
/// Returns (length, surface points); r1/r2 may be updated.
pub(crate) fn make_spiral_path(
    radius: f64,
    p1: &V3,
    p2: &V3,
    far_side_wrap: bool,
    r1: &mut V3,
    r2: &mut V3,
    single_wrap: bool,
) -> (f64, Vec<V3>) {
    let (p0, dn) = (p0(), dn());
    let sense = if far_side_wrap { -1.0 } else { 1.0 };
    let mut iterations = 0;
    'restart: loop {
        let (r1a, _) = closest_point_on_line(r1, &p0, &dn);
        let (r2a, _) = closest_point_on_line(r2, &p0, &dn);
        let axial_dist = (r2a - r1a).dot(&dn);
        let uu = *r1 - r1a;
        let vv = *r2 - r2a;
        let mut theta = uu.cross(&vv).dot(&dn).atan2(uu.dot(&vv));
        if far_side_wrap {
            theta = 2.0 * std::f64::consts::PI - theta;
        }
        let x = radius * theta;
        let y = axial_dist;
        let len = (x * x + y * y).sqrt();
        // OpenSim's lambda reads the *current* r1, which the adjustment of
        // r1 below may already have changed when r2's sample is taken.
        let spiral =
            |r1: &V3, t: f64| rotate_about(r1, &dn, sense * t * theta) + dn * (t * axial_dist);
        if single_wrap {
            // Visualization off and a single wrap: OpenSim keeps one chord.
            return (len, vec![spiral(r1, 0.0), spiral(r1, 1.0)]);
        }
        // Samples every 0.002 m (model units assumed metres, as in OpenSim).
        let n = ((len / 0.002) as i64).max(1) as usize;
        let mut pts = Vec::with_capacity(n);
        for i in 0..n {
            let t = i as f64 / n as f64;
            let wrap_pt = spiral(r1, t);
            if i == 1 && iterations < MAX_ITERATIONS {
                let adj1 = adjust_tangent_point(p1, &dn, r1, &wrap_pt);
                let temp = spiral(r1, 1.0 - t);
                let adj2 = adjust_tangent_point(p2, &dn, r2, &temp);
                if adj1 || adj2 {
                    iterations += 1;
                    continue 'restart;
                }
            }
            pts.push(wrap_pt);
        }
        return (len, pts);
    }
}

/// `WrapCylinder::_adjust_tangent_point`: if the line pt1→r1 and the
/// surface direction r1→w1 differ in angle to the axis by more than 0.1°,
/// move r1 1.5× towards the intersection of pt1→w1 with r1's axial line.
fn adjust_tangent_point(pt1: &V3, dn: &V3, r1: &mut V3, w1: &V3) -> bool {
    let pr_vec = unit_or_zero(&(*r1 - pt1));
    let rw_vec = unit_or_zero(&(w1 - *r1));
    let alpha = pr_vec.dot(dn).acos();
    let omega = rw_vec.dot(dn).acos();
    if (alpha - omega).abs() > TANGENCY_THRESHOLD {
        let (p1a, _) = closest_point_on_line(pt1, r1, dn);
        let (w1a, _) = closest_point_on_line(w1, r1, dn);
        // OpenSim uses an unset point when the lines are parallel; we do
        // not adjust in that (degenerate) case.
        if let Some((_, _, p1aw1a_int, _)) = intersect_lines(pt1, w1, &p1a, &w1a) {
            *r1 += 1.5 * (p1aw1a_int - *r1);
            return true;
        }
    }
    false
}
