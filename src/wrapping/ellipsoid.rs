//! `WrapEllipsoid::wrapLine` (opensim-semantics §5.4, WrapEllipsoid.cpp).
//!
//! Reproduces OpenSim's algorithm: coordinates scaled by 3/(a+b+c); inside
//! test with tolerance 1e-4; no wrap when P1, P2 and the centre are nearly
//! collinear or the segment misses the ellipsoid; the wrapping-plane point
//! c1 from the midpoint, axial (Frans) or hybrid (Frans blended with a
//! 300-sample fan, μ ∈ [0.7073, 0.9], end fade 0.3) construction; flipping
//! of c1 to the active side for a constrained quadrant; the damped
//! Gauss–Newton tangent search `calcTangentPoint` (≤ 50 outer and ≤ 1000
//! inner iterations, tolerance 1e-8); the surface polyline
//! `CalcDistanceOnEllipsoid` (segments of ~1 mm, at most 499) and the
//! far-side retry for a wrong-way wrap.
//!
//! Point-to-ellipsoid projection is Eberly's (Graphics Gems IV) method with
//! OpenSim's special handling near the coordinate planes.
//!
//! History: OpenSim seeds `c1` from the previous wrap result; it is only
//! read when the general-case projection fails to converge in 64 Newton
//! steps. We seed it with the origin instead (no history).

use std::f64::consts::PI;

use nalgebra::Matrix4;

use super::math::*;
use super::types::{Quadrant, WrapAction, WrapMethod, WrapResult};

const ELLIPSOID_TINY: f64 = 0.00000001;
const MU_BLEND_MIN: f64 = 0.7073;
const MU_BLEND_MAX: f64 = 0.9;
const NUM_FAN_SAMPLES: usize = 300;
const SV_BOUNDARY_BLEND: f64 = 0.3;

#[allow(
    clippy::nonminimal_bool,
    reason = "!(0 < l && l < 1) also refuses a NaN root, as OpenSim's test does"
)]
pub fn wrap_ellipsoid(
    dims: V3,
    quadrant: Quadrant,
    method: WrapMethod,
    point1: V3,
    point2: V3,
) -> WrapResult {
    let wrap_sign = quadrant.wrap_sign();
    let wrap_axis = quadrant.wrap_axis();
    let factor = 3.0 / dims.sum();
    let p1 = point1 * factor;
    let p2 = point2 * factor;
    let m = V3::zeros();
    let a = dims * factor;
    let ell = Ell { a };

    let mut p1e = -1.0;
    let mut p2e = -1.0;
    for i in 0..3 {
        p1e += ((p1[i] - m[i]) / a[i]).powi(2);
        p2e += ((p2[i] - m[i]) / a[i]).powi(2);
    }
    if p1e < -0.0001 || p2e < -0.0001 {
        return WrapResult::no_wrap(WrapAction::InsideRadius, point1, point2);
    }
    let p1p2 = p1 - p2;
    let p1m = unit_or_zero(&(p1 - m));
    let p2m = unit_or_zero(&(p2 - m));
    let ppm = p1m.dot(&p2m) - 1.0;
    if ppm.abs() < 0.0001 {
        return WrapResult::no_wrap(WrapAction::NoWrap, point1, point2);
    }
    let f1 = p1p2.component_div(&a);
    let f2 = (p2 - m).component_div(&a);
    let aa = f1.dot(&f1);
    let bb = 2.0 * f1.dot(&f2);
    let cc = f2.dot(&f2) - 1.0;
    let disc = bb * bb - 4.0 * aa * cc;
    if disc < 0.0 {
        return WrapResult::no_wrap(WrapAction::NoWrap, point1, point2);
    }
    let l1 = (-bb + disc.sqrt()) / (2.0 * aa);
    let l2 = (-bb - disc.sqrt()) / (2.0 * aa);
    if !(0.0 < l1 && l1 < 1.0) || !(0.0 < l2 && l2 < 1.0) {
        return WrapResult::no_wrap(WrapAction::NoWrap, point1, point2);
    }
    // Intersection points of the line with the ellipsoid.
    let mut r1 = p2 + l1 * p1p2;
    let mut r2 = p2 + l2 * p1p2;
    let mut c1 = V3::zeros();
    let mut sv = V3::zeros();
    let mut fan_weight = f64::NEG_INFINITY;

    // ==== wrapping plane ====
    let r1r2 = r2 - r1;
    let mut mu = unit_or_zero(&p1p2);
    let mut t = V3::zeros();
    let mut t_sv = [V3::zeros(); 3];
    let mut t_c1 = [V3::zeros(); 3];
    for i in 0..3 {
        mu[i] = mu[i].abs();
        t[i] = (m[i] - r1[i]) / r1r2[i];
        t_sv[i] = r1 + t[i] * r1r2;
        ell.closest_point(&t_sv[i], &mut t_c1[i], i as i32);
    }
    let mut best = 0;
    for i in 1..3 {
        if mu[i] > mu[best] {
            best = i;
        }
    }
    match method {
        WrapMethod::Hybrid | WrapMethod::Axial => {
            if method == WrapMethod::Hybrid && mu[best] > MU_BLEND_MIN {
                // Fade the Frans result out when its sv nears the ends of r1→r2.
                let tb = t[best];
                let s = if !(0.0..=1.0).contains(&tb) {
                    0.0
                } else if tb < SV_BOUNDARY_BLEND {
                    tb / SV_BOUNDARY_BLEND
                } else if tb > 1.0 - SV_BOUNDARY_BLEND {
                    (1.0 - tb) / SV_BOUNDARY_BLEND
                } else {
                    1.0
                };
                if s < 1.0 {
                    mu[best] = MU_BLEND_MIN + s * (mu[best] - MU_BLEND_MIN);
                }
            }
            if method == WrapMethod::Axial || mu[best] > MU_BLEND_MIN {
                c1 = t_c1[best];
                sv = t_sv[best];
            }
            if method == WrapMethod::Hybrid && mu[best] < MU_BLEND_MAX {
                // Fan: average the sv→c1 "blades" over the segment r1→r2.
                let mut v_sum = V3::zeros();
                let sv_mid = r1 + 0.5 * r1r2;
                let mut blade_c1 = t_c1[0];
                for i in 1..NUM_FAN_SAMPLES - 1 {
                    let tt = i as f64 / NUM_FAN_SAMPLES as f64;
                    let svi = r1 + tt * r1r2;
                    ell.closest_point(&svi, &mut blade_c1, -1);
                    v_sum += unit_or_zero(&(blade_c1 - svi));
                }
                let v_sum = unit_or_zero(&v_sum);
                let fan_c1 = sv_mid + v_sum;
                if mu[best] <= MU_BLEND_MIN {
                    ell.closest_point(&fan_c1, &mut c1, -1);
                    sv = sv_mid;
                    fan_weight = 1.0;
                } else {
                    let tt = (mu[best] - MU_BLEND_MIN) / (MU_BLEND_MAX - MU_BLEND_MIN);
                    let one_minus_t = 1.0 - tt;
                    let mut fan_proj = t_c1[1];
                    ell.closest_point(&fan_c1, &mut fan_proj, -1);
                    let blend = tt * c1 + one_minus_t * fan_proj;
                    sv = tt * sv + one_minus_t * sv_mid;
                    ell.closest_point(&blend, &mut c1, -1);
                    fan_weight = one_minus_t;
                }
            }
        }
        WrapMethod::Midpoint => {
            sv = r1 + 0.5 * (r2 - r1);
            ell.closest_point(&sv.clone(), &mut c1, -1);
        }
    }

    // Start the tangent search from c1 (axial: only if sv lies within r1→r2).
    let use_c1 = match method {
        WrapMethod::Axial => t[best] > 0.0 && t[best] < 1.0,
        _ => true,
    };
    if use_c1 {
        r1 = c1;
        r2 = c1;
    }

    // Constrained quadrant: flip c1 to the active side.
    if wrap_sign != 0 {
        let ax = wrap_axis;
        let dist = c1[ax] - m[ax];
        if dsign(dist) != wrap_sign {
            let orig_c1 = c1;
            c1[ax] = -c1[ax];
            r1 = c1;
            r2 = c1;
            if equal_within_error(fan_weight, f64::NEG_INFINITY) {
                fan_weight = 1.0 - (mu[best] - MU_BLEND_MIN) / (MU_BLEND_MAX - MU_BLEND_MIN);
            }
            if fan_weight > 1.0 {
                fan_weight = 1.0;
            }
            if fan_weight > 0.0 {
                let bisection = (orig_c1[ax] + c1[ax]) / 2.0;
                c1[ax] += fan_weight * (bisection - c1[ax]);
                let tc1 = c1;
                ell.closest_point(&tc1, &mut c1, -1);
            }
        }
    }

    // Wrapping plane through p1, p2 and c1.
    let p1c1 = p1 - c1;
    let vs = unit_or_zero(&p1p2.cross(&p1c1));
    let vs4 = -vs.dot(&c1);
    calc_tangent_point(p1e, &mut r1, &p1, &m, &a, &vs, vs4);
    calc_tangent_point(p2e, &mut r2, &p2, &m, &a, &vs, vs4);

    let mut far_side_wrap = false;
    let (mut length, mut pts);
    loop {
        (length, pts) = distance_on_ellipsoid(&r1, &r2, &m, &a, &vs, vs4, far_side_wrap, factor);
        if wrap_sign != 0 && pts.len() > 2 && !far_side_wrap {
            let w1 = pts[1];
            let w2 = pts[pts.len() - 2];
            let r1p1 = unit_or_zero(&(p1 - r1));
            let r1w1 = unit_or_zero(&(w1 - r1));
            let r2p2 = unit_or_zero(&(p2 - r2));
            let r2w2 = unit_or_zero(&(w2 - r2));
            if r1p1.dot(&r1w1) > 0.0 || r2p2.dot(&r2w2) > 0.0 {
                far_side_wrap = true;
                continue;
            }
        }
        break;
    }

    WrapResult {
        action: WrapAction::MandatoryWrap,
        r1: r1 / factor,
        r2: r2 / factor,
        wrap_path_length: length / factor,
        wrap_points: pts.iter().map(|p| p * (1.0 / factor)).collect(),
        c1,
        sv,
    }
}

/// Ellipsoid (x/a)² + (y/b)² + (z/c)² = 1 in normalized coordinates.
struct Ell {
    a: V3,
}

impl Ell {
    /// `WrapEllipsoid::findClosestPoint`. `out` is left unchanged when the
    /// general-case Newton iteration does not converge (as in OpenSim).
    fn closest_point(&self, uvw: &V3, out: &mut V3, special_case_axis: i32) -> f64 {
        let (a, b, c) = (self.a[0], self.a[1], self.a[2]);
        let (u, v, w) = (uvw[0], uvw[1], uvw[2]);
        let mut axis = special_case_axis;
        if axis < 0 {
            let mut min_sum = f64::INFINITY;
            for i in 0..3 {
                if equal_within_error(0.0, uvw[i]) {
                    let sum: f64 = (0..3).filter(|j| *j != i).map(|j| self.a[j]).sum();
                    if min_sum > sum {
                        axis = i as i32;
                        min_sum = sum;
                    }
                }
            }
        }
        match axis {
            0 => {
                out[0] = u;
                let (y, z, d) = closest_point_to_ellipse(b, c, v, w);
                out[1] = y;
                out[2] = z;
                return d;
            }
            1 => {
                out[1] = v;
                let (z, x, d) = closest_point_to_ellipse(c, a, w, u);
                out[2] = z;
                out[0] = x;
                return d;
            }
            2 => {
                out[2] = w;
                let (x, y, d) = closest_point_to_ellipse(a, b, u, v);
                out[0] = x;
                out[1] = y;
                return d;
            }
            _ => {}
        }
        let (a2, b2, c2) = (a * a, b * b, c * c);
        let (a2u2, b2v2, c2w2) = (a2 * u * u, b2 * v * v, c2 * w * w);
        let mut t = if (u / a) * (u / a) + (v / b) * (v / b) + (w / c) * (w / c) < 1.0 {
            0.0
        } else {
            a.max(b).max(c) * (u * u + v * v + w * w).sqrt()
        };
        for _ in 0..64 {
            let p = t + a2;
            let q = t + b2;
            let r = t + c2;
            let (p2, q2, r2) = (p * p, q * q, r * r);
            let f = p2 * q2 * r2 - a2u2 * q2 * r2 - b2v2 * p2 * r2 - c2w2 * p2 * q2;
            if f.abs() < 1e-09 {
                *out = V3::new(a2 * u / p, b2 * v / q, c2 * w / r);
                return (*out - uvw).norm();
            }
            let (pq, pr, qr) = (p * q, p * r, q * r);
            let pqr = p * q * r;
            let fp = 2.0
                * (pqr * (qr + pr + pq)
                    - a2u2 * qr * (q + r)
                    - b2v2 * pr * (p + r)
                    - c2w2 * pq * (p + q));
            t -= f / fp;
        }
        -1.0
    }
}

/// `WrapEllipsoid::closestPointToEllipse`: (x, y, distance).
fn closest_point_to_ellipse(a: f64, b: f64, u: f64, v: f64) -> (f64, f64, f64) {
    let (a2, b2) = (a * a, b * b);
    let (a2u2, b2v2) = (a2 * u * u, b2 * v * v);
    let near_x = equal_within_error(0.0, u);
    let near_y = equal_within_error(0.0, v);
    if near_x && near_y {
        return if a < b {
            (if u < 0.0 { -a } else { a }, v, a)
        } else {
            (u, if v < 0.0 { -b } else { b }, b)
        };
    }
    if near_x {
        if a >= b || v.abs() >= b - a2 / b {
            let y = if v >= 0.0 { b } else { -b };
            return (u, y, (y - v).abs());
        }
        let y = b2 * v / (b2 - a2);
        let dy = y - v;
        let ydb = y / b;
        let x = a * (1.0 - ydb * ydb).abs().sqrt();
        return (x, y, (x * x + dy * dy).sqrt());
    }
    if near_y {
        if b >= a || u.abs() >= a - b2 / a {
            let x = if u >= 0.0 { a } else { -a };
            return (x, v, (x - u).abs());
        }
        let x = a2 * u / (a2 - b2);
        let dx = x - u;
        let xda = x / a;
        let y = b * (1.0 - xda * xda).abs().sqrt();
        return (x, y, (dx * dx + y * y).sqrt());
    }
    let mut t = if (u / a) * (u / a) + (v / b) * (v / b) < 1.0 {
        0.0
    } else {
        a.max(b) * (u * u + v * v).sqrt()
    };
    let (mut p, mut q) = (0.0, 0.0);
    for _ in 0..64 {
        p = t + a2;
        q = t + b2;
        let f = p * p * q * q - a2u2 * q * q - b2v2 * p * p;
        if f.abs() < 1e-09 {
            break;
        }
        let fp = 2.0 * (p * q * (p + q) - a2u2 * q - b2v2 * p);
        t -= f / fp;
    }
    let x = a2 * u / p;
    let y = b2 * v / q;
    let (dx, dy) = (x - u, y - v);
    (x, y, (dx * dx + dy * dy).sqrt())
}

/// Residuals of the tangent-point conditions (`ee` in OpenSim): r in the
/// plane, r on the ellipsoid, and the tangent plane at r (offset d1)
/// through r and through p.
fn residuals(r: &V3, d1: f64, p: &V3, m: &V3, a: &V3, vs: &V3, vs4: f64) -> [f64; 4] {
    let mut nr = V3::zeros();
    let mut e1 = -1.0;
    for i in 0..3 {
        nr[i] = 2.0 * (r[i] - m[i]) / (a[i] * a[i]);
        e1 += ((r[i] - m[i]) / a[i]).powi(2);
    }
    [vs.dot(r) + vs4, e1, nr.dot(r) + d1, nr.dot(p) + d1]
}

fn ssq_of(e: &[f64; 4]) -> f64 {
    e[0] * e[0] + e[1] * e[1] + e[2] * e[2] + e[3] * e[3]
}

/// `WrapEllipsoid::calcTangentPoint`: move r1 (starting from its current
/// value) to the point in the plane (vs, vs4) where the line from p1 is
/// tangent to the ellipsoid. Normalized coordinates.
fn calc_tangent_point(p1e: f64, r1: &mut V3, p1: &V3, m: &V3, a: &V3, vs: &V3, vs4: f64) {
    if p1e.abs() < 0.0001 {
        *r1 = *p1;
        return;
    }
    const MAXIT: usize = 50;
    const MAXIT2: usize = 1000;
    let mut alpha = 0.01;
    let mut nr1 = V3::zeros();
    for i in 0..3 {
        nr1[i] = 2.0 * (r1[i] - m[i]) / (a[i] * a[i]);
    }
    let mut d1 = -nr1.dot(r1);
    let mut ee = residuals(r1, d1, p1, m, a, vs, vs4);
    let mut ssqo = ssq_of(&ee);
    let mut ssq = ssqo;
    let mut nit = 0;
    while ssq > ELLIPSOID_TINY && nit < MAXIT {
        nit += 1;
        let mut dedth = Matrix4::<f64>::zeros();
        for i in 0..3 {
            let a2 = a[i] * a[i];
            dedth[(i, 0)] = vs[i];
            dedth[(i, 1)] = 2.0 * (r1[i] - m[i]) / a2;
            dedth[(i, 2)] = 2.0 * (2.0 * r1[i] - m[i]) / a2;
            dedth[(i, 3)] = 2.0 * p1[i] / a2;
        }
        dedth[(3, 2)] = 1.0;
        dedth[(3, 3)] = 1.0;
        let p1r1 = unit_or_zero(&(p1 - *r1));
        let p1m = unit_or_zero(&(p1 - m));
        let pcos = p1r1.dot(&p1m);
        let dd = if pcos > 0.1 {
            1.0 - pcos.powi(100)
        } else {
            1.0
        };
        let mut v = [0.0; 4];
        for i in 0..4 {
            for j in 0..4 {
                v[i] -= dedth[(i, j)] * ee[j];
            }
        }
        let mut dedth2 = dedth * dedth.transpose();
        let diag = [
            dedth2[(0, 0)],
            dedth2[(1, 1)],
            dedth2[(2, 2)],
            dedth2[(3, 3)],
        ];
        let mut vt = [0.0; 4];
        let mut nit2 = 0;
        while ssq >= ssqo && nit2 < MAXIT2 {
            for i in 0..4 {
                dedth2[(i, i)] = diag[i] * (1.0 + alpha);
            }
            let inv = match dedth2.try_inverse() {
                Some(inv) => inv,
                None => return,
            };
            for i in 0..4 {
                vt[i] = 0.0;
                for j in 0..4 {
                    vt[i] += dd * inv[(i, j)] * v[j] / 16.0;
                }
            }
            for i in 0..3 {
                r1[i] += vt[i];
            }
            d1 += vt[3];
            ee = residuals(r1, d1, p1, m, a, vs, vs4);
            ssqo = ssq;
            ssq = ssq_of(&ee);
            alpha *= 4.0;
            nit2 += 1;
        }
        alpha /= 8.0;
        let mut fakt = 0.5;
        nit2 = 0;
        while ssq <= ssqo && nit2 < MAXIT2 {
            fakt *= 2.0;
            for i in 0..3 {
                r1[i] += vt[i] * fakt;
            }
            d1 += vt[3] * fakt;
            ee = residuals(r1, d1, p1, m, a, vs, vs4);
            ssqo = ssq;
            ssq = ssq_of(&ee);
            nit2 += 1;
        }
        for i in 0..3 {
            r1[i] -= vt[i] * fakt;
        }
        d1 -= vt[3] * fakt;
        ee = residuals(r1, d1, p1, m, a, vs, vs4);
        ssq = ssq_of(&ee);
        ssqo = ssq;
    }
}

/// `WrapEllipsoid::CalcDistanceOnEllipsoid`: polyline on the ellipsoid in
/// the wrapping plane from r1 to r2 (normalized coordinates). Returns the
/// (normalized) length and the points.
#[allow(clippy::too_many_arguments)]
fn distance_on_ellipsoid(
    r1: &V3,
    r2: &V3,
    m: &V3,
    a: &V3,
    vs: &V3,
    vs4: f64,
    far_side_wrap: bool,
    factor: f64,
) -> (f64, Vec<V3>) {
    const DESIRED_SEG_LENGTH: f64 = 0.001;
    let len = (r1 - r2).norm() / factor;
    if len < DESIRED_SEG_LENGTH {
        return (len * factor, vec![*r1, *r2]);
    }
    let n_seg = ((len / DESIRED_SEG_LENGTH) as i64).min(499);
    if n_seg <= 0 {
        // Unreachable for finite len ≥ 1 mm; OpenSim returns len unscaled
        // and no points here.
        return (len, Vec::new());
    }
    let n_seg = n_seg as usize;
    let n_interior = n_seg - 1;
    let mut imax = 0;
    for i in 1..3 {
        if vs[i].abs() > vs[imax].abs() {
            imax = i;
        }
    }
    let mut u = V3::zeros();
    u[imax] = 1.0;
    let mu = (-vs.dot(m) - vs4) / vs.dot(&u);
    let a0 = m + mu * u;
    let ar1 = unit_or_zero(&(r1 - a0));
    let ar2 = unit_or_zero(&(r2 - a0));
    let phi0 = ar1.dot(&ar2).acos();
    let dphi = if far_side_wrap {
        -(2.0 * PI - phi0) / n_seg as f64
    } else {
        phi0 / n_seg as f64
    };
    let vsz = unit_or_zero(&ar1.cross(&ar2));
    let vsy = vsz.cross(&ar1);
    let mut pts = Vec::with_capacity(n_seg + 1);
    pts.push(*r1);
    let f2 = (a0 - m).component_div(a);
    for i in 0..n_interior {
        let phi = (i + 1) as f64 * dphi;
        let r = ar1 * phi.cos() + vsy * phi.sin();
        let f1 = r.component_div(a);
        let aa = f1.dot(&f1);
        let bb = 2.0 * f1.dot(&f2);
        let cc = f2.dot(&f2) - 1.0;
        let mu3 = (-bb + (bb * bb - 4.0 * aa * cc).sqrt()) / (2.0 * aa);
        pts.push(a0 + mu3 * r);
    }
    pts.push(*r2);
    let length = pts.windows(2).map(|w| (w[1] - w[0]).norm()).sum();
    (length, pts)
}
