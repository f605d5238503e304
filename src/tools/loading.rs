//! Shared input loading for the tools: model, coordinates (filtered as
//! OpenSim filters them), force classification.

use std::path::Path;

use crate::error::Result;
use crate::model::{compile, Model};
use crate::motion::filter;
use crate::parse::osim::ModelSpec;
use crate::storage::{self, Storage};
use crate::xml::Element;

/// Read and compile a model file.
pub fn load_model(path: &Path) -> Result<(ModelSpec, Model)> {
    let spec = ModelSpec::read(path)?;
    let model = compile(&spec)?;
    Ok((spec, model))
}

/// Read a coordinates file and, with a non-negative cutoff, pad it by half its
/// length and low-pass filter it as OpenSim's tools do (§9.2).
pub fn load_coordinates(path: &Path, lowpass_cutoff: f64) -> Result<Storage> {
    let mut table = storage::read(path)?;
    if lowpass_cutoff >= 0.0 {
        let n = table.time.len() / 2;
        filter::pad(&mut table, n);
        filter::lowpass_iir(&mut table, lowpass_cutoff)
            .map_err(|e| e.context(format!("filtering {}", path.display())))?;
    }
    Ok(table)
}

/// The broad kind of a force element, for exclusion lists and for deciding
/// what an analysis must evaluate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ForceKind {
    Muscle,
    /// Non-muscle actuator (force = control × optimal_force).
    Actuator,
    /// PointOnPlaneContact (or the original plugin's ContactPointOnPlane).
    Contact,
    Other,
}

pub fn force_kind(el: &Element) -> ForceKind {
    let t = el.name.as_str();
    if t.ends_with("Muscle") {
        ForceKind::Muscle
    } else if matches!(
        t,
        "CoordinateActuator"
            | "PointActuator"
            | "TorqueActuator"
            | "ActivationCoordinateActuator"
            | "PointToPointActuator"
    ) {
        ForceKind::Actuator
    } else if matches!(t, "PointOnPlaneContact" | "ContactPointOnPlane") {
        ForceKind::Contact
    } else {
        ForceKind::Other
    }
}

/// Whether a force element applies force (`appliesForce`, or 3.x `isDisabled`).
pub fn applies_force(el: &Element) -> Result<bool> {
    match el.child("appliesForce") {
        Some(a) if !a.text().is_empty() => a.bool(),
        _ => Ok(!el.child_bool_or("isDisabled", false)?),
    }
}

/// A model with the force set an AnalyzeTool setup asks for.
pub struct AnalysisModel {
    pub model: Model,
    pub spec: ModelSpec,
    /// ForceSet elements: the model's own (unless replace_force_set), then
    /// each force_set_files set, in order.
    pub forces: Vec<Element>,
    pub warnings: Vec<String>,
}

/// Read the force elements of a force-set file (`<ForceSet>` document).
pub fn read_force_set_file(path: &Path) -> Result<Vec<Element>> {
    let root = crate::xml::parse_file(path)?;
    let set = if root.name == "ForceSet" {
        Some(&root)
    } else {
        root.child("ForceSet")
    };
    let set = set.ok_or_else(|| root.error("no <ForceSet> element in force-set file"))?;
    Ok(set
        .child("objects")
        .map(|o| o.children.clone())
        .unwrap_or_default())
}

pub fn load_analysis_model(setup: &crate::parse::setup::AnalyzeSetup) -> Result<AnalysisModel> {
    let (spec, model) = load_model(&setup.model_file)?;
    let mut forces = if setup.replace_force_set {
        Vec::new()
    } else {
        spec.forces.clone()
    };
    for f in &setup.force_set_files {
        forces.extend(read_force_set_file(f)?);
    }
    let mut warnings = model.warnings.clone();
    for (what, loc) in &spec.unsupported {
        warnings.push(format!("{loc}: {what} is not supported and was ignored"));
    }
    Ok(AnalysisModel {
        model,
        spec,
        forces,
        warnings,
    })
}
