//! The weak root residuals of ground-reaction prediction
//! (docs/grf_prediction.md): the actuators on a model's root joint that a
//! setup's force sets define are replaced by one weak coordinate actuator
//! per root coordinate, so that the feet, not the pelvis, carry the body.

use std::path::PathBuf;

use crate::error::Result;
use crate::model::Model;
use crate::xml::Element;

/// Optimal force (N or N·m) of the weak root residuals predict-grf uses: 100 N
/// on the pelvis costs as much as 100 muscles at full activation.
pub const ROOT_RESIDUAL_OPTIMAL_FORCE: f64 = 1.0;

/// What [`weak_root_residuals`] makes of a setup's force sets.
pub struct WeakRootResiduals {
    /// The force-set documents (the setup's, then its files'), those with
    /// actuators on the root joint filtered.
    pub documents: Vec<Element>,
    /// Which of `documents` were filtered (each to be written as a copy).
    pub filtered: Vec<usize>,
    /// The ForceSet document of the weak residuals and reserves (None: no
    /// root coordinate and no reserves).
    pub residuals: Option<String>,
}

/// One policy for the root (pelvis) residuals, whatever the setup defines:
/// in each force-set document the actuators acting on the root joint only
/// (point and torque actuators on the root body, coordinate actuators on
/// its coordinates) are dropped (predict-grf writes each filtered copy to
/// the results folder), and one coordinate actuator per root coordinate,
/// named `<coordinate>_residual`, with [`ROOT_RESIDUAL_OPTIMAL_FORCE`], is
/// added in a ForceSet document (`<name>_root_residuals.xml`), with the
/// setup's `<reserve_actuators>` on every other unconstrained coordinate
/// and, on each of `toes` (the toe coordinates nothing but muscles drives:
/// `contacts::ground::undriven_toe_coordinates`), an actuator of optimal
/// force `toe_strength` standing for the plantar aponeurosis
/// (`<coordinate>_plantar_aponeurosis`, docs/grf_prediction.md, step 5).
/// The model's own ForceSet is left as it is. Each force-set file is read
/// once.
pub fn weak_root_residuals(
    force_set_documents: &[Element],
    force_set_files: &[PathBuf],
    model: &Model,
    reserves: Option<f64>,
    toes: &[usize],
    toe_strength: f64,
) -> Result<WeakRootResiduals> {
    let mut documents = force_set_documents.to_vec();
    for f in force_set_files {
        documents.push(crate::forces::read_force_set_document(f)?);
    }
    let roots: Vec<usize> = (0..model.nq())
        .filter(|&c| model.is_root_coordinate(c))
        .collect();
    if roots.is_empty() && reserves.is_none() && toes.is_empty() {
        return Ok(WeakRootResiduals {
            documents,
            filtered: Vec::new(),
            residuals: None,
        });
    }
    let root_body = roots
        .first()
        .map(|&c| model.bodies[model.coordinates[c].body].name.clone())
        .unwrap_or_default();
    let root_names: Vec<&str> = roots
        .iter()
        .map(|&c| model.coordinates[c].name.as_str())
        .collect();
    let mut filtered = Vec::new();
    for (k, doc) in documents.iter_mut().enumerate() {
        let Some(without) = crate::forces::without_root_actuators(doc, &root_names, &root_body)
        else {
            continue;
        };
        *doc = without;
        filtered.push(k);
    }
    let mut xml = String::from("<?xml version=\"1.0\" encoding=\"UTF-8\" ?>\n<!-- Weak root residuals of statopt predict-grf (docs/grf_prediction.md). -->\n<OpenSimDocument Version=\"40000\">\n\t<ForceSet name=\"root_residuals\">\n\t\t<objects>\n");
    for name in &root_names {
        xml.push_str(&format!(
            "\t\t\t<CoordinateActuator name=\"{name}_residual\">\n\t\t\t\t<coordinate>{name}</coordinate>\n\t\t\t\t<optimal_force>{ROOT_RESIDUAL_OPTIMAL_FORCE}</optimal_force>\n\t\t\t\t<min_control>-Inf</min_control>\n\t\t\t\t<max_control>Inf</max_control>\n\t\t\t</CoordinateActuator>\n"
        ));
    }
    // The setup's <reserve_actuators>, on every unconstrained coordinate
    // but the root's (those are the weak residuals above).
    if let Some(f) = reserves {
        for c in (0..model.nq())
            .filter(|&c| !model.coordinates[c].is_constrained() && !model.is_root_coordinate(c))
        {
            let name = &model.coordinates[c].name;
            xml.push_str(&format!(
                "\t\t\t<CoordinateActuator name=\"{name}_reserve\">\n\t\t\t\t<coordinate>{name}</coordinate>\n\t\t\t\t<optimal_force>{f}</optimal_force>\n\t\t\t\t<min_control>-Inf</min_control>\n\t\t\t\t<max_control>Inf</max_control>\n\t\t\t</CoordinateActuator>\n"
            ));
        }
    }
    // The plantar aponeurosis on the toe joints nothing else drives.
    for &c in toes {
        let name = &model.coordinates[c].name;
        xml.push_str(&format!(
            "\t\t\t<CoordinateActuator name=\"{name}_plantar_aponeurosis\">\n\t\t\t\t<coordinate>{name}</coordinate>\n\t\t\t\t<optimal_force>{toe_strength}</optimal_force>\n\t\t\t\t<min_control>-Inf</min_control>\n\t\t\t\t<max_control>Inf</max_control>\n\t\t\t</CoordinateActuator>\n"
        ));
    }
    xml.push_str("\t\t</objects>\n\t</ForceSet>\n</OpenSimDocument>\n");
    Ok(WeakRootResiduals {
        documents,
        filtered,
        residuals: Some(xml),
    })
}
