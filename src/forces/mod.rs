//! Forces that are known at a frame (not optimisation unknowns): external
//! loads from data files; and the non-muscle force elements of a model's
//! ForceSet or of a setup's appended force-set files (opensim-semantics.md
//! §8.2–8.4): actuators (reserves, residuals) and passive forces.
pub mod analysis_model;
pub mod external_loads;

pub mod actuators;
pub mod lepton;
pub mod passive;
pub mod root_residuals;
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

/// A force-set file named by a setup, as its parsed document (see
/// [`force_set_members`]; a tool that edits a plan's force sets in memory).
pub fn read_force_set_document(path: &Path) -> Result<Element> {
    xml::parse_file(path)
}

/// A force-set document a tool builds as text (predict-grf's foot
/// contacts and root residuals), parsed as if it were the file `path` it
/// is also written to: its elements' messages name that file and line.
pub fn force_set_document(text: &str, path: &Path) -> Result<Element> {
    xml::parse_str(text, path)
}

/// The force-set document `root` without its actuators that act on the
/// root joint only: coordinate actuators on one of `root_coordinates`,
/// point actuators on `root_body`, torque actuators with `root_body` as a
/// body (a body path's last part counts). None when it holds none.
pub fn without_root_actuators(
    root: &Element,
    root_coordinates: &[&str],
    root_body: &str,
) -> Option<Element> {
    let is_root_actuator = |el: &Element| -> bool {
        let text = |n: &str| el.child_text(n).map(str::trim).unwrap_or("");
        let on_root_body = |n: &str| {
            let b = text(n);
            b == root_body || b.rsplit('/').next() == Some(root_body)
        };
        match el.name.as_str() {
            "CoordinateActuator" => root_coordinates.contains(&text("coordinate")),
            "PointActuator" => on_root_body("body"),
            "TorqueActuator" => on_root_body("bodyA") || on_root_body("bodyB"),
            _ => false,
        }
    };
    let mut root = root.clone();
    let mut removed = 0;
    let mut stack = vec![&mut root];
    while let Some(el) = stack.pop() {
        if el.name == "objects" {
            let before = el.children.len();
            el.children.retain(|c| !is_root_actuator(c));
            removed += before - el.children.len();
        }
        stack.extend(el.children.iter_mut());
    }
    (removed > 0).then_some(root)
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
