//! `WrapTorus::wrapLine` (opensim-semantics §5.4, WrapTorus.cpp).
//!
//! 1. Find the point of the centre circle (radius `outer_radius`, z = 0)
//!    closest to the muscle line: two least-squares solves (MINPACK
//!    `lmdif`, from each endpoint; ftol = xtol = 1e-4, step bound 0.2,
//!    forward-difference step 1e-5, ≤ 500 evaluations), choosing the better
//!    one (or the one on the active side for a constrained quadrant).
//! 2. Place a cylinder of radius `inner_radius`, length 10000, tangent to
//!    the circle at that point, quadrant "+x" pointing to the torus centre,
//!    and wrap over it with the cylinder algorithm.
//!
//! OpenSim always returns `wrapped` here; when the cylinder does not wrap
//! its point list is empty and `GeometryPath` does not insert the wrap
//! (`WrapResult::wraps()` is false). We keep that behaviour.

use nalgebra::Matrix3;

use super::cylinder::wrap_cylinder;
use super::math::*;
use super::types::{Quadrant, WrapAction, WrapResult};

const CYL_LENGTH: f64 = 10000.0;

pub fn wrap_torus(
    inner_radius: f64,
    outer_radius: f64,
    quadrant: Quadrant,
    p1: V3,
    p2: V3,
    single_wrap: bool,
) -> WrapResult {
    let closest = match find_closest_point(outer_radius, &p1, &p2, quadrant) {
        Some(c) => c,
        None => return WrapResult::no_wrap(WrapAction::NoWrap, p1, p2),
    };
    // Cylinder frame: x towards the torus centre, y = −z_torus, z = x × y.
    let cx = unit_or_zero(&(-closest));
    let cy = V3::new(0.0, 0.0, -1.0);
    let cz = cx.cross(&cy);
    let rot = Matrix3::from_rows(&[cx.transpose(), cy.transpose(), cz.transpose()]);
    let to_cyl = |p: &V3| rot * (p - closest);
    let to_torus = |p: &V3| rot.transpose() * p + closest;
    let q1 = to_cyl(&p1);
    let q2 = to_cyl(&p2);
    let plus_x = Quadrant::Axis { axis: 0, sign: 1 };
    let res = wrap_cylinder(inner_radius, CYL_LENGTH, plus_x, q1, q2, single_wrap);
    if !matches!(res.action, WrapAction::Wrapped | WrapAction::MandatoryWrap) {
        // OpenSim: code `wrapped`, but no tangent points / surface points,
        // so the wrap is never used.
        return WrapResult::no_wrap(WrapAction::Wrapped, p1, p2);
    }
    WrapResult {
        action: WrapAction::Wrapped,
        r1: to_torus(&res.r1),
        r2: to_torus(&res.r2),
        wrap_path_length: res.wrap_path_length,
        wrap_points: res.wrap_points.iter().map(to_torus).collect(),
        c1: V3::zeros(),
        sv: V3::zeros(),
    }
}

/// `WrapTorus::findClosestPoint`: the point of the centre circle closest
/// to the line p1–p2, or `None` when constrained and neither candidate is
/// on the active side.
fn find_closest_point(radius: f64, p1: &V3, p2: &V3, quadrant: Quadrant) -> Option<V3> {
    let pass = |a: &V3, b: &V3| -> (V3, f64) {
        let n = (b - a) / (b - a).norm();
        let c2 = 2.0 * a.dot(&n);
        let c3 = a[0] * n[0] + a[1] * n[1];
        let c4 = n[0] * n[0] + n[1] * n[1];
        let c5 = a[0] * a[0] + a[1] * a[1];
        let resid = |u: f64| {
            c2 + 2.0 * u
                - 2.0 * radius * (2.0 * c4 * u + 2.0 * c3) / (u * u * c4 + 2.0 * c3 * u + c5).sqrt()
        };
        let u = lmdif_1d(resid, 0.0, 1e-4, 1e-4, 0.0, 500, 0.2);
        let x = a + u * n;
        let rho = (x[0] * x[0] + x[1] * x[1]).sqrt();
        let dist = (x.norm_squared() + radius * radius - 2.0 * radius * rho).sqrt();
        (x, dist)
    };
    let (a1, d1) = pass(p1, p2);
    let (a2, d2) = pass(p2, p1);
    let better_first = match quadrant {
        Quadrant::All => d1 < d2,
        Quadrant::Axis { axis, sign } => {
            let on1 = dsign(a1[axis]) == sign;
            let on2 = dsign(a2[axis]) == sign;
            if on1 && on2 {
                d1 < d2
            } else if on1 {
                true
            } else if on2 {
                false
            } else {
                return None;
            }
        }
    };
    let a = if better_first { a1 } else { a2 };
    let mag = (a[0] * a[0] + a[1] * a[1]).sqrt();
    Some(V3::new(a[0] * radius / mag, a[1] * radius / mag, 0.0))
}

/// OpenSim's `lmdif_C` (MINPACK Levenberg–Marquardt with OpenSim's
/// changes: fixed forward-difference step 1e-5, initial step bound
/// `factor` when |x0| is tiny) specialised to one residual and one
/// unknown. Returns the final x.
fn lmdif_1d(
    fcn: impl Fn(f64) -> f64,
    x0: f64,
    ftol: f64,
    xtol: f64,
    gtol: f64,
    maxfev: usize,
    factor: f64,
) -> f64 {
    const MACHEP: f64 = 1.2e-16;
    const DWARF: f64 = 1.0e-38;
    let mut x = x0;
    let mut fvec = fcn(x);
    let mut nfev = 1usize;
    let mut fnorm = fvec.abs();
    let mut par = 0.0;
    let mut iter = 1;
    let mut diag = 0.0;
    let mut delta = 0.0;
    let mut xnorm = 0.0;
    loop {
        // fdjac2
        let h = 1e-5;
        let jac = (fcn(x + h) - fvec) / h;
        // qrfac (1×1): R = −jac, Qᵀf = −f (f if jac = 0).
        let acnorm = jac.abs();
        let r = -jac;
        let qtf = if jac != 0.0 { -fvec } else { fvec };
        if iter == 1 {
            diag = if acnorm == 0.0 { 1.0 } else { acnorm };
            xnorm = (diag * x).abs();
            delta = factor * xnorm;
            if delta.abs() <= 1e-4 {
                delta = factor;
            }
        }
        let mut gnorm = 0.0;
        if fnorm != 0.0 && acnorm != 0.0 {
            gnorm = ((r * (qtf / fnorm)) / acnorm).abs();
        }
        if gnorm <= gtol {
            return x;
        }
        diag = diag.max(acnorm);
        loop {
            // L200
            let step = lmpar_1d(r, diag, qtf, delta, &mut par, DWARF);
            let wa1 = -step;
            let wa2 = x + wa1;
            let pnorm = (diag * wa1).abs();
            if iter == 1 {
                delta = delta.min(pnorm);
            }
            let fnew = fcn(wa2);
            nfev += 1;
            let fnorm1 = fnew.abs();
            let mut actred = -1.0;
            if 0.1 * fnorm1 < fnorm {
                let t = fnorm1 / fnorm;
                actred = 1.0 - t * t;
            }
            let temp1 = (r * wa1).abs() / fnorm;
            let temp2 = (par.sqrt() * pnorm) / fnorm;
            let prered = temp1 * temp1 + (temp2 * temp2) / 0.5;
            let dirder = -(temp1 * temp1 + temp2 * temp2);
            let ratio = if prered != 0.0 { actred / prered } else { 0.0 };
            if ratio <= 0.25 {
                let mut temp = if actred >= 0.0 {
                    0.5
                } else {
                    0.5 * dirder / (dirder + 0.5 * actred)
                };
                if 0.1 * fnorm1 >= fnorm || temp < 0.1 {
                    temp = 0.1;
                }
                delta = temp * delta.min(pnorm / 0.1);
                par /= temp;
            } else if par == 0.0 || ratio >= 0.75 {
                delta = pnorm / 0.5;
                par *= 0.5;
            }
            if ratio >= 1e-4 {
                x = wa2;
                fvec = fnew;
                xnorm = (diag * x).abs();
                fnorm = fnorm1;
                iter += 1;
            }
            let small = actred.abs() <= ftol && prered <= ftol && 0.5 * ratio <= 1.0;
            if small || delta <= xtol * xnorm {
                return x;
            }
            if nfev >= maxfev
                || (actred.abs() <= MACHEP && prered <= MACHEP && 0.5 * ratio <= 1.0)
                || delta <= MACHEP * xnorm
                || gnorm <= MACHEP
            {
                return x;
            }
            if !x.is_finite() {
                return x;
            }
            if ratio >= 1e-4 {
                break; // back to L30 (new Jacobian)
            }
        }
    }
}

/// MINPACK `lmpar` for n = 1 (with `qrsolv`). Returns the step x solving
/// r·x ≈ qtb with the Levenberg–Marquardt parameter `par` updated.
fn lmpar_1d(r: f64, diag: f64, qtb: f64, delta: f64, par: &mut f64, dwarf: f64) -> f64 {
    let nsing_full = r != 0.0;
    let mut x = if nsing_full { qtb / r } else { 0.0 };
    let mut wa2 = diag * x;
    let mut dxnorm = wa2.abs();
    let mut fp = dxnorm - delta;
    if fp <= 0.1 * delta {
        *par = 0.0;
        return x;
    }
    let mut parl = 0.0;
    if nsing_full {
        let wa1 = diag * (wa2 / dxnorm) / r;
        let temp = wa1.abs();
        parl = ((fp / delta) / temp) / temp;
    }
    let gnorm = (r * qtb / diag).abs();
    let mut paru = gnorm / delta;
    if paru == 0.0 {
        paru = dwarf / delta.min(0.1);
    }
    *par = par.max(parl).min(paru);
    if *par == 0.0 {
        *par = gnorm / dxnorm;
    }
    let mut iter = 0;
    loop {
        iter += 1;
        if *par == 0.0 {
            *par = dwarf.max(0.001 * paru);
        }
        let d = par.sqrt() * diag;
        // qrsolv (1×1): Givens rotation eliminating d against r.
        let (mut sdiag, mut wa) = (r, qtb);
        if d != 0.0 {
            let (s, c);
            if r.abs() < d.abs() {
                let cotan = r / d;
                s = 0.5 / (0.25 + 0.25 * cotan * cotan).sqrt();
                c = s * cotan;
            } else {
                let tan = d / r;
                c = 0.5 / (0.25 + 0.25 * tan * tan).sqrt();
                s = c * tan;
            }
            sdiag = c * r + s * d;
            wa *= c;
        }
        x = if sdiag != 0.0 { wa / sdiag } else { 0.0 };
        wa2 = diag * x;
        dxnorm = wa2.abs();
        let temp = fp;
        fp = dxnorm - delta;
        if fp.abs() <= 0.1 * delta || (parl == 0.0 && fp <= temp && temp < 0.0) || iter == 10 {
            return x;
        }
        let wa1 = diag * (wa2 / dxnorm) / sdiag;
        let t = wa1.abs();
        let parc = ((fp / delta) / t) / t;
        if fp > 0.0 {
            parl = parl.max(*par);
        }
        if fp < 0.0 {
            paru = paru.min(*par);
        }
        *par = parl.max(*par + parc);
    }
}
