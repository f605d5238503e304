//! The layout of a static-optimization run's own tables (OpenSim's
//! ForceReporter description for the force table; statopt's diagnostics
//! table: columns, description, one row per frame).

use crate::frame::problem::{status_code, FrameResult};

/// OpenSim's ForceReporter description.
pub const FORCE_DESCRIPTION: &str = "\nThis file contains the forces exerted on a model during a simulation.\n\nA force is a generalized force, meaning that it can be either a force (N) or a torque (Nm).\n\nUnits are S.I. units (second, meters, Newtons, ...)\nIf the header above contains a line with 'inDegrees', this indicates whether rotational values are in degrees (yes) or radians (no).\n\n";

/// Columns of the diagnostics table.
pub const DIAGNOSTICS_COLUMNS: [&str; 8] = [
    "status",
    "iterations",
    "objective",
    "equation_residual",
    "relative_residual",
    "friction_violation",
    "solve_time_ms",
    "solver",
];

pub const DIAGNOSTICS_DESCRIPTION: &str = "statopt solver diagnostics per frame: status 0 solved, 1 solved to reduced accuracy, -1 failed;\nequation_residual = max |A x - b| (N or N m); relative_residual = that / max |b|;\nfriction_violation = largest excess of shear over the friction limit in multiplier units (<= 0 when met);\nsolver 0 = dual Newton, 1 = Clarabel (iterations: Newton linear solves, or Clarabel iterations plus a failed Newton attempt's solves).\n";

pub fn diagnostics_row(r: &FrameResult) -> Vec<f64> {
    vec![
        status_code(r.solution.status),
        r.solution.iterations as f64,
        r.solution.objective,
        r.solution.eq_residual,
        r.relative_residual,
        r.friction_violation,
        r.solution.solve_time.as_secs_f64() * 1e3,
        r.solution.solver.code(),
    ]
}

/// OpenSim's storage description (`JointReaction::constructDescription`).
pub const JOINT_REACTION_DESCRIPTION: &str = "\nThis file contains the reaction forces and moments\napplied to the specified body of a joint pair and expressed  in the specified reference frame.\n\nUnits are S.I. units (seconds, meters, Newtons, ...)";
