//! OpenSim's BodyKinematics and PointKinematics analyses: where bodies and
//! points are, how fast they move and accelerate, per frame of the motion
//! (`dynamics::body_kinematics`), written as OpenSim 4.6 names its tables
//! (`writers::kinematics_tables`). A thin driver over the AnalyzeTool's
//! state stream and frame driver.

use std::borrow::Cow;

use crate::dynamics::body_kinematics::{body_set, BodySelection, PointSelection};
use crate::dynamics::{kinematics, Data};
use crate::error::Result;
use crate::frame::driver::write_each_frame;
use crate::parse::kinematics::KinematicsSetup;
use crate::parse::setup::AnalyzeSetup;
use crate::storage::TableFile;
use crate::tools::inputs::{open_motion_stream, results_dir};
use crate::tools::loading::{load_analysis_model, AnalysisModel};
use crate::tools::{RunOptions, RunSummary};
use crate::writers::kinematics_tables::{KinematicsTables, TableSpec};

/// What one analysis records, resolved on the model.
enum Selection {
    Body(BodySelection),
    Point(PointSelection),
}

/// Resolve the analysis's body and frame names on the model (errors name
/// the setup's element and line).
fn select(am: &AnalysisModel, k: &KinematicsSetup) -> Result<Selection> {
    Ok(match k {
        KinematicsSetup::Body(b) => {
            let set = body_set(&am.model, am.spec.bodies.iter().map(|b| b.name.as_str()))?;
            Selection::Body(BodySelection::compile(&am.model, &set, b)?)
        }
        KinematicsSetup::Point(p) => Selection::Point(PointSelection::compile(&am.model, p)?),
    })
}

/// Check the analysis's names against the model without running it
/// (`--check`).
pub fn check(am: &AnalysisModel, k: &KinematicsSetup) -> Result<()> {
    select(am, k).map(|_| ())
}

pub fn run(
    setup: &AnalyzeSetup,
    k: &KinematicsSetup,
    motion: &TableFile,
    model: Option<&AnalysisModel>,
    opts: &RunOptions,
) -> Result<RunSummary> {
    let am = match model {
        Some(am) => Cow::Borrowed(am),
        None => Cow::Owned(load_analysis_model(setup)?),
    };
    let mut warnings = am.warnings.clone();
    let model = &am.model;
    let selection = select(&am, k)?;
    let mut stream = open_motion_stream(setup, motion, model, &[])?;
    warnings.extend(stream.motion_warnings(&[]));
    warnings.extend(crate::tools::inputs::missing_columns_warning(
        setup,
        &stream.missing,
    ));
    let dir = results_dir(setup, opts)?;
    let name = &k.common().name;
    let labels = match &selection {
        Selection::Body(s) => s.labels(model),
        Selection::Point(p) => p.labels.clone(),
    };
    let spec = TableSpec {
        setup_file: &setup.setup_file,
        dir: &dir,
        precision: opts.precision.unwrap_or(setup.output_precision),
        labels: &labels,
    };
    let mut tables = match (k, &selection) {
        (KinematicsSetup::Body(b), Selection::Body(s)) => KinematicsTables::body(
            &spec,
            &setup.name,
            name,
            &model.name,
            b.express_in_body_frame,
            s.in_degrees,
        )?,
        (KinematicsSetup::Point(p), _) => {
            let relative = match &p.relative_to {
                Some(r) => format!(" relative to {r}"),
                None => String::new(),
            };
            KinematicsTables::point(
                &spec,
                &setup.name,
                name,
                &p.point_name,
                &format!(
                    "point ({}, {}, {}) on {}{relative} of model {}",
                    p.point[0], p.point[1], p.point[2], p.body_name, model.name
                ),
            )?
        }
        (KinematicsSetup::Body(_), Selection::Point(_)) => unreachable!("selected from the setup"),
    };
    let (i0, i1, step) = (stream.first_row, stream.last_row, k.common().step_interval);
    // The frame driver of every analysis: frames in parallel chunks over
    // per-thread buffers, written in order.
    let (nframes, stopped) = write_each_frame(
        &mut stream,
        i0,
        i1,
        step,
        || Data::new(model),
        |data, block, b| {
            data.q.copy_from_slice(&block.q[b]);
            data.u.copy_from_slice(&block.u[b]);
            data.udot.copy_from_slice(&block.udot[b]);
            kinematics::full(model, data);
            let (mut p, mut v, mut a) = (Vec::new(), Vec::new(), Vec::new());
            match &selection {
                Selection::Body(s) => s.rows(model, data, &mut p, &mut v, &mut a),
                Selection::Point(s) => {
                    let [x, y, z] = s.rows(data);
                    p.extend(x.iter());
                    v.extend(y.iter());
                    a.extend(z.iter());
                }
            }
            Ok((block.time[b], [p, v, a]))
        },
        |t, [p, v, a]| tables.write(t, [&p, &v, &a]),
    )?;
    Ok(RunSummary {
        frames: nframes,
        results_dirs: vec![dir],
        files: tables.finish()?,
        warnings,
        stopped,
        ..Default::default()
    })
}
