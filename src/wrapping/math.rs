//! Geometry helpers with the exact conventions of OpenSim's `WrapMath.cpp`
//! and `SimmMacros.h` (opensim-semantics §5.4). Several wrap algorithms
//! depend on these conventions (e.g. which parameter is normalized), so
//! they are reproduced rather than replaced by textbook versions.

use nalgebra::Vector3;

pub type V3 = Vector3<f64>;

/// `SimTK::Eps`.
pub const EPS: f64 = f64::EPSILON;
/// `LINE_EPSILON` in WrapMath.cpp.
const LINE_EPSILON: f64 = 0.00001;
/// `ROUNDOFF_ERROR` in SimmMacros.h.
pub const ROUNDOFF_ERROR: f64 = 0.0000000000002;

/// `DSIGN`: +1 for x ≥ 0, else −1 (also −1 for NaN).
#[inline]
pub fn dsign(x: f64) -> i32 {
    if x >= 0.0 {
        1
    } else {
        -1
    }
}

/// `EQUAL_WITHIN_ERROR(a, b)`.
#[inline]
pub fn equal_within_error(a: f64, b: f64) -> bool {
    (a - b).abs() <= ROUNDOFF_ERROR
}

/// `WrapMath::NormalizeOrZero`: unit vector, or zero if |v| < Eps (or NaN);
/// returns (unit, |v|).
#[inline]
pub fn normalize_or_zero(v: &V3) -> (V3, f64) {
    let mag = v.norm();
    if mag >= EPS {
        (v * (1.0 / mag), mag)
    } else {
        (V3::zeros(), mag)
    }
}

/// Shorthand for the unit part of [`normalize_or_zero`].
#[inline]
pub fn unit_or_zero(v: &V3) -> V3 {
    normalize_or_zero(v).0
}

/// `SimTK::UnitVec3(v)`: plain division by the norm (NaN for zero input).
#[inline]
pub fn unit_vec(v: &V3) -> V3 {
    v / v.norm()
}

/// `WrapMath::IntersectLines`: closest points between line p1→p2 and line
/// p3→p4. Returns `None` when parallel (OpenSim leaves the points unset and
/// s = t = NaN). Otherwise `(pint1, s, pint2, t)` with s, t measured in
/// units of |p2−p1| and |p4−p3|.
pub fn intersect_lines(p1: &V3, p2: &V3, p3: &V3, p4: &V3) -> Option<(V3, f64, V3, f64)> {
    let (vec1, mag1) = normalize_or_zero(&(p2 - p1));
    let (vec2, mag2) = normalize_or_zero(&(p4 - p3));
    let cross = vec1.cross(&vec2);
    let denom = cross.norm_squared();
    if equal_within_error(denom, 0.0) {
        return None;
    }
    let row0 = p3 - p1;
    // det of the matrix with rows (row0, vec1, cross) and (row0, vec2, cross).
    let t = row0.dot(&vec1.cross(&cross)) / denom;
    let pint2 = p3 + t * vec2;
    let s = row0.dot(&vec2.cross(&cross)) / denom;
    let pint1 = p1 + s * vec1;
    Some((pint1, s / mag1, pint2, t / mag2))
}

/// `WrapMath::IntersectLineSegPlane`: intersection of segment pt1→pt2 with
/// the plane n·x + d = 0, accepting t in [−1e-5, 1 + 1e-5].
#[allow(
    clippy::manual_range_contains,
    reason = "OpenSim's two comparisons let a NaN t through; a range test would refuse it"
)]
pub fn intersect_line_seg_plane(pt1: &V3, pt2: &V3, plane: &V3, d: f64) -> Option<V3> {
    let vec = pt2 - pt1;
    let dotprod = vec.dot(plane);
    if dotprod.abs() < LINE_EPSILON {
        return None;
    }
    let t = (-d - plane.dot(pt1)) / dotprod;
    if t < -LINE_EPSILON || t > 1.0 + LINE_EPSILON {
        return None;
    }
    Some(pt1 + t * vec)
}

/// `WrapMath::GetClosestPointOnLineToPoint`: closest point to `pt` on the
/// line through `line_pt` with direction `line` (need not be unit), and the
/// parameter t in units of |line|.
pub fn closest_point_on_line(pt: &V3, line_pt: &V3, line: &V3) -> (V3, f64) {
    let (v1, mag) = normalize_or_zero(&(pt - line_pt));
    let (v2, mag2) = normalize_or_zero(line);
    let t = v1.dot(&v2) * mag;
    let closest = line_pt + t * v2;
    (closest, t / mag2)
}

/// `WrapMath::CalcDistanceSquaredPointToLine`.
pub fn dist_sq_point_to_line(point: &V3, line_pt: &V3, line: &V3) -> f64 {
    let p = line_pt - point;
    let n = line / line.norm();
    (p - p.dot(&n) * n).norm_squared()
}

/// Rotation of `v` by `angle` about the unit axis `axis`
/// (`SimTK::Rotation(angle, axis) * v`).
pub fn rotate_about(v: &V3, axis: &V3, angle: f64) -> V3 {
    let (s, c) = angle.sin_cos();
    v * c + axis.cross(v) * s + axis * (axis.dot(v) * (1.0 - c))
}
