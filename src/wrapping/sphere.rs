//! `WrapSphere::wrapLine` (opensim-semantics §5.4, WrapSphere.cpp).
//!
//! The segment must cross the sphere (both roots of the line–sphere
//! quadratic in (0, 1)); tangent points lie in the plane through P1, P2 and
//! the centre; the surface path is a great-circle arc. OpenSim quirks kept:
//! * the quadrant "mandatory" test compares a *distance along the line*
//!   (metres) with 1.0;
//! * a far-side wrap stores a **negative** arc length −r(2π − angle), which
//!   `GeometryPath` then adds to the path length as is.
//!
//! Deviation: when the line passes within 1e-5 (normalized) of the centre
//! OpenSim falls back to the previous wrap's tangent points, which are
//! always NaN after `WrapResult`'s copy (its `factor` is not copied), so the
//! wrap is never chosen; we return `NoWrap` directly.

use std::f64::consts::PI;

use super::math::*;
use super::types::{Quadrant, WrapAction, WrapResult};

/// Tangent candidates from point `p` to the sphere in the plane with unit
/// normal `n` (OpenSim's `ra * ~Rx(±a)` construction).
fn tangent_candidates(radius: f64, p: &V3, n: &V3) -> (V3, V3) {
    let y = unit_or_zero(&(-p));
    let z = n.cross(&y);
    let pm = p.norm();
    let a1 = (radius / pm).asin();
    let (s, c) = a1.sin_cos();
    let k = pm * c;
    // Column 1 of ra·Rx(a)ᵀ is c·y − s·z; for −a it is c·y + s·z.
    (p + (c * y - s * z) * k, p + (c * y + s * z) * k)
}

#[allow(
    clippy::nonminimal_bool,
    reason = "!(0 < l && l < 1) also refuses a NaN root, as OpenSim's test does"
)]
pub fn wrap_sphere(radius: f64, quadrant: Quadrant, p1: V3, p2: V3) -> WrapResult {
    let wrap_sign = quadrant.wrap_sign();
    let wrap_axis = quadrant.wrap_axis();
    let mut return_code = WrapAction::Wrapped;
    let mut far_side_wrap = false;

    if p1.norm() < radius || p2.norm() < radius {
        return WrapResult::no_wrap(WrapAction::InsideRadius, p1, p2);
    }
    let ri = p1 - p2;
    let mp = -p2;
    let a = ri.dot(&ri);
    let b = -2.0 * mp.dot(&ri);
    let c = mp.dot(&mp) - radius * radius;
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        return WrapResult::no_wrap(WrapAction::NoWrap, p1, p2);
    }
    let l1 = (-b + disc.sqrt()) / (2.0 * a);
    let l2 = (-b - disc.sqrt()) / (2.0 * a);
    if !(0.0 < l1 && l1 < 1.0) || !(0.0 < l2 && l2 < 1.0) || l1 < l2 {
        return WrapResult::no_wrap(WrapAction::NoWrap, p1, p2);
    }
    let p1p2 = unit_or_zero(&(p1 - p2));
    let np2 = unit_or_zero(&p2);
    let hp2 = p1p2.cross(&np2);
    if hp2.norm() < 0.00001 {
        return WrapResult::no_wrap(WrapAction::NoWrap, p1, p2);
    }
    let n = unit_or_zero(&hp2);
    let (r1a, r1b) = tangent_candidates(radius, &p1, &n);
    let (r2a, r2b) = tangent_candidates(radius, &p2, &n);
    let r1am = unit_or_zero(&r1a);
    let r1bm = unit_or_zero(&r1b);
    let r2am = unit_or_zero(&r2a);
    let r2bm = unit_or_zero(&r2b);
    let j1 = r1am.dot(&r2am);
    let j2 = r1am.dot(&r2bm);
    let j3 = r1bm.dot(&r2am);
    let j4 = r1bm.dot(&r2bm);
    // The pair of candidates with the most similar directions.
    let (mut r1, mut r2) = if j1 > j2 && j1 > j3 && j1 > j4 {
        (r1a, r2a)
    } else if j2 > j3 && j2 > j4 {
        (r1a, r2b)
    } else if j3 > j4 {
        (r1b, r2a)
    } else {
        (r1b, r2b)
    };

    if wrap_sign != 0 {
        let ax = wrap_axis;
        let s = wrap_sign;
        if dsign(p1[ax]) == s || dsign(p2[ax]) == s {
            let (mm, tt) = closest_point_on_line(&V3::zeros(), &p1, &p1p2);
            let tt = -tt; // p1p2 points from P2 to P1
            if mm.norm_squared() < radius * radius && tt > 0.0 && tt < 1.0 {
                return_code = WrapAction::MandatoryWrap;
            } else if dsign(p1[ax]) != dsign(p2[ax]) && dsign(mm[ax]) != s {
                return_code = WrapAction::Wrapped;
            } else {
                return WrapResult::no_wrap(WrapAction::NoWrap, p1, p2);
            }
        }
        if dsign(p1[ax]) != s || dsign(p2[ax]) != s {
            let mut wrapaxis = V3::zeros();
            wrapaxis[ax] = s as f64;
            let sum_musc = unit_or_zero(&(-p1 - p2));
            // (r11, r22): the alternates used if the pair must be flipped.
            let (r11, r22);
            if r1am.dot(&sum_musc) > r1bm.dot(&sum_musc) {
                r1 = r1a;
                r11 = r1b;
            } else {
                r1 = r1b;
                r11 = r1a;
            }
            if r2am.dot(&sum_musc) > r2bm.dot(&sum_musc) {
                r2 = r2a;
                r22 = r2b;
            } else {
                r2 = r2b;
                r22 = r2a;
            }
            let sum_musc = unit_or_zero(&((r1 - p1) + (r2 - p2)));
            if sum_musc.dot(&wrapaxis) < 0.0 {
                r1 = r11;
                r2 = r22;
            }
            let sum_musc = (r1 - p1) + (r2 - p2);
            let sum_r = r1 + r2;
            if sum_r.dot(&sum_musc) < 0.0 {
                far_side_wrap = true;
            }
        }
    }

    let r1n = unit_or_zero(&r1);
    let r2n = unit_or_zero(&r2);
    let mut angle = r1n.dot(&r2n).acos();
    if far_side_wrap {
        angle = -(2.0 * PI - angle);
    }
    let wrap_path_length = radius * angle;
    // Surface points: OpenSim's sampling (which mixes degrees and radians)
    // matters only for display; we keep r1, evenly spaced arc points, r2.
    let axis = unit_or_zero(&r1n.cross(&r2n));
    let nseg = ((wrap_path_length / 0.002) as i64).max(1);
    let mut wrap_points = vec![r1];
    for i in 0..(nseg - 2).max(0) {
        let w = angle * (i + 1) as f64 / (nseg - 1) as f64;
        wrap_points.push(rotate_about(&r1, &axis, w));
    }
    wrap_points.push(r2);
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
