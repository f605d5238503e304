//! Data of one frame's force-sharing problem and of its solution.
use std::time::Duration;

use nalgebra::{DMatrix, DVector};

use super::friction::FrictionModel;
pub use super::friction::StaticContact;
use crate::{Error, Result};

/// Solver settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolveSettings {
    /// Clarabel's absolute duality-gap tolerance and its primal/dual
    /// feasibility tolerance (`tol_gap_abs`, `tol_feas`); the relative gap
    /// tolerance `tol_gap_rel` is 1e-4 of it (see `solve`). Default 1e-8. (OpenSim's IPOPT uses the
    /// `optimizer_convergence_criterion`, 1e-4, §6.4; a tighter tolerance
    /// here only makes the answer closer to the exact optimum.)
    pub tolerance: f64,
    /// Maximum number of interior-point iterations (OpenSim's
    /// `optimizer_max_iterations`, default 100).
    pub max_iter: u32,
    /// Which solver [`super::solve()`] uses.
    pub solver: SolverChoice,
}

pub use crate::parse::analyses::SolverChoice;

/// The solver that produced a [`FrameSolution`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SolverKind {
    /// Dual semismooth Newton ([`super::dual`]).
    Newton,
    /// Clarabel interior point ([`super::solve_clarabel`]).
    Clarabel,
}

impl SolverKind {
    /// "newton" or "clarabel".
    pub fn name(self) -> &'static str {
        match self {
            SolverKind::Newton => "newton",
            SolverKind::Clarabel => "clarabel",
        }
    }

    /// Numeric code for tables: 0 newton, 1 clarabel.
    pub fn code(self) -> f64 {
        match self {
            SolverKind::Newton => 0.0,
            SolverKind::Clarabel => 1.0,
        }
    }
}

impl Default for SolveSettings {
    fn default() -> Self {
        SolveSettings {
            tolerance: 1e-8,
            max_iter: 100,
            solver: SolverChoice::Auto,
        }
    }
}

/// One frame's convex program (see the module documentation).
#[derive(Debug, Clone, PartialEq)]
pub struct FrameProblem {
    /// Equality constraints A x = b (n_eq × n_var).
    pub a: DMatrix<f64>,
    pub b: DVector<f64>,
    /// Objective Σ_i weight_i · |x_i|^p. Weights must be finite and ≥ 0
    /// (1 for muscles and actuators as in OpenSim §6.4; 1/w0 for contact
    /// multipliers as in Krüger & Wartzack eq. 6). A weight of 0 leaves the
    /// variable out of the objective.
    pub weights: Vec<f64>,
    /// The activation exponent p (OpenSim `activation_exponent`, default 2).
    /// Must be finite and ≥ 1: for p < 1 the objective is not convex.
    pub exponent: f64,
    /// Bounds per variable; ±∞ allowed, `lower == upper` fixes a variable.
    pub lower: Vec<f64>,
    pub upper: Vec<f64>,
    /// Contacts in the static friction regime.
    pub static_contacts: Vec<StaticContact>,
    /// How the friction cone of the static contacts is represented.
    pub friction: FrictionModel,
    pub settings: SolveSettings,
}

/// Outcome of a solve, mapped from Clarabel's `SolverStatus` (the Newton
/// solver reports only `Solved`; it leaves every other case to Clarabel).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SolveStatus {
    /// Clarabel `Solved`: optimal to the requested tolerance.
    Solved,
    /// Clarabel `AlmostSolved`: optimal to Clarabel's reduced tolerances
    /// (gap 5e-5, feasibility 1e-4) — comparable to OpenSim's IPOPT 1e-4
    /// (`Solved_To_Acceptable_Level`, §6.5).
    AlmostSolved,
    /// Clarabel `PrimalInfeasible` or `AlmostPrimalInfeasible`: no x satisfies
    /// the equalities, bounds and friction constraints together. The returned
    /// x is the solution of the elastic problem (see [`super::solve()`]).
    Infeasible,
    /// Clarabel `MaxIterations`.
    MaxIterations,
    /// Clarabel `MaxTime` (no time limit is set, so this should not occur).
    TimeLimit,
    /// Clarabel `NumericalError`, `InsufficientProgress`, `DualInfeasible`,
    /// `AlmostDualInfeasible` (impossible in exact arithmetic, because the
    /// objective is bounded below by 0), `Unsolved`, `CallbackTerminated`,
    /// or Clarabel refused the data.
    NumericalError,
    /// The problem failed [`FrameProblem::validate`]; x is all zeros
    /// (projected onto the bounds where they are valid).
    InvalidProblem,
}

impl SolveStatus {
    /// `Solved` or `AlmostSolved`: the statuses OpenSim accepts without
    /// entering its failure handling (§6.5).
    pub fn is_ok(self) -> bool {
        matches!(self, SolveStatus::Solved | SolveStatus::AlmostSolved)
    }
}

/// Result of [`super::solve()`].
#[derive(Debug, Clone, PartialEq)]
pub struct FrameSolution {
    /// The variables; always finite and of length n_var.
    pub x: Vec<f64>,
    pub status: SolveStatus,
    /// Newton: linear solves summed over the independent blocks. Clarabel:
    /// its iterations (including those of the elastic re-solve of an
    /// infeasible frame), plus the Newton solves spent before falling back.
    pub iterations: u32,
    /// Σ weight_i |x_i|^p evaluated at `x`.
    pub objective: f64,
    /// max_j |(A x − b)_j| at `x` (0 when there are no equalities).
    pub eq_residual: f64,
    /// Wall-clock time of the whole call (validation, assembly, solve;
    /// a failed Newton attempt included).
    pub solve_time: Duration,
    /// Which solver answered.
    pub solver: SolverKind,
    /// Clarabel's answer was polished to the exact optimum
    /// ([`super::polish`]); always false for Newton, whose answers are
    /// exact.
    pub polished: bool,
    /// One multiplier per equation, with which `x` meets the optimality
    /// conditions ([`super::dual::optimality_violation`]): Newton's, or the
    /// polish's. Empty when Clarabel's answer was not polished.
    pub y: Vec<f64>,
}

impl Default for FrameSolution {
    /// An empty answer (no variables), to be filled by
    /// [`super::solve_into`].
    fn default() -> Self {
        FrameSolution {
            x: Vec::new(),
            // (Nothing solved yet.)
            status: SolveStatus::InvalidProblem,
            iterations: 0,
            objective: f64::NAN,
            eq_residual: f64::NAN,
            solve_time: Duration::ZERO,
            solver: SolverKind::Newton,
            polished: false,
            y: Vec::new(),
        }
    }
}

impl FrameProblem {
    /// Number of variables.
    pub fn n_var(&self) -> usize {
        self.a.ncols()
    }

    /// Number of equality constraints.
    pub fn n_eq(&self) -> usize {
        self.a.nrows()
    }

    /// Checks dimensions and values; the error message says what is wrong.
    pub fn validate(&self) -> Result<()> {
        self.validate_with(true, true)
    }

    /// [`validate`](Self::validate) but for the finiteness of A's entries,
    /// for a caller that knows them finite (`frame::candidates`: a frame's
    /// A checked once for all its candidates, which change b, the weights
    /// and a few columns it checks).
    pub fn validate_but_a_entries(&self) -> Result<()> {
        self.validate_with(false, true)
    }

    /// [`validate`](Self::validate) but for the finiteness of A's and b's
    /// entries (`frame::candidates`: a frame's program checked once, each
    /// candidate's b and changed columns apart).
    pub fn validate_but_a_entries_and_b(&self) -> Result<()> {
        self.validate_with(false, false)
    }

    fn validate_with(&self, check_a: bool, check_b: bool) -> Result<()> {
        let n = self.n_var();
        let m = self.n_eq();
        let bad = |msg: String| Err(Error::msg(format!("optimisation problem: {msg}")));
        if self.b.len() != m {
            return bad(format!("A has {m} rows but b has {} entries", self.b.len()));
        }
        for (name, len) in [
            ("weights", self.weights.len()),
            ("lower", self.lower.len()),
            ("upper", self.upper.len()),
        ] {
            if len != n {
                return bad(format!("A has {n} columns but {name} has {len} entries"));
            }
        }
        if !(self.exponent.is_finite() && self.exponent >= 1.0) {
            return bad(format!(
                "activation exponent {} is not allowed: it must be a finite number >= 1 \
                 (for exponents below 1 the objective is not convex)",
                self.exponent
            ));
        }
        // (A is stored by column.) A count without early exit first (it
        // vectorises; A is the bulk of a frame's data), the position only
        // when it is not 0.
        let a = self.a.as_slice();
        if check_a && a.iter().map(|v| usize::from(!v.is_finite())).sum::<usize>() > 0 {
            let k = a.iter().position(|v| !v.is_finite()).unwrap_or(0);
            let (i, j) = (k % m, k / m);
            return bad(format!("A[{i},{j}] = {} is not finite", self.a[(i, j)]));
        }
        let bad_b = if check_b {
            self.b.iter().position(|v| !v.is_finite())
        } else {
            None
        };
        if let Some(i) = bad_b {
            return bad(format!("b[{i}] = {} is not finite", self.b[i]));
        }
        for i in 0..n {
            let (w, lo, hi) = (self.weights[i], self.lower[i], self.upper[i]);
            if !(w.is_finite() && w >= 0.0) {
                return bad(format!(
                    "weight of variable {i} is {w}; it must be finite and >= 0"
                ));
            }
            if lo.is_nan() || hi.is_nan() || lo == f64::INFINITY || hi == f64::NEG_INFINITY {
                return bad(format!("variable {i} has invalid bounds [{lo}, {hi}]"));
            }
            if lo > hi {
                return bad(format!(
                    "variable {i} has lower bound {lo} above its upper bound {hi}"
                ));
            }
        }
        // (Distinct indices checked pairwise, in plain loops: contacts are
        // few, and a frame's validation allocates nothing.)
        let indices = |c: &StaticContact| [c.normal, c.shear[0], c.shear[1]];
        for (k, c) in self.static_contacts.iter().enumerate() {
            if !(c.mu.is_finite() && c.mu >= 0.0) {
                return bad(format!(
                    "contact {k}: friction coefficient {} must be finite and >= 0",
                    c.mu
                ));
            }
            let own = indices(c);
            for (i, &idx) in own.iter().enumerate() {
                if idx >= n {
                    return bad(format!(
                        "contact {k}: variable index {idx} out of range (n_var = {n})"
                    ));
                }
                let mut used = own[..i].contains(&idx);
                for d in &self.static_contacts[..k] {
                    used |= d.normal == idx || d.shear[0] == idx || d.shear[1] == idx;
                }
                if used {
                    return bad(format!(
                        "contact {k}: variable {idx} is already used by a contact"
                    ));
                }
            }
        }
        let s = &self.settings;
        if !(s.tolerance.is_finite() && s.tolerance > 0.0) {
            return bad(format!("tolerance {} must be > 0", s.tolerance));
        }
        if s.max_iter == 0 {
            return bad("max_iter must be at least 1".to_string());
        }
        Ok(())
    }

    /// Σ weight_i |x_i|^p.
    pub fn objective(&self, x: &[f64]) -> f64 {
        let p = self.exponent;
        self.weights
            .iter()
            .zip(x)
            .filter(|(w, _)| **w != 0.0)
            .map(|(w, xi)| {
                if p == 2.0 {
                    w * xi * xi
                } else {
                    w * xi.abs().powf(p)
                }
            })
            .sum()
    }

    /// max_j |(A x − b)_j|, 0 without equalities.
    pub fn eq_residual(&self, x: &[f64]) -> f64 {
        // Column by column (A is stored by column).
        let m = self.n_eq();
        if m == 0 {
            return 0.0;
        }
        let mut r: Vec<f64> = self.b.iter().map(|b| -b).collect();
        for (column, xj) in self.a.as_slice().chunks_exact(m).zip(x) {
            for (ri, a) in r.iter_mut().zip(column) {
                *ri += a * xj;
            }
        }
        r.iter().fold(0.0f64, |worst, ri| worst.max(ri.abs()))
    }
}
