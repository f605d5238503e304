//! Per-frame force-sharing optimisation: OpenSim static optimization
//! (opensim-semantics.md §6.4–6.5) extended by the frictional point-on-plane
//! contacts of Krüger & Wartzack (2017, §2.2).
//!
//! The physics (moment arms, contact Jacobians, target accelerations) is
//! assembled elsewhere; this module receives plain matrices in a
//! [`FrameProblem`] and solves the convex program
//!
//! ```text
//! minimise   Σ_i weight_i · |x_i|^p
//! subject to A x = b,  lower ≤ x ≤ upper,
//!            friction constraints of every contact in the static regime
//! ```
//!
//! [`solve()`] dispatches: for p = 2 (the default) a dedicated dual
//! semismooth Newton method ([`dual`]) answers when it applies and converges;
//! otherwise, and with `SolverChoice::Clarabel`, the conic interior-point
//! solver Clarabel ([`solve_clarabel()`]) does. For p = 2 the program is a
//! QP; for other p ≥ 1 Clarabel gives each weighted variable an epigraph
//! variable t_i ≥ |x_i|^p expressed with a 3-D power cone.
//!
//! Files: [`problem`] (data types and validation), [`friction`] (contact
//! constraint geometry), [`dual`] (dual Newton), [`polish`] (an
//! interior-point answer to the exact optimum), [`solve`](mod@solve)
//! (dispatch and Clarabel formulation).
pub mod dual;
pub mod friction;
pub mod polish;
pub mod problem;
pub mod solve;

pub use friction::FrictionModel;
pub use problem::{
    FrameProblem, FrameSolution, SolveSettings, SolveStatus, SolverChoice, SolverKind,
    StaticContact,
};
pub use solve::{
    fresh_a_key, solve, solve_clarabel, solve_into, solve_into_finite_a, solve_into_valid,
    solve_into_valid_keyed,
};

#[cfg(test)]
mod tests;
