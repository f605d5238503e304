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
//! edge, or 0 for a pyramid); each step solves (A D Aᵀ + ε S) d = F(y) by
//! Cholesky, with S the diagonal of A W⁻¹ Aᵀ/2 (each equation's curvature
//! with every bound inactive) and ε = 1e-12 + ν·min(1, ‖F‖∞/max(1, ‖b‖∞))
//! (Levenberg–Marquardt-like: A D Aᵀ is singular when all variables of an
//! equation sit at bounds or a contact lies on the cone's surface; ν starts
//! at 0.1 from the cold start and 1e-6 from a warm one, falls a
//! thousandfold after a full step and a hundredfold after a step longer
//! than 1 (the damping held the step short), rises tenfold after a step
//! shorter than ¼; ε = 1e-12 when a full step left every clip's derivative
//! as it was, where F is linear and the plain Newton step exact). The step
//! y + t d takes t = 1 when |φ'(1)| ≤ ½ φ'(0) for the concave
//! φ(t) = g(y + t d), whose derivative φ'(t) = F(y + t d)ᵀd is decreasing
//! (piecewise linear without contacts); otherwise t with |φ'(t)| ≤ ½ φ'(0),
//! bracketed by doubling beyond 1 or between 0 and 1 and found by regula
//! falsi (Illinois). φ' costs no product with A: with v = Aᵀy/2w and
//! δ = Aᵀd/2w per variable, φ'(t) = bᵀd − Σ (Aᵀd)_i Proj(v + tδ)_i.
//! A step longer than `STEP_CAP`·max(‖y‖∞, 1) is damped further (ν
//! tenfold, up to 1e3) until it is not: along a direction where most
//! variables sit at their bounds g rises slowly, and the line search would
//! take such a step whole.
//! With friction cones a cut step (t < 1) gets a second-order correction
//! (`Block::second_order_correction`): a contact held near the cone's apex
//! while its Mᵀy/2w is large confines y to a curved ridge that the linear
//! model steps off.
//! The iterate x(y) is feasible for the bounds and friction cones by
//! construction, and it is the exact
//! minimiser of the problem with right-hand side A x(y); the method stops when
//! ‖A x − b‖∞ ≤ [`TARGET_TOLERANCE`]·max(1, ‖b‖∞) (1e-12), and accepts
//! [`RESIDUAL_TOLERANCE`] (1e-10) when it cannot get there. Where a full
//! step fails to cut a residual below 1e-6·max(1, ‖b‖∞) (and at the step
//! limit) the residual is the rounding of x(y) itself: a cheap contact
//! (weight 1/w0) barely loaded while its column meets large multipliers
//! has (Aᵀy)_j as the small sum of large terms, and one ulp of y moves F by
//! more than the tolerance. `Block::refine` then refines in the primal:
//! x is carried explicitly and corrected by D Mᵀδy/2w with H δy = F.
//!
//! Linear algebra: A's columns are kept with their nonzero entries only;
//! A D Aᵀ is updated between steps by removing and adding the variables
//! whose derivative changed (rebuilt when most did); the Cholesky factor is
//! computed on the equations ordered by their number of nonzero entries,
//! so the equations coupled to most others (the pelvis beside two legs)
//! come last and the zeros between the others survive. [`DualWorkspace`]
//! holds every buffer, for callers that solve many frames
//! ([`super::solve()`] keeps one per thread), and the block structure of
//! the last problem (blocks, row orders, A's columns laid out block by
//! block), a function of the grouping of the variables and of A's pattern
//! of nonzero entries alone: each call checks both against the new problem
//! (one pass over A, which also takes its values) and rebuilds the
//! structure when either differs, so the answer is the same bit for bit as
//! from a fresh workspace. A caller that solves one A for many right-hand
//! sides and weights (a force sweep's candidates) names it by a key
//! ([`DualWorkspace::solve_into_keyed`]), and the pass over A is skipped
//! when the layout last took its values under that key.
//!
//! Starting point: the multipliers of the unconstrained problem (every
//! bound and cone inactive), (A W⁻¹ Aᵀ/2) y = b, or a caller's warm start.
//! Static optimization warm-starts a frame from the previous frame's
//! multipliers (`optimize::solve_into`), deterministically: the frame driver
//! takes frames in fixed groups of `frame::driver::GROUP` consecutive
//! analysed frames, each group in order on one thread; the first frame of a
//! group starts cold, and a resumed run solves its resume point's group
//! again from the start (`for_each_frame_grouped`). So a frame's answer
//! depends only on its group's earlier frames, never on the thread count,
//! and a resumed run equals an uninterrupted one bit for bit. A warm start
//! that fails (or does not fit the problem's shape) is retried cold before
//! Clarabel takes over. On gait2392 warm starts cut the Newton linear
//! solves from 2,347 to 1,431 over the 151 frames; the answers moved by
//! rounding (≤ 1e-10 of each column's largest value).
//!
//! Block splitting: equations that share no free variable (a contact's three
//! variables count as one) are independent; they are grouped by union-find
//! and each group is solved on its own, with its own line search. A muscle
//! has an exact 0 in the rows of coordinates that carry its whole path
//! rigidly (`paths::geometry::add_unit_tension_force`), so gait2392's 23
//! equations split into four blocks: the pelvis (residual actuators only),
//! each leg, the lumbar joint. Contacts join the blocks of the bodies they
//! touch. Fixed variables
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
use nalgebra::DVector;

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
/// Newton steps allowed per block before giving up. (Frames of the
/// ten-contact gait2392 scene of `benches/contacts.rs` with friction cones
/// held near their apex take up to ~150; three of its 151 take more and
/// fall back to Clarabel.)
pub const MAX_NEWTON_STEPS: u32 = 200;
/// Trial steps of one line search (after bracketing) before giving up.
const MAX_LINE_SEARCH: u32 = 60;
/// A step t is taken when |φ'(t)| ≤ this · φ'(0) (strong Wolfe curvature
/// condition on the concave φ(t) = g(y + t d)).
const CURVATURE: f64 = 0.5;
/// A residual at most this · max(1, ‖b‖∞) that a full Newton step fails to
/// cut is taken for the rounding floor of x(y) and refined in the primal
/// (`Block::refine`).
const REFINE_BELOW: f64 = 1e-6;
/// An undamped Newton step longer than this · max(1, ‖y‖∞) is recomputed
/// with the damping.
const HUGE_STEP: f64 = 1e6;
/// Longest Newton step, relative to max(‖y‖∞, 1), before more damping.
const STEP_CAP: f64 = 1e3;
/// Longest step tried along a Newton direction.
const MAX_STEP: f64 = 1024.0;

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
    /// max |A x − b| ([`FrameProblem::eq_residual`] of x).
    pub eq_residual: f64,
}

/// What [`DualWorkspace::solve_into`] reports besides x and y (as in
/// [`DualSolution`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DualInfo {
    pub iterations: u32,
    pub blocks: usize,
    pub eq_residual: f64,
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

/// Projection onto a group's set (no derivative).
fn project_group(set: Set, v: [f64; 3]) -> [f64; 3] {
    match set {
        Set::Interval { lo, hi } => [v[0].clamp(lo, hi), 0.0, 0.0],
        Set::Cone {
            mu,
            model: FrictionModel::Cone,
        } => project_cone(v, mu).0,
        Set::Cone { mu, model } => project_pyramid(v, mu, model).0,
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

/// Columns of a matrix stored by column with their nonzero entries only (a
/// muscle spans a few joints): column c holds entries col_ptr[c]..col_ptr[c
/// + 1] of row_idx (ascending) and val.
#[derive(Debug, Default)]
struct SparseCols {
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    val: Vec<f64>,
}

impl SparseCols {
    fn clear(&mut self) {
        self.col_ptr.clear();
        self.col_ptr.push(0);
        self.row_idx.clear();
        self.val.clear();
    }

    /// Appends a column from (row, value) pairs.
    fn push_col(&mut self, entries: impl Iterator<Item = (usize, f64)>) {
        for (r, v) in entries {
            self.row_idx.push(r);
            self.val.push(v);
        }
        self.col_ptr.push(self.row_idx.len());
    }

    /// Makes room for `entries` entries to be written by
    /// [`SparseCols::push_dense_col`] (columns are read by col_ptr; the
    /// room left over is dropped by [`SparseCols::trim`]).
    fn make_room(&mut self, entries: usize) {
        self.row_idx.resize(entries, 0);
        self.val.resize(entries, 0.0);
    }

    fn trim(&mut self) {
        let end = self.col_ptr[self.col_ptr.len() - 1];
        self.row_idx.truncate(end);
        self.val.truncate(end);
    }

    /// Appends the nonzero entries of a dense column, within the room made
    /// by [`SparseCols::make_room`].
    fn push_dense_col(&mut self, column: &[f64]) {
        let start = self.col_ptr[self.col_ptr.len() - 1];
        let (ri, vals) = (&mut self.row_idx[start..], &mut self.val[start..]);
        let mut k = 0;
        for (c4, chunk) in column.chunks(4).enumerate() {
            // (Most entries are zero, in runs.)
            if chunk.iter().all(|e| *e == 0.0) {
                continue;
            }
            for (i, &e) in chunk.iter().enumerate() {
                // Written always, kept when nonzero.
                ri[k] = 4 * c4 + i;
                vals[k] = e;
                k += usize::from(e != 0.0);
            }
        }
        self.col_ptr.push(start + k);
    }

    fn col(&self, c: usize) -> (&[usize], &[f64]) {
        let r = self.col_ptr[c]..self.col_ptr[c + 1];
        (&self.row_idx[r.clone()], &self.val[r])
    }

    /// Columns `cols` (a block's) as a [`Cols`] numbered from 0.
    fn view(&self, cols: std::ops::Range<usize>) -> Cols<'_> {
        Cols {
            col_ptr: &self.col_ptr[cols.start..cols.end + 1],
            row_idx: &self.row_idx,
            val: &self.val,
        }
    }
}

/// Some consecutive columns of a [`SparseCols`]: column c holds entries
/// col_ptr[c]..col_ptr[c + 1] of row_idx and val.
#[derive(Debug, Clone, Copy)]
struct Cols<'a> {
    col_ptr: &'a [usize],
    row_idx: &'a [usize],
    val: &'a [f64],
}

impl<'a> Cols<'a> {
    #[inline]
    fn col(&self, c: usize) -> (&'a [usize], &'a [f64]) {
        let r = self.col_ptr[c]..self.col_ptr[c + 1];
        (&self.row_idx[r.clone()], &self.val[r])
    }

    /// (M_c)ᵀ y.
    #[inline]
    fn dot(&self, c: usize, y: &[f64]) -> f64 {
        let (ri, v) = self.col(c);
        ri.iter().zip(v).map(|(&r, a)| a * y[r]).sum()
    }
}

/// The derivative of a group's projection at the current point, as used
/// for the Hessian.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Deriv {
    /// 0: at a bound, at the apex or in the polar cone.
    Zero,
    /// I: inside the bounds.
    Identity,
    /// Σ c_k c_kᵀ over the three factors (a contact).
    Factors([[f64; 3]; 3]),
}

/// One independent block: its equations (global rows), its groups, the
/// submatrix (columns in group order, local rows) and the right-hand side
/// with the fixed variables moved over; views into a [`DualWorkspace`].
#[derive(Debug, Clone, Copy)]
struct Block<'a> {
    rows: &'a [usize],
    groups: Part<'a, Group>,
    /// Each group's first column.
    group_col: &'a [usize],
    m: Cols<'a>,
    b: Part<'a, f64>,
}

/// A slice of a block's data in the workspace, used as [`Block`] used its
/// own vectors (`for gr in &block.groups`, `copy_from_slice(&block.b)`).
#[derive(Debug, Clone, Copy)]
struct Part<'a, T>(&'a [T]);

impl<T> std::ops::Deref for Part<'_, T> {
    type Target = [T];
    fn deref(&self) -> &[T] {
        self.0
    }
}

impl<'a, T> IntoIterator for &Part<'a, T> {
    type Item = &'a T;
    type IntoIter = std::slice::Iter<'a, T>;
    fn into_iter(self) -> Self::IntoIter {
        self.0.iter()
    }
}

/// Newton's buffers for one block (sized by [`Newton::resize`]).
#[derive(Debug, Default)]
struct Newton {
    /// Multipliers, one per equation of the block.
    y: Vec<f64>,
    /// Newton direction.
    d: Vec<f64>,
    /// F = b − M x(y) = ∇g.
    f: Vec<f64>,
    /// Per column: v = (Mᵀy)/2w (the unprojected point), x = Proj(v),
    /// q = Mᵀd and dv = q/2w (the change of v along d).
    v: Vec<f64>,
    x: Vec<f64>,
    q: Vec<f64>,
    dv: Vec<f64>,
    /// Per group: the projection's derivative at v, and the derivative
    /// that h holds.
    deriv: Vec<Deriv>,
    h_deriv: Vec<Deriv>,
    /// h holds nothing to update (a warm start builds it afresh).
    h_stale: bool,
    /// H = M D Mᵀ (lower triangle, by column, n×n) and its Cholesky factor.
    h: Vec<f64>,
    l: Vec<f64>,
    /// The diagonal of M W⁻¹ Mᵀ/2 (every bound and cone inactive): the
    /// scale of each equation's curvature, which the damping follows.
    h_free_diag: Vec<f64>,
    /// Scratch of the block's row count.
    u: Vec<f64>,
    /// x, y and F before a primal refinement (`Block::refine`).
    keep_x: Vec<f64>,
    keep_y: Vec<f64>,
    keep_f: Vec<f64>,
}

impl Newton {
    fn resize(&mut self, n_rows: usize, n_cols: usize, n_groups: usize) {
        for (buf, len) in [
            (&mut self.y, n_rows),
            (&mut self.d, n_rows),
            (&mut self.f, n_rows),
            (&mut self.u, n_rows),
            (&mut self.keep_y, n_rows),
            (&mut self.keep_f, n_rows),
            (&mut self.keep_x, n_cols),
            (&mut self.h_free_diag, n_rows),
            (&mut self.v, n_cols),
            (&mut self.x, n_cols),
            (&mut self.q, n_cols),
            (&mut self.dv, n_cols),
        ] {
            buf.clear();
            buf.resize(len, 0.0);
        }
        // H and its factor are written whole before they are read (H by
        // `Block::hessian` at a cold start and at a warm start's first
        // step, `h_stale`; L copied from H): not cleared, which was a
        // block's largest cost when a warm start needs one step (a force
        // sweep's candidates).
        self.h.resize(n_rows * n_rows, 0.0);
        self.l.resize(n_rows * n_rows, 0.0);
        self.deriv.clear();
        self.deriv.resize(n_groups, Deriv::Zero);
        self.h_deriv.clear();
        self.h_deriv.resize(n_groups, Deriv::Zero);
    }
}

/// A block's outcome: Ok(linear solves) with the answer in the [`Newton`]
/// buffers, or (linear solves, why it failed).
type BlockResult = Result<u32, (u32, &'static str)>;

impl Block<'_> {
    fn n_rows(&self) -> usize {
        self.rows.len()
    }

    /// h += s · u uᵀ (lower triangle) for u = Σ_k coef_k M_(c+k); `u` is
    /// scratch of the block's row count.
    fn add_outer(&self, h: &mut [f64], c: usize, coef: &[f64; 3], s: f64, u: &mut [f64]) {
        let n = u.len();
        u.iter_mut().for_each(|e| *e = 0.0);
        for (k, &ck) in coef.iter().enumerate() {
            if ck != 0.0 {
                let (ri, v) = self.m.col(c + k);
                for (&r, a) in ri.iter().zip(v) {
                    u[r] += ck * a;
                }
            }
        }
        for r1 in 0..n {
            if u[r1] != 0.0 {
                let k = s * u[r1];
                for (hv, ur) in h[r1 * n + r1..(r1 + 1) * n].iter_mut().zip(&u[r1..]) {
                    *hv += k * ur;
                }
            }
        }
    }

    /// h += s · M_c M_cᵀ (lower triangle; the column's rows need not be
    /// in order).
    fn add_col_outer(&self, h: &mut [f64], n: usize, c: usize, s: f64) {
        let (ri, v) = self.m.col(c);
        for (i, (&r1, a1)) in ri.iter().zip(v).enumerate() {
            let k = s * a1;
            for (&r2, a2) in ri[i..].iter().zip(&v[i..]) {
                h[r1.min(r2) * n + r1.max(r2)] += k * a2;
            }
        }
    }

    /// H = M D Mᵀ into `h` (lower triangle, by column): D from `deriv`, or
    /// with every bound and cone inactive (D = W⁻¹/2, for the starting
    /// point) when `deriv` is None.
    fn hessian(&self, deriv: Option<&[Deriv]>, h: &mut [f64], u: &mut [f64]) {
        h.iter_mut().for_each(|e| *e = 0.0);
        for gi in 0..self.groups.len() {
            let d = deriv.map_or(&Deriv::Identity, |d| &d[gi]);
            if *d != Deriv::Zero {
                self.add_group(h, gi, d, 1.0, u);
            }
        }
    }

    /// The diagonal of M W⁻¹ Mᵀ/2 (every bound and cone inactive), as
    /// [`hessian`](Self::hessian)`(None)` sums it, into `diag`.
    fn free_diagonal(&self, diag: &mut [f64]) {
        diag.iter_mut().for_each(|e| *e = 0.0);
        for gi in 0..self.groups.len() {
            let gr = &self.groups[gi];
            let s = 0.5 / gr.w;
            for k in 0..gr.len() {
                let (ri, v) = self.m.col(self.group_col[gi] + k);
                for (&r, a) in ri.iter().zip(v) {
                    diag[r] += s * a * a;
                }
            }
        }
    }

    /// h += sign · M_g D_g M_gᵀ for group gi with derivative d.
    fn add_group(&self, h: &mut [f64], gi: usize, d: &Deriv, sign: f64, u: &mut [f64]) {
        let gr = &self.groups[gi];
        let c = self.group_col[gi];
        let s = sign * 0.5 / gr.w;
        match d {
            Deriv::Zero => {}
            Deriv::Identity => {
                for k in 0..gr.len() {
                    self.add_col_outer(h, self.n_rows(), c + k, s);
                }
            }
            Deriv::Factors(factors) => {
                for fac in factors {
                    if fac.iter().any(|e| *e != 0.0) {
                        self.add_outer(h, c, fac, s, u);
                    }
                }
            }
        }
    }

    /// Brings s.h to M D Mᵀ for D = s.deriv: from the matrix it holds
    /// (D = s.h_deriv) by removing and adding the groups whose derivative
    /// changed, or afresh when that is less work (the first step, where
    /// many variables leave their bounds or reach them). Returns how many
    /// groups changed.
    fn update_hessian(&self, s: &mut Newton) -> usize {
        let changed = s
            .deriv
            .iter()
            .zip(&s.h_deriv)
            .filter(|(a, b)| a != b)
            .count();
        let nonzero = s.deriv.iter().filter(|d| **d != Deriv::Zero).count();
        if s.h_stale || 2 * changed >= nonzero {
            s.h_stale = false;
            self.hessian(Some(&s.deriv), &mut s.h, &mut s.u);
            s.h_deriv.copy_from_slice(&s.deriv);
        } else if changed > 0 {
            for gi in 0..self.groups.len() {
                let (old, new) = (&s.h_deriv[gi], &s.deriv[gi]);
                if old != new {
                    self.add_group(&mut s.h, gi, old, -1.0, &mut s.u);
                    self.add_group(&mut s.h, gi, new, 1.0, &mut s.u);
                    s.h_deriv[gi] = s.deriv[gi];
                }
            }
        }
        changed
    }

    /// The state at s.y: v = (Mᵀy)/2w, x = Proj(v), the derivatives and
    /// F = b − M x (one pass over the columns).
    fn eval(&self, s: &mut Newton) {
        s.f.copy_from_slice(&self.b);
        let mut c = 0;
        for (gi, gr) in self.groups.iter().enumerate() {
            let inv2w = 0.5 / gr.w;
            match gr.set {
                Set::Interval { lo, hi } => {
                    let (ri, a) = self.m.col(c);
                    let v = ri.iter().zip(a).map(|(&r, a)| a * s.y[r]).sum::<f64>() * inv2w;
                    let x = v.clamp(lo, hi);
                    s.v[c] = v;
                    s.x[c] = x;
                    s.deriv[gi] = if v > lo && v < hi {
                        Deriv::Identity
                    } else {
                        Deriv::Zero
                    };
                    if x != 0.0 {
                        for (&r, a) in ri.iter().zip(a) {
                            s.f[r] -= a * x;
                        }
                    }
                }
                Set::Cone { mu, model } => {
                    let v = [
                        self.m.dot(c, &s.y) * inv2w,
                        self.m.dot(c + 1, &s.y) * inv2w,
                        self.m.dot(c + 2, &s.y) * inv2w,
                    ];
                    let (p, factors) = project_friction(v, mu, model);
                    s.v[c..c + 3].copy_from_slice(&v);
                    s.x[c..c + 3].copy_from_slice(&p);
                    s.deriv[gi] = Deriv::Factors(factors);
                    for (k, &xk) in p.iter().enumerate() {
                        if xk != 0.0 {
                            let (ri, a) = self.m.col(c + k);
                            for (&r, a) in ri.iter().zip(a) {
                                s.f[r] -= a * xk;
                            }
                        }
                    }
                }
            }
            c += gr.len();
        }
    }

    /// φ'(t) = F(y + t d)ᵀd along the step, from v, dv and q alone:
    /// bᵀd − Σ_c q_c x_c(t) with x(t) = Proj(v + t dv).
    fn slope_at(&self, s: &Newton, bd: f64, t: f64) -> f64 {
        let mut acc = bd;
        let mut c = 0;
        for gr in &self.groups {
            match gr.set {
                Set::Interval { lo, hi } => {
                    acc -= s.q[c] * (s.v[c] + t * s.dv[c]).clamp(lo, hi);
                }
                set => {
                    let v = [
                        s.v[c] + t * s.dv[c],
                        s.v[c + 1] + t * s.dv[c + 1],
                        s.v[c + 2] + t * s.dv[c + 2],
                    ];
                    let p = project_group(set, v);
                    acc -= s.q[c] * p[0] + s.q[c + 1] * p[1] + s.q[c + 2] * p[2];
                }
            }
            c += gr.len();
        }
        acc
    }

    /// The step length along s.d (see the module documentation): t with
    /// |φ'(t)| ≤ [`CURVATURE`]·φ'(0), 1 if it qualifies, else bracketed by
    /// doubling beyond 1 or between 0 and 1 and found by regula falsi
    /// (Illinois). None when no such t turns up.
    fn line_search(&self, s: &Newton, bd: f64, slope: f64) -> Option<f64> {
        let tol = CURVATURE * slope;
        let phi = |t: f64| self.slope_at(s, bd, t);
        // Bracket [a, b] with φ'(a) > 0 > φ'(b).
        let p1 = phi(1.0);
        if !p1.is_finite() {
            return None;
        }
        if p1.abs() <= tol {
            return Some(1.0);
        }
        let (mut a, mut pa, mut b, mut pb) = (0.0, slope, 1.0, p1);
        if p1 > 0.0 {
            (a, pa) = (1.0, p1);
            loop {
                if b >= MAX_STEP {
                    return Some(a);
                }
                b *= 2.0;
                pb = phi(b);
                if !pb.is_finite() {
                    return Some(a);
                }
                if pb.abs() <= tol {
                    return Some(b);
                }
                if pb < 0.0 {
                    break;
                }
                (a, pa) = (b, pb);
            }
        }
        let mut side = 0;
        for _ in 0..MAX_LINE_SEARCH {
            let t = (a * pb - b * pa) / (pb - pa);
            if !(t > a && t < b) {
                break;
            }
            let p = phi(t);
            if !p.is_finite() {
                break;
            }
            if p.abs() <= tol {
                return Some(t);
            }
            if p > 0.0 {
                (a, pa) = (t, p);
                if side == -1 {
                    pb *= 0.5;
                }
                side = -1;
            } else {
                (b, pb) = (t, p);
                if side == 1 {
                    pa *= 0.5;
                }
                side = 1;
            }
        }
        // Not within the tolerance: the largest t known to raise g.
        (a > 0.0).then_some(a)
    }

    /// Primal refinement at a converged active set, for frames where the
    /// residual stalls at the rounding of x(y) = Proj(Mᵀy/2w): a column
    /// with large entries and a small weight (a contact, w = 1/w0) turns
    /// the rounding of Mᵀy (terms far larger than their sum) into errors of
    /// x that no representable y removes. Here x is carried explicitly:
    /// each round solves H δy = F for the current derivative D, moves
    /// y by δy and x by D Mᵀδy/2w (a small correction, computed to its own
    /// precision), and evaluates F = b − M x from that x. Stops at
    /// `target`, after three rounds, or when F no longer halves. The answer
    /// stays in s.x and s.y; returns max |F|.
    fn refine(&self, s: &mut Newton, target: f64) -> f64 {
        let mut fmax = amax(&s.f);
        s.keep_x.copy_from_slice(&s.x);
        s.keep_y.copy_from_slice(&s.y);
        s.keep_f.copy_from_slice(&s.f);
        let start = fmax;
        for _ in 0..3 {
            if fmax <= target {
                break;
            }
            self.update_hessian(s);
            s.u.copy_from_slice(&s.f);
            if !regularised_solve(s, 1e-12, Target::D) {
                break;
            }
            let mut c = 0;
            for (gi, gr) in self.groups.iter().enumerate() {
                let inv2w = 0.5 / gr.w;
                match (gr.set, s.deriv[gi]) {
                    (_, Deriv::Zero) => {}
                    (Set::Interval { lo, hi }, Deriv::Identity) => {
                        let dx = self.m.dot(c, &s.d) * inv2w;
                        s.x[c] = (s.x[c] + dx).clamp(lo, hi);
                    }
                    (set @ Set::Cone { .. }, Deriv::Factors(factors)) => {
                        let dv = [
                            self.m.dot(c, &s.d) * inv2w,
                            self.m.dot(c + 1, &s.d) * inv2w,
                            self.m.dot(c + 2, &s.d) * inv2w,
                        ];
                        for f in &factors {
                            let k = f[0] * dv[0] + f[1] * dv[1] + f[2] * dv[2];
                            if k != 0.0 {
                                for (xj, fj) in s.x[c..c + 3].iter_mut().zip(f) {
                                    *xj += k * fj;
                                }
                            }
                        }
                        // Back onto the set (a tangential move leaves a face
                        // near an edge, the cone's surface to second order).
                        let p = project_group(set, [s.x[c], s.x[c + 1], s.x[c + 2]]);
                        s.x[c..c + 3].copy_from_slice(&p);
                    }
                    // (A cone's derivative is always Factors, an
                    // interval's never.)
                    (Set::Cone { .. }, Deriv::Identity)
                    | (Set::Interval { .. }, Deriv::Factors(_)) => {}
                }
                c += gr.len();
            }
            for (y, d) in s.y.iter_mut().zip(&s.d) {
                *y += d;
            }
            s.f.copy_from_slice(&self.b);
            for c in 0..s.x.len() {
                let xc = s.x[c];
                if xc != 0.0 {
                    let (ri, a) = self.m.col(c);
                    for (&r, a) in ri.iter().zip(a) {
                        s.f[r] -= a * xc;
                    }
                }
            }
            let new = amax(&s.f);
            // (NaN counts as no progress.)
            if new.is_nan() || new > 0.5 * fmax {
                fmax = new;
                break;
            }
            fmax = new;
        }
        if fmax.is_nan() || fmax >= start {
            s.x.copy_from_slice(&s.keep_x);
            s.y.copy_from_slice(&s.keep_y);
            s.f.copy_from_slice(&s.keep_f);
            return start;
        }
        fmax
    }

    /// Along s.d: q = Mᵀd, dv = q/2w per column; returns (φ'(0), bᵀd).
    fn direction(&self, s: &mut Newton) -> (f64, f64) {
        let slope: f64 = s.f.iter().zip(&s.d).map(|(f, d)| f * d).sum();
        let bd: f64 = self.b.iter().zip(&s.d).map(|(b, d)| b * d).sum();
        let mut c = 0;
        for gr in &self.groups {
            let inv2w = 0.5 / gr.w;
            for k in c..c + gr.len() {
                s.q[k] = self.m.dot(k, &s.d);
                s.dv[k] = s.q[k] * inv2w;
            }
            c += gr.len();
        }
        (slope, bd)
    }

    /// Second-order correction of a Newton step the line search cut to
    /// `t` < 1, for blocks with friction cones. A contact on the cone's
    /// surface near its polar cone (a large Mᵀy/2w whose projection is
    /// small: the contact wants to pull and is held at a small force)
    /// confines the multipliers to a curved ridge {n + μ‖s‖ ≈ 0}: the
    /// linear model steps off it, the line search cuts the step, and Newton
    /// creeps along the ridge (seen: g still short of its maximum after 200
    /// steps). The correction d₂ = (H + εS)⁻¹F(y + d), with the factor at
    /// hand, bends the step back; the corrected direction d + d₂ is taken
    /// when its line search accepts the full step, otherwise the cut step
    /// along d stands. Leaves s.d and the direction buffers on the step
    /// taken; returns its length.
    fn second_order_correction(&self, s: &mut Newton, t: f64) -> f64 {
        let n = s.y.len();
        s.keep_y.copy_from_slice(&s.y);
        for (y, d) in s.y.iter_mut().zip(&s.d) {
            *y += d;
        }
        self.eval(s);
        s.u.copy_from_slice(&s.f);
        cholesky_solve(&s.l, n, &mut s.u);
        s.y.copy_from_slice(&s.keep_y);
        self.eval(s);
        if !s.u.iter().all(|v| v.is_finite()) {
            self.direction(s);
            return t;
        }
        // keep_y holds d while d becomes d + d₂.
        s.keep_y.copy_from_slice(&s.d);
        for (d, d2) in s.d.iter_mut().zip(&s.u) {
            *d += d2;
        }
        let (slope, bd) = self.direction(s);
        if slope > 0.0 && self.line_search(s, bd, slope) == Some(1.0) {
            return 1.0;
        }
        s.d.copy_from_slice(&s.keep_y);
        self.direction(s);
        t
    }

    /// Newton from s.y (the caller's start) or, when `warm` is false, from
    /// the unconstrained multipliers; the answer is left in s.x and s.y.
    fn solve(&self, s: &mut Newton, warm: bool, target: f64, accept: f64) -> BlockResult {
        let nr = self.n_rows();
        if warm {
            // Only the diagonal of the every-bound-inactive matrix: the
            // first step builds H for its own derivative.
            self.free_diagonal(&mut s.h_free_diag);
            s.h_stale = true;
        } else {
            self.hessian(None, &mut s.h, &mut s.u);
            for r in 0..nr {
                s.h_free_diag[r] = s.h[r * nr + r];
            }
            s.h_stale = false;
        }
        let scale = s.h_free_diag.iter().fold(0.0, |m: f64, &d| m.max(d));
        if !(scale > 0.0 && scale.is_finite()) {
            return Err((0, "degenerate equations"));
        }
        for d in s.h_free_diag.iter_mut() {
            *d = d.max(1e-12 * scale);
        }
        let bscale = accept / RESIDUAL_TOLERANCE;
        // Damping factor ν: a cold start is far from the answer (its active
        // set is the unconstrained one), a warm start presumably close.
        let mut nu = if warm { 1e-6 } else { 0.1 };
        let mut solves = 0u32;
        let mut full_step = false;
        // h holds the matrix of every variable free.
        s.h_deriv.iter_mut().for_each(|d| *d = Deriv::Identity);
        if !warm {
            solves += 1;
            s.u.copy_from_slice(&self.b);
            if !regularised_solve(s, 1e-12, Target::Y) {
                return Err((solves, "singular start"));
            }
        }
        self.eval(s);
        // Stopping short of the target: accepted if within `accept`, after
        // a primal refinement when the residual is small.
        let give_up = |s: &mut Newton, solves: u32, why: &'static str| {
            let mut f = amax(&s.f);
            if f > target && f <= REFINE_BELOW * bscale {
                f = self.refine(s, target);
            }
            if f <= accept {
                Ok(solves)
            } else {
                Err((solves, why))
            }
        };
        let mut last_fmax = f64::INFINITY;
        let has_cone = self.groups.iter().any(|g| {
            matches!(
                g.set,
                Set::Cone {
                    model: FrictionModel::Cone,
                    ..
                }
            )
        });
        for _ in 0..MAX_NEWTON_STEPS {
            let fmax = amax(&s.f);
            if fmax <= target {
                return Ok(solves);
            }
            if full_step && fmax > 0.25 * last_fmax && fmax <= REFINE_BELOW * bscale {
                // A full step that did not cut a small residual: at the
                // rounding floor of x(y) (see `refine`).
                let f = self.refine(s, target);
                if f <= accept {
                    return Ok(solves + 1);
                }
                // (x and F back in step with y.)
                self.eval(s);
            }
            last_fmax = fmax;
            solves += 1;
            // Levenberg–Marquardt-like damping in proportion to each
            // equation's curvature scale and to the residual (bounded steps
            // where A D Aᵀ is singular: equations all of whose variables sit
            // at bounds, a contact on the cone's surface; vanishing as it
            // converges), with ν lowered after full steps and raised after
            // short ones.
            // Once a full step leaves every derivative as it was, F is
            // linear between the last two iterates and the plain Newton
            // step is exact (piecewise-linear F: intervals only).
            let changed = self.update_hessian(s);
            let eps = if full_step && changed == 0 {
                1e-12
            } else {
                1e-12 + nu * (fmax / bscale).min(1.0)
            };
            s.u.copy_from_slice(&s.f);
            if !regularised_solve(s, eps, Target::D) {
                return give_up(s, solves, "Newton system not solvable");
            }
            if eps == 1e-12 && amax(&s.d) > HUGE_STEP * amax(&s.y).max(1.0) {
                // The undamped step along a near-null direction of H (an
                // equation whose variables all sit at bounds): seen to throw
                // y to 1e10, where rounding stalls every later step. Damped
                // as usual instead.
                s.u.copy_from_slice(&s.f);
                let eps = 1e-12 + nu * (fmax / bscale).min(1.0);
                if !regularised_solve(s, eps, Target::D) {
                    return give_up(s, solves, "Newton system not solvable");
                }
            }
            // A step a thousand times longer than y (and than 1): damped
            // more until it is not. Along a direction where most variables
            // sit at bounds g rises only slowly, and the line search takes
            // such a step whole: seen to throw y from 33 to 9e4 on a frame
            // whose optimal multipliers are 60 (ten sliding contacts), after
            // which Newton crept for 200 steps.
            let mut tries = 0;
            while amax(&s.d) > STEP_CAP * amax(&s.y).max(1.0) && tries < 12 {
                nu = (nu * 10.0).min(1e3);
                s.u.copy_from_slice(&s.f);
                let eps = 1e-12 + nu * (fmax / bscale).min(1.0);
                if !regularised_solve(s, eps, Target::D) {
                    return give_up(s, solves, "Newton system not solvable");
                }
                tries += 1;
            }
            let (slope, bd) = self.direction(s);
            let t = if slope > 0.0 {
                self.line_search(s, bd, slope)
            } else {
                None
            };
            let Some(mut t) = t else {
                return give_up(s, solves, "line search stalled");
            };
            if t < 1.0 && has_cone {
                t = self.second_order_correction(s, t);
            }
            full_step = t == 1.0;
            if t == 1.0 {
                nu = (nu * 1e-3).max(1e-12);
            } else if t > 1.0 {
                nu = (nu * 1e-2).max(1e-12);
            } else if t < 0.25 {
                nu = (nu * 10.0).min(1.0);
            }
            for (y, d) in s.y.iter_mut().zip(&s.d) {
                *y += t * d;
            }
            // v afresh from y (v + t·dv would carry the rounding of long
            // steps: the optimality conditions hold to ~1e-11 instead).
            self.eval(s);
        }
        give_up(s, solves, "step limit")
    }
}

/// max |v_i| (0 for an empty slice).
fn amax(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, e| m.max(e.abs()))
}

/// Cholesky factor L of the n×n matrix `l` (lower triangle, by column; the
/// upper triangle is not read) in place, with 1/L_jj in place of L_jj.
/// False when a pivot is not positive.
fn cholesky(l: &mut [f64], n: usize) -> bool {
    for j in 0..n {
        let (left, right) = l.split_at_mut((j + 1) * n);
        let col = &mut left[j * n..];
        let d = col[j];
        if d.is_nan() || d <= 0.0 {
            return false;
        }
        let inv = 1.0 / d.sqrt();
        col[j] = inv;
        col[j + 1..].iter_mut().for_each(|e| *e *= inv);
        // Columns k > j: rows k.. less l_kj · (l_rj)_r.
        for (k, next) in (j + 1..n).zip(right.chunks_exact_mut(n)) {
            let lkj = col[k];
            if lkj != 0.0 {
                for (e, lr) in next[k..].iter_mut().zip(&col[k..]) {
                    *e -= lkj * lr;
                }
            }
        }
    }
    true
}

/// Solves L Lᵀ z = z in place with the factor of [`cholesky`].
fn cholesky_solve(l: &[f64], n: usize, z: &mut [f64]) {
    for j in 0..n {
        let col = &l[j * n..(j + 1) * n];
        z[j] *= col[j];
        let zj = z[j];
        for (e, lr) in z[j + 1..].iter_mut().zip(&col[j + 1..]) {
            *e -= zj * lr;
        }
    }
    for j in (0..n).rev() {
        let col = &l[j * n..(j + 1) * n];
        let s: f64 = col[j + 1..]
            .iter()
            .zip(&z[j + 1..])
            .map(|(a, b)| a * b)
            .sum();
        z[j] = (z[j] - s) * col[j];
    }
}

/// Which vector [`regularised_solve`] writes.
#[derive(Clone, Copy)]
enum Target {
    Y,
    D,
}

/// Cholesky solve of (H + eps·diag(h_free_diag)) z = s.u with H = s.h,
/// into s.y or s.d, raising eps by 1e3 up to four times when the
/// factorisation fails. False when it never succeeds.
fn regularised_solve(s: &mut Newton, eps: f64, target: Target) -> bool {
    let n = s.h_free_diag.len();
    let mut e = eps;
    for _ in 0..5 {
        s.l.copy_from_slice(&s.h);
        for i in 0..n {
            s.l[i * n + i] += e * s.h_free_diag[i];
        }
        if cholesky(&mut s.l, n) {
            let z = match target {
                Target::Y => &mut s.y,
                Target::D => &mut s.d,
            };
            z.copy_from_slice(&s.u);
            cholesky_solve(&s.l, n, z);
            if z.iter().all(|v| v.is_finite()) {
                return true;
            }
        }
        e *= 1e3;
    }
    false
}

/// The block structure of a problem: which groups and equations form each
/// independent block, the order of each block's equations, and A's columns
/// laid out block by block. It is a function of the grouping of the
/// variables and of A's pattern of nonzero entries alone, so
/// [`DualWorkspace`] keeps it from one problem to the next and rebuilds it
/// when either differs ([`Layout::refill`] checks both on every call): a
/// problem's answer is the same bit for bit whatever was solved before.
#[derive(Debug, Default)]
struct Layout {
    /// Built for these dimensions and these groups' variables (in the order
    /// the partition lists them).
    valid: bool,
    m: usize,
    n: usize,
    key: Vec<[usize; 3]>,
    /// Groups (indices into the partition's list) block by block, and each
    /// block's first (n_blocks + 1 entries).
    order: Vec<usize>,
    block_group: Vec<usize>,
    /// Per entry of `order`: its first column, counted from its block's.
    group_col: Vec<usize>,
    /// Groups in no equation.
    idle_groups: Vec<usize>,
    /// The ordered groups' columns, rows local to their block (entries in
    /// ascending global row), each entry's global row, and each block's
    /// first column (n_blocks + 1 entries).
    cols: SparseCols,
    src_row: Vec<usize>,
    block_col: Vec<usize>,
    /// Per variable: its column in `cols` (usize::MAX: a fixed variable or
    /// one of an idle group).
    var_col: Vec<usize>,
    /// The caller's key of the A this layout last took its values from
    /// ([`DualWorkspace::solve_into_keyed`]); None after any other call.
    a_key: Option<u64>,
    /// Each block's equations (global rows) in the block's order, and each
    /// block's first (n_blocks + 1 entries).
    rows: Vec<usize>,
    block_row: Vec<usize>,
    /// Equations without free variables.
    idle_rows: Vec<usize>,
    /// Scratch of [`Layout::rebuild`].
    tmp: SparseCols,
    tmp_first: Vec<usize>,
    parent: Vec<usize>,
    block_of_root: Vec<usize>,
    block_of_group: Vec<usize>,
    row_block: Vec<usize>,
    count: Vec<usize>,
    local: Vec<usize>,
}

/// Number of nonzero (or NaN) entries of a dense column.
fn nonzeros(column: &[f64]) -> usize {
    column.iter().map(|&e| usize::from(e != 0.0)).sum()
}

impl Layout {
    fn n_blocks(&self) -> usize {
        self.block_row.len().saturating_sub(1)
    }

    /// Whether the layout was built for these dimensions and groups.
    fn fits(&self, m: usize, n: usize, groups: &[Group]) -> bool {
        self.valid
            && self.m == m
            && self.n == n
            && self.key.len() == groups.len()
            && self.key.iter().zip(groups).all(|(k, g)| *k == g.vars)
    }

    /// Takes A's values (dense, m rows) into the columns when A has the
    /// pattern the layout was built for: every column of a grouped
    /// variable nonzero exactly in its recorded rows. False otherwise (the
    /// values are then partly written; [`Layout::rebuild`] follows).
    fn refill(&mut self, a: &[f64], m: usize, groups: &[Group]) -> bool {
        let mut c = 0;
        for &g in &self.order {
            let gr = &groups[g];
            for &v in &gr.vars[..gr.len()] {
                let column = &a[v * m..(v + 1) * m];
                let (start, end) = (self.cols.col_ptr[c], self.cols.col_ptr[c + 1]);
                if nonzeros(column) != end - start {
                    return false;
                }
                for (e, &r) in self.cols.val[start..end]
                    .iter_mut()
                    .zip(&self.src_row[start..end])
                {
                    *e = column[r];
                    if *e == 0.0 {
                        return false;
                    }
                }
                c += 1;
            }
        }
        self.idle_groups.iter().all(|&g| {
            let gr = &groups[g];
            gr.vars[..gr.len()]
                .iter()
                .all(|&v| nonzeros(&a[v * m..(v + 1) * m]) == 0)
        })
    }

    /// Builds the layout afresh for A (dense, m rows) and these groups.
    fn rebuild(&mut self, a: &[f64], m: usize, n: usize, groups: &[Group]) {
        self.valid = false;
        // The groups' columns (global rows); union-find over the equations
        // they share.
        let tmp = &mut self.tmp;
        tmp.clear();
        tmp.make_room(m * groups.iter().map(Group::len).sum::<usize>());
        let parent = &mut self.parent;
        parent.clear();
        parent.extend(0..m);
        let first = &mut self.tmp_first;
        first.clear();
        for gr in groups {
            let c0 = tmp.col_ptr.len() - 1;
            first.push(c0);
            for &v in &gr.vars[..gr.len()] {
                tmp.push_dense_col(&a[v * m..(v + 1) * m]);
            }
            let (start, end) = (tmp.col_ptr[c0], tmp.col_ptr[tmp.col_ptr.len() - 1]);
            if end > start {
                // Every row of the group under the root of its first row.
                let root = find(parent, tmp.row_idx[start]);
                for &r in &tmp.row_idx[start + 1..end] {
                    let rr = find(parent, r);
                    if rr != root {
                        parent[rr] = root;
                    }
                }
            }
        }
        tmp.trim();
        first.push(tmp.col_ptr.len() - 1);
        // Blocks numbered by root row, in order of their first group.
        let block_of_root = &mut self.block_of_root;
        block_of_root.clear();
        block_of_root.resize(m, usize::MAX);
        let block_of_group = &mut self.block_of_group;
        block_of_group.clear();
        let mut n_blocks = 0;
        for gi in 0..groups.len() {
            let (start, end) = (tmp.col_ptr[first[gi]], tmp.col_ptr[first[gi + 1]]);
            if start == end {
                block_of_group.push(usize::MAX);
                continue;
            }
            let root = find(parent, tmp.row_idx[start]);
            if block_of_root[root] == usize::MAX {
                block_of_root[root] = n_blocks;
                n_blocks += 1;
            }
            block_of_group.push(block_of_root[root]);
        }
        // Each block's rows in order of their count of nonzero entries
        // (then index): equations coupled to many others (a pelvis beside
        // two legs) come last, so the Cholesky factor keeps the zeros of H
        // between the others (no fill between the legs).
        let count = &mut self.count;
        count.clear();
        count.resize(m, 0);
        for &r in &tmp.row_idx {
            count[r] += 1;
        }
        self.row_block.clear();
        self.idle_rows.clear();
        for r in 0..m {
            let k = block_of_root[find(parent, r)];
            self.row_block.push(k);
            if k == usize::MAX {
                self.idle_rows.push(r);
            }
        }
        self.rows.clear();
        self.block_row.clear();
        self.local.clear();
        self.local.resize(m, usize::MAX);
        for k in 0..n_blocks {
            let start = self.rows.len();
            self.block_row.push(start);
            let row_block = &self.row_block;
            self.rows.extend((0..m).filter(|&r| row_block[r] == k));
            self.rows[start..].sort_unstable_by_key(|&r| (count[r], r));
            for (i, &r) in self.rows[start..].iter().enumerate() {
                self.local[r] = i;
            }
        }
        self.block_row.push(self.rows.len());
        // The groups block by block, their columns with local rows.
        self.order.clear();
        self.block_group.clear();
        self.group_col.clear();
        self.block_col.clear();
        self.src_row.clear();
        let cols = &mut self.cols;
        cols.clear();
        for k in 0..n_blocks {
            self.block_group.push(self.order.len());
            let c0 = cols.col_ptr.len() - 1;
            self.block_col.push(c0);
            for gi in (0..groups.len()).filter(|&gi| block_of_group[gi] == k) {
                self.order.push(gi);
                self.group_col.push(cols.col_ptr.len() - 1 - c0);
                for c in first[gi]..first[gi + 1] {
                    let (ri, v) = tmp.col(c);
                    let local = &self.local;
                    cols.push_col(ri.iter().zip(v).map(|(&r, &e)| (local[r], e)));
                    self.src_row.extend_from_slice(ri);
                }
            }
        }
        self.block_group.push(self.order.len());
        self.block_col.push(cols.col_ptr.len() - 1);
        self.var_col.clear();
        self.var_col.resize(n, usize::MAX);
        let mut c = 0;
        for &gi in &self.order {
            let gr = &groups[gi];
            for &v in &gr.vars[..gr.len()] {
                self.var_col[v] = c;
                c += 1;
            }
        }
        self.idle_groups.clear();
        self.idle_groups
            .extend((0..groups.len()).filter(|&gi| block_of_group[gi] == usize::MAX));
        self.key.clear();
        self.key.extend(groups.iter().map(|g| g.vars));
        (self.m, self.n) = (m, n);
        self.valid = true;
    }
}

/// Reusable buffers of the dual Newton method. [`DualWorkspace::solve`]
/// answers exactly as [`solve_dual`] does: besides allocated memory it
/// keeps only the block structure of the last problem ([`Layout`]), which
/// it checks against each new problem and rebuilds when it differs. A
/// caller solving many frames keeps one per thread.
#[derive(Debug, Default)]
pub struct DualWorkspace {
    /// Per variable: its fixed value, whether it belongs to a contact.
    fixed: Vec<Option<f64>>,
    in_contact: Vec<bool>,
    /// The groups in the partition's order, and in the layout's.
    groups: Vec<Group>,
    ordered: Vec<Group>,
    /// Right-hand side with the fixed variables moved over, and that of
    /// the blocks' rows in the layout's order.
    b: Vec<f64>,
    block_b: Vec<f64>,
    /// A x − b of the answer.
    residual: Vec<f64>,
    layout: Layout,
    newton: Newton,
    /// Layouts built (to test that they are reused and rebuilt).
    #[cfg(test)]
    rebuilds: u64,
    /// Calls that took A's values from the last call's (its key matched).
    #[cfg(test)]
    refills_skipped: u64,
}

impl DualWorkspace {
    pub fn new() -> Self {
        Self::default()
    }

    /// As [`solve_dual`], with this workspace's buffers.
    pub fn solve(
        &mut self,
        p: &FrameProblem,
        y0: Option<&[f64]>,
    ) -> Result<DualSolution, DualFailure> {
        let (mut x, mut y) = (Vec::new(), Vec::new());
        let info = self.solve_into(p, y0, &mut x, &mut y)?;
        Ok(DualSolution {
            x,
            y,
            iterations: info.iterations,
            blocks: info.blocks,
            eq_residual: info.eq_residual,
        })
    }

    /// [`solve`](Self::solve) into the caller's `x` and `y` (resized to
    /// the problem; no allocation once they and the workspace have their
    /// sizes). On failure their contents are unspecified.
    pub fn solve_into(
        &mut self,
        p: &FrameProblem,
        y0: Option<&[f64]>,
        x: &mut Vec<f64>,
        y: &mut Vec<f64>,
    ) -> Result<DualInfo, DualFailure> {
        self.solve_into_keyed(p, y0, x, y, None)
    }

    /// [`solve_into`](Self::solve_into) of a problem whose A the caller
    /// names by `a_key`: a key given to this workspace before names the
    /// same A bit for bit (the caller's promise; keys from
    /// [`super::solve::fresh_a_key`]). When the last problem laid out had
    /// that key, A's values are not read again (a force sweep solves one
    /// frame's A for thousands of candidates). The same answer as without
    /// the key.
    pub fn solve_into_keyed(
        &mut self,
        p: &FrameProblem,
        y0: Option<&[f64]>,
        x: &mut Vec<f64>,
        y: &mut Vec<f64>,
        a_key: Option<u64>,
    ) -> Result<DualInfo, DualFailure> {
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
        let fixed = &mut self.fixed;
        fixed.clear();
        fixed.resize(n, None);
        let in_contact = &mut self.in_contact;
        in_contact.clear();
        in_contact.resize(n, false);
        let groups = &mut self.groups;
        groups.clear();
        for c in &p.static_contacts {
            for s in c.shear {
                in_contact[s] = true;
            }
            if c.mu == 0.0 {
                // Shear is 0 in every friction model; the normal is an
                // ordinary bounded variable (handled below).
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
        let a = p.a.as_slice();
        let b = &mut self.b;
        b.clear();
        b.extend_from_slice(p.b.as_slice());
        x.clear();
        x.resize(n, 0.0);
        for (j, v) in fixed.iter().enumerate() {
            if let Some(v) = *v {
                x[j] = v;
                if v != 0.0 {
                    for (bi, aij) in b.iter_mut().zip(&a[j * m..(j + 1) * m]) {
                        *bi -= v * aij;
                    }
                }
            }
        }

        // The block structure: the last problem's when it applies.
        let layout = &mut self.layout;
        let same_a = a_key.is_some() && layout.a_key == a_key;
        // (Forgotten until the values are in: a panic in between leaves
        // no key behind.)
        layout.a_key = None;
        if !(layout.fits(m, n, groups) && (same_a || layout.refill(a, m, groups))) {
            layout.rebuild(a, m, n, groups);
            #[cfg(test)]
            {
                self.rebuilds += 1;
            }
        }
        #[cfg(test)]
        if same_a && layout.valid {
            self.refills_skipped += 1;
        }
        layout.a_key = a_key;
        for &g in &layout.idle_groups {
            // In no equation: the projection of 0.
            let gr = &groups[g];
            let v = gr.at_zero();
            for k in 0..gr.len() {
                x[gr.vars[k]] = v[k];
            }
        }
        if layout.idle_rows.iter().any(|&r| b[r].abs() > tol) {
            // No free variable in this equation.
            return Err(DualFailure::NotConverged {
                iterations: 0,
                reason: "an equation without free variables does not hold",
            });
        }
        self.ordered.clear();
        self.ordered.extend(layout.order.iter().map(|&g| groups[g]));
        self.block_b.clear();
        self.block_b.extend(layout.rows.iter().map(|&r| b[r]));

        y.clear();
        y.resize(m, 0.0);
        let mut iterations = 0u32;
        let n_blocks = layout.n_blocks();
        for k in 0..n_blocks {
            let (r0, r1) = (layout.block_row[k], layout.block_row[k + 1]);
            let (g0, g1) = (layout.block_group[k], layout.block_group[k + 1]);
            let (c0, c1) = (layout.block_col[k], layout.block_col[k + 1]);
            let block = Block {
                rows: &layout.rows[r0..r1],
                groups: Part(&self.ordered[g0..g1]),
                group_col: &layout.group_col[g0..g1],
                m: layout.cols.view(c0..c1),
                b: Part(&self.block_b[r0..r1]),
            };
            let s = &mut self.newton;
            s.resize(r1 - r0, c1 - c0, g1 - g0);
            if let Some(y0) = y0 {
                for (yk, &r) in s.y.iter_mut().zip(block.rows) {
                    *yk = y0[r];
                }
            }
            match block.solve(s, y0.is_some(), TARGET_TOLERANCE * bmax.max(1.0), tol) {
                Ok(it) => {
                    iterations += it;
                    let mut c = 0;
                    for gr in &block.groups {
                        for &j in &gr.vars[..gr.len()] {
                            x[j] = s.x[c];
                            c += 1;
                        }
                    }
                    for (yk, &r) in s.y.iter().zip(block.rows) {
                        y[r] = *yk;
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
        // Safety net: the whole system, with the original matrix: as
        // FrameProblem::eq_residual, without allocating, and skipping the
        // columns of variables at 0 (which add ±0 to a finite A's sums).
        // A grouped variable's column is summed from its nonzero entries
        // in the layout (the same values as A's, in the same order of
        // variables and rows: the same sums bit for bit, since A's zeros
        // add ±0), a fixed one's from A.
        let r = &mut self.residual;
        r.clear();
        r.extend(p.b.iter().map(|b| -b));
        if m > 0 {
            let layout = &self.layout;
            let r = r.as_mut_slice();
            let (col_ptr, src_row, val) = (&layout.cols.col_ptr, &layout.src_row, &layout.cols.val);
            for (j, (column, &xj)) in a.chunks_exact(m).zip(x.iter()).enumerate() {
                if xj == 0.0 {
                    continue;
                }
                let c = layout.var_col[j];
                if c == usize::MAX {
                    for (ri, aij) in r.iter_mut().zip(column) {
                        *ri += aij * xj;
                    }
                } else {
                    let (start, end) = (col_ptr[c], col_ptr[c + 1]);
                    for (&i, aij) in src_row[start..end].iter().zip(&val[start..end]) {
                        r[i] += aij * xj;
                    }
                }
            }
        }
        let residual = r.iter().fold(0.0f64, |worst, ri| worst.max(ri.abs()));
        if residual.is_nan() || residual > tol {
            return Err(DualFailure::NotConverged {
                iterations,
                reason: "residual of the assembled solution",
            });
        }
        Ok(DualInfo {
            iterations,
            blocks: n_blocks,
            eq_residual: residual,
        })
    }
}

/// Solves a valid problem (see [`FrameProblem::validate`]) by dual Newton,
/// optionally from multipliers `y0` (one per equation). See the module
/// documentation for what is handled. A fresh [`DualWorkspace`] each call.
pub fn solve_dual(p: &FrameProblem, y0: Option<&[f64]>) -> Result<DualSolution, DualFailure> {
    DualWorkspace::new().solve(p, y0)
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
    optimality_violation_floored(p, x, y, 0.0)
}

/// [`optimality_violation`] with each variable's scale raised to at least
/// `floor` · Σ_i |a_ij y_i|, the size of the terms whose sum is (Aᵀy)_j
/// (and a contact's x, in its complementarity, to `floor` · Σ_i |a_ij y_i|
/// / 2w, the size of the point it is projected from).
/// Where those terms cancel to a small (Aᵀy)_j (a contact barely loaded
/// while its column meets large multipliers), the rounding of Aᵀy alone,
/// about 1e-16 of the terms, exceeds 1e-9 of (Aᵀy)_j, and no pair (x, y) in
/// double precision meets the plain test; a floor of 1e-6 accepts that
/// rounding and nothing beyond a few units of it. `floor` = 0 is
/// [`optimality_violation`].
pub fn optimality_violation_floored(p: &FrameProblem, x: &[f64], y: &[f64], floor: f64) -> f64 {
    let aty = p.a.tr_mul(&DVector::from_column_slice(y));
    let terms: Vec<f64> = if floor > 0.0 {
        (0..p.n_var())
            .map(|j| {
                floor
                    * p.a
                        .column(j)
                        .iter()
                        .zip(y)
                        .map(|(a, y)| (a * y).abs())
                        .sum::<f64>()
            })
            .collect()
    } else {
        vec![0.0; p.n_var()]
    };
    let mut worst = 0.0f64;
    let mut in_cone = vec![false; p.n_var()];
    for c in p.static_contacts.iter().filter(|c| c.mu > 0.0) {
        let v = [c.normal, c.shear[0], c.shear[1]];
        let w = p.weights[c.normal];
        let z: Vec<f64> = v.iter().map(|&j| aty[j] - 2.0 * w * x[j]).collect();
        let scale = v
            .iter()
            .map(|&j| aty[j].abs().max(2.0 * w * x[j].abs()).max(terms[j]))
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
        // x is the projection of Aᵀy/2w (the contact's rows of z + 2w x):
        // where that point is far larger than x (a light contact, large
        // multipliers) x carries its rounding, and the floor raises the
        // scale of x to that point's.
        let xs = v
            .iter()
            .map(|&j| x[j].abs().max(terms[j] / (2.0 * w)))
            .fold(1e-300, f64::max);
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
            .max(terms[j])
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
