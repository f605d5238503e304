//! The knee contact method's outputs and its subcommand
//! (`statopt-tool knee-contact SETUP.xml [--results-dir DIR] [--joint J]`):
//! the setup's static optimization with `<knee_contact>` (the knees'
//! compartments as unknown contact forces, `frame::knee_contact`), the usual
//! tables, `<name>_KneeContact_ReactionLoads.sto` (each knee's reaction on
//! its tibia in the tibia frame) and `<name>_KneeContact.sto`:
//!
//! - `<joint>_flexion_deg`: knee flexion (degrees, flexion positive; as
//!   `tools::knee_loads`),
//! - `<joint>_total_N`: |F| of the tibiofemoral reaction on the tibia, as the
//!   eTibia's total measures it,
//! - `<joint>_medial_N`, `<joint>_lateral_N`: the compartments' compressive
//!   loads (the method's two rows solved for them; ≥ 0 at its solutions).
use std::path::{Path, PathBuf};

use crate::dynamics::{kinematics, Data};
use crate::error::{Error, Result};
use crate::frame::knee_contact::{compartments, Knee};
use crate::model::{Model, Transform};
use crate::parse::setup::{Analysis, Setup};
use crate::reactions::ReactionSpec;
use crate::storage::{self, StoWriter};
use crate::tools::knee_loads::flexion_degrees;
use crate::tools::{RunOptions, RunSummary};

/// The name of the reactions the method reports (`<name>_KneeContact_ReactionLoads.sto`).
pub const REACTIONS_NAME: &str = "KneeContact";

/// Each knee's reaction on its tibia, in the tibia's body frame, at the joint centre.
pub fn reaction_specs(model: &Model, knees: &[Knee]) -> Vec<ReactionSpec> {
    knees
        .iter()
        .map(|k| {
            let tibia = &model.bodies[k.tibia].name;
            ReactionSpec {
                joint: k.tibia,
                on_child: true,
                frame_body: k.tibia,
                frame: Transform::identity(),
                label_root: format!("{}_on_{tibia}_in_{tibia}", k.name),
            }
        })
        .collect()
}

/// Column labels of `<name>_KneeContact.sto`.
pub fn labels(knees: &[Knee]) -> Vec<String> {
    knees
        .iter()
        .flat_map(|k| {
            ["flexion_deg", "total_N", "medial_N", "lateral_N"].map(|c| format!("{}_{c}", k.name))
        })
        .collect()
}

pub const DESCRIPTION: &str = "Knee contact forces of statopt's knee contact method (docs/knee_contact.md): per knee, flexion in degrees (flexion positive); total_N = magnitude of the tibiofemoral reaction on the tibia; medial_N, lateral_N = the compartments' compressive loads (along the tibial long axis, balancing the frontal-plane moment at 40 mm apart). Units N.";

/// Write `out` from the knees' reaction table `reactions` (from
/// [`reaction_specs`]), knee angles from the positions `q` at `time` at the
/// table's times.
#[allow(clippy::too_many_arguments)]
pub fn write(
    model: &Model,
    knees: &[Knee],
    time: &[f64],
    q: &[Vec<f64>],
    reactions: &Path,
    out: &Path,
    setup_file: &Path,
    precision: usize,
) -> Result<PathBuf> {
    let table = storage::read(reactions)?;
    let specs = reaction_specs(model, knees);
    let cols: Vec<[usize; 3]> = specs
        .iter()
        .map(|s| {
            let c = |x: &str| {
                table
                    .column_index(&format!("{}_{x}", s.label_root))
                    .ok_or_else(|| {
                        Error::msg(format!(
                            "{}: no column {}_{x}",
                            reactions.display(),
                            s.label_root
                        ))
                    })
            };
            Ok([c("fx")?, c("fy")?, c("fz")?])
        })
        .collect::<Result<_>>()?;
    let mx: Vec<usize> = specs
        .iter()
        .map(|s| {
            table
                .column_index(&format!("{}_mx", s.label_root))
                .ok_or_else(|| Error::msg(format!("{}: no mx column", reactions.display())))
        })
        .collect::<Result<_>>()?;
    let mut w = StoWriter::create_for_setup(
        setup_file,
        out,
        "Knee contact",
        DESCRIPTION,
        &labels(knees),
        precision,
        false,
    )?;
    let mut data = Data::new(model);
    let mut row = Vec::with_capacity(4 * knees.len());
    for (i, &t) in table.time.iter().enumerate() {
        let k = crate::motion::coordinates::find_index(time, t);
        data.q.copy_from_slice(&q[k]);
        data.u.iter_mut().for_each(|x| *x = 0.0);
        kinematics::full(model, &mut data);
        row.clear();
        let r = &table.rows[i];
        for ((knee, [x, y, z]), &m) in knees.iter().zip(&cols).zip(&mx) {
            let (med, lat) = compartments(knee, r[*y], r[m]);
            row.push(flexion_degrees(&data, knee.femur, knee.tibia));
            row.push((r[*x] * r[*x] + r[*y] * r[*y] + r[*z] * r[*z]).sqrt());
            row.push(med);
            row.push(lat);
        }
        w.write_row(t, &row)?;
    }
    w.finish()?;
    Ok(out.to_path_buf())
}

/// The subcommand: run `setup_file`'s static optimization with
/// `<knee_contact>` set to `joints` (every knee when empty), then draw the
/// contact forces. Returns the run's summary (its files include the figure).
pub fn run(setup_file: &Path, joints: &[String], opts: &RunOptions) -> Result<RunSummary> {
    let mut setup = match Setup::read(setup_file)? {
        Setup::Analyze(s) => s,
        _ => {
            return Err(Error::msg(format!(
                "{}: knee-contact needs an AnalyzeTool setup with a StaticOptimization analysis",
                setup_file.display()
            )))
        }
    };
    let mut found = false;
    for a in setup.analyses.iter_mut() {
        if let Analysis::StaticOptimization(so) = a {
            let words = if joints.is_empty() {
                vec!["all".to_string()]
            } else {
                joints.to_vec()
            };
            so.set_knee_contact(&words)?;
            found = true;
        }
    }
    if !found {
        return Err(Error::msg(format!(
            "{}: knee-contact needs a StaticOptimization analysis in the setup",
            setup_file.display()
        )));
    }
    let mut summary = crate::tools::analyze::run(&setup, opts)?;
    let tables: Vec<PathBuf> = summary
        .files
        .iter()
        .filter(|f| {
            f.file_name()
                .is_some_and(|n| n.to_string_lossy().ends_with("_KneeContact.sto"))
        })
        .cloned()
        .collect();
    for t in tables {
        summary.files.extend(plot(&t)?);
    }
    Ok(summary)
}

/// A figure of a `_KneeContact.sto` table: per knee, total, medial and
/// lateral force over time (PNG and SVG beside the table).
pub fn plot(table: &Path) -> Result<Vec<PathBuf>> {
    let t = storage::read(table)?;
    let mut chart = crate::plots::Chart {
        title: "Knee contact forces (statopt's knee contact method)".into(),
        x_label: "time (s)".into(),
        y_label: "force (N)".into(),
        ..Default::default()
    };
    for (j, l) in t.labels.iter().enumerate() {
        let style = if l.ends_with("_total_N") {
            Some(crate::plots::Style::color(chart.series.len()))
        } else if l.ends_with("_medial_N") || l.ends_with("_lateral_N") {
            Some(crate::plots::Style::dashed(chart.series.len()))
        } else {
            None
        };
        if let Some(style) = style {
            chart.series.push(crate::plots::Series::new(
                l.clone(),
                t.time.clone(),
                t.rows.iter().map(|r| r[j]).collect(),
                style,
            ));
        }
    }
    crate::plots::write(&chart, &table.with_extension(""))
}
