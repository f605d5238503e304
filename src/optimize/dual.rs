//! Dual semismooth Newton method for the quadratic frame problem (p = 2).
//!
//! The problem of a frame is
//!
//! ```text
//! minimise Σ_i w_i x_i²  subject to  A x = b,  x ∈ C
//! ```
//!
//! where C is a product of intervals [lower_i, upper_i] (independent
//! variables) and, per static contact with μ > 0, the friction cone
//! K_μ = {(λn, λs1, λs2): ‖(λs1, λs2)‖ ≤ μ λn} (FrictionModel::Cone) or one
//! of the circumscribed pyramids.
//! Its Lagrangian dual function, one multiplier y_r per equation, is
//!
//! ```text
//! g(y) = min_{x ∈ C} Σ_i w_i x_i² − yᵀ(A x − b)
//! ```
//!
//! Because every block of C (a variable, or the three variables of a contact,
//! which share one weight) has a single weight w, the inner minimiser is a
//! Euclidean projection, x(y) = Proj_C(Aᵀy / 2w) block by block: a clip to
//! [lower, upper], or the closed-form projection onto K_μ ([`project_cone`]),
//! or onto a circumscribed pyramid (`FrictionModel::Pyramid4`/`Pyramid8`:
//! inside, a face, an edge or the apex, [`project_pyramid`]).
//! g is concave and piecewise quadratic with gradient ∇g(y) = b − A x(y), so
//! the dual optimum is a root of the piecewise-linear map F(y) = b − A x(y).
//! Semismooth Newton solves it: the generalized Jacobian of F is
//! −A D Aᵀ with D block-diagonal, D = J / 2w, J the (Clarke) derivative of
//! the projection (1 or 0 for a clip; I, 0 or a rank-2 matrix for the cone,
//! [`cone_jacobian_factors`]; I, the projector onto a face's plane, onto an
//! edge, or 0 for a pyramid); each step solves (A D Aᵀ + εI) d = F(y) by
//! Cholesky, ε = s·(1e-12 + ν·min(1, ‖F‖∞/max(1, ‖b‖∞))) with s the
//! largest diagonal entry of A W⁻¹ Aᵀ/2 (Levenberg–Marquardt-like: A D Aᵀ
//! is singular when all variables of an equation sit at bounds or a contact
//! lies on the cone's surface; ν starts at 1e-6, falls tenfold after a full
//! step and rises tenfold after a step shorter than ¼), and takes y + t d
//! with the first t of the sequence 1, t₁, t₂, … that raises g by the Armijo
//! fraction 1e-4·t·Fᵀd (or, where g's gain drowns in rounding, shrinks ‖F‖₂
//! by 1 − 1e-4·t without lowering g beyond rounding); each next t is the
//! zero of the secant of the (piecewise-linear, decreasing) directional
//! derivative φ'(t) = F(y + t d)ᵀd, kept within [0.1, 0.5] of the last.
//! The iterate x(y) is feasible for the bounds and friction cones by
//! construction, and it is the exact
//! minimiser of the problem with right-hand side A x(y); the method stops when
//! ‖A x − b‖∞ ≤ [`TARGET_TOLERANCE`]·max(1, ‖b‖∞) (1e-12), and accepts
//! [`RESIDUAL_TOLERANCE`] (1e-10) when it cannot get there.
//!
//! Starting point: the multipliers of the unconstrained problem (every
//! bound and cone inactive), (A W⁻¹ Aᵀ/2) y = b, or a caller's warm start.
//! static optimization solves every frame from this cold start, so a frame's
//! answer never depends on which frames were solved before it or on which
//! thread (results are bit-identical for any thread count and when a run is
//! resumed).
//!
//! Block splitting: equations that share no free variable (a contact's three
//! variables count as one) are independent; they are grouped by union-find
//! and each group is solved on its own, with its own line search. (In the
//! analytic force-space rows a muscle crossing the hip also loads the pelvis
//! coordinates, so gait2392's 23 equations form a single block; the split
//! pays off for models whose parts do not interact.) Fixed variables
//! (lower == upper, and the shear multipliers of a contact with μ = 0) move
//! to the right-hand side; variables that appear in no equation take their
//! projection of 0.
//!
//! Not handled (the caller falls back to Clarabel, [`super::solve()`]):
//! exponents other than 2, free variables of weight 0, contacts whose three
//! variables do not share one
//! positive weight or carry bounds other than λn ≥ 0 (or none). When Newton
//! has not converged within [`MAX_NEWTON_STEPS`] steps per block, the line
//! search stalls, or an equation without free variables has a nonzero
//! right-hand side, the caller falls back too: Clarabel certifies
//! infeasibility and computes the elastic solution.
use nalgebra::{DMatrix, DVector};

use super::friction::FrictionModel;
use super::problem::FrameProblem;

/// Acceptance test: ‖A x − b‖∞ ≤ this · max(1, ‖b‖∞).
pub const RESIDUAL_TOLERANCE: f64 = 1e-10;
/// Newton iterates until ‖A x − b‖∞ ≤ this · max(1, ‖b‖∞) (accepting
/// [`RESIDUAL_TOLERANCE`] when it stops short of it). Tighter than the
/// acceptance test because the scale is the largest equation's: small
/// equations (toe joints beside the hip) otherwise keep activations off by
/// up to ~3e-8; the extra precision costs about half a linear solve per
/// frame (quadratic convergence once the active set is right).
pub const TARGET_TOLERANCE: f64 = 1e-12;
/// Newton steps allowed per block before giving up.
pub const MAX_NEWTON_STEPS: u32 = 50;
/// Step halvings of one line search before giving up.
const MAX_HALVINGS: u32 = 60;
/// Armijo fraction.
const SIGMA: f64 = 1e-4;

/// The dual Newton answer.
#[derive(Debug, Clone, PartialEq)]
pub struct DualSolution {
    /// The primal variables (within bounds and friction cones).
    pub x: Vec<f64>,
    /// One multiplier per equation (0 for equations with no free variable):
    /// 2 w x = Aᵀy up to the bound and cone multipliers.
    pub y: Vec<f64>,
    /// Linear solves, summed over the blocks (the starting point's solve
    /// included).
    pub iterations: u32,
    /// Number of independent blocks of equations.
    pub blocks: usize,
}

/// Why [`solve_dual`] gave no answer.
#[derive(Debug, Clone, PartialEq)]
pub enum DualFailure {
    /// The problem lies outside what the method handles (see the module
    /// documentation); the reason says what.
    NotHandled(&'static str),
    /// Not converged (step limit, stalled line search, an inconsistent
    /// equation): possibly infeasible. `iterations` as in [`DualSolution`].
    NotConverged {
        iterations: u32,
        reason: &'static str,
    },
}

impl DualFailure {
    /// Newton iterations spent before failing (0 when not handled).
    pub fn iterations(&self) -> u32 {
        match self {
            DualFailure::NotHandled(_) => 0,
            DualFailure::NotConverged { iterations, .. } => *iterations,
        }
    }
}

/// A block of the feasible set C.
#[derive(Debug, Clone, Copy)]
enum Set {
    /// One variable in [lo, hi].
    Interval { lo: f64, hi: f64 },
    /// (λn, λs1, λs2) in the friction cone or pyramid (`model`) of
    /// coefficient mu > 0.
    Cone { mu: f64, model: FrictionModel },
}

/// A block of variables: its set, weight and global variable indices
/// (1 or 3, normal first).
#[derive(Debug, Clone, Copy)]
struct Group {
    set: Set,
    w: f64,
    vars: [usize; 3],
}

impl Group {
    fn len(&self) -> usize {
        match self.set {
            Set::Interval { .. } => 1,
            Set::Cone { .. } => 3,
        }
    }

    /// Projection of 0: the group's value when no equation involves it.
    fn at_zero(&self) -> [f64; 3] {
        match self.set {
            Set::Interval { lo, hi } => [0.0f64.clamp(lo, hi), 0.0, 0.0],
            Set::Cone { .. } => [0.0; 3],
        }
    }
}

/// Euclidean projection of (n, s1, s2) onto {‖(s1, s2)‖ ≤ mu n}, mu > 0.
/// Returns the projection and which piece applied (0 interior, 1 boundary,
/// 2 polar cone).
pub fn project_cone(v: [f64; 3], mu: f64) -> ([f64; 3], u8) {
    let [n, s1, s2] = v;
    let r = s1.hypot(s2);
    if r <= mu * n {
        return (v, 0);
    }
    if n + mu * r <= 0.0 {
        return ([0.0; 3], 2);
    }
    // Onto the ray (1, mu u), u = s / r (r > 0 here).
    let alpha = (n + mu * r) / (1.0 + mu * mu);
    let k = mu * alpha / r;
    ([alpha, k * s1, k * s2], 1)
}

const IDENTITY: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// Projection onto the friction set of `model` and its derivative as
/// factors (J = Σ c cᵀ over the three returned vectors).
fn project_friction(v: [f64; 3], mu: f64, model: FrictionModel) -> ([f64; 3], [[f64; 3]; 3]) {
    match model {
        FrictionModel::Cone => {
            let (p, piece) = project_cone(v, mu);
            (p, cone_jacobian_factors(v, mu, piece))
        }
        _ => {
            let (p, piece) = project_pyramid(v, mu, model);
            (p, pyramid_jacobian_factors(piece))
        }
    }
}

/// Corners of the base polygon of a circumscribed pyramid for μ = 1 (in the
/// shear plane; the polygon for μ is μ times it): where adjacent faces
/// c·s ≤ 1 of [`FrictionModel::facets`] meet.
fn unit_corners(model: FrictionModel) -> &'static [(f64, f64)] {
    const T: f64 = std::f64::consts::SQRT_2 - 1.0; // tan(π/8)
    const P4: [(f64, f64); 4] = [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)];
    const P8: [(f64, f64); 8] = [
        (1.0, T),
        (1.0, -T),
        (-1.0, T),
        (-1.0, -T),
        (T, 1.0),
        (-T, 1.0),
        (T, -1.0),
        (-T, -1.0),
    ];
    match model {
        FrictionModel::Pyramid4 => &P4,
        FrictionModel::Pyramid8 => &P8,
        FrictionModel::Cone => &[],
    }
}

/// Where [`project_pyramid`] landed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PyramidPiece {
    /// Inside: the point itself.
    Interior,
    /// On a face; its unit normal in (n, s1, s2).
    Face([f64; 3]),
    /// On an edge; its unit direction.
    Edge([f64; 3]),
    /// At the apex.
    Origin,
}

/// Euclidean projection of (n, s1, s2) onto the circumscribed pyramid
/// {c·s ≤ mu n for every face normal c} of `model` (mu > 0). The projection
/// lies inside, in the relative interior of a face (the projection onto
/// that face's plane, when it satisfies the other faces), on an edge (the
/// projection onto its ray) or at the apex: the closest of these
/// candidates.
pub fn project_pyramid(v: [f64; 3], mu: f64, model: FrictionModel) -> ([f64; 3], PyramidPiece) {
    let faces = model.facets();
    let viol = |x: &[f64; 3], c: &(f64, f64)| c.0 * x[1] + c.1 * x[2] - mu * x[0];
    if faces.iter().all(|c| viol(&v, c) <= 0.0) {
        return (v, PyramidPiece::Interior);
    }
    let vv = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
    let tol = 1e-12 * vv.sqrt() * (1.0 + mu);
    let mut best = ([0.0; 3], PyramidPiece::Origin, vv);
    for c in faces {
        let e = viol(&v, c);
        if e <= 0.0 {
            continue;
        }
        // g = (−μ, c1, c2), |g|² = μ² + 1.
        let g2 = mu * mu + 1.0;
        let k = e / g2;
        let p = [v[0] + k * mu, v[1] - k * c.0, v[2] - k * c.1];
        let d2 = e * e / g2;
        if d2 < best.2 && faces.iter().all(|c2| viol(&p, c2) <= tol) {
            let gn = g2.sqrt();
            best = (p, PyramidPiece::Face([-mu / gn, c.0 / gn, c.1 / gn]), d2);
        }
    }
    for &(a, b) in unit_corners(model) {
        let r = [1.0, mu * a, mu * b];
        let rn = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
        let r = [r[0] / rn, r[1] / rn, r[2] / rn];
        let t = v[0] * r[0] + v[1] * r[1] + v[2] * r[2];
        if t > 0.0 && vv - t * t < best.2 {
            best = (
                [t * r[0], t * r[1], t * r[2]],
                PyramidPiece::Edge(r),
                vv - t * t,
            );
        }
    }
    (best.0, best.1)
}

/// The derivative of [`project_pyramid`] on its piece as factors: I
/// (inside), an orthonormal basis of the face's plane, the edge's direction,
/// nothing at the apex.
fn pyramid_jacobian_factors(piece: PyramidPiece) -> [[f64; 3]; 3] {
    match piece {
        PyramidPiece::Interior => IDENTITY,
        PyramidPiece::Origin => [[0.0; 3]; 3],
        PyramidPiece::Edge(r) => [r, [0.0; 3], [0.0; 3]],
        PyramidPiece::Face(g) => {
            // e1 ⟂ g from the axis least aligned with g, e2 = g × e1.
            let k = (0..3)
                .min_by(|&i, &j| g[i].abs().total_cmp(&g[j].abs()))
                .unwrap_or(0);
            let mut e1 = [0.0; 3];
            e1[k] = 1.0;
            let d = g[k];
            for i in 0..3 {
                e1[i] -= d * g[i];
            }
            let n1 = (e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]).sqrt();
            for e in e1.iter_mut() {
                *e /= n1;
            }
            let e2 = [
                g[1] * e1[2] - g[2] * e1[1],
                g[2] * e1[0] - g[0] * e1[2],
                g[0] * e1[1] - g[1] * e1[0],
            ];
            [e1, e2, [0.0; 3]]
        }
    }
}

/// The derivative J of [`project_cone`] at v as at most three columns c_k
/// with J = Σ c_k c_kᵀ: I (interior), nothing (polar), or, on the boundary
/// piece, q/√(1+μ²) with q = (1, μu) and √(μα/r)·(0, u⊥).
fn cone_jacobian_factors(v: [f64; 3], mu: f64, piece: u8) -> [[f64; 3]; 3] {
    match piece {
        0 => [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        2 => [[0.0; 3]; 3],
        _ => {
            let [n, s1, s2] = v;
            let r = s1.hypot(s2);
            let (u1, u2) = (s1 / r, s2 / r);
            let alpha = (n + mu * r) / (1.0 + mu * mu);
            let c = 1.0 / (1.0 + mu * mu).sqrt();
            let e = (mu * alpha / r).max(0.0).sqrt();
            [
                [c, c * mu * u1, c * mu * u2],
                [0.0, -e * u2, e * u1],
                [0.0; 3],
            ]
        }
    }
}

/// Union-find with path halving.
fn find(parent: &mut [usize], mut i: usize) -> usize {
    while parent[i] != i {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    i
}

/// One independent block: its equations (global rows), its groups, the
/// submatrix (columns in group order, stored by column with the nonzero
/// entries only: a muscle spans a few joints) and the right-hand side with
/// the fixed variables moved over.
struct Block {
    rows: Vec<usize>,
    groups: Vec<Group>,
    /// Column c holds entries col_ptr[c]..col_ptr[c + 1] of row_idx (local
    /// rows) and val.
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    val: Vec<f64>,
    b: DVector<f64>,
}

/// A block's (x, y, linear solves), or (linear solves, why it failed).
type BlockResult = Result<(DVector<f64>, DVector<f64>, u32), (u32, &'static str)>;

/// State of a block at a multiplier vector.
struct Eval {
    x: DVector<f64>,
    /// F = b − M x = ∇g.
    f: DVector<f64>,
    g: f64,
}

/// Which derivative [`Block::eval`] accumulates into H = M D Mᵀ.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Hessian {
    /// The projection's derivative at the point.
    AtPoint,
    /// Every bound and cone inactive (D = W⁻¹/2), for the starting point.
    Free,
}

impl Block {
    fn n_cols(&self) -> usize {
        self.col_ptr.len() - 1
    }

    fn col(&self, c: usize) -> (&[usize], &[f64]) {
        let r = self.col_ptr[c]..self.col_ptr[c + 1];
        (&self.row_idx[r.clone()], &self.val[r])
    }

    /// (M_c)ᵀ y.
    fn dot(&self, c: usize, y: &DVector<f64>) -> f64 {
        let (ri, v) = self.col(c);
        ri.iter().zip(v).map(|(&r, a)| a * y[r]).sum()
    }

    /// h += s · u uᵀ for u = Σ_k coef_k M_(c+k) (k < coef.len()); `u` is
    /// scratch of the block's row count.
    fn add_outer(&self, h: &mut DMatrix<f64>, c: usize, coef: &[f64], s: f64, u: &mut [f64]) {
        if coef.len() == 1 {
            let (ri, v) = self.col(c);
            let k = s * coef[0] * coef[0];
            for (&r1, a1) in ri.iter().zip(v) {
                for (&r2, a2) in ri.iter().zip(v) {
                    h[(r1, r2)] += k * a1 * a2;
                }
            }
            return;
        }
        u.iter_mut().for_each(|e| *e = 0.0);
        for (k, &ck) in coef.iter().enumerate() {
            if ck != 0.0 {
                let (ri, v) = self.col(c + k);
                for (&r, a) in ri.iter().zip(v) {
                    u[r] += ck * a;
                }
            }
        }
        for r1 in 0..u.len() {
            if u[r1] != 0.0 {
                let k = s * u[r1];
                for r2 in 0..u.len() {
                    h[(r1, r2)] += k * u[r2];
                }
            }
        }
    }

    /// Projected point x(y), gradient F and dual value g at y; with `hess`,
    /// also H = M D Mᵀ (overwritten).
    fn eval(&self, y: &DVector<f64>, mut hess: Option<(&mut DMatrix<f64>, Hessian)>) -> Eval {
        let nr = self.rows.len();
        let mut x = DVector::zeros(self.n_cols());
        let mut f = self.b.clone();
        let mut obj = 0.0;
        let mut u = vec![0.0; nr];
        if let Some((h, _)) = hess.as_mut() {
            h.fill(0.0);
        }
        let mut c = 0;
        for gr in &self.groups {
            let inv2w = 0.5 / gr.w;
            match gr.set {
                Set::Interval { lo, hi } => {
                    let v = self.dot(c, y) * inv2w;
                    let xc = v.clamp(lo, hi);
                    x[c] = xc;
                    obj += gr.w * xc * xc;
                    if let Some((h, kind)) = hess.as_mut() {
                        if *kind == Hessian::Free || (v > lo && v < hi) {
                            self.add_outer(h, c, &[1.0], inv2w, &mut u);
                        }
                    }
                }
                Set::Cone { mu, model } => {
                    let v = [
                        self.dot(c, y) * inv2w,
                        self.dot(c + 1, y) * inv2w,
                        self.dot(c + 2, y) * inv2w,
                    ];
                    let (p, factors) = project_friction(v, mu, model);
                    for k in 0..3 {
                        x[c + k] = p[k];
                        obj += gr.w * p[k] * p[k];
                    }
                    if let Some((h, kind)) = hess.as_mut() {
                        let factors = if *kind == Hessian::Free {
                            IDENTITY
                        } else {
                            factors
                        };
                        for fac in factors {
                            if fac.iter().any(|e| *e != 0.0) {
                                self.add_outer(h, c, &fac, inv2w, &mut u);
                            }
                        }
                    }
                }
            }
            for k in 0..gr.len() {
                let xk = x[c + k];
                if xk != 0.0 {
                    let (ri, v) = self.col(c + k);
                    for (&r, a) in ri.iter().zip(v) {
                        f[r] -= a * xk;
                    }
                }
            }
            c += gr.len();
        }
        // g(y) = Σ w x² − yᵀ(M x − b) at the minimiser x(y).
        let g = obj + y.dot(&f);
        Eval { x, f, g }
    }

    /// Newton from `y`; returns (x, y, linear solves) or the failure.
    fn solve(&self, y0: Option<DVector<f64>>, target: f64, accept: f64) -> BlockResult {
        let nr = self.rows.len();
        let mut h = DMatrix::zeros(nr, nr);
        let mut h_free = DMatrix::zeros(nr, nr);
        self.eval(&DVector::zeros(nr), Some((&mut h_free, Hessian::Free)));
        let scale = (0..nr).map(|r| h_free[(r, r)]).fold(0.0, f64::max);
        if !(scale > 0.0 && scale.is_finite()) {
            return Err((0, "degenerate equations"));
        }
        let eps0 = 1e-12 * scale;
        let bscale = accept / RESIDUAL_TOLERANCE;
        let mut nu = 1e-6;
        let mut solves = 0u32;
        let mut y = match y0 {
            Some(y) => y,
            None => {
                solves += 1;
                match regularised_solve(h_free, &self.b, eps0) {
                    Some(y) => y,
                    None => return Err((solves, "singular start")),
                }
            }
        };
        let mut cur = self.eval(&y, Some((&mut h, Hessian::AtPoint)));
        // Stopping short of the target: accepted if within `accept`.
        let give_up = |cur: Eval, y: DVector<f64>, solves: u32, why: &'static str| {
            if cur.f.amax() <= accept {
                Ok((cur.x, y, solves))
            } else {
                Err((solves, why))
            }
        };
        for _ in 0..MAX_NEWTON_STEPS {
            if cur.f.amax() <= target {
                return Ok((cur.x, y, solves));
            }
            solves += 1;
            // Levenberg–Marquardt-like damping, proportional to the residual
            // (bounded steps where A D Aᵀ is singular: a row all of whose
            // variables sit at bounds, a contact on the cone's surface;
            // vanishing as it converges), with a factor ν lowered after full
            // steps and raised after short ones.
            let eps = eps0 + nu * scale * (cur.f.amax() / bscale).min(1.0);
            let Some(d) = regularised_solve(h.clone(), &cur.f, eps) else {
                return give_up(cur, y, solves, "Newton system not solvable");
            };
            let slope = cur.f.dot(&d);
            let fnorm = cur.f.norm();
            let mut t = 1.0;
            let mut next = None;
            for _ in 0..MAX_HALVINGS {
                let yt = &y + &d * t;
                let e = self.eval(&yt, None);
                // Armijo on the concave g; near convergence, where g's gain
                // drowns in its rounding, a shrinking residual with g not
                // lower beyond rounding.
                if e.g >= cur.g + SIGMA * t * slope
                    || (e.g >= cur.g - 1e-13 * cur.g.abs()
                        && e.f.norm() <= (1.0 - SIGMA * t) * fnorm)
                {
                    next = Some((yt, e));
                    break;
                }
                // Next trial: the zero of the secant of φ'(s) = Fᵀd along
                // the step (φ' is piecewise linear and decreasing, φ'(0) =
                // slope), kept within [0.1 t, 0.5 t].
                let dphi = e.f.dot(&d);
                let secant = if slope - dphi > 0.0 {
                    t * slope / (slope - dphi)
                } else {
                    0.5 * t
                };
                t = secant.clamp(0.1 * t, 0.5 * t);
            }
            let Some((yt, _)) = next else {
                return give_up(cur, y, solves, "line search stalled");
            };
            if t == 1.0 {
                nu = (nu * 0.1).max(1e-12);
            } else if t < 0.25 {
                nu = (nu * 10.0).min(1.0);
            }
            y = yt;
            cur = self.eval(&y, Some((&mut h, Hessian::AtPoint)));
        }
        give_up(cur, y, solves, "step limit")
    }
}

/// Cholesky solve of (h + eps I) z = rhs, raising eps by 1e3 up to four
/// times when the factorisation fails.
fn regularised_solve(mut h: DMatrix<f64>, rhs: &DVector<f64>, eps: f64) -> Option<DVector<f64>> {
    let n = h.nrows();
    let mut added = 0.0;
    let mut e = eps;
    for _ in 0..5 {
        for i in 0..n {
            h[(i, i)] += e - added;
        }
        added = e;
        if let Some(ch) = h.clone().cholesky() {
            let z = ch.solve(rhs);
            if z.iter().all(|v| v.is_finite()) {
                return Some(z);
            }
        }
        e *= 1e3;
    }
    None
}

/// Solves a valid problem (see [`FrameProblem::validate`]) by dual Newton,
/// optionally from multipliers `y0` (one per equation). See the module
/// documentation for what is handled.
pub fn solve_dual(p: &FrameProblem, y0: Option<&[f64]>) -> Result<DualSolution, DualFailure> {
    use DualFailure::NotHandled;
    if p.exponent != 2.0 {
        return Err(NotHandled("activation exponent other than 2"));
    }
    let n = p.n_var();
    let m = p.n_eq();
    if y0.is_some_and(|y| y.len() != m) {
        return Err(NotHandled("warm start of the wrong length"));
    }
    // Partition the variables: fixed values, groups.
    let mut fixed: Vec<Option<f64>> = vec![None; n];
    let mut in_contact = vec![false; n];
    let mut groups: Vec<Group> = Vec::with_capacity(n);
    for c in &p.static_contacts {
        for s in c.shear {
            in_contact[s] = true;
        }
        if c.mu == 0.0 {
            // Shear is 0 in every friction model; the normal is an ordinary
            // bounded variable (handled below).
            for s in c.shear {
                if !(p.lower[s] <= 0.0 && p.upper[s] >= 0.0) {
                    return Err(NotHandled(
                        "frictionless contact with shear bounds excluding 0",
                    ));
                }
                fixed[s] = Some(0.0);
            }
            continue;
        }
        in_contact[c.normal] = true;
        let w = p.weights[c.normal];
        let vars = [c.normal, c.shear[0], c.shear[1]];
        if w <= 0.0 || vars.iter().any(|&v| p.weights[v] != w) {
            return Err(NotHandled("contact variables of unequal or zero weight"));
        }
        if c.shear
            .iter()
            .any(|&s| p.lower[s] != f64::NEG_INFINITY || p.upper[s] != f64::INFINITY)
            || p.lower[c.normal] > 0.0
            || p.upper[c.normal] != f64::INFINITY
        {
            return Err(NotHandled("contact with bounds other than the cone's"));
        }
        groups.push(Group {
            set: Set::Cone {
                mu: c.mu,
                model: p.friction,
            },
            w,
            vars,
        });
    }
    for j in 0..n {
        if in_contact[j] {
            continue;
        }
        let (lo, hi, w) = (p.lower[j], p.upper[j], p.weights[j]);
        if lo == hi {
            fixed[j] = Some(lo);
        } else if w > 0.0 {
            groups.push(Group {
                set: Set::Interval { lo, hi },
                w,
                vars: [j, usize::MAX, usize::MAX],
            });
        } else {
            return Err(NotHandled("free variable of weight 0"));
        }
    }

    let bmax = p.b.amax();
    let tol = RESIDUAL_TOLERANCE * bmax.max(1.0);
    // Right-hand side with the fixed variables moved over.
    let mut b = p.b.clone();
    for (j, v) in fixed.iter().enumerate() {
        if let Some(v) = *v {
            if v != 0.0 {
                b.axpy(-v, &p.a.column(j), 1.0);
            }
        }
    }

    // Union-find over equations; the first row each group touches.
    let mut parent: Vec<usize> = (0..m).collect();
    let mut first_row = vec![usize::MAX; groups.len()];
    for (gi, gr) in groups.iter().enumerate() {
        for &v in &gr.vars[..gr.len()] {
            for r in 0..m {
                if p.a[(r, v)] != 0.0 {
                    if first_row[gi] == usize::MAX {
                        first_row[gi] = r;
                    } else {
                        let (a, bb) = (find(&mut parent, first_row[gi]), find(&mut parent, r));
                        parent[a] = bb;
                    }
                }
            }
        }
    }
    let mut x = vec![0.0; n];
    let mut y = vec![0.0; m];
    for (j, v) in fixed.iter().enumerate() {
        if let Some(v) = *v {
            x[j] = v;
        }
    }
    // Blocks keyed by root row.
    let mut block_of_root = vec![usize::MAX; m];
    let mut blocks: Vec<(Vec<usize>, Vec<Group>)> = Vec::new();
    for (gi, gr) in groups.iter().enumerate() {
        if first_row[gi] == usize::MAX {
            let v = gr.at_zero();
            for k in 0..gr.len() {
                x[gr.vars[k]] = v[k];
            }
            continue;
        }
        let root = find(&mut parent, first_row[gi]);
        if block_of_root[root] == usize::MAX {
            block_of_root[root] = blocks.len();
            blocks.push((Vec::new(), Vec::new()));
        }
        blocks[block_of_root[root]].1.push(*gr);
    }
    for r in 0..m {
        let root = find(&mut parent, r);
        match block_of_root[root] {
            usize::MAX => {
                // No free variable in this equation.
                if b[r].abs() > tol {
                    return Err(DualFailure::NotConverged {
                        iterations: 0,
                        reason: "an equation without free variables does not hold",
                    });
                }
            }
            k => blocks[k].0.push(r),
        }
    }

    let mut iterations = 0u32;
    let n_blocks = blocks.len();
    for (rows, groups) in blocks {
        let cols: Vec<usize> = groups
            .iter()
            .flat_map(|g| g.vars[..g.len()].iter().copied())
            .collect();
        let mut local = vec![usize::MAX; m];
        for (k, &r) in rows.iter().enumerate() {
            local[r] = k;
        }
        let mut col_ptr = Vec::with_capacity(cols.len() + 1);
        let (mut row_idx, mut val) = (Vec::new(), Vec::new());
        col_ptr.push(0);
        for &j in &cols {
            for &r in &rows {
                let v = p.a[(r, j)];
                if v != 0.0 {
                    row_idx.push(local[r]);
                    val.push(v);
                }
            }
            col_ptr.push(row_idx.len());
        }
        let block = Block {
            col_ptr,
            row_idx,
            val,
            b: DVector::from_iterator(rows.len(), rows.iter().map(|&r| b[r])),
            rows,
            groups,
        };
        let start = y0
            .map(|y0| DVector::from_iterator(block.rows.len(), block.rows.iter().map(|&r| y0[r])));
        match block.solve(start, TARGET_TOLERANCE * bmax.max(1.0), tol) {
            Ok((xb, yb, it)) => {
                iterations += it;
                for (k, &j) in cols.iter().enumerate() {
                    x[j] = xb[k];
                }
                for (k, &r) in block.rows.iter().enumerate() {
                    y[r] = yb[k];
                }
            }
            Err((it, reason)) => {
                return Err(DualFailure::NotConverged {
                    iterations: iterations + it,
                    reason,
                })
            }
        }
    }
    // Safety net: the whole system, with the original matrix.
    let residual = p.eq_residual(&x);
    if residual.is_nan() || residual > tol {
        return Err(DualFailure::NotConverged {
            iterations,
            reason: "residual of the assembled solution",
        });
    }
    Ok(DualSolution {
        x,
        y,
        iterations,
        blocks: n_blocks,
    })
}

#[cfg(test)]
#[path = "dual_tests.rs"]
mod tests;

/// Largest violation of the optimality conditions of `x` with multipliers
/// `y`, computed from the problem data alone: for an interval variable,
/// g = 2 w x − (Aᵀy) must vanish inside the bounds, be ≥ 0 at a lower and
/// ≤ 0 at an upper bound; for a contact z = (Aᵀy) − 2 w x must lie in the
/// polar cone ({z_n + μ‖z_s‖ ≤ 0} for the cone, zᵀr ≤ 0 for every edge r
/// of a pyramid) and be orthogonal to x (normal cone of the set at x). Relative to the size of the terms. With A x = b, x in the set
/// (checked separately), these conditions certify x as the optimum; the
/// unit tests and tests/dual_newton.rs hold every Newton answer to them.
pub fn optimality_violation(p: &FrameProblem, x: &[f64], y: &[f64]) -> f64 {
    let aty = p.a.tr_mul(&DVector::from_column_slice(y));
    let mut worst = 0.0f64;
    let mut in_cone = vec![false; p.n_var()];
    for c in p.static_contacts.iter().filter(|c| c.mu > 0.0) {
        let v = [c.normal, c.shear[0], c.shear[1]];
        let w = p.weights[c.normal];
        let z: Vec<f64> = v.iter().map(|&j| aty[j] - 2.0 * w * x[j]).collect();
        let scale = v
            .iter()
            .map(|&j| aty[j].abs().max(2.0 * w * x[j].abs()))
            .fold(1e-300, f64::max);
        // Polar of the cone: z_n + μ‖z_s‖ ≤ 0; of a pyramid: zᵀr ≤ 0 for
        // every edge direction r = (1, μ·corner).
        let polar = match p.friction {
            FrictionModel::Cone => z[0] + c.mu * z[1].hypot(z[2]),
            model => unit_corners(model)
                .iter()
                .map(|&(a, b)| (z[0] + c.mu * (a * z[1] + b * z[2])) / (1.0 + c.mu))
                .fold(f64::NEG_INFINITY, f64::max),
        };
        worst = worst.max(polar.max(0.0) / scale);
        let xs = v.iter().map(|&j| x[j].abs()).fold(1e-300, f64::max);
        let dot: f64 = v.iter().zip(&z).map(|(&j, zj)| x[j] * zj).sum();
        worst = worst.max(dot.abs() / (scale * xs));
        for j in v {
            in_cone[j] = true;
        }
    }
    for c in p.static_contacts.iter().filter(|c| c.mu == 0.0) {
        // Without friction the shears are fixed at 0.
        for s in c.shear {
            worst = worst.max(x[s].abs());
            in_cone[s] = true;
        }
    }
    for j in 0..p.n_var() {
        if in_cone[j] || p.lower[j] == p.upper[j] {
            continue;
        }
        let g = 2.0 * p.weights[j] * x[j] - aty[j];
        let scale = aty[j]
            .abs()
            .max(2.0 * p.weights[j] * x[j].abs())
            .max(1e-300);
        let v = if x[j] == p.lower[j] {
            (-g).max(0.0)
        } else if x[j] == p.upper[j] {
            g.max(0.0)
        } else {
            g.abs()
        };
        worst = worst.max(v / scale);
    }
    worst
}
