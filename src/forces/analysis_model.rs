//! The model an AnalyzeTool setup runs on, with its force set (the model's
//! own forces, its artifacts', the setup's force-set files), and the broad
//! kinds of force elements the analyses sort them into.

use crate::error::Result;
use crate::model::load::load_composed_model;
use crate::model::Model;
use crate::parse::osim::ModelSpec;
use crate::xml::Element;

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
#[derive(Clone)]
pub struct AnalysisModel {
    pub model: Model,
    pub spec: ModelSpec,
    /// ForceSet elements: the composed model's own (those of the model and its
    /// artifacts, unless replace_force_set), then
    /// each force_set_files set, in order, then each of
    /// `force_set_documents`. (They are moved here from
    /// `spec.forces`, which stays empty.)
    pub forces: Vec<Element>,
    pub warnings: Vec<String>,
}

pub fn load_analysis_model(setup: &crate::parse::setup::AnalyzeSetup) -> Result<AnalysisModel> {
    with_force_sets(load_composed_model_of(setup)?, setup)
}

/// The setup's model and artifacts, parsed and compiled, with the model's
/// own force elements kept apart: what [`with_force_sets`] completes with
/// a setup's force sets. A tool that runs the same model with other force
/// sets (predict-grf: the user's, then its own with the foot contacts)
/// loads it once.
#[derive(Clone)]
pub struct ComposedModel {
    pub model: Model,
    pub spec: ModelSpec,
    /// The model's and its artifacts' own force elements (moved out of
    /// `spec.forces`, which stays empty).
    pub own_forces: Vec<Element>,
}

/// Parse and compile the setup's model and artifacts.
pub fn load_composed_model_of(setup: &crate::parse::setup::AnalyzeSetup) -> Result<ComposedModel> {
    // Artifacts are merged before compilation and force-set files are read
    // after it: contacts in a force-set file resolve their bodies against the
    // composed model.
    let (mut spec, model) = load_composed_model(&setup.model_file, &setup.artifact_files)?;
    // The model's own force elements move to `own_forces` (not copied: 92
    // muscles' elements on gait2392); `spec.forces` is left empty.
    let own_forces = std::mem::take(&mut spec.forces);
    Ok(ComposedModel {
        model,
        spec,
        own_forces,
    })
}

/// The [`AnalysisModel`] of `setup` on a model already composed: its own
/// forces (unless `replace_force_set`), then the setup's force-set files
/// and documents.
pub fn with_force_sets(
    composed: ComposedModel,
    setup: &crate::parse::setup::AnalyzeSetup,
) -> Result<AnalysisModel> {
    let ComposedModel {
        model,
        spec,
        own_forces,
    } = composed;
    let mut forces = if setup.replace_force_set {
        Vec::new()
    } else {
        own_forces
    };
    let mut warnings = model.warnings.clone();
    let read: Vec<crate::xml::Element> = setup
        .force_set_files
        .iter()
        .map(|f| crate::xml::parse_file(f))
        .collect::<Result<_>>()?;
    for root in read.iter().chain(&setup.force_set_documents) {
        let members = crate::forces::force_set_members(root)?;
        let version = root.attr("Version").and_then(|v| v.trim().parse().ok());
        for m in &members {
            warnings.extend(crate::parse::known::unknown_properties_in_version(
                m, version,
            ));
        }
        forces.extend(members);
    }
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
