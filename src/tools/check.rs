//! `statopt-tool SETUP --check`: read and compile everything a setup or a
//! study names (files, models, force sets, external loads, the motion, the
//! analyses' problems, a study's figure references) and report every problem
//! found, without solving a frame.
//!
//! Each stage that does not depend on an earlier one that failed is still
//! checked, so one pass lists everything that would stop a run.

use std::path::Path;

use crate::error::Error;
use crate::parse::setup::{
    missing_input_files, Analysis, AnalyzeSetup, InverseDynamicsSetup, Setup,
};
use crate::tools::{analyze, joint_reaction, loading, static_optimization, study};

/// What a check found: errors (each would stop a run) and warnings.
#[derive(Debug, Default)]
pub struct CheckReport {
    pub errors: Vec<Error>,
    pub warnings: Vec<String>,
    /// Setups checked (a study's and the study's own document).
    pub checked: Vec<String>,
}

/// Check a setup or a study document.
pub fn run(path: &Path) -> CheckReport {
    let mut report = CheckReport::default();
    if study::is_study(path) {
        match study::check(path) {
            Ok(setups) => {
                for s in setups {
                    check_setup(&s, &mut report);
                }
            }
            Err(e) => {
                report.errors.push(e);
                // The study's setups are still checked one by one.
                for s in study::setup_files(path).unwrap_or_default() {
                    check_setup(&s, &mut report);
                }
            }
        }
        report.checked.push(path.display().to_string());
    } else {
        check_setup(path, &mut report);
    }
    report
}

fn check_setup(path: &Path, report: &mut CheckReport) {
    report.checked.push(path.display().to_string());
    // Every missing file at once (reading the setup stops at the first).
    match missing_input_files(path) {
        Ok(missing) if !missing.is_empty() => {
            report.errors.extend(missing);
            return;
        }
        Ok(_) => {}
        Err(e) => {
            report.errors.push(e);
            return;
        }
    }
    match Setup::read(path) {
        Ok(Setup::Analyze(a)) => {
            report.warnings.extend(a.warnings.iter().cloned());
            check_analyze(&a, report);
        }
        Ok(Setup::InverseDynamics(i)) => {
            report.warnings.extend(i.warnings.iter().cloned());
            check_inverse_dynamics(&i, report);
        }
        Err(e) => report.errors.push(e),
    }
}

fn check_analyze(setup: &AnalyzeSetup, report: &mut CheckReport) {
    let am = match loading::load_analysis_model(setup) {
        Ok(am) => am,
        Err(e) => {
            report.errors.push(e);
            return;
        }
    };
    report.warnings.extend(am.warnings.iter().cloned());
    match analyze::open_state_stream(setup, &am.model) {
        Ok(stream) => report.warnings.extend(stream.motion_warnings(&[])),
        Err(e) => report.errors.push(e),
    }
    for a in &setup.analyses {
        let Analysis::Other { element, common } = a else {
            continue;
        };
        match element.name.as_str() {
            "StaticOptimization" => {
                let so = match static_optimization::StaticOptimizationSetup::from_xml(
                    element,
                    common.clone(),
                ) {
                    Ok(so) => so,
                    Err(e) => {
                        report.errors.push(e);
                        continue;
                    }
                };
                match static_optimization::SoProblem::build_from(setup, &so, am.clone()) {
                    Ok((_, w)) => report.warnings.extend(w),
                    Err(e) => report.errors.push(e),
                }
            }
            "JointReaction" => {
                let dir = setup.dir();
                match joint_reaction::JointReactionSetup::from_xml(element, common.clone(), dir) {
                    // Without a forces file the reactions come from the
                    // setup's own static optimization (checked above); a
                    // forces file from an earlier run need not exist yet.
                    Ok(jr) if jr.forces_file.as_ref().is_none_or(|f| !f.exists()) => {}
                    Ok(jr) => {
                        if let Err(e) = joint_reaction::JointReactionProblem::build(setup, &jr) {
                            report.errors.push(e);
                        }
                    }
                    Err(e) => report.errors.push(e),
                }
            }
            _ => {}
        }
    }
}

fn check_inverse_dynamics(setup: &InverseDynamicsSetup, report: &mut CheckReport) {
    let (spec, model) = match loading::load_composed_model(&setup.model_file, &setup.artifact_files)
    {
        Ok(m) => m,
        Err(e) => {
            report.errors.push(e);
            return;
        }
    };
    let mut w = Vec::new();
    if let Err(e) =
        crate::tools::inverse_dynamics::check_forces(&spec, &setup.forces_to_exclude, &mut w)
    {
        report.errors.push(e);
    }
    report.warnings.extend(w);
    if let Some(p) = &setup.external_loads_file {
        let dir = setup.dir();
        if let Err(e) = crate::forces::external_loads::ExternalLoads::load(p, dir, &model) {
            report.errors.push(e);
        }
    }
    match crate::storage::read(&setup.coordinates_file) {
        Ok(raw) => match crate::motion::checks::motion_warnings(
            &model,
            &setup.coordinates_file,
            &raw.labels,
            &crate::motion::checks::TimeSteps::of(&raw.time),
            setup.lowpass_cutoff,
        ) {
            Ok(w) => report.warnings.extend(w),
            Err(e) => report.errors.push(e),
        },
        Err(e) => report.errors.push(e),
    }
}
