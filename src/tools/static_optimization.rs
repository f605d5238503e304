//! Static optimization (opensim-semantics.md §6): per frame, the actuator
//! controls x minimising Σ x_i^p subject to the equations of motion,
//! built analytically — one inverse-dynamics pass for the generalized forces
//! the actuators must supply, and the actuators' unit generalized forces
//! (muscle moment arms × strength) — and solved with Clarabel.
//!
//! The equations are written in force space and reduced to the independent,
//! unconstrained coordinates with the coupling vectors C_k:
//! `C_kᵀ Σ_i x_i f_i g_i = C_kᵀ τ_required`, which is OpenSim's
//! acceleration-level constraint `u̇_I(x) = u̇_target` multiplied by the
//! (constraint-reduced) mass matrix.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

use crate::dynamics::{kinematics, rnea, Data};
use crate::error::{Error, Location, Result};
use crate::forces::actuators::{Actuator, ActuatorKind};
use crate::forces::external_loads::ExternalLoads;
use crate::forces::passive::PassiveForce;
use crate::model::Model;
use crate::motion::states::{assemble, States};
use crate::muscles::set::{MuscleFrame, MuscleSet};
use crate::optimize::{
    self, FrameProblem, FrameSolution, FrictionModel, SolveSettings, SolveStatus,
};
use crate::parse::setup::{AnalysisCommon, AnalyzeSetup};
use crate::paths::coupling;
use crate::storage::StoWriter;
use crate::tools::analyze::{frame_rows, load_states, results_dir};
use crate::tools::loading::{applies_force, force_kind, load_analysis_model, ForceKind};
use crate::tools::{RunOptions, RunSummary};
use crate::xml::Element;

/// The StaticOptimization element of an AnalyzeTool setup.
#[derive(Debug, Clone)]
pub struct StaticOptimizationSetup {
    pub common: AnalysisCommon,
    pub use_model_force_set: bool,
    pub activation_exponent: f64,
    pub use_muscle_physiology: bool,
    /// OpenSim's IPOPT tolerance; statopt passes it to Clarabel only if it is
    /// tighter than [`DEFAULT_TOLERANCE`].
    pub convergence_criterion: f64,
    pub max_iterations: u32,
    /// statopt: add passive fiber force to each muscle (off by default, as
    /// OpenSim ignores it).
    pub passive_fiber_forces: bool,
    /// statopt: add a CoordinateActuator `<coordinate>_reserve` with this
    /// optimal force to every unconstrained coordinate, so that every frame
    /// can be solved; the run reports how much they carried.
    pub reserve_actuators: Option<f64>,
}

/// Clarabel's feasibility/gap tolerance unless the setup asks for tighter.
pub const DEFAULT_TOLERANCE: f64 = 1e-8;

impl StaticOptimizationSetup {
    pub fn from_xml(el: &Element, common: AnalysisCommon) -> Result<Self> {
        let p = el.child_f64_or("activation_exponent", 2.0)?;
        if !(p >= 1.0 && p.is_finite()) {
            return Err(el.req("activation_exponent")?.error(format!("activation_exponent must be a finite number >= 1 (the problem is convex only then), found {p}")));
        }
        let max_iter = el.child_f64_or("optimizer_max_iterations", 100.0)?;
        if !(max_iter >= 1.0) {
            return Err(el
                .req("optimizer_max_iterations")?
                .error("optimizer_max_iterations must be positive"));
        }
        Ok(StaticOptimizationSetup {
            common,
            use_model_force_set: el.child_bool_or("use_model_force_set", true)?,
            activation_exponent: p,
            use_muscle_physiology: el.child_bool_or("use_muscle_physiology", true)?,
            convergence_criterion: el.child_f64_or("optimizer_convergence_criterion", 1e-4)?,
            max_iterations: max_iter as u32,
            passive_fiber_forces: el.child_bool_or("passive_fiber_forces", false)?,
            reserve_actuators: match el.child("reserve_actuators") {
                Some(r) if !r.text().is_empty() => {
                    let v = r.f64()?;
                    if !(v > 0.0 && v.is_finite()) {
                        return Err(r.error(format!("reserve_actuators is the reserves' optimal force and must be positive, found {v}")));
                    }
                    Some(v)
                }
                _ => None,
            },
        })
    }
}

/// One optimisation variable: a muscle (index into the MuscleSet) or another actuator.
#[derive(Debug, Clone)]
pub enum Control {
    Muscle(usize),
    Actuator(Actuator),
}

/// Everything a frame needs, compiled once.
pub struct SoProblem {
    pub model: Model,
    pub muscles: MuscleSet,
    /// Variables in ForceSet order (the activation file's columns).
    pub controls: Vec<Control>,
    pub labels: Vec<String>,
    pub lower: Vec<f64>,
    pub upper: Vec<f64>,
    pub passive: Vec<PassiveForce>,
    pub loads: Option<ExternalLoads>,
    /// Independent, unconstrained coordinates: the equations' rows.
    pub rows: Vec<usize>,
    pub settings: StaticOptimizationSetup,
    /// Labels of the force file (ForceSet record labels, then external forces).
    pub force_labels: Vec<String>,
}

/// Result of one frame.
#[derive(Debug, Clone)]
pub struct FrameResult {
    pub time: f64,
    pub solution: FrameSolution,
    /// Actuator forces (x_i · f_i), same order as the controls.
    pub forces: Vec<f64>,
    /// The force file row.
    pub force_row: Vec<f64>,
    /// max |A x − b| relative to the largest |b| (1 when b = 0).
    pub relative_residual: f64,
}

impl SoProblem {
    pub fn build(
        setup: &AnalyzeSetup,
        so: &StaticOptimizationSetup,
    ) -> Result<(SoProblem, Vec<String>)> {
        let am = load_analysis_model(setup)?;
        let model = am.model;
        let mut warnings = am.warnings;
        let mut forces: Vec<Element> = Vec::new();
        for f in am.forces {
            if applies_force(&f)? {
                forces.push(f);
            }
        }
        let rows: Vec<usize> = (0..model.nq())
            .filter(|&c| !model.coordinates[c].is_constrained())
            .collect();
        let mut controls = Vec::new();
        let mut labels = Vec::new();
        let mut lower = Vec::new();
        let mut upper = Vec::new();
        let mut passive = Vec::new();
        let mut force_labels = Vec::new();
        let muscles;
        if !so.use_model_force_set {
            // OpenSim: a CoordinateActuator "<coord>_actuator" (optimal force 1)
            // per unconstrained coordinate, then the non-muscle forces.
            for &c in &rows {
                let name = format!("{}_actuator", model.coordinates[c].name);
                controls.push(Control::Actuator(Actuator {
                    name: name.clone(),
                    kind: ActuatorKind::Coordinate { coordinate: c },
                    optimal_force: 1.0,
                    min_control: f64::NEG_INFINITY,
                    max_control: f64::INFINITY,
                    applies_force: true,
                    type_name: "CoordinateActuator".into(),
                }));
                labels.push(name.clone());
                force_labels.push(name);
                lower.push(f64::NEG_INFINITY);
                upper.push(f64::INFINITY);
            }
            forces.retain(|f| force_kind(f) != ForceKind::Muscle);
            muscles = MuscleSet::compile(&am.spec, &[], &model)?;
        } else {
            muscles = MuscleSet::compile(&am.spec, &forces, &model)?;
        }
        let mut next_muscle = 0;
        for f in &forces {
            match force_kind(f) {
                ForceKind::Muscle => {
                    let m = &muscles.muscles[next_muscle];
                    controls.push(Control::Muscle(next_muscle));
                    labels.push(m.muscle.name.clone());
                    force_labels.push(m.muscle.name.clone());
                    lower.push(m.muscle.params.min_control);
                    upper.push(m.muscle.params.max_control);
                    next_muscle += 1;
                }
                ForceKind::Actuator => {
                    let a =
                        Actuator::from_xml(f, &model)?.ok_or_else(|| f.error("not an actuator"))?;
                    labels.push(a.name.clone());
                    force_labels.push(a.name.clone());
                    lower.push(a.min_control);
                    upper.push(a.max_control);
                    controls.push(Control::Actuator(a));
                }
                ForceKind::Contact => {
                    return Err(f.error("contact elements in static optimization arrive with the contact model (not yet supported)"));
                }
                ForceKind::Other => match PassiveForce::from_xml(f, &model)? {
                    Some(p) => {
                        force_labels.extend(p.record_labels());
                        passive.push(p);
                    }
                    None => {
                        return Err(f.error(format!(
                            "force type '{}' is not supported by statopt's static optimization",
                            f.name
                        )))
                    }
                },
            }
        }
        if let Some(opt) = so.reserve_actuators {
            for &c in &rows {
                let name = format!("{}_reserve", model.coordinates[c].name);
                if labels.contains(&name) {
                    return Err(Error::input(
                        Location::file(&setup.setup_file),
                        format!("reserve_actuators: the model already has a force named '{name}'"),
                    ));
                }
                controls.push(Control::Actuator(Actuator {
                    name: name.clone(),
                    kind: ActuatorKind::Coordinate { coordinate: c },
                    optimal_force: opt,
                    min_control: f64::NEG_INFINITY,
                    max_control: f64::INFINITY,
                    applies_force: true,
                    type_name: "CoordinateActuator".into(),
                }));
                // Reserve columns follow the ForceSet's actuators in both files.
                let at = labels.len();
                labels.insert(at, name.clone());
                force_labels.insert(at, name);
                lower.push(f64::NEG_INFINITY);
                upper.push(f64::INFINITY);
            }
        }
        if controls.len() < rows.len() {
            return Err(Error::input(
                Location::file(&setup.model_file),
                format!(
                    "over-constrained: {} actuators for {} unconstrained coordinates",
                    controls.len(),
                    rows.len()
                ),
            ));
        }
        let setup_dir = setup
            .setup_file
            .parent()
            .unwrap_or(std::path::Path::new("."));
        let loads = match &setup.external_loads_file {
            Some(p) => Some(ExternalLoads::load(p, setup_dir, &model)?),
            None => None,
        };
        if let Some(l) = &loads {
            for ef in &l.forces {
                force_labels.extend(ef.labels.iter().cloned());
            }
        }
        if so.activation_exponent != 2.0 {
            warnings.push(format!(
                "activation_exponent {} is solved with power cones",
                so.activation_exponent
            ));
        }
        Ok((
            SoProblem {
                model,
                muscles,
                controls,
                labels,
                lower,
                upper,
                passive,
                loads,
                rows,
                settings: so.clone(),
                force_labels,
            },
            warnings,
        ))
    }

    /// Build one frame's optimisation problem: returns the problem, each
    /// variable's force scale (f_i) and the passive forces' record values.
    pub fn frame_problem(
        &self,
        t: f64,
        q: &[f64],
        u: &[f64],
        udot_target: &[f64],
        data: &mut Data,
        mf: &mut MuscleFrame,
    ) -> (FrameProblem, Vec<f64>, Vec<f64>) {
        let model = &self.model;
        let nq = model.nq();
        data.q.copy_from_slice(q);
        data.u.copy_from_slice(u);
        assemble(model, t, &mut data.q, &mut data.u);
        // Accelerations: targets for the unconstrained coordinates; the
        // constrained ones follow from their constraints.
        for c in 0..nq {
            data.udot[c] = if model.coordinates[c].is_constrained() {
                0.0
            } else {
                udot_target[c]
            };
        }
        for cp in &model.couplers {
            let i = cp.independent[0];
            let (_, d1, d2) = cp.function.eval2(data.q[i]);
            data.udot[cp.dependent] = cp.scale * (d2 * data.u[i] * data.u[i] + d1 * data.udot[i]);
        }
        for (c, coord) in model.coordinates.iter().enumerate() {
            if let Some(f) = &coord.prescribed {
                data.udot[c] = f.derivative(t, 2);
            }
        }
        kinematics::full(model, data);
        data.clear_applied();
        if let Some(l) = &self.loads {
            l.apply(t, data);
        }
        let mut passive_values = Vec::new();
        for p in &self.passive {
            let mut g = vec![0.0; nq];
            p.add_generalized_force(model, data, t, &mut g);
            for k in 0..nq {
                data.applied_gen[k] += g[k];
            }
            passive_values.extend(p.record_values(data, t));
        }
        mf.evaluate(&self.muscles, model, data);
        if self.settings.passive_fiber_forces {
            for (m, f) in mf.unit_force.iter().enumerate() {
                let fp = mf.passive_force[m];
                for k in 0..nq {
                    data.applied_gen[k] += fp * f[k];
                }
            }
        }
        rnea::inverse_dynamics_after_kinematics(model, data, true);
        // Rows: C_kᵀ τ_required = C_kᵀ Σ x_i f_i g_i.
        let nr = self.rows.len();
        let nv = self.controls.len();
        let mut a = DMatrix::zeros(nr, nv);
        let mut b = DVector::zeros(nr);
        let couplings: Vec<Vec<(usize, f64)>> = self
            .rows
            .iter()
            .map(|&k| coupling::coupling_vector(model, &data.q, k))
            .collect();
        for (r, cv) in couplings.iter().enumerate() {
            b[r] = cv.iter().map(|(i, c)| c * data.tau[*i]).sum();
        }
        let mut scale = vec![0.0; nv];
        let mut g = vec![0.0; nq];
        for (v, ctl) in self.controls.iter().enumerate() {
            let (f, gen): (f64, &[f64]) = match ctl {
                Control::Muscle(m) => {
                    let pm = &self.muscles.muscles[*m];
                    let f = if self.settings.use_muscle_physiology {
                        mf.max_active_force[*m]
                    } else {
                        pm.muscle.params.max_isometric_force
                    };
                    (f, &mf.unit_force[*m])
                }
                Control::Actuator(act) => {
                    g.iter_mut().for_each(|x| *x = 0.0);
                    act.add_unit_generalized_force(model, data, &mut g);
                    (act.optimal_force, &g)
                }
            };
            scale[v] = f;
            for (r, cv) in couplings.iter().enumerate() {
                a[(r, v)] = f * cv.iter().map(|(i, c)| c * gen[*i]).sum::<f64>();
            }
        }
        let problem = FrameProblem {
            a,
            b,
            weights: vec![1.0; nv],
            exponent: self.settings.activation_exponent,
            lower: self.lower.clone(),
            upper: self.upper.clone(),
            static_contacts: Vec::new(),
            friction: FrictionModel::Cone,
            settings: SolveSettings {
                tolerance: self.settings.convergence_criterion.min(DEFAULT_TOLERANCE),
                max_iter: self.settings.max_iterations.max(100),
                ..SolveSettings::default()
            },
        };
        (problem, scale, passive_values)
    }

    /// Solve one frame. `data` and `mf` are per-thread workspaces.
    pub fn solve_frame(
        &self,
        t: f64,
        q: &[f64],
        u: &[f64],
        udot_target: &[f64],
        data: &mut Data,
        mf: &mut MuscleFrame,
    ) -> FrameResult {
        let (problem, scale, passive_values) = self.frame_problem(t, q, u, udot_target, data, mf);
        let solution = optimize::solve(&problem);
        let bmax = problem.b.amax();
        let relative_residual = if bmax > 0.0 {
            solution.eq_residual / bmax
        } else {
            solution.eq_residual
        };
        let forces: Vec<f64> = solution.x.iter().zip(&scale).map(|(x, f)| x * f).collect();
        let mut force_row = forces.clone();
        force_row.extend(passive_values);
        if let Some(l) = &self.loads {
            for ef in &l.forces {
                let (f, p, tq) = ef.evaluate(t, data);
                force_row.extend(ef.record(&f, &p, &tq, data));
            }
        }
        FrameResult {
            time: t,
            solution,
            forces,
            force_row,
            relative_residual,
        }
    }
}

/// Status code written to the diagnostics table.
fn status_code(s: SolveStatus) -> f64 {
    match s {
        SolveStatus::Solved => 0.0,
        SolveStatus::AlmostSolved => 1.0,
        _ => -1.0,
    }
}

pub fn run(
    setup: &AnalyzeSetup,
    el: &Element,
    common: &AnalysisCommon,
    opts: &RunOptions,
) -> Result<RunSummary> {
    let so = StaticOptimizationSetup::from_xml(el, common.clone())?;
    let (problem, mut warnings) = SoProblem::build(setup, &so)?;
    let states: States = load_states(setup, &problem.model)?;
    if !states.missing.is_empty() {
        warnings.push(format!(
            "the coordinates file lacks {:?}; they are set to 0 as OpenSim's AnalyzeTool does",
            states.missing
        ));
    }
    let coordinates_file = setup.coordinates_file.clone().unwrap_or_default();
    let udot = states.speed_derivatives(&coordinates_file)?;
    let rows = frame_rows(
        &states.time,
        setup.initial_time,
        setup.final_time,
        so.common.step_interval,
    );
    let dir = results_dir(setup, opts)?;
    let prefix = format!("{}_{}_", setup.name, so.common.name);
    let precision = opts.precision.unwrap_or(setup.output_precision);
    let act_path = dir.join(format!("{prefix}activation.sto"));
    let force_path = dir.join(format!("{prefix}force.sto"));
    let diag_path = dir.join(format!("{prefix}diagnostics.sto"));
    let mut act_w = StoWriter::create(
        &act_path,
        "Static Optimization",
        "This file contains static optimization results.\n",
        &problem.labels,
        precision,
        false,
    )?;
    let mut force_w = StoWriter::create(
        &force_path,
        "ModelForces",
        FORCE_DESCRIPTION,
        &problem.force_labels,
        precision,
        false,
    )?;
    let diag_labels: Vec<String> = [
        "status",
        "iterations",
        "objective",
        "equation_residual",
        "relative_residual",
        "solve_time_ms",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let mut diag_w = StoWriter::create(
        &diag_path,
        "Static Optimization Diagnostics",
        "statopt solver diagnostics per frame: status 0 solved, 1 solved to reduced accuracy, -1 failed;\nequation_residual = max |A x - b| (N or N m); relative_residual = that / max |b|.\n",
        &diag_labels,
        16,
        false,
    )?;
    // Frames in chunks: solved in parallel, written in order, so memory stays flat.
    let progress = crate::tools::progress::bar(rows.len() as u64, opts.verbose);
    let failed_any = AtomicBool::new(false);
    let mut failures: Vec<String> = Vec::new();
    let reserve_vars: Vec<usize> = problem
        .labels
        .iter()
        .enumerate()
        .filter(|(_, l)| so.reserve_actuators.is_some() && l.ends_with("_reserve"))
        .map(|(i, _)| i)
        .collect();
    let mut reserve_peak = (0.0f64, String::new());
    let start = Instant::now();
    for chunk in rows.chunks(256) {
        let results: Vec<FrameResult> = chunk
            .par_iter()
            .map_init(
                || {
                    (
                        Data::new(&problem.model),
                        MuscleFrame::new(&problem.muscles, &problem.model),
                    )
                },
                |(data, mf), &i| {
                    problem.solve_frame(
                        states.time[i],
                        &states.q[i],
                        &states.u[i],
                        &udot[i],
                        data,
                        mf,
                    )
                },
            )
            .collect();
        for r in results {
            if !r.solution.status.is_ok() {
                failed_any.store(true, Ordering::Relaxed);
                failures.push(format!(
                    "t={}: {:?}, equation residual {:.3e}",
                    r.time, r.solution.status, r.solution.eq_residual
                ));
            }
            for &v in &reserve_vars {
                if r.forces[v].abs() > reserve_peak.0 {
                    reserve_peak = (
                        r.forces[v].abs(),
                        format!("{} at t={}", problem.labels[v], r.time),
                    );
                }
            }
            act_w.write_row(r.time, &r.solution.x)?;
            force_w.write_row(r.time, &r.force_row)?;
            diag_w.write_row(
                r.time,
                &[
                    status_code(r.solution.status),
                    r.solution.iterations as f64,
                    r.solution.objective,
                    r.solution.eq_residual,
                    r.relative_residual,
                    r.solution.solve_time.as_secs_f64() * 1e3,
                ],
            )?;
            progress.inc(1);
        }
    }
    progress.finish_and_clear();
    act_w.finish()?;
    force_w.finish()?;
    diag_w.finish()?;
    if !failures.is_empty() {
        warnings.push(format!(
            "static optimization failed on {} of {} frames (first: {}); their rows hold the solver's last iterate, see {}",
            failures.len(),
            rows.len(),
            failures[0],
            diag_path.display()
        ));
    }
    let loop_seconds = start.elapsed().as_secs_f64();
    if !reserve_vars.is_empty() {
        warnings.push(format!(
            "reserve actuators carried at most {:.6} (N or N m){}",
            reserve_peak.0,
            if reserve_peak.1.is_empty() {
                String::new()
            } else {
                format!(", {}", reserve_peak.1)
            }
        ));
    }
    if opts.verbose {
        let secs = loop_seconds;
        warnings.push(format!(
            "static optimization: {} frames in {:.3} s ({:.0} frames/s)",
            rows.len(),
            secs,
            rows.len() as f64 / secs.max(1e-12)
        ));
    }
    Ok(RunSummary {
        frames: rows.len(),
        files: vec![act_path, force_path, diag_path],
        warnings,
        loop_seconds,
    })
}

/// OpenSim's ForceReporter description.
pub const FORCE_DESCRIPTION: &str = "\nThis file contains the forces exerted on a model during a simulation.\n\nA force is a generalized force, meaning that it can be either a force (N) or a torque (Nm).\n\nUnits are S.I. units (second, meters, Newtons, ...)\nIf the header above contains a line with 'inDegrees', this indicates whether rotational values are in degrees (yes) or radians (no).\n\n";
