//! Dispatch between the solvers ([`solve`]) and the conic formulation of a
//! [`FrameProblem`] for Clarabel ([`solve_clarabel`]).
//!
//! Clarabel solves  min ½ zᵀPz + qᵀz  s.t.  M z + s = h, s ∈ K  (its own
//! names are P, q, A, b; here M and h to avoid a clash with the problem's
//! A and b). The decision vector is z = [x; t; r]:
//!
//! * x — the problem variables (n_var);
//! * t — epigraph variables t_i ≥ |x_i|^p, one per variable of positive
//!   weight, only when p ≠ 2;
//! * r — equality slacks, only in the elastic re-solve of an infeasible
//!   frame.
//!
//! Rows of M, block by block (cones in this order):
//! 1. zero cone — A x (− r) = b; x_i = lower_i for fixed variables
//!    (lower == upper); λs1 = λs2 = 0 for contacts with μ_s = 0;
//! 2. non-negative cone — finite bounds x_i ≤ upper_i, −x_i ≤ −lower_i
//!    (infinite bounds produce no row); pyramid faces c·(λs1, λs2) − μ λn ≤ 0;
//!    for p = 1, ±x_i − t_i ≤ 0;
//! 3. second-order cones (3-D) — (μ λn, λs1, λs2) for `FrictionModel::Cone`;
//! 4. power cones K(α = 1/p) = {(u, v, w): u^α v^(1−α) ≥ |w|, u, v ≥ 0} —
//!    (t_i, 1, x_i), i.e. t_i^(1/p) ≥ |x_i| ⇔ t_i ≥ |x_i|^p, for p ∉ {1, 2}.
//!
//! Objective: p = 2: P = 2·diag(weights) (upper triangle, zero weights
//! omitted), q = 0. Otherwise P = 0 and q_t = weights, a linear objective
//! Σ w_i t_i over the epigraph variables. The elastic re-solve adds
//! [`ELASTIC_PENALTY`]·‖r‖² to either.
//!
//! M is assembled directly in compressed-sparse-column form in two passes
//! over the same row generator (one to count entries per column, one to
//! fill them), so no triplet list or dense copy is made.
use std::time::Instant;

use clarabel::algebra::CscMatrix;
use clarabel::solver::{DefaultSettings, DefaultSolver, IPSolver, SolverStatus, SupportedConeT};

use super::dual;
use super::friction::FrictionModel;
use super::polish;
use super::problem::{FrameProblem, FrameSolution, SolveStatus, SolverChoice, SolverKind};

/// Weight of ‖A x − b‖² in the elastic problem solved when a frame is
/// infeasible, relative to the objective normalised as described at `objective_scale`
/// (cheapest variable weight 1). It is large compared with that objective
/// (activations are O(1)), so the elastic optimum is, to a relative 1e-6 or
/// so, the x within bounds and friction limits that comes closest to
/// satisfying the equalities in the least-squares sense.
pub const ELASTIC_PENALTY: f64 = 1e6;

const NONE: usize = usize::MAX;

/// Solves one frame. Never panics.
///
/// With `SolverChoice::Auto` (the default) a valid problem goes to the dual
/// Newton method ([`dual::solve_dual`], cold start); its answer has status
/// `Solved` and `solver` [`SolverKind::Newton`]. When that method does not
/// handle the problem or does not converge, and with
/// `SolverChoice::Clarabel`, [`solve_clarabel`] answers.
pub fn solve(p: &FrameProblem) -> FrameSolution {
    let mut out = FrameSolution::default();
    solve_into(p, None, &mut out);
    out
}

/// [`solve`] into `out`, whose buffers are reused: a Newton answer
/// allocates nothing once `out` and this thread's Newton workspace have
/// their sizes (a frame Clarabel answers allocates: Clarabel builds its
/// solver on every call). Newton starts from `y0` (one multiplier per
/// equation, e.g. the previous frame's `out.y`: a warm start) when given,
/// else cold; a `y0` of the wrong length is ignored. When the warm-started
/// Newton fails, the frame is solved as [`solve`] solves it (Newton from the
/// cold start, then Clarabel), so a warm start changes an answer by
/// rounding at most; `iterations` then counts the failed attempt's linear
/// solves too. `out.y` receives the answer's multipliers (empty when
/// Clarabel answered without a polish).
pub fn solve_into(p: &FrameProblem, y0: Option<&[f64]>, out: &mut FrameSolution) {
    solve_into_checked(p, y0, out, p.validate().is_ok());
}

/// [`solve_into`] of a problem whose A has only finite entries, which the
/// caller checked ([`FrameProblem::validate_but_a_entries`]): the same
/// answer, without scanning A again (a force sweep solves one frame's A for
/// thousands of candidates).
pub fn solve_into_finite_a(p: &FrameProblem, y0: Option<&[f64]>, out: &mut FrameSolution) {
    solve_into_checked(p, y0, out, p.validate_but_a_entries().is_ok());
}

/// [`solve_into`] of a problem the caller validated
/// ([`FrameProblem::validate`]: `valid` is whether it passed; a force sweep
/// checks a frame's program once, then of each candidate only what it
/// changed).
pub fn solve_into_valid(
    p: &FrameProblem,
    y0: Option<&[f64]>,
    out: &mut FrameSolution,
    valid: bool,
) {
    solve_into_checked(p, y0, out, valid);
}

/// [`solve_into_valid`] of a problem whose A the caller names by `a_key`
/// (from [`fresh_a_key`]): the caller promises that every problem it gives
/// with this key has the same A bit for bit, so this thread's Newton
/// workspace, when its last problem had the key, does not read A's values
/// again. The same answer as [`solve_into_valid`].
pub fn solve_into_valid_keyed(
    p: &FrameProblem,
    y0: Option<&[f64]>,
    out: &mut FrameSolution,
    valid: bool,
    a_key: u64,
) {
    solve_into_keyed(p, y0, out, valid, Some(a_key));
}

/// A key no other call of this process returned (for
/// [`solve_into_valid_keyed`]).
pub fn fresh_a_key() -> u64 {
    use std::sync::atomic::{AtomicU64, Ordering};
    static NEXT: AtomicU64 = AtomicU64::new(0);
    NEXT.fetch_add(1, Ordering::Relaxed)
}

fn solve_into_checked(p: &FrameProblem, y0: Option<&[f64]>, out: &mut FrameSolution, valid: bool) {
    solve_into_keyed(p, y0, out, valid, None);
}

fn solve_into_keyed(
    p: &FrameProblem,
    y0: Option<&[f64]>,
    out: &mut FrameSolution,
    valid: bool,
    a_key: Option<u64>,
) {
    if p.settings.solver == SolverChoice::Clarabel || !valid {
        *out = solve_clarabel(p);
        return;
    }
    let y0 = y0.filter(|y| y.len() == p.n_eq());
    let start = Instant::now();
    thread_local! {
        // Buffers only: an answer depends on nothing but the problem and
        // the warm start.
        static WORKSPACE: std::cell::RefCell<dual::DualWorkspace> = Default::default();
    }
    let mut attempt = |y0: Option<&[f64]>| {
        let newton = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            WORKSPACE.with(|ws| match ws.try_borrow_mut() {
                Ok(mut ws) => ws.solve_into_keyed(p, y0, &mut out.x, &mut out.y, a_key),
                // (Only if a solve were re-entered.)
                Err(_) => dual::DualWorkspace::new().solve_into(p, y0, &mut out.x, &mut out.y),
            })
        }));
        match newton {
            Ok(Ok(d)) => Ok(d),
            Ok(Err(f)) => Err(f.iterations()),
            Err(_) => Err(0),
        }
    };
    let mut spent = 0;
    let mut newton = attempt(y0);
    if y0.is_some() {
        if let Err(it) = newton {
            spent = it;
            newton = attempt(None);
        }
    }
    match newton {
        Ok(d) => {
            out.objective = p.objective(&out.x);
            out.eq_residual = d.eq_residual;
            out.status = SolveStatus::Solved;
            out.iterations = d.iterations + spent;
            out.solve_time = start.elapsed();
            out.solver = SolverKind::Newton;
            out.polished = false;
        }
        Err(it) => {
            *out = solve_clarabel(p);
            out.iterations += spent + it;
            out.solve_time = start.elapsed();
        }
    }
}

/// Solves one frame with Clarabel. Never panics.
///
/// On `Solved`/`AlmostSolved` x is Clarabel's optimum. When Clarabel
/// certifies the problem infeasible (status [`SolveStatus::Infeasible`]) its
/// primal vector is an infeasibility certificate, not a candidate, so the
/// frame is solved again with the equalities relaxed to
/// A x − r = b and [`ELASTIC_PENALTY`]·‖r‖² added to the objective; x is that
/// elastic solution (within bounds and friction limits, with the smallest
/// equality violation it can have) and `eq_residual` shows how far from
/// equilibrium it is. OpenSim in the same situation keeps IPOPT's last
/// iterate (§6.5), which is not reproducible across solvers; the elastic x
/// serves the same purpose (a best-effort row) deterministically. On other
/// failures x is Clarabel's last iterate. In every case x is finite and
/// clamped into [lower, upper].
pub fn solve_clarabel(p: &FrameProblem) -> FrameSolution {
    let start = Instant::now();
    let n = p.n_var();
    if p.validate().is_err() {
        let x: Vec<f64> = (0..n)
            .map(|i| {
                let (lo, hi) = (
                    p.lower.get(i).copied().unwrap_or(0.0),
                    p.upper.get(i).copied().unwrap_or(0.0),
                );
                if lo <= hi {
                    0.0f64.clamp(lo, hi)
                } else {
                    0.0
                }
            })
            .collect();
        return FrameSolution {
            x,
            status: SolveStatus::InvalidProblem,
            iterations: 0,
            objective: f64::NAN,
            eq_residual: f64::NAN,
            solve_time: start.elapsed(),
            solver: SolverKind::Clarabel,
            polished: false,
            y: Vec::new(),
        };
    }

    let (mut x, mut status, mut iterations) = if n == 0 {
        // Nothing to optimise (Clarabel cannot factor an empty system).
        let status = if p.b.iter().all(|v| *v == 0.0) {
            SolveStatus::Solved
        } else {
            SolveStatus::Infeasible
        };
        (Vec::new(), status, 0)
    } else {
        run_guarded(p, Mode::Plain)
    };
    if status == SolveStatus::Infeasible && n > 0 {
        // Clarabel's infeasibility test (tolerance 1e-8) can fire after a
        // few iterations on feasible but badly scaled frames (seen: a frame
        // with unbounded reserves and generalized forces of 1.8e3 declared
        // infeasible at iteration 3). Check the claim once with a much
        // stricter test before treating the frame as infeasible.
        let (xs, ss, it) = run_guarded(p, Mode::StrictInfeasibility);
        iterations += it;
        if matches!(ss, SolveStatus::Solved | SolveStatus::AlmostSolved) {
            x = xs;
            status = ss;
        } else {
            let (xe, _, it) = run_guarded(p, Mode::Elastic);
            x = xe;
            iterations += it;
        }
    }
    for (i, xi) in x.iter_mut().enumerate() {
        if !xi.is_finite() {
            *xi = 0.0;
        }
        *xi = xi.clamp(p.lower[i], p.upper[i]);
    }
    if x.len() != n {
        // Defensive: Clarabel always returns n entries for n columns.
        x.resize(n, 0.0);
        status = SolveStatus::NumericalError;
    }
    let mut polished = false;
    let mut y = Vec::new();
    if matches!(status, SolveStatus::Solved | SolveStatus::AlmostSolved) {
        // To the exact optimum when its active set can be identified and
        // the answer passes the optimality certificate ([`polish`]).
        if let Some((xp, yp)) = polish::polish(p, &x) {
            x = xp;
            y = yp;
            status = SolveStatus::Solved;
            polished = true;
        }
    }
    FrameSolution {
        objective: p.objective(&x),
        eq_residual: p.eq_residual(&x),
        x,
        status,
        iterations,
        solve_time: start.elapsed(),
        solver: SolverKind::Clarabel,
        polished,
        y,
    }
}

/// [`run`], with a panic inside Clarabel (an internal assertion or index
/// error on data it should have refused) turned into `NumericalError`, so
/// that one bad frame cannot abort a whole analysis.
fn run_guarded(p: &FrameProblem, mode: Mode) -> (Vec<f64>, SolveStatus, u32) {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| run(p, mode)))
        .unwrap_or_else(|_| (vec![0.0; p.n_var()], SolveStatus::NumericalError, 0))
}

/// How [`run`] formulates and solves a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    /// The frame's program as it is.
    Plain,
    /// As `Plain`, with Clarabel's infeasibility tolerances at 1e-14
    /// instead of 1e-8, to re-check an infeasibility claim.
    StrictInfeasibility,
    /// Equalities relaxed (see [`ELASTIC_PENALTY`]).
    Elastic,
}

/// Builds and solves the conic program; returns (x, status, iterations).
fn run(p: &FrameProblem, mode: Mode) -> (Vec<f64>, SolveStatus, u32) {
    let elastic = mode == Mode::Elastic;
    let layout = Layout::new(p, elastic);
    let nz = layout.n_z;

    // Pass 1: count entries per column, collect h and the block sizes.
    let mut counter = Counter {
        col_count: vec![0; nz],
        h: Vec::new(),
    };
    let blocks = layout.visit(p, &mut counter);
    let m_rows = counter.h.len();

    // Column pointers, then pass 2 fills row indices and values.
    let mut colptr = Vec::with_capacity(nz + 1);
    colptr.push(0usize);
    for c in &counter.col_count {
        let last = colptr[colptr.len() - 1];
        colptr.push(last + c);
    }
    let nnz = colptr[nz];
    let mut filler = Filler {
        next: colptr[..nz].to_vec(),
        rowval: vec![0; nnz],
        nzval: vec![0.0; nnz],
        row: 0,
    };
    layout.visit(p, &mut filler);
    let h = counter.h;
    let m_mat = CscMatrix::new(m_rows, nz, colptr, filler.rowval, filler.nzval);

    // Objective, normalised so that the smallest positive weight is 1 (see
    // `objective_scale`).
    let scale = objective_scale(p);
    let mut q = vec![0.0; nz];
    let mut p_colptr = Vec::with_capacity(nz + 1);
    let mut p_rowval = Vec::new();
    let mut p_nzval = Vec::new();
    p_colptr.push(0);
    for j in 0..nz {
        let diag = if j < p.n_var() {
            if layout.quadratic && p.weights[j] > 0.0 {
                2.0 * scale * p.weights[j]
            } else {
                0.0
            }
        } else if j >= layout.r0 {
            2.0 * ELASTIC_PENALTY
        } else {
            0.0
        };
        if diag != 0.0 {
            p_rowval.push(j);
            p_nzval.push(diag);
        }
        p_colptr.push(p_rowval.len());
    }
    for (i, &ti) in layout.t_of.iter().enumerate() {
        if ti != NONE {
            q[ti] = scale * p.weights[i];
        }
    }
    let p_mat = CscMatrix::new(nz, nz, p_colptr, p_rowval, p_nzval);

    let mut cones = Vec::with_capacity(2 + blocks.n_soc + blocks.n_pow);
    if blocks.n_zero > 0 {
        cones.push(SupportedConeT::ZeroConeT(blocks.n_zero));
    }
    if blocks.n_nonneg > 0 {
        cones.push(SupportedConeT::NonnegativeConeT(blocks.n_nonneg));
    }
    for _ in 0..blocks.n_soc {
        cones.push(SupportedConeT::SecondOrderConeT(3));
    }
    for _ in 0..blocks.n_pow {
        cones.push(SupportedConeT::PowerConeT(1.0 / p.exponent));
    }

    let tol = p.settings.tolerance;
    let settings = DefaultSettings {
        max_iter: p.settings.max_iter,
        verbose: false,
        tol_gap_abs: tol,
        // The relative gap is measured against the objective, which reserve
        // or residual actuators of small optimal force (reserve
        // "activations" of hundreds) make 1e4–1e5 times larger than the
        // muscles' share: at a relative gap equal to `tol` the muscle
        // activations were then only pinned to ~1e-3 (gait10dof18musc at
        // 1e-8; 0.2 at 1e-4). Four decades tighter pins them to ~1e-5 at a
        // cost of an iteration or two (`statopt-tool bench --grid`).
        tol_gap_rel: (tol * 1e-4).max(1e-15),
        tol_feas: tol,
        ..DefaultSettings::default()
    };
    let settings = if mode == Mode::StrictInfeasibility {
        DefaultSettings {
            tol_infeas_abs: 1e-14,
            tol_infeas_rel: 1e-14,
            ..settings
        }
    } else {
        settings
    };
    let mut solver = match DefaultSolver::new(&p_mat, &q, &m_mat, &h, &cones, settings) {
        Ok(s) => s,
        Err(_) => return (vec![0.0; p.n_var()], SolveStatus::NumericalError, 0),
    };
    solver.solve();
    let sol = &solver.solution;
    let status = map_status(sol.status);
    let x = sol.x.get(..p.n_var()).unwrap_or(&[]).to_vec();
    (x, status, sol.iterations)
}

/// Factor applied to the objective before it is handed to Clarabel: one
/// over the smallest positive weight (1 if no weight is positive), clamped
/// to [1e-8, 1e8].
///
/// Clarabel stops when the duality gap is below `tol_gap_abs` or below
/// `tol_gap_rel · max(1, |objective|)`, so for objectives below 1 the test is
/// absolute. With the cheap contact multipliers of Krüger & Wartzack (weight
/// 1/w0, w0 up to 1e6) the whole optimum can be ~1e-6, and an absolute gap of
/// 1e-8 then leaves the muscle activations wrong by ~1e-5 (measured on the
/// inclined-block test). Scaling the objective so that its cheapest variable
/// costs 1 per unit² (or unit^p) makes the tolerance meaningful for every
/// variable; the minimiser is unchanged.
fn objective_scale(p: &FrameProblem) -> f64 {
    let w_min = p
        .weights
        .iter()
        .copied()
        .filter(|w| *w > 0.0)
        .fold(f64::INFINITY, f64::min);
    if w_min.is_finite() {
        (1.0 / w_min).clamp(1e-8, 1e8)
    } else {
        1.0
    }
}

/// Clarabel status → [`SolveStatus`] (documented on the variants).
fn map_status(s: SolverStatus) -> SolveStatus {
    match s {
        SolverStatus::Solved => SolveStatus::Solved,
        SolverStatus::AlmostSolved => SolveStatus::AlmostSolved,
        SolverStatus::PrimalInfeasible | SolverStatus::AlmostPrimalInfeasible => {
            SolveStatus::Infeasible
        }
        SolverStatus::MaxIterations => SolveStatus::MaxIterations,
        SolverStatus::MaxTime => SolveStatus::TimeLimit,
        SolverStatus::DualInfeasible
        | SolverStatus::AlmostDualInfeasible
        | SolverStatus::NumericalError
        | SolverStatus::InsufficientProgress
        | SolverStatus::CallbackTerminated
        | SolverStatus::Unsolved => SolveStatus::NumericalError,
    }
}

/// Where the auxiliary variables live in z.
struct Layout {
    /// Epigraph column of each variable (NONE if it has none).
    t_of: Vec<usize>,
    /// Column of the constant y = 1 shared by the power cones (NONE if
    /// there are none).
    y: usize,
    /// First elastic slack column (n_z when not elastic).
    r0: usize,
    n_z: usize,
    elastic: bool,
    /// p = 2: quadratic objective.
    quadratic: bool,
    /// p = 1: |x| ≤ t by two linear rows instead of a power cone.
    linear: bool,
}

#[derive(Default)]
struct Blocks {
    n_zero: usize,
    n_nonneg: usize,
    n_soc: usize,
    n_pow: usize,
}

/// Receives the rows of M in order: entries of the current row, then its
/// right-hand side.
trait RowSink {
    fn entry(&mut self, col: usize, val: f64);
    fn end_row(&mut self, h: f64);
}

/// Counts the rows passed to a sink.
struct Rows<'s, S> {
    sink: &'s mut S,
    rows: usize,
}

impl<S: RowSink> Rows<'_, S> {
    fn entry(&mut self, col: usize, val: f64) {
        self.sink.entry(col, val);
    }
    fn end(&mut self, h: f64) {
        self.sink.end_row(h);
        self.rows += 1;
    }
}

struct Counter {
    col_count: Vec<usize>,
    h: Vec<f64>,
}

impl RowSink for Counter {
    fn entry(&mut self, col: usize, _val: f64) {
        self.col_count[col] += 1;
    }
    fn end_row(&mut self, h: f64) {
        self.h.push(h);
    }
}

struct Filler {
    next: Vec<usize>,
    rowval: Vec<usize>,
    nzval: Vec<f64>,
    row: usize,
}

impl RowSink for Filler {
    fn entry(&mut self, col: usize, val: f64) {
        let k = self.next[col];
        self.rowval[k] = self.row;
        self.nzval[k] = val;
        self.next[col] += 1;
    }
    fn end_row(&mut self, _h: f64) {
        self.row += 1;
    }
}

impl Layout {
    fn new(p: &FrameProblem, elastic: bool) -> Layout {
        let n = p.n_var();
        let quadratic = p.exponent == 2.0;
        let linear = p.exponent == 1.0;
        let mut t_of = vec![NONE; n];
        let mut next = n;
        if !quadratic {
            for (i, t) in t_of.iter_mut().enumerate() {
                if p.weights[i] > 0.0 {
                    *t = next;
                    next += 1;
                }
            }
        }
        let mut y = NONE;
        if !quadratic && !linear && next > n {
            y = next;
            next += 1;
        }
        let r0 = next;
        if elastic {
            next += p.n_eq();
        }
        Layout {
            t_of,
            y,
            r0,
            n_z: next,
            elastic,
            quadratic,
            linear,
        }
    }

    /// Generates every row of M (in row order, entries of a row in any
    /// order) and returns the cone block sizes.
    fn visit<S: RowSink>(&self, p: &FrameProblem, sink: &mut S) -> Blocks {
        let n = p.n_var();
        let mut blocks = Blocks::default();
        let fixed = |i: usize| p.lower[i] == p.upper[i];
        let mut w = Rows { sink, rows: 0 };

        // 1. Zero cone.
        for i in 0..p.n_eq() {
            for j in 0..n {
                let v = p.a[(i, j)];
                if v != 0.0 {
                    w.entry(j, v);
                }
            }
            if self.elastic {
                w.entry(self.r0 + i, -1.0);
            }
            w.end(p.b[i]);
        }
        if self.y != NONE {
            w.entry(self.y, 1.0);
            w.end(1.0);
        }
        for i in (0..n).filter(|&i| fixed(i)) {
            w.entry(i, 1.0);
            w.end(p.lower[i]);
        }
        for c in p.static_contacts.iter().filter(|c| c.mu == 0.0) {
            for s in c.shear {
                w.entry(s, 1.0);
                w.end(0.0);
            }
        }
        blocks.n_zero = w.rows;

        // 2. Non-negative cone.
        for i in (0..n).filter(|&i| !fixed(i)) {
            if p.upper[i].is_finite() {
                w.entry(i, 1.0);
                w.end(p.upper[i]);
            }
            if p.lower[i].is_finite() {
                w.entry(i, -1.0);
                w.end(-p.lower[i]);
            }
        }
        for c in p.static_contacts.iter().filter(|c| c.mu > 0.0) {
            for &(c1, c2) in p.friction.facets() {
                if c1 != 0.0 {
                    w.entry(c.shear[0], c1);
                }
                if c2 != 0.0 {
                    w.entry(c.shear[1], c2);
                }
                w.entry(c.normal, -c.mu);
                w.end(0.0);
            }
        }
        if self.linear {
            for (i, &ti) in self.t_of.iter().enumerate() {
                if ti != NONE {
                    w.entry(i, 1.0);
                    w.entry(ti, -1.0);
                    w.end(0.0);
                    w.entry(i, -1.0);
                    w.entry(ti, -1.0);
                    w.end(0.0);
                }
            }
        }
        blocks.n_nonneg = w.rows - blocks.n_zero;

        // 3. Second-order cones: s = (μ λn, λs1, λs2).
        if p.friction == FrictionModel::Cone {
            for c in p.static_contacts.iter().filter(|c| c.mu > 0.0) {
                w.entry(c.normal, -c.mu);
                w.end(0.0);
                w.entry(c.shear[0], -1.0);
                w.end(0.0);
                w.entry(c.shear[1], -1.0);
                w.end(0.0);
                blocks.n_soc += 1;
            }
        }

        // 4. Power cones: s = (t_i, 1, x_i).
        if !self.quadratic && !self.linear {
            for (i, &ti) in self.t_of.iter().enumerate() {
                if ti != NONE {
                    w.entry(ti, -1.0);
                    w.end(0.0);
                    w.entry(self.y, -1.0);
                    w.end(0.0);
                    w.entry(i, -1.0);
                    w.end(0.0);
                    blocks.n_pow += 1;
                }
            }
        }
        blocks
    }
}
