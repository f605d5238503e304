//! Forces that are known at a frame (not optimisation unknowns): external
//! loads from data files; and the non-muscle force elements of a model's
//! ForceSet or of a setup's appended force-set files (opensim-semantics.md
//! §8.2–8.4): actuators (reserves, residuals) and passive forces.
pub mod analysis_model;
pub mod external_loads;

pub mod actuators;
pub mod lepton;
pub mod passive;
#[cfg(test)]
mod tests;

pub use actuators::{Actuator, ActuatorKind};
pub use passive::PassiveForce;

use std::path::Path;

use crate::error::Result;
use crate::model::{Frame, Model};
use crate::xml::{self, Element};

/// Read a force-set file named by a setup (`force_set_files`): an
/// `<OpenSimDocument><ForceSet>…</ForceSet></OpenSimDocument>` or a bare
/// `<ForceSet>`; returns its member elements in file order.
pub fn read_force_set_file(path: &Path) -> Result<Vec<Element>> {
    let root = xml::parse_file(path)?;
    force_set_members(&root)
}

/// The members of a force-set document already parsed (see [`read_force_set_file`]).
pub fn force_set_members(root: &Element) -> Result<Vec<Element>> {
    let set = match root.name.as_str() {
        "ForceSet" => root,
        "OpenSimDocument" => root
            .child("ForceSet")
            .ok_or_else(|| root.error("document holds no <ForceSet> element"))?,
        other => {
            return Err(root.error(format!(
                "expected a <ForceSet> (optionally inside <OpenSimDocument>), found <{other}>"
            )))
        }
    };
    Ok(match set.child("objects") {
        Some(o) => o.children.to_vec(),
        None => Vec::new(),
    })
}

/// `appliesForce` (4.0) or `!isDisabled` (3.x); true when neither is given.
pub(crate) fn applies_force(el: &Element) -> Result<bool> {
    match el.child("appliesForce") {
        Some(a) if !a.text().is_empty() => a.bool(),
        _ => Ok(!el.child_bool_or("isDisabled", false)?),
    }
}

/// The coordinate named by the required property `prop` of `el`.
pub(crate) fn coordinate_property(el: &Element, prop: &str, model: &Model) -> Result<usize> {
    let p = el.req(prop)?;
    let name = p.text();
    if name.is_empty() {
        return Err(p.error(format!("{} has an empty <{prop}>", el.name)));
    }
    model.coordinate_index(name).ok_or_else(|| {
        p.error(format!(
            "{} '{}': unknown coordinate '{name}'",
            el.name,
            el.name_attr()
        ))
    })
}

/// Resolve a frame name as OpenSim components do: as a path (absolute, or
/// relative to the model: `ground`, `./bodyset/x`), then as `bodyset/<name>`.
pub(crate) fn find_frame<'m>(model: &'m Model, name: &str) -> Option<&'m Frame> {
    let trimmed = name.trim_start_matches("./");
    let abs = if trimmed.starts_with('/') {
        trimmed.to_string()
    } else {
        format!("/{trimmed}")
    };
    model.frames.iter().find(|f| f.path == abs).or_else(|| {
        model
            .frames
            .iter()
            .find(|f| f.path == format!("/bodyset/{trimmed}"))
    })
}
