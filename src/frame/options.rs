//! The numbers a static-optimization run is solved with ([`SoOptions`]),
//! compiled once from the plan's StaticOptimization element
//! ([`SoOptions::compile`]) and owned by the compiled problem
//! (`SoProblem::options`), as MuJoCo's `mjOption` is owned by its compiled
//! model: the plan (`parse::analyses::StaticOptimizationSetup`) keeps what
//! the user wrote, with its element for located messages; the options keep
//! only what a frame is solved with. A tool that changes a run changes the
//! plan through its checked setters (`set_contact_weights`, `set_friction`,
//! ...) before the problem is compiled; nothing edits the options of a
//! compiled problem but its own compile.
//!
//! There is one set of defaults: those the plan applies to an element that
//! leaves a property out (`parse::analyses`, `DEFAULT_*`); [`SoOptions`]'s
//! `Default` is the compile of an empty element, tested to be so.

use crate::frame::settings::{
    ConstraintMatrix, StaticOptimizationSetup, DEFAULT_ACTIVATION_EXPONENT, DEFAULT_CONTACT_WEIGHT,
    DEFAULT_CONVERGENCE_CRITERION, DEFAULT_MAX_ITERATIONS, DEFAULT_TOLERANCE,
};
use crate::optimize::{FrictionModel, SolveSettings, SolverChoice};

/// What a frame of static optimization is solved with, compiled from the
/// plan ([`SoOptions::compile`]).
#[derive(Debug, Clone, PartialEq)]
pub struct SoOptions {
    /// The objective's exponent p of Σ a^p (2: a quadratic program).
    pub activation_exponent: f64,
    /// Muscles' force from their force-length-velocity state (OpenSim's
    /// `use_muscle_physiology`), else their maximum isometric force.
    pub use_muscle_physiology: bool,
    /// Passive fiber forces added to the equations (statopt).
    pub passive_fiber_forces: bool,
    /// The reserves' optimal force, when the run adds them.
    pub reserve_actuators: Option<f64>,
    /// The contact weights w0 (Krüger & Wartzack eq. 6): the first is the
    /// weight a single frame problem is assembled with; several run a sweep
    /// from that one assembly.
    pub contact_weights: Vec<f64>,
    /// The static friction constraint's representation.
    pub friction: FrictionModel,
    /// How the equations of motion become the constraint matrix.
    pub constraint_matrix: ConstraintMatrix,
    /// The frame solve's tolerance, iteration limit and solver: the
    /// setup's `<solver_tolerance>`, else its convergence criterion capped
    /// at [`DEFAULT_TOLERANCE`]; at least 100 iterations.
    pub solve: SolveSettings,
}

impl SoOptions {
    /// The options of a run of `so`.
    pub fn compile(so: &StaticOptimizationSetup) -> SoOptions {
        SoOptions {
            activation_exponent: so.activation_exponent,
            use_muscle_physiology: so.use_muscle_physiology,
            passive_fiber_forces: so.passive_fiber_forces,
            reserve_actuators: so.reserve_actuators,
            contact_weights: so.contact_weights.clone(),
            friction: so.friction,
            constraint_matrix: so.constraint_matrix,
            solve: solve_settings(
                so.solver_tolerance,
                so.convergence_criterion,
                so.max_iterations,
                so.solver,
            ),
        }
    }
}

/// The frame solve's settings: `<solver_tolerance>` when given, else
/// OpenSim's convergence criterion capped at [`DEFAULT_TOLERANCE`] (a
/// tighter tolerance only brings the answer closer to the exact optimum);
/// at least 100 iterations.
fn solve_settings(
    solver_tolerance: Option<f64>,
    convergence_criterion: f64,
    max_iterations: u32,
    solver: SolverChoice,
) -> SolveSettings {
    SolveSettings {
        tolerance: solver_tolerance.unwrap_or(convergence_criterion.min(DEFAULT_TOLERANCE)),
        max_iter: max_iterations.max(100),
        solver,
    }
}

impl Default for SoOptions {
    /// The options of a StaticOptimization element that gives no property:
    /// the plan's defaults, compiled.
    fn default() -> Self {
        SoOptions {
            activation_exponent: DEFAULT_ACTIVATION_EXPONENT,
            use_muscle_physiology: true,
            passive_fiber_forces: false,
            reserve_actuators: None,
            contact_weights: vec![DEFAULT_CONTACT_WEIGHT],
            friction: FrictionModel::default(),
            constraint_matrix: ConstraintMatrix::default(),
            solve: solve_settings(
                None,
                DEFAULT_CONVERGENCE_CRITERION,
                DEFAULT_MAX_ITERATIONS,
                SolverChoice::default(),
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan(body: &str) -> StaticOptimizationSetup {
        let el = crate::xml::parse_str(
            &format!("<StaticOptimization name=\"SO\">{body}</StaticOptimization>"),
            std::path::Path::new("setup.xml"),
        )
        .unwrap();
        let common = crate::parse::setup::AnalysisCommon {
            name: "SO".into(),
            on: true,
            step_interval: 1,
            in_degrees: false,
        };
        StaticOptimizationSetup::from_xml(&el, common).unwrap()
    }

    /// One set of defaults: an element that gives nothing compiles to
    /// `SoOptions::default()`, and so does one that gives OpenSim's and
    /// statopt's defaults in words.
    #[test]
    fn an_empty_element_compiles_to_the_default_options() {
        assert_eq!(SoOptions::compile(&plan("")), SoOptions::default());
        let spelled = plan(
            "<activation_exponent>2</activation_exponent>\
             <use_muscle_physiology>true</use_muscle_physiology>\
             <optimizer_convergence_criterion>0.0001</optimizer_convergence_criterion>\
             <optimizer_max_iterations>100</optimizer_max_iterations>\
             <contact_weight>1000</contact_weight>\
             <friction_cone>cone</friction_cone>\
             <constraint_matrix>analytic</constraint_matrix>\
             <solver>auto</solver>",
        );
        assert_eq!(SoOptions::compile(&spelled), SoOptions::default());
        let d = SoOptions::default();
        assert_eq!(d.contact_weights, [1000.0]);
        assert_eq!(d.solve.tolerance, 1e-8);
        assert_eq!(d.solve.max_iter, 100);
    }

    /// The compiled numbers follow the element, and the plan's setters
    /// reach them.
    #[test]
    fn options_follow_the_plan() {
        let mut so = plan(
            "<contact_weight>10 100</contact_weight>\
             <optimizer_convergence_criterion>1e-10</optimizer_convergence_criterion>\
             <optimizer_max_iterations>20</optimizer_max_iterations>\
             <reserve_actuators>5</reserve_actuators>",
        );
        let o = SoOptions::compile(&so);
        assert_eq!(o.contact_weights, [10.0, 100.0]);
        assert_eq!(o.solve.tolerance, 1e-10);
        assert_eq!(o.solve.max_iter, 100);
        assert_eq!(o.reserve_actuators, Some(5.0));
        so.set_solver_tolerance(1e-6).unwrap();
        so.set_friction(FrictionModel::Pyramid4);
        so.set_solver(SolverChoice::Clarabel);
        so.set_contact_weights(&[3.0]).unwrap();
        let o = SoOptions::compile(&so);
        assert_eq!(o.solve.tolerance, 1e-6);
        assert_eq!(o.friction, FrictionModel::Pyramid4);
        assert_eq!(o.solve.solver, SolverChoice::Clarabel);
        assert_eq!(o.contact_weights, [3.0]);
    }
}
