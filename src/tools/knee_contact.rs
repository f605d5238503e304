//! The knee contact method's subcommand (its table: `tools::knee_contact_table`)
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

use crate::error::{Error, Result};
use crate::parse::setup::{Analysis, Setup};
use crate::storage;
pub use crate::tools::knee_contact_table::{labels, reaction_specs, DESCRIPTION, REACTIONS_NAME};
use crate::tools::{RunOptions, RunSummary};

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
