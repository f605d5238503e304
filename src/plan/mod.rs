//! The plan stage (docs/architecture.md): a setup document read once from
//! its parsed XML into typed values, each with the file and line it came
//! from: a tool setup ([`Setup`]: the InverseDynamicsTool or AnalyzeTool,
//! its analyses, statopt's own elements; read by `parse::setup` and
//! `parse::analyses`) or a study document ([`StudyPlan`]: its setups, force
//! sweeps, figures and metrics). Every element is known or refused
//! (`parse::known`). Tools receive a plan and never read setup XML again;
//! a tool that adds to a setup (predict-grf's foot contacts) builds its
//! plan from the user's plan in memory.
pub mod force_sweep;
pub mod study;

/// A study's or setup's figures and metrics, typed (`parse::figures`).
pub use crate::parse::figures;

use std::path::Path;

pub use crate::parse::setup::{Analysis, AnalyzeSetup, InverseDynamicsSetup, Setup};
pub use force_sweep::{CandidateSpec, ForceSweepPlan};
pub use study::{StudyDocument, StudyPlan, StudyRun};

/// The plan of a setup document.
#[derive(Debug, Clone)]
pub enum Plan {
    Tool(Box<Setup>),
    Study(Box<StudyPlan>),
}

impl Plan {
    /// Read a setup or study document once; with `allow_unknown`
    /// (`--allow-unknown`) an element neither OpenSim 4.6 nor statopt knows
    /// is a warning instead of an error.
    pub fn read(path: &Path, allow_unknown: bool) -> crate::Result<Plan> {
        let root = crate::parse::setup::read_document(path)?;
        if study::is_study_document(&root) {
            Ok(Plan::Study(Box::new(StudyPlan::from_document(
                StudyDocument::from_root(&root, path)?,
                allow_unknown,
            )?)))
        } else {
            Ok(Plan::Tool(Box::new(Setup::from_document(
                &root,
                path,
                allow_unknown,
            )?)))
        }
    }
}

impl Plan {
    /// The unknown elements read on past (`allow_unknown`), as warnings:
    /// the document's, and for a study its setups' and force sweeps'.
    pub fn unknown_elements_read_on(&self) -> Vec<String> {
        match self {
            Plan::Tool(s) => s.warnings().to_vec(),
            Plan::Study(s) => {
                let mut w = s.warnings.clone();
                for r in &s.runs {
                    for x in r.setup.warnings() {
                        if !w.contains(x) {
                            w.push(x.clone());
                        }
                    }
                }
                w
            }
        }
    }
}

/// Whether the file is a study document (false when it cannot be read).
pub fn is_study(path: &Path) -> bool {
    crate::parse::setup::read_document(path).is_ok_and(|r| study::is_study_document(&r))
}
