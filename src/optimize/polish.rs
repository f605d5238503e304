//! Polishing an interior-point answer to the exact optimum (exponent 2).
//!
//! An interior-point method stops short of the bounds it will end on: at
//! tolerance 1e-10 Clarabel leaves activations that belong at 0 or 1 up to
//! ~1e-6 away from them, and every other variable off by as much through
//! the equations. The exact optimum of
//!
//! ```text
//! minimise Σ w_i x_i²  subject to  A x = b,  x in C
//! ```
//!
//! is, once it is known which constraints of C hold with equality, the
//! solution of one linear system. [`polish`] reads that active set off the
//! interior-point answer, solves the system, corrects the guess for bounds
//! a few times as a primal–dual active-set method would (free variables
//! beyond a bound join it; variables at a bound whose multiplier has the
//! wrong sign are freed) and returns the answer only when it passes the
//! same certificate as the dual Newton solver's
//! ([`super::dual::optimality_violation`] with the system's multipliers,
//! the equations to [`super::dual::RESIDUAL_TOLERANCE`], bounds and cones
//! exactly): it is then the optimum, up to rounding.
//!
//! With the active constraints as equalities every piece of C is a linear
//! subspace, so the free part is a set of *generalised variables* g, each a
//! fixed combination x = Σ e_k g of problem variables: a variable on its
//! own; a static contact at rest (fixed at 0), strictly inside its friction
//! set (three free variables), on one face of a pyramid (λ = n (1, μ c) +
//! τ (0, c⊥): two), on an edge of a pyramid or the surface of the cone
//! (λ = n (1, μ d): one, d the edge's corner or the shear's direction).
//! For g with column a_g = A e_g and weight w_g = Σ w e_k², x_g = a_gᵀ y /
//! 2 w_g where (Σ a_g a_gᵀ / 2 w_g) y = b − A x_fixed. On the cone the
//! direction d is itself unknown: it is updated to the direction of the
//! shear pull (Aᵀy)_s, which the optimum's has, until it no longer moves.
//!
//! The linear algebra is nalgebra's (Cholesky; SVD when singular): the
//! method shares no code with the dual Newton solver, so it is an
//! independent reference for it (tests/dual_newton.rs).
use nalgebra::{DMatrix, DVector};

use super::dual::{optimality_violation, RESIDUAL_TOLERANCE};
use super::friction::{FrictionModel, StaticContact};
use super::problem::FrameProblem;

/// Active-set corrections and cone-direction updates tried before giving up.
const MAX_ROUNDS: usize = 40;
/// A Newton step on (y, φ) this small (relative in y, in radians in φ)
/// that no longer reduces the residual is taken for its rounding floor.
const ROUNDING_STEP: f64 = 1e-11;
/// Certificate required of a polished answer (as of a Newton answer).
const OPTIMALITY_TOLERANCE: f64 = 1e-9;
/// A constraint is guessed active when the interior-point answer is within
/// this fraction of the variable's range (or of its size) of it.
const ACTIVE: f64 = 1e-6;

#[derive(Debug, Clone, Copy, PartialEq)]
enum Var {
    Free,
    /// Fixed at this value (a bound).
    At(f64),
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Contact {
    Rest,
    Inside,
    /// On the pyramid face with unit normal c (c·λs = μ λn).
    Face([f64; 2]),
    /// λs = μ λn d: a pyramid's edge (d its corner) or the cone's surface
    /// (d a unit vector).
    Ray([f64; 2]),
}

/// The exact optimum near `x` (an interior-point answer), with one
/// multiplier per equation, or None when the active set cannot be
/// identified or the answer fails the certificate. Exponent 2 only.
pub fn polish(p: &FrameProblem, x: &[f64]) -> Option<(Vec<f64>, Vec<f64>)> {
    let n = p.n_var();
    if p.exponent != 2.0 || x.len() != n || x.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let friction: Vec<&StaticContact> = p.static_contacts.iter().filter(|c| c.mu > 0.0).collect();
    let mut in_contact = vec![false; n];
    for c in &friction {
        for v in [c.normal, c.shear[0], c.shear[1]] {
            in_contact[v] = true;
        }
    }
    let mut vars = vec![Var::Free; n];
    for c in p.static_contacts.iter().filter(|c| c.mu == 0.0) {
        for s in c.shear {
            // Without friction the shears are 0.
            in_contact[s] = true;
            vars[s] = Var::At(0.0);
        }
    }
    let size = x.iter().fold(1.0f64, |m, v| m.max(v.abs()));
    for j in (0..n).filter(|&j| !in_contact[j]) {
        let (lo, hi) = (p.lower[j], p.upper[j]);
        let width = if (hi - lo).is_finite() { hi - lo } else { size };
        if lo == hi || x[j] - lo <= ACTIVE * width {
            vars[j] = Var::At(lo);
        } else if hi - x[j] <= ACTIVE * width {
            vars[j] = Var::At(hi);
        } else if p.weights[j] <= 0.0 {
            return None;
        }
    }
    let mut contacts = Vec::with_capacity(friction.len());
    for c in &friction {
        let (nv, s) = (x[c.normal], [x[c.shear[0]], x[c.shear[1]]]);
        if p.weights[c.normal] <= 0.0 {
            return None;
        }
        contacts.push(if nv <= ACTIVE * size {
            Contact::Rest
        } else {
            classify(p.friction, c.mu, nv, s)?
        });
    }

    for _ in 0..MAX_ROUNDS {
        let (xp, y) = solve_active(p, &friction, &vars, &mut contacts)?;
        let aty = p.a.tr_mul(&DVector::from_column_slice(&y));
        let mut changed = false;
        for j in (0..n).filter(|&j| !in_contact[j]) {
            let (lo, hi) = (p.lower[j], p.upper[j]);
            if lo == hi {
                continue;
            }
            let g = 2.0 * p.weights[j] * xp[j] - aty[j];
            let tol = 1e-12
                * aty[j]
                    .abs()
                    .max(2.0 * p.weights[j] * xp[j].abs())
                    .max(1e-300);
            match vars[j] {
                Var::Free if xp[j] < lo => {
                    vars[j] = Var::At(lo);
                    changed = true;
                }
                Var::Free if xp[j] > hi => {
                    vars[j] = Var::At(hi);
                    changed = true;
                }
                // A bound's multiplier must push inwards.
                Var::At(v) if (v == lo && g < -tol) || (v == hi && g > tol) => {
                    if p.weights[j] <= 0.0 {
                        return None;
                    }
                    vars[j] = Var::Free;
                    changed = true;
                }
                _ => {}
            }
        }
        if changed {
            continue;
        }
        let bmax = p.b.amax();
        let ok = p.eq_residual(&xp) <= RESIDUAL_TOLERANCE * bmax.max(1.0)
            && optimality_violation(p, &xp, &y) <= OPTIMALITY_TOLERANCE
            && (0..n).all(|j| xp[j] >= p.lower[j] && xp[j] <= p.upper[j])
            && friction
                .iter()
                .all(|c| p.friction.violation(c, &xp) <= 1e-12 * xp[c.normal].abs());
        return ok.then_some((xp, y));
    }
    None
}

/// The state of a loaded static contact (normal n > 0, shear s) read off an
/// interior-point answer: inside, on a face, on an edge (or the cone's
/// surface); None when it touches more faces than an edge has.
fn classify(model: FrictionModel, mu: f64, n: f64, s: [f64; 2]) -> Option<Contact> {
    let limit = mu * n;
    let near = ACTIVE * limit.max(s[0].hypot(s[1]));
    match model {
        FrictionModel::Cone => Some(if s[0].hypot(s[1]) < limit - near {
            Contact::Inside
        } else {
            let r = s[0].hypot(s[1]);
            Contact::Ray([s[0] / r, s[1] / r])
        }),
        _ => {
            let active: Vec<(f64, f64)> = model
                .facets()
                .iter()
                .copied()
                .filter(|(c1, c2)| c1 * s[0] + c2 * s[1] >= limit - near)
                .collect();
            match active[..] {
                [] => Some(Contact::Inside),
                [(c1, c2)] => Some(Contact::Face([c1, c2])),
                [(a1, b1), (a2, b2)] => {
                    // The corner: c·d = 1 on both faces.
                    let det = a1 * b2 - a2 * b1;
                    (det.abs() > 1e-9).then(|| Contact::Ray([(b2 - b1) / det, (a1 - a2) / det]))
                }
                _ => None,
            }
        }
    }
}

/// The minimiser with the active set fixed, and its multipliers; None when
/// the reduced system is numerically unusable. On the cone's surface the
/// shear direction d = (cos φ, sin φ) of a contact is unknown too: (y, φ)
/// then solve the equations by Newton's method, the extra equation of each
/// such contact being that the shear pull (Aᵀy)_s has no component across
/// d (stationarity in φ); `contacts` receives the directions found.
fn solve_active(
    p: &FrameProblem,
    friction: &[&StaticContact],
    vars: &[Var],
    contacts: &mut [Contact],
) -> Option<(Vec<f64>, Vec<f64>)> {
    let m = p.n_eq();
    let on_cone: Vec<usize> = if p.friction == FrictionModel::Cone {
        (0..contacts.len())
            .filter(|&k| matches!(contacts[k], Contact::Ray(_)))
            .collect()
    } else {
        Vec::new()
    };
    let (mut h, rhs, mut gens) = reduced_system(p, friction, vars, contacts);
    let mut y = linear_solve(&h, &rhs)?;
    if !on_cone.is_empty() {
        let k = on_cone.len();
        let mut phi: Vec<f64> = on_cone
            .iter()
            .map(|&c| match contacts[c] {
                Contact::Ray(d) => d[1].atan2(d[0]),
                _ => unreachable!(),
            })
            .collect();
        let mut converged = false;
        // The residual of the previous iteration: once a small step no
        // longer cuts it, Newton has reached the rounding floor.
        let mut last_f = f64::INFINITY;
        for _ in 0..30 {
            // F = [H(φ) y − rhs; t_cᵀ A_sᵀ y], J = ∂F/∂(y, φ).
            let mut f = DVector::<f64>::zeros(m + k);
            f.rows_mut(0, m).copy_from(&(&h * &y - &rhs));
            let mut jac = DMatrix::<f64>::zeros(m + k, m + k);
            jac.view_mut((0, 0), (m, m)).copy_from(&h);
            for (i, &c) in on_cone.iter().enumerate() {
                let ct = friction[c];
                let (s1, s2) = (p.a.column(ct.shear[0]), p.a.column(ct.shear[1]));
                let (d, t) = ([phi[i].cos(), phi[i].sin()], [-phi[i].sin(), phi[i].cos()]);
                let a_c = p.a.column(ct.normal) + (s1 * (ct.mu * d[0])) + (s2 * (ct.mu * d[1]));
                let a_t = (s1 * t[0] + s2 * t[1]) * ct.mu;
                let w_c = p.weights[ct.normal] * (1.0 + ct.mu * ct.mu);
                let d_col = (&a_t * a_c.dot(&y) + &a_c * a_t.dot(&y)) / (2.0 * w_c);
                jac.view_mut((0, m + i), (m, 1)).copy_from(&d_col);
                let pull = [s1.dot(&y), s2.dot(&y)];
                f[m + i] = t[0] * pull[0] + t[1] * pull[1];
                let row = s1 * t[0] + s2 * t[1];
                jac.view_mut((m + i, 0), (1, m)).copy_from(&row.transpose());
                jac[(m + i, m + i)] = -(d[0] * pull[0] + d[1] * pull[1]);
            }
            let step = jac.lu().solve(&(-&f))?;
            if step.iter().any(|v| !v.is_finite()) {
                return None;
            }
            y += step.rows(0, m);
            for i in 0..k {
                phi[i] += step[m + i];
            }
            for (i, &c) in on_cone.iter().enumerate() {
                contacts[c] = Contact::Ray([phi[i].cos(), phi[i].sin()]);
            }
            (h, _, gens) = reduced_system(p, friction, vars, contacts);
            let ystep = step.rows(0, m).amax() / y.amax().max(1e-300);
            let phistep = step.rows(m, k).amax();
            // Converged when the step is at the rounding of y and φ; or
            // when a step within ROUNDING_STEP has stopped reducing F
            // (a contact whose shear pull is small has φ defined to ~1e-13
            // only). The certificate below decides either way.
            let fmax = f.amax();
            let floor = ystep <= ROUNDING_STEP && phistep <= ROUNDING_STEP && fmax > 0.25 * last_f;
            if (ystep <= 1e-14 && phistep <= 1e-14) || floor {
                converged = true;
                break;
            }
            last_f = fmax;
        }
        if !converged {
            return None;
        }
        // Newton's y, not H⁻¹ rhs afresh: where H is singular (an equation
        // no free variable enters alone) the φ equations are what pick y.
    }
    let mut x = vec![0.0; p.n_var()];
    for (j, v) in vars.iter().enumerate() {
        if let Var::At(v) = v {
            x[j] = *v;
        }
    }
    for (combo, w, col) in &gens {
        let g = col.dot(&y) * 0.5 / w;
        for &(j, k) in combo {
            x[j] += k * g;
        }
    }
    Some((x, y.as_slice().to_vec()))
}

/// A generalised variable: x = Σ coef e_j g, its weight and its column A e.
type Gen = (Vec<(usize, f64)>, f64, DVector<f64>);

/// H = Σ a_g a_gᵀ / 2 w_g over the free generalised variables, the right-hand
/// side b − A x_fixed, and the variables.
fn reduced_system(
    p: &FrameProblem,
    friction: &[&StaticContact],
    vars: &[Var],
    contacts: &[Contact],
) -> (DMatrix<f64>, DVector<f64>, Vec<Gen>) {
    let (m, n) = (p.n_eq(), p.n_var());
    let mut rhs = p.b.clone();
    let mut combos: Vec<(Vec<(usize, f64)>, f64)> = Vec::new();
    let mut in_contact = vec![false; n];
    for (c, state) in friction.iter().zip(contacts) {
        let (nv, s1, s2, w, mu) = (c.normal, c.shear[0], c.shear[1], p.weights[c.normal], c.mu);
        for v in [nv, s1, s2] {
            in_contact[v] = true;
        }
        match *state {
            Contact::Rest => {}
            Contact::Inside => {
                for v in [nv, s1, s2] {
                    combos.push((vec![(v, 1.0)], p.weights[v]));
                }
            }
            Contact::Face(c) => {
                combos.push((
                    vec![(nv, 1.0), (s1, mu * c[0]), (s2, mu * c[1])],
                    w * (1.0 + mu * mu),
                ));
                combos.push((vec![(s1, -c[1]), (s2, c[0])], w));
            }
            Contact::Ray(d) => {
                let combo = vec![(nv, 1.0), (s1, mu * d[0]), (s2, mu * d[1])];
                combos.push((combo, w * (1.0 + mu * mu * (d[0] * d[0] + d[1] * d[1]))));
            }
        }
    }
    for j in (0..n).filter(|&j| !in_contact[j]) {
        match vars[j] {
            Var::At(v) => {
                if v != 0.0 {
                    rhs.axpy(-v, &p.a.column(j), 1.0);
                }
            }
            Var::Free => combos.push((vec![(j, 1.0)], p.weights[j])),
        }
    }
    let mut h = DMatrix::<f64>::zeros(m, m);
    let gens = combos
        .into_iter()
        .map(|(combo, w)| {
            let mut col = DVector::<f64>::zeros(m);
            for &(j, k) in &combo {
                col.axpy(k, &p.a.column(j), 1.0);
            }
            h.ger(0.5 / w, &col, &col, 1.0);
            (combo, w, col)
        })
        .collect();
    (h, rhs, gens)
}

/// H y = rhs: Cholesky, or the least-squares solution by SVD when H is
/// singular (equations no free variable enters).
fn linear_solve(h: &DMatrix<f64>, rhs: &DVector<f64>) -> Option<DVector<f64>> {
    let hmax = h.diagonal().amax();
    if !(hmax.is_finite() && hmax > 0.0) {
        return None;
    }
    let y = match h.clone().cholesky() {
        Some(ch) => ch.solve(rhs),
        None => h.clone().svd(true, true).solve(rhs, 1e-13 * hmax).ok()?,
    };
    y.iter().all(|v| v.is_finite()).then_some(y)
}
