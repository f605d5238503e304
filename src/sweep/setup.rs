//! A sweep's setup read and its motion opened: the entry points a caller
//! without a command line (the Python binding's `Scene` and `force_sweep`)
//! and the force sweep tool share.

use crate::error::{Error, Location, Result};
use crate::motion::stream::StateStream;
use crate::parse::setup::{AnalyzeSetup, Setup};
use crate::plan::CandidateSpec;
use crate::sweep::metrics::SweepOutcome;
use crate::sweep::plan::SweepPlan;
use crate::sweep::run::Scene;

/// The AnalyzeTool setup in `setup_file` (or `text`, read as if it were
/// that file); with `allow_unknown` elements neither OpenSim nor statopt
/// knows are read past.
pub fn read_setup(
    setup_file: &std::path::Path,
    text: Option<&str>,
    allow_unknown: bool,
) -> Result<AnalyzeSetup> {
    let setup = match text {
        Some(t) => Setup::parse_with(t, setup_file, allow_unknown)?,
        None => Setup::read_with(setup_file, allow_unknown)?,
    };
    match setup {
        Setup::Analyze(s) => Ok(s),
        _ => Err(Error::input(
            Location::file(setup_file),
            "a force sweep runs an AnalyzeTool setup with a StaticOptimization",
        )),
    }
}

/// The setup's motion streamed for `plan` (its contacts closed with the
/// plan's compiled contacts), its warnings added to `warnings`.
pub fn open_stream<'m>(
    setup: &AnalyzeSetup,
    plan: &'m SweepPlan,
    warnings: &mut Vec<String>,
) -> Result<StateStream<'m>> {
    let stream = crate::frame::inputs::open_state_stream_with(
        setup,
        &plan.problem.model,
        &plan.problem.contacts,
    )?;
    warnings.extend(stream.motion_warnings(&[]));
    if !stream.missing.is_empty() {
        warnings.push(format!(
            "the coordinates file lacks {:?}; they are set to 0 as OpenSim's AnalyzeTool does",
            stream.missing
        ));
    }
    Ok(stream)
}

/// A [`Scene`] of the AnalyzeTool setup in `setup_file` (or `text`, read
/// as if it were that file): compiled and every frame prepared, on a pool
/// of `threads` (None: every core).
pub fn compile_scene(
    setup_file: &std::path::Path,
    text: Option<&str>,
    threads: Option<usize>,
) -> Result<Scene> {
    let setup = read_setup(setup_file, text, false)?;
    crate::frame::threads::in_pool(threads, move || {
        let plan = SweepPlan::compile(&setup)?;
        Scene::prepare(plan, |plan, warnings| open_stream(&setup, plan, warnings))
    })
}

/// Solve `scene`'s frames for `candidates` on a pool of `threads`, each
/// warm-started from the previous one of its w0 when `warm` (metrics only;
/// a force sweep writes candidates' tables, `sweep::stream`).
pub fn run_scene(
    scene: &mut Scene,
    candidates: &[CandidateSpec],
    threads: Option<usize>,
    warm: bool,
) -> Result<SweepOutcome> {
    crate::frame::threads::in_pool(threads, || scene.run(candidates, warm))
}
