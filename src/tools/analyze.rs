//! OpenSim's AnalyzeTool: build the states from the coordinates file, select
//! the frames (rows i0..=i1 of the states table; opensim-semantics.md §9.3),
//! and run each analysis of the setup on them. The dispatcher only: what the
//! tools read (motion, states, streams, results folder) is `tools::inputs`,
//! re-exported here for callers outside `tools/`.

use crate::error::{Error, Location, Result};
pub use crate::frame::driver::{for_each_frame, frame_rows, is_frame};
use crate::parse::setup::{Analysis, AnalyzeSetup};
use crate::storage::TableFile;
pub use crate::tools::inputs::{
    coupled_reactions, load_motion_states, load_states, load_states_with, missing_columns_warning,
    open_motion_stream, open_state_stream, open_state_stream_with, read_motion, results_dir,
};
use crate::tools::loading::AnalysisModel;
use crate::tools::{joint_reaction, muscle_analysis, static_optimization, RunOptions, RunSummary};

/// Run the setup's analyses. The coordinates file is read once
/// ([`read_motion`]) and every analysis reads the motion from those bytes.
pub fn run(setup: &AnalyzeSetup, opts: &RunOptions) -> Result<RunSummary> {
    run_in(setup, None, None, opts)
}

/// [`run`] on the run's motion, `motion`, already read by the caller (the
/// setup's coordinates file, [`read_motion`]; predict-grf reads it once
/// for its feet and its run).
pub fn run_motion(
    setup: &AnalyzeSetup,
    motion: &TableFile,
    opts: &RunOptions,
) -> Result<RunSummary> {
    run_in(setup, Some(motion), None, opts)
}

/// [`run_motion`] on the model the caller loaded for this setup (its force
/// sets included: `forces::analysis_model::with_force_sets`), which every
/// analysis then runs on (predict-grf loads its model once).
pub fn run_prepared(
    setup: &AnalyzeSetup,
    motion: &TableFile,
    model: AnalysisModel,
    opts: &RunOptions,
) -> Result<RunSummary> {
    run_in(setup, Some(motion), Some(model), opts)
}

fn run_in(
    setup: &AnalyzeSetup,
    motion: Option<&TableFile>,
    model: Option<AnalysisModel>,
    opts: &RunOptions,
) -> Result<RunSummary> {
    // The tables the setup's figures and metrics name, before the first
    // frame (a figure naming a table the run does not write used to fail
    // only after every table was written).
    let out = opts
        .results_dir
        .clone()
        .unwrap_or_else(|| setup.results_directory.clone());
    if let Some(e) = crate::tools::figures::figure_reference_problems(setup, &out)
        .into_iter()
        .next()
    {
        return Err(e);
    }
    // The figures and metrics read them from the run's kept outputs.
    crate::tools::figures::want_tables(&setup.figures, &out);
    let run =
        crate::frame::threads::in_pool(opts.threads, || run_analyses(setup, motion, model, opts));
    run.and_then(|mut summary| {
        if !setup.figures.is_empty() && summary.stopped.is_none() {
            // Figures read the run's tables: their paths are relative to the results directory.
            let out = results_dir(setup, opts)?;
            summary.files.extend(crate::tools::figures::draw(
                &setup.figures,
                &out,
                &out,
                &setup.name,
                &Default::default(),
            )?);
            crate::tools::figures::tables_read(&setup.figures, &out);
        }
        Ok(summary)
    })
}

fn run_analyses(
    setup: &AnalyzeSetup,
    motion: Option<&TableFile>,
    model: Option<AnalysisModel>,
    opts: &RunOptions,
) -> Result<RunSummary> {
    let mut summary = RunSummary {
        warnings: setup.warnings.clone(),
        unused_properties: setup.unused_properties.clone(),
        ..Default::default()
    };
    let active: Vec<&Analysis> = setup.analyses.iter().filter(|a| a.common().on).collect();
    if active.is_empty() {
        return Err(Error::input(
            Location::file(&setup.setup_file).with_element("<AnalysisSet>"),
            "the setup has no analysis that is on",
        ));
    }
    // A JointReaction without a forces_file in a setup that also runs
    // StaticOptimization takes each frame's solution directly.
    let has_so = active
        .iter()
        .any(|a| matches!(a, Analysis::StaticOptimization(_)));
    let coupled = coupled_reactions(active.iter().copied(), has_so);
    // The motion, read once for every analysis below.
    let motion = match motion {
        Some(m) => m.clone(),
        None => read_motion(setup)?,
    };
    // The model with its force set, loaded once when several analyses run
    // on it; a single analysis loads its own (static optimization reads
    // the external loads on a second thread meanwhile).
    let on_model = active
        .iter()
        .filter(|a| match a {
            Analysis::MuscleAnalysis(_)
            | Analysis::StaticOptimization(_)
            | Analysis::Kinematics(_) => true,
            Analysis::JointReaction(jr) => !coupled.iter().any(|c| c.common.name == jr.common.name),
            Analysis::Unsupported { .. } => false,
        })
        .count();
    let shared = match model {
        Some(am) => Some(am),
        None if on_model > 1 => Some(crate::tools::loading::load_analysis_model(setup)?),
        None => None,
    };
    let model = shared.as_ref();
    // A JointReaction's forces file may be this run's force table: kept
    // in memory until the JointReaction has read it (`storage::results`).
    let forces_file = |a: &Analysis| match a {
        Analysis::JointReaction(jr) => jr.forces_file.clone(),
        _ => None,
    };
    let forces_files: Vec<_> = active.iter().filter_map(|a| forces_file(a)).collect();
    forces_files
        .iter()
        .for_each(|f| crate::storage::results::want(f));
    for a in active {
        match a {
            Analysis::MuscleAnalysis(m) => {
                let s = muscle_analysis::run(setup, m, &motion, model, opts)?;
                summary.absorb(s, None);
                if summary.stopped.is_some() {
                    return Ok(summary);
                }
            }
            Analysis::StaticOptimization(so) => {
                let s = static_optimization::run(setup, so, &coupled, &motion, model, opts)?;
                summary.absorb(s, None);
                if summary.stopped.is_some() {
                    return Ok(summary);
                }
            }
            Analysis::JointReaction(jr) => {
                if coupled.iter().any(|c| c.common.name == jr.common.name) {
                    continue; // computed inside static optimization
                }
                let s = joint_reaction::run(setup, jr, &motion, model, opts)?;
                if let Some(f) = &jr.forces_file {
                    crate::storage::results::done(f);
                }
                summary.absorb(s, None);
                if summary.stopped.is_some() {
                    return Ok(summary);
                }
            }
            Analysis::Kinematics(k) => {
                let s = crate::tools::kinematics::run(setup, k, &motion, model, opts)?;
                summary.absorb(s, None);
                if summary.stopped.is_some() {
                    return Ok(summary);
                }
            }
            Analysis::Unsupported { element, .. } => {
                return Err(element.error(format!(
                    "the analysis '{}' is not supported yet; supported: MuscleAnalysis, StaticOptimization, JointReaction, BodyKinematics, PointKinematics",
                    element.name
                )));
            }
        }
    }
    Ok(summary)
}
