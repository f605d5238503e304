//! The force sweep tool: a thin driver over the sweep stage
//! (`crate::sweep::stream`: the setup compiled, the motion streamed, each
//! frame solved for every candidate, the metrics collected and, on
//! request, each candidate's tables written). It adds the command line's
//! threads, precision and progress bar, and writes a study's
//! `<name>_force_sweep.csv`.

use crate::error::{Error, Location, Result};
use crate::tools::RunOptions;
use crate::writers::names::{OutputKind, RunKey, Sweep};

pub use crate::plan::force_sweep::CandidateSpec;
pub use crate::sweep::stream::{CandidateTables, SweepOptions};
pub use crate::sweep::{Scene, SweepOutcome};

/// Run a force sweep of the AnalyzeTool setup in `setup_file` (or `text`,
/// read as if it were that file): `crate::sweep::stream::run_file` with
/// the command line's threads, precision and progress bar.
pub fn run_file(
    setup_file: &std::path::Path,
    text: Option<&str>,
    candidates: &[CandidateSpec],
    opts: &RunOptions,
    sweep: &SweepOptions,
) -> Result<SweepOutcome> {
    let setup = crate::sweep::setup::read_setup(setup_file, text, opts.allow_unknown)?;
    run(&setup, candidates, opts, sweep)
}

/// Run a force sweep of `setup` (`crate::sweep::stream::run`), with the
/// command line's threads and precision (when `sweep` names none) and a
/// progress bar (`tools::progress`).
pub fn run(
    setup: &crate::parse::setup::AnalyzeSetup,
    candidates: &[CandidateSpec],
    opts: &RunOptions,
    sweep: &SweepOptions,
) -> Result<SweepOutcome> {
    use std::sync::{Arc, Mutex};
    let bar: Arc<Mutex<Option<crate::tools::progress::Progress>>> = Arc::default();
    let label = format!("{}_force_sweep", setup.name);
    let mut with = sweep.clone();
    with.threads = sweep.threads.or(opts.threads);
    with.precision = sweep.precision.or(opts.precision);
    let (b, o, outer) = (bar.clone(), opts.clone(), sweep.progress.clone());
    with.progress = Some(Arc::new(move |done, total| {
        let mut b = b.lock().unwrap_or_else(|p| p.into_inner());
        match b.as_mut() {
            Some(p) => p.inc(1),
            None => *b = Some(crate::tools::progress::bar(total, &o, &label)),
        }
        if let Some(outer) = &outer {
            outer(done, total);
        }
    }));
    let outcome = crate::sweep::stream::run(setup, candidates, &with);
    if let Some(p) = bar.lock().unwrap_or_else(|p| p.into_inner()).as_mut() {
        p.finish_and_clear();
    }
    outcome
}

/// A study's `<ForceSweep>` element (see `tools::study`):
///
/// ```xml
/// <ForceSweep name="cam_shapes" setup="leg_extension_rajagopal_cam2.xml">
///   <contact_weight>1 500 1000</contact_weight>   (default: the setup's)
///   <write_tables>false</write_tables>   (default: metrics only)
///   <Candidate name="circular">
///     <expression force="cam_torque">-50</expression>
///     <optimal_force actuator="knee_angle_r_reserve">50</optimal_force>
///     <external_scale force="plate1_left">1.2</external_scale>  (no force: all)
///   </Candidate>
///   ...
/// </ForceSweep>
/// ```
///
/// Every candidate runs at every w0; the metrics (the setup's `<Metric>`s)
/// go to `<out>/<name>_force_sweep.csv`, one row per (candidate, w0):
/// `candidate`, `w0`, `frames`, `failed`, then the metrics (unrounded).
/// With `<write_tables>true</write_tables>` each candidate's tables go to
/// `<out>/<name>_force_sweep/<candidate>/`, named as a run of its own setup
/// names them (w0-tagged when the element has several w0).
/// The sweep was read with the study (`plan::ForceSweepPlan`).
pub fn run_plan(
    sweep: &crate::plan::ForceSweepPlan,
    out: &std::path::Path,
    opts: &RunOptions,
) -> Result<Vec<std::path::PathBuf>> {
    let (specs, names) = (&sweep.specs, &sweep.names);
    let name = &sweep.name;
    let own = RunKey::setup(name, Sweep::Single);
    let mut options = SweepOptions::default();
    if sweep.write_tables {
        let n_w0 = names.iter().filter(|n| *n == &names[0]).count();
        let mut seen = std::collections::HashSet::new();
        for n in names.iter().step_by(n_w0.max(1)) {
            if !seen.insert(n) {
                return Err(Error::input(
                    sweep.loc.clone(),
                    format!("write_tables: two candidates are named '{n}' (their tables would share a folder)"),
                ));
            }
        }
        options.tables = names
            .iter()
            .map(|n| CandidateTables {
                dir: out.join(own.file(OutputKind::ForceSweepDir(n.clone()))),
                w0_tag: n_w0 > 1,
            })
            .collect();
    }
    let outcome = run(&sweep.setup, specs, opts, &options)?;
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    let path = out.join(own.file(OutputKind::ForceSweep));
    let csv_err = |e: csv::Error| Error::input(Location::file(&path), e.to_string());
    let mut w = csv::Writer::from_path(&path).map_err(csv_err)?;
    let mut header = vec![
        "candidate".to_string(),
        "w0".into(),
        "frames".into(),
        "failed".into(),
    ];
    header.extend(outcome.metric_names.iter().cloned());
    w.write_record(&header).map_err(csv_err)?;
    for (((n, spec), values), failed) in names
        .iter()
        .zip(specs.iter())
        .zip(&outcome.values)
        .zip(&outcome.failed)
    {
        let mut rec = vec![
            n.clone(),
            format!("{}", spec.w0),
            outcome.frames.to_string(),
            failed.to_string(),
        ];
        rec.extend(values.iter().map(|v| format!("{v:e}")));
        w.write_record(&rec).map_err(csv_err)?;
    }
    w.flush().map_err(|e| Error::io(&path, e))?;
    let mut files = vec![path];
    files.extend(outcome.files);
    Ok(files)
}
