//! Tests of the per-frame optimisation. Every expected value is derived in
//! closed form (or by a brute-force 1-D search) in the test itself.
#![allow(clippy::needless_range_loop)]
use nalgebra::{DMatrix, DVector};

use super::*;

const INF: f64 = f64::INFINITY;

fn problem(
    rows: &[&[f64]],
    b: &[f64],
    weights: &[f64],
    lower: &[f64],
    upper: &[f64],
) -> FrameProblem {
    let n = weights.len();
    let a = DMatrix::from_fn(rows.len(), n, |i, j| rows[i][j]);
    FrameProblem {
        a,
        b: DVector::from_column_slice(b),
        weights: weights.to_vec(),
        exponent: 2.0,
        lower: lower.to_vec(),
        upper: upper.to_vec(),
        static_contacts: Vec::new(),
        friction: FrictionModel::Pyramid4,
        settings: SolveSettings::default(),
    }
}

fn assert_close(got: f64, want: f64, tol: f64, what: &str) {
    assert!(
        (got - want).abs() <= tol,
        "{what}: got {got:.12e}, want {want:.12e} (diff {:.3e} > {tol:.1e})",
        (got - want).abs()
    );
}

// ---------------------------------------------------------------------
// OpenSim-like static optimisation of one coordinate.
// minimise Σ a_i² s.t. Σ r_i a_i = τ. Lagrange: 2 a_i = ν r_i, so
// a_i = τ r_i / Σ r_j² when no bound is active.

const R: [f64; 4] = [20.0, 35.0, 15.0, 50.0];

fn so_problem(tau: f64) -> FrameProblem {
    // OpenSim muscle bounds [0.01, 1] (§6.4).
    problem(&[&R], &[tau], &[1.0; 4], &[0.01; 4], &[1.0; 4])
}

#[test]
fn so_closed_form_with_inactive_bounds() {
    let tau = 30.0;
    let sol = solve(&so_problem(tau));
    assert_eq!(sol.status, SolveStatus::Solved);
    let sum_r2: f64 = R.iter().map(|r| r * r).sum();
    for i in 0..4 {
        assert_close(sol.x[i], tau * R[i] / sum_r2, 1e-8, &format!("a[{i}]"));
    }
    assert!(sol.eq_residual < 1e-8, "residual {}", sol.eq_residual);
    let want_obj: f64 = R.iter().map(|r| (tau * r / sum_r2).powi(2)).sum();
    assert_close(sol.objective, want_obj, 1e-8, "objective");
    assert!(sol.iterations > 0);
}

#[test]
fn so_closed_form_with_active_upper_bound() {
    // τ = 100: unconstrained a_4 = 100·50/4350 = 1.149 > 1, so a_4 = 1 and
    // the others share τ' = τ − r_4: a_i = τ' r_i / Σ_{j≠4} r_j² (all < 1).
    // KKT: ν = 2τ'/Σ' = 0.054 and ∂/∂a_4 = 2·1 − ν·50 < 0 (pushes upward
    // against the bound), so this is the optimum.
    let tau = 100.0;
    let sol = solve(&so_problem(tau));
    assert_eq!(sol.status, SolveStatus::Solved);
    let rest = tau - R[3];
    let sum_r2: f64 = R[..3].iter().map(|r| r * r).sum();
    for i in 0..3 {
        assert_close(sol.x[i], rest * R[i] / sum_r2, 1e-7, &format!("a[{i}]"));
    }
    assert_close(sol.x[3], 1.0, 1e-7, "a[3] at its upper bound");
}

#[test]
fn so_infeasible_frame_reports_status_and_elastic_x() {
    // Σ r_i · 1 = 120 < τ = 200: no activation in [0.01, 1] reaches τ.
    for exponent in [2.0, 3.0] {
        let mut p = so_problem(200.0);
        p.exponent = exponent;
        let sol = solve(&p);
        assert_eq!(sol.status, SolveStatus::Infeasible);
        assert!(!sol.status.is_ok());
        assert_eq!(sol.x.len(), 4);
        for &xi in &sol.x {
            assert!(
                xi.is_finite() && (0.01..=1.0).contains(&xi),
                "x = {:?}",
                sol.x
            );
        }
        // The elastic re-solve gets as close as the bounds allow: every muscle
        // at full activation, leaving 200 − 120 = 80 unbalanced.
        for (i, &xi) in sol.x.iter().enumerate() {
            assert_close(xi, 1.0, 1e-4, &format!("elastic a[{i}]"));
        }
        assert_close(sol.eq_residual, 80.0, 1e-3, "residual");
    }
}

// ---------------------------------------------------------------------
// Krüger & Wartzack (2017) Figure 5: block on an incline.
//
// Block of mass m on a slope of angle θ; one muscle pulls up-slope with
// force a·F_m; one point-on-plane contact with multipliers λn (normal),
// λs1 (along the slope), λs2 (across), force = multiplier · F0, w(d) = 1.
// Equilibrium (slope frame; G = m g sin θ, N = m g cos θ):
//   along:   F_m a + F0 λs1 = G
//   normal:  F0 λn          = N
//   across:  F0 λs2         = 0
// Objective a² + (λn² + λs1² + λs2²)/w0. λn = N/F0 and λs2 = 0 are forced;
// on the line F_m a + F0 λs1 = G, Lagrange gives 2a = ν F_m,
// 2 λs1/w0 = ν F0, hence
//   a = G F_m / (F_m² + w0 F0²),  λs1 = G w0 F0 / (F_m² + w0 F0²).
// Friction (any model, shear is along e1 only): λs1 ≤ μ λn. If the free
// λs1 exceeds it, the 1-D convex objective is minimised at the limit:
//   λs1 = μ λn,  a = (G − μ N) / F_m.
// (0 ≤ a ≤ 1 holds for the numbers below: G = 49.05 N < F_m.)

const M: f64 = 10.0;
const GRAV: f64 = 9.81;
const FM: f64 = 200.0;
const F0: f64 = 100.0;

fn incline(w0: f64, mu: f64, model: FrictionModel) -> FrameProblem {
    let th = 30f64.to_radians();
    let (g_along, n_force) = (M * GRAV * th.sin(), M * GRAV * th.cos());
    let wc = 1.0 / w0;
    let mut p = problem(
        &[
            &[FM, 0.0, F0, 0.0],
            &[0.0, F0, 0.0, 0.0],
            &[0.0, 0.0, 0.0, F0],
        ],
        &[g_along, n_force, 0.0],
        &[1.0, wc, wc, wc],
        &[0.0, 0.0, -INF, -INF],
        &[1.0, INF, INF, INF],
    );
    p.static_contacts = vec![StaticContact {
        normal: 1,
        shear: [2, 3],
        mu,
    }];
    p.friction = model;
    p
}

/// (a, λn, λs1) of the analytic optimum.
fn incline_expected(w0: f64, mu: f64) -> (f64, f64, f64) {
    let th = 30f64.to_radians();
    let (g_along, n_force) = (M * GRAV * th.sin(), M * GRAV * th.cos());
    let ln = n_force / F0;
    let free = g_along * w0 * F0 / (FM * FM + w0 * F0 * F0);
    let ls1 = free.min(mu * ln);
    ((g_along - F0 * ls1) / FM, ln, ls1)
}

const W0S: [f64; 10] = [1e-3, 1e-2, 1e-1, 1.0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6];

#[test]
fn incline_block_matches_closed_form_friction_inactive() {
    // μ = 0.8 > tan 30°: the free optimum never reaches the friction limit
    // (λs1 → G/F0 = 0.49 < μ λn = 0.68 as w0 → ∞).
    for model in [
        FrictionModel::Pyramid4,
        FrictionModel::Pyramid8,
        FrictionModel::Cone,
    ] {
        let mut last_a = f64::INFINITY;
        for w0 in W0S {
            let sol = solve(&incline(w0, 0.8, model));
            assert_eq!(sol.status, SolveStatus::Solved, "{model:?} w0={w0}");
            let (a, ln, ls1) = incline_expected(w0, 0.8);
            let tag = format!("{model:?} w0={w0}");
            assert_close(sol.x[0], a, 1e-6, &format!("{tag} a"));
            assert_close(sol.x[1], ln, 1e-6, &format!("{tag} λn"));
            assert_close(sol.x[2], ls1, 1e-6, &format!("{tag} λs1"));
            assert_close(sol.x[3], 0.0, 1e-6, &format!("{tag} λs2"));
            // Paper §2.2.1: larger w0 shifts load from muscle to contact.
            assert!(sol.x[0] < last_a, "{tag}: muscle share must fall with w0");
            last_a = sol.x[0];
        }
    }
}

#[test]
fn incline_block_friction_limit_binds() {
    // μ = 0.3 < tan 30°: the contact alone cannot hold the block. The free
    // λs1 reaches μ λn at w0* = μ λn F_m² / (F0 (G − μ λn F0)) ≈ 4.33, so
    // for w0 ≥ 10 friction is saturated and the muscle carries the rest.
    let mu = 0.3;
    for model in [
        FrictionModel::Pyramid4,
        FrictionModel::Pyramid8,
        FrictionModel::Cone,
    ] {
        for w0 in W0S {
            let sol = solve(&incline(w0, mu, model));
            assert_eq!(sol.status, SolveStatus::Solved, "{model:?} w0={w0}");
            let (a, ln, ls1) = incline_expected(w0, mu);
            let tag = format!("{model:?} w0={w0}");
            assert_close(sol.x[0], a, 1e-6, &format!("{tag} a"));
            assert_close(sol.x[1], ln, 1e-6, &format!("{tag} λn"));
            assert_close(sol.x[2], ls1, 1e-6, &format!("{tag} λs1"));
            let (n, s1, s2) = (sol.x[1], sol.x[2], sol.x[3]);
            if w0 >= 10.0 {
                let limit = mu * n;
                match model {
                    FrictionModel::Cone => {
                        assert_close(s1.hypot(s2), limit, 1e-6, &format!("{tag} |s| = μn"))
                    }
                    _ => {
                        assert!(s1.abs() <= limit + 1e-9, "{tag}: |s1| {s1} > μn {limit}");
                        assert_close(s1, limit, 1e-6, &format!("{tag} s1 at the face"));
                    }
                }
                // The muscle carries what friction cannot: G − μ N.
                let th = 30f64.to_radians();
                let rest = M * GRAV * (th.sin() - mu * th.cos());
                assert_close(sol.x[0] * FM, rest, 1e-4, &format!("{tag} muscle force"));
            }
            assert!(
                model.violation(
                    &StaticContact {
                        normal: 1,
                        shear: [2, 3],
                        mu
                    },
                    &sol.x
                ) <= 1e-9
            );
        }
    }
}

// ---------------------------------------------------------------------
// Cone vs pyramids. Block on a horizontal plane, in-plane load H in the
// direction d = (cos φ, sin φ), a muscle along d with force a F_m, normal
// load N. Equilibrium in e1, e2 forces the shear s = σ d with
// F_m a + F0 σ = H, and λn = N/F0. With w0 = 1e6 friction is cheap, the
// free σ ≈ H/F0 exceeds every limit, so σ sits on the boundary of the
// friction set along d: σ = k μ λn with k = 1 (cone) or k = 1/cos δ for a
// circumscribed pyramid (δ = angle between d and the nearest face normal).

fn diagonal(phi_deg: f64, model: FrictionModel) -> FrameSolution {
    let (h, n_load, mu, w0) = (50.0, 100.0, 0.2, 1e6);
    let phi = phi_deg.to_radians();
    let (c, s) = (phi.cos(), phi.sin());
    let wc = 1.0 / w0;
    let mut p = problem(
        &[
            &[FM * c, 0.0, F0, 0.0],
            &[FM * s, 0.0, 0.0, F0],
            &[0.0, F0, 0.0, 0.0],
        ],
        &[h * c, h * s, n_load],
        &[1.0, wc, wc, wc],
        &[0.0, 0.0, -INF, -INF],
        &[1.0, INF, INF, INF],
    );
    p.static_contacts = vec![StaticContact {
        normal: 1,
        shear: [2, 3],
        mu,
    }];
    p.friction = model;
    solve(&p)
}

fn diagonal_expected(k: f64) -> (f64, f64) {
    let (h, n_load, mu, w0) = (50.0f64, 100.0f64, 0.2, 1e6);
    let free = h * w0 * F0 / (FM * FM + w0 * F0 * F0);
    let sigma = free.min(k * mu * n_load / F0);
    ((h - F0 * sigma) / FM, sigma)
}

#[test]
fn cone_is_tighter_than_pyramid4_on_the_diagonal() {
    // φ = 45°: Pyramid4 admits √2 μ λn along the diagonal (its corner),
    // the cone μ λn; the circumscribed Pyramid8 has a face normal at 45° so
    // it coincides with the cone there.
    let k4 = 1.0 / 45f64.to_radians().cos();
    for (model, k) in [
        (FrictionModel::Cone, 1.0),
        (FrictionModel::Pyramid4, k4),
        (FrictionModel::Pyramid8, 1.0),
    ] {
        let sol = diagonal(45.0, model);
        assert_eq!(sol.status, SolveStatus::Solved, "{model:?}");
        let (a, sigma) = diagonal_expected(k);
        assert_close(sol.x[0], a, 1e-6, &format!("{model:?} a"));
        assert_close(
            sol.x[2].hypot(sol.x[3]),
            sigma,
            1e-6,
            &format!("{model:?} |s|"),
        );
    }
    let cone = diagonal(45.0, FrictionModel::Cone);
    let pyr = diagonal(45.0, FrictionModel::Pyramid4);
    // The pyramid lets friction carry more, so the muscle does less.
    assert!(
        cone.x[0] > pyr.x[0] + 0.02,
        "cone {} pyramid {}",
        cone.x[0],
        pyr.x[0]
    );
    // Pyramid4's solution violates the exact cone by the factor √2 − 1.
    let c = StaticContact {
        normal: 1,
        shear: [2, 3],
        mu: 0.2,
    };
    let over = FrictionModel::Cone.violation(&c, &pyr.x) / (0.2 * pyr.x[1]);
    assert_close(
        over,
        2f64.sqrt() - 1.0,
        1e-5,
        "Pyramid4 overshoot of the cone",
    );
}

#[test]
fn pyramid8_lies_between_cone_and_pyramid4() {
    // φ = 30°: Pyramid4's nearest face normal is at 0° (δ = 30°),
    // Pyramid8's at 45° (δ = 15°), so the admitted shear is
    // μλn · {1, 1/cos 15°, 1/cos 30°} for cone, Pyramid8, Pyramid4.
    let cases = [
        (FrictionModel::Cone, 1.0),
        (FrictionModel::Pyramid8, 1.0 / 15f64.to_radians().cos()),
        (FrictionModel::Pyramid4, 1.0 / 30f64.to_radians().cos()),
    ];
    let mut a = Vec::new();
    for (model, k) in cases {
        let sol = diagonal(30.0, model);
        assert_eq!(sol.status, SolveStatus::Solved, "{model:?}");
        let (a_want, sigma) = diagonal_expected(k);
        assert_close(sol.x[0], a_want, 1e-6, &format!("{model:?} a"));
        assert_close(
            sol.x[2].hypot(sol.x[3]),
            sigma,
            1e-6,
            &format!("{model:?} |s|"),
        );
        // Shear is along d.
        assert_close(
            sol.x[3].atan2(sol.x[2]),
            30f64.to_radians(),
            1e-5,
            "shear direction",
        );
        assert_close(
            model.shear_limit_factor(30f64.to_radians()),
            k,
            1e-12,
            "limit factor",
        );
        a.push(sol.x[0]);
    }
    assert!(a[0] > a[1] && a[1] > a[2], "muscle activations {a:?}");
}

#[test]
fn zero_friction_coefficient_forbids_shear() {
    for model in [
        FrictionModel::Pyramid4,
        FrictionModel::Pyramid8,
        FrictionModel::Cone,
    ] {
        let sol = solve(&incline(1e3, 0.0, model));
        assert_eq!(sol.status, SolveStatus::Solved, "{model:?}");
        let th = 30f64.to_radians();
        assert_close(sol.x[0], M * GRAV * th.sin() / FM, 1e-7, "muscle holds all");
        assert_close(sol.x[2], 0.0, 1e-9, "λs1");
        assert_close(sol.x[3], 0.0, 1e-9, "λs2");
    }
}

// ---------------------------------------------------------------------
// Other exponents. Accuracy note: with power cones the objective is linear
// in the epigraph variables and all curvature sits in the cone, so the
// duality gap (~1e-8 at the default tolerance) bounds the error in x only
// to about its square root; measured errors are 1e-6…2e-5. The power-cone
// tests therefore compare x to 5e-5 (OpenSim's own IPOPT tolerance is 1e-4,
// opensim-semantics.md §6.4) and the objective, which is accurate to the
// gap, to 1e-7.
const POW_TOL: f64 = 5e-5;

// Closed form. min Σ w_i |x_i|^p s.t. Σ r_i x_i = τ (τ > 0, free
// bounds). Stationarity: p w_i |x_i|^(p−1) sign(x_i) = ν r_i, so
// x_i = sign(r_i) (|r_i|/w_i)^(1/(p−1)) · c with
// c = τ / Σ_j |r_j|^(1+1/(p−1)) w_j^(−1/(p−1)).

#[test]
fn power_cone_exponents_match_lagrangian() {
    let r = [2.0, -1.0, 0.5];
    let w = [1.0, 2.0, 0.5];
    let tau = 1.5;
    for pexp in [1.5, 3.0, 4.0] {
        let mut p = problem(&[&r], &[tau], &w, &[-INF; 3], &[INF; 3]);
        p.exponent = pexp;
        let sol = solve(&p);
        assert_eq!(sol.status, SolveStatus::Solved, "p = {pexp}");
        let e = 1.0 / (pexp - 1.0);
        let denom: f64 = (0..3)
            .map(|j| r[j].abs().powf(1.0 + e) * w[j].powf(-e))
            .sum();
        let c = tau / denom;
        for i in 0..3 {
            let want = r[i].signum() * (r[i].abs() / w[i]).powf(e) * c;
            assert_close(sol.x[i], want, POW_TOL, &format!("p={pexp} x[{i}]"));
        }
        let want_obj: f64 = (0..3)
            .map(|i| w[i] * ((r[i].abs() / w[i]).powf(e) * c).powf(pexp))
            .sum();
        assert_close(
            sol.objective,
            want_obj,
            1e-7,
            &format!("p={pexp} objective"),
        );
    }
}

#[test]
fn exponent_three_with_active_bound_matches_brute_force() {
    // min x1³ + 2|x2|³ s.t. 3 x1 + x2 = 2, 0 ≤ x1 ≤ 0.45, x2 free.
    // Brute force: minimise the objective on the constraint line
    // x2 = 2 − 3 x1 over x1 ∈ [0, 0.45] by ternary search (it is convex).
    // The interior optimum is x1 ≈ 0.587, so the bound is active.
    let f = |x1: f64| x1.abs().powi(3) + 2.0 * (2.0 - 3.0 * x1).abs().powi(3);
    let (mut lo, mut hi) = (0.0f64, 0.45f64);
    for _ in 0..200 {
        let (m1, m2) = (lo + (hi - lo) / 3.0, hi - (hi - lo) / 3.0);
        if f(m1) < f(m2) {
            hi = m2;
        } else {
            lo = m1;
        }
    }
    let x1 = 0.5 * (lo + hi);
    assert!(
        (x1 - 0.45).abs() < 1e-9,
        "the bound is meant to be active, x1 = {x1}"
    );
    let mut p = problem(
        &[&[3.0, 1.0]],
        &[2.0],
        &[1.0, 2.0],
        &[0.0, -INF],
        &[0.45, INF],
    );
    p.exponent = 3.0;
    let sol = solve(&p);
    assert_eq!(sol.status, SolveStatus::Solved);
    assert_close(sol.x[0], x1, POW_TOL, "x1");
    assert_close(sol.x[1], 2.0 - 3.0 * x1, POW_TOL, "x2");
    assert_close(sol.objective, f(x1), 1e-7, "objective");

    // Same with the bound relaxed: interior brute-force optimum.
    let (mut lo, mut hi) = (-1.0f64, 2.0f64);
    for _ in 0..200 {
        let (m1, m2) = (lo + (hi - lo) / 3.0, hi - (hi - lo) / 3.0);
        if f(m1) < f(m2) {
            hi = m2;
        } else {
            lo = m1;
        }
    }
    let x1 = 0.5 * (lo + hi);
    p.upper[0] = INF;
    let sol = solve(&p);
    assert_eq!(sol.status, SolveStatus::Solved);
    assert_close(sol.x[0], x1, POW_TOL, "x1 (interior)");
    assert_close(sol.objective, f(x1), 1e-7, "objective (interior)");
}

#[test]
fn exponent_one_is_a_linear_program() {
    // min |x1| + 2|x2| s.t. x1 + x2 = 1: the cheaper variable takes it all.
    let mut p = problem(&[&[1.0, 1.0]], &[1.0], &[1.0, 2.0], &[-INF; 2], &[INF; 2]);
    p.exponent = 1.0;
    let sol = solve(&p);
    assert_eq!(sol.status, SolveStatus::Solved);
    assert_close(sol.x[0], 1.0, 1e-6, "x1");
    assert_close(sol.x[1], 0.0, 1e-6, "x2");
    assert_close(sol.objective, 1.0, 1e-6, "objective");
}

#[test]
fn fixed_and_unweighted_variables() {
    // x0 fixed at 0.25: min x0² + x1² + x2² s.t. x0 + x1 + x2 = 1 gives
    // x1 = x2 = 0.375. Checked for p = 2 and p = 3 (both symmetric).
    for pexp in [2.0, 3.0] {
        let mut p = problem(
            &[&[1.0, 1.0, 1.0]],
            &[1.0],
            &[1.0; 3],
            &[0.25, 0.0, 0.0],
            &[0.25, 1.0, 1.0],
        );
        p.exponent = pexp;
        let sol = solve(&p);
        assert_eq!(sol.status, SolveStatus::Solved, "p = {pexp}");
        assert_eq!(sol.x[0], 0.25);
        let tol = if pexp == 2.0 { 1e-8 } else { POW_TOL };
        assert_close(sol.x[1], 0.375, tol, "x1");
        assert_close(sol.x[2], 0.375, tol, "x2");
    }
    // Weight 0: min x1² s.t. x0 + x1 = 1, x0 ≤ 0.3 (x0 costs nothing, so it
    // takes as much as it may).
    for pexp in [2.0, 3.0] {
        let mut p = problem(
            &[&[1.0, 1.0]],
            &[1.0],
            &[0.0, 1.0],
            &[-INF, -INF],
            &[0.3, INF],
        );
        p.exponent = pexp;
        let sol = solve(&p);
        assert_eq!(sol.status, SolveStatus::Solved, "p = {pexp}");
        let tol = if pexp == 2.0 { 1e-8 } else { POW_TOL };
        assert_close(sol.x[0], 0.3, tol, "x0");
        assert_close(sol.x[1], 0.7, tol, "x1");
    }
}

#[test]
fn invalid_problems_are_refused_without_panic() {
    let mut p = so_problem(30.0);
    p.exponent = 0.5;
    let err = p.validate().unwrap_err().to_string();
    assert!(err.contains("exponent") && err.contains(">= 1"), "{err}");
    let sol = solve(&p);
    assert_eq!(sol.status, SolveStatus::InvalidProblem);
    assert!(sol.x.iter().all(|x| x.is_finite()));

    let mut p = so_problem(30.0);
    p.weights.pop();
    assert!(p.validate().unwrap_err().to_string().contains("weights"));
    assert_eq!(solve(&p).status, SolveStatus::InvalidProblem);

    let mut p = so_problem(30.0);
    p.a[(0, 1)] = f64::NAN;
    assert_eq!(solve(&p).status, SolveStatus::InvalidProblem);

    let mut p = so_problem(30.0);
    p.lower[2] = 2.0;
    assert!(p
        .validate()
        .unwrap_err()
        .to_string()
        .contains("above its upper"));

    let mut p = incline(1.0, 0.3, FrictionModel::Cone);
    p.static_contacts[0].shear = [2, 1];
    assert!(p
        .validate()
        .unwrap_err()
        .to_string()
        .contains("already used"));
    p.static_contacts[0].shear = [2, 7];
    assert!(p
        .validate()
        .unwrap_err()
        .to_string()
        .contains("out of range"));
}

// ---------------------------------------------------------------------
// Size and speed: 40 equalities, 100 variables (70 muscles, 10 contacts).

fn lcg(state: &mut u64) -> f64 {
    *state = state
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    ((*state >> 11) as f64) / ((1u64 << 53) as f64)
}

fn random_frame(seed: u64, model: FrictionModel, exponent: f64) -> (FrameProblem, Vec<f64>) {
    let (m, n_mus, n_con) = (40, 70, 10);
    let n = n_mus + 3 * n_con;
    let mut s = seed;
    let a = DMatrix::from_fn(m, n, |_, _| 2.0 * lcg(&mut s) - 1.0);
    // A feasible point: muscles inside their bounds, contacts inside the cone.
    let mut x = vec![0.0; n];
    for xi in x.iter_mut().take(n_mus) {
        *xi = 0.1 + 0.8 * lcg(&mut s);
    }
    let mut contacts = Vec::new();
    for k in 0..n_con {
        let base = n_mus + 3 * k;
        let ang = std::f64::consts::TAU * lcg(&mut s);
        x[base] = 1.0;
        x[base + 1] = 0.3 * ang.cos();
        x[base + 2] = 0.3 * ang.sin();
        contacts.push(StaticContact {
            normal: base,
            shear: [base + 1, base + 2],
            mu: 0.5,
        });
    }
    let b = &a * DVector::from_column_slice(&x);
    let mut weights = vec![1.0; n];
    let mut lower = vec![0.01; n];
    let mut upper = vec![1.0; n];
    for k in 0..n_con {
        let base = n_mus + 3 * k;
        for j in 0..3 {
            weights[base + j] = 1.0 / 10.0;
            upper[base + j] = INF;
            lower[base + j] = if j == 0 { 0.0 } else { -INF };
        }
    }
    let p = FrameProblem {
        a,
        b,
        weights,
        exponent,
        lower,
        upper,
        static_contacts: contacts,
        friction: model,
        settings: SolveSettings::default(),
    };
    (p, x)
}

#[test]
fn forty_by_hundred_frames_solve_and_report_time() {
    for (model, exponent) in [
        (FrictionModel::Pyramid4, 2.0),
        (FrictionModel::Cone, 2.0),
        (FrictionModel::Cone, 3.0),
    ] {
        let reps = 10;
        let mut total = std::time::Duration::ZERO;
        let mut iters = 0;
        for seed in 0..reps {
            let (p, x_feas) = random_frame(seed + 1, model, exponent);
            let sol = solve(&p);
            assert_eq!(
                sol.status,
                SolveStatus::Solved,
                "{model:?} p={exponent} seed {seed}"
            );
            assert!(sol.eq_residual < 1e-6, "residual {}", sol.eq_residual);
            for c in &p.static_contacts {
                assert!(model.violation(c, &sol.x) < 1e-7);
            }
            // The known feasible point cannot beat the optimum.
            assert!(sol.objective <= p.objective(&x_feas) + 1e-9);
            total += sol.solve_time;
            iters += sol.iterations;
        }
        println!(
            "40x100 {model:?} p={exponent}: mean {:.3} ms per solve, {:.1} iterations",
            total.as_secs_f64() * 1e3 / reps as f64,
            iters as f64 / reps as f64
        );
    }
}

#[test]
fn degenerate_problems_do_not_panic() {
    // No variables at all.
    let p = problem(&[], &[], &[], &[], &[]);
    let sol = solve(&p);
    assert!(sol.x.is_empty());
    println!("empty: {:?}", sol.status);
    // Only an unweighted free variable: every x is optimal.
    let p = problem(&[], &[], &[0.0], &[-INF], &[INF]);
    let sol = solve(&p);
    assert!(sol.x[0].is_finite());
    println!("free unweighted: {:?} {:?}", sol.status, sol.x);
    // Inconsistent equalities 0·x = 1.
    let p = problem(&[&[0.0, 0.0]], &[1.0], &[1.0, 1.0], &[-INF; 2], &[INF; 2]);
    let sol = solve(&p);
    println!(
        "0 = 1: {:?} {:?} res {}",
        sol.status, sol.x, sol.eq_residual
    );
    assert_eq!(sol.status, SolveStatus::Infeasible);
    assert_close(sol.eq_residual, 1.0, 1e-9, "residual of 0 = 1");
    // Contradictory equalities x = 1, x = 2 (elastic answer: x = 1.5).
    let p = problem(&[&[1.0], &[1.0]], &[1.0, 2.0], &[1.0], &[-INF], &[INF]);
    let sol = solve(&p);
    println!("x=1,x=2: {:?} {:?}", sol.status, sol.x);
    assert_eq!(sol.status, SolveStatus::Infeasible);
    assert_close(sol.x[0], 1.5, 1e-5, "elastic compromise");
}

/// The friction model a StaticOptimization uses without `<friction_cone>`
/// is `FrictionModel::default()`, and both are the exact cone
/// docs/speed_accuracy.md promises (the type's default used to be the pyramid).
#[test]
fn friction_default_is_the_cone_everywhere() {
    use crate::optimize::friction::FrictionModel;
    assert_eq!(FrictionModel::default(), FrictionModel::Cone);
    let el = crate::xml::parse_str(
        "<StaticOptimization name=\"SO\"/>",
        std::path::Path::new("setup.xml"),
    )
    .unwrap();
    let common = crate::parse::setup::AnalysisCommon {
        name: "SO".into(),
        on: true,
        step_interval: 1,
        in_degrees: false,
    };
    let so =
        crate::tools::static_optimization::StaticOptimizationSetup::from_xml(&el, common).unwrap();
    assert_eq!(so.friction, FrictionModel::Cone);
    let doc = include_str!("../../docs/speed_accuracy.md");
    assert!(
        doc.contains("**Exact friction cone.**"),
        "docs/speed_accuracy.md states the cone default"
    );
}

// ---------------------------------------------------------------------
// Polishing Clarabel's answer to the exact optimum (`polish`).

/// min Σ x_i² s.t. x1 + x2 + x3 = 2.5, x1 ≤ 0.5: the bound is active, so
/// x1 = 0.5 and x2 = x3 = 1 exactly. An interior point stops short of the
/// bound; the polished answer is exact to rounding.
#[test]
fn clarabel_answers_are_polished_onto_active_bounds() {
    let mut p = problem(
        &[&[1.0, 1.0, 1.0]],
        &[2.5],
        &[1.0; 3],
        &[-INF; 3],
        &[0.5, INF, INF],
    );
    p.settings.solver = SolverChoice::Clarabel;
    let sol = solve(&p);
    assert!(sol.polished);
    assert_eq!(sol.status, SolveStatus::Solved);
    assert_eq!(sol.solver, SolverKind::Clarabel);
    for (got, want) in sol.x.iter().zip([0.5, 1.0, 1.0]) {
        assert_close(*got, want, 1e-14, "x");
    }
    // From a rough start (three interior-point iterations, far from the
    // bound's neighbourhood): the active-set corrections still find it.
    let mut rough = p.clone();
    rough.settings.max_iter = 3;
    let raw = solve_clarabel(&rough).x;
    let (xp, y) = polish::polish(&p, &raw).expect("polished from a rough start");
    for (got, want) in xp.iter().zip([0.5, 1.0, 1.0]) {
        assert_close(*got, want, 1e-14, "x from a rough start");
    }
    // y: 2 x_free = Aᵀ y → y = 2.
    assert_close(y[0], 2.0, 1e-13, "y");
}

/// A contact on the surface of its friction cone. Variables (λn, λs1, λs2,
/// u), weights 1: λn = 1, λs2 = 0.3, λs1 + u = 1, μ = 0.5. Unconstrained,
/// λs1 = u = 0.5, but ‖λs‖ ≤ 0.5 allows λs1 ≤ 0.4: the optimum is on the
/// cone, λs = (0.4, 0.3), u = 0.6.
#[test]
fn clarabel_answers_are_polished_onto_the_friction_cone() {
    for model in [FrictionModel::Cone, FrictionModel::Pyramid8] {
        let mut p = problem(
            &[
                &[1.0, 0.0, 0.0, 0.0],
                &[0.0, 1.0, 0.0, 1.0],
                &[0.0, 0.0, 1.0, 0.0],
            ],
            &[1.0, 1.0, 0.3],
            &[1.0; 4],
            &[0.0, -INF, -INF, -INF],
            &[INF; 4],
        );
        p.static_contacts = vec![StaticContact {
            normal: 0,
            shear: [1, 2],
            mu: 0.5,
        }];
        p.friction = model;
        p.settings.solver = SolverChoice::Clarabel;
        let sol = solve(&p);
        assert!(sol.polished, "{model:?}");
        // Against Newton (exact; the pyramid's optimum lies on a face).
        let mut q = p.clone();
        q.settings.solver = SolverChoice::Auto;
        let newton = solve(&q);
        assert_eq!(newton.solver, SolverKind::Newton);
        for k in 0..4 {
            assert_close(sol.x[k], newton.x[k], 1e-13, &format!("{model:?} x[{k}]"));
        }
        if model == FrictionModel::Cone {
            for (got, want) in sol.x.iter().zip([1.0, 0.4, 0.3, 0.6]) {
                assert_close(*got, want, 1e-13, "cone x");
            }
        }
    }
}

/// `solve_into_finite_a` answers as `solve_into` does and skips only the
/// scan of A's entries: every other check still refuses the problem.
#[test]
fn solve_into_finite_a_skips_only_a_scan() {
    let p = incline(1.0, 0.3, FrictionModel::Cone);
    let (mut a, mut b) = (FrameSolution::default(), FrameSolution::default());
    solve_into(&p, None, &mut a);
    solve_into_finite_a(&p, None, &mut b);
    assert_eq!(a.status, SolveStatus::Solved);
    assert_eq!((a.x, a.y, a.iterations), (b.x, b.y, b.iterations));

    let mut p = so_problem(30.0);
    p.a[(0, 1)] = f64::NAN;
    assert!(p.validate().is_err());
    assert!(p.validate_but_a_entries().is_ok());
    p.lower[2] = 2.0;
    let err = p.validate_but_a_entries().unwrap_err().to_string();
    assert!(err.contains("above its upper"), "{err}");
    let mut out = FrameSolution::default();
    solve_into_finite_a(&p, None, &mut out);
    assert_eq!(out.status, SolveStatus::InvalidProblem);

    // A contact's variable used twice, by itself or by an earlier contact.
    let mut p = incline(1.0, 0.3, FrictionModel::Cone);
    let c = p.static_contacts[0];
    p.static_contacts[0].shear = [c.normal, c.shear[1]];
    assert!(p
        .validate_but_a_entries()
        .unwrap_err()
        .to_string()
        .contains("already used"));
    let mut p = incline(1.0, 0.3, FrictionModel::Cone);
    p.static_contacts.push(c);
    let err = p.validate().unwrap_err().to_string();
    assert!(
        err.contains("contact 1") && err.contains("already used"),
        "{err}"
    );
}
