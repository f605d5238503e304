//! Composing a model from a human model and artifact (machine, device)
//! models: the setup property `<artifact_files>` (docs/composition.md).
//!
//! An artifact is an ordinary OpenSim model document. [`merge`] appends its
//! bodies, joints, offset frames, coupler constraints, forces and wrap objects
//! to the base model's, before the composed spec is compiled. The artifact's
//! ground *is* the base model's ground, so a joint whose parent is `/ground`
//! attaches the artifact to the world the human stands in.
//!
//! Component paths need no rewriting: every path in a 4.0 model is rooted at
//! the model (`/bodyset/<body>`, `/jointset/<joint>/<frame>`,
//! `/componentset/<frame>`, `/<frame>` for the model's `components`,
//! `/ground`), and a member keeps its set and name when it moves into the
//! composed model, so absolute and relative socket paths resolve to the same
//! components as in the artifact alone. What must hold instead is that no two
//! components share a name (or, for frames, a path): every clash is an error
//! naming both files, the element and the lines.

use std::collections::HashMap;

use crate::error::{Error, Location, Result};
use crate::parse::osim::ModelSpec;

/// Relative tolerance on gravity equality.
const GRAVITY_TOL: f64 = 1e-12;

fn describe(loc: &Location) -> String {
    let file = loc
        .file
        .as_ref()
        .map(|f| f.display().to_string())
        .unwrap_or_else(|| "?".into());
    match (loc.line, &loc.element) {
        (Some(l), Some(e)) => format!("{file}, line {l}, {e}"),
        (Some(l), None) => format!("{file}, line {l}"),
        (None, Some(e)) => format!("{file}, {e}"),
        (None, None) => file,
    }
}

/// Names seen so far in one namespace of the composed model.
struct Names<'a> {
    what: &'a str,
    seen: HashMap<String, Location>,
}

impl<'a> Names<'a> {
    fn new(what: &'a str) -> Self {
        Names {
            what,
            seen: HashMap::new(),
        }
    }
    fn add_base(&mut self, name: &str, loc: &Location) {
        // A base model that clashes with itself is reported by compile.
        self.seen
            .entry(name.to_string())
            .or_insert_with(|| loc.clone());
    }
    fn add_artifact(&mut self, name: &str, loc: &Location) -> Result<()> {
        if name.is_empty() {
            return Ok(());
        }
        if let Some(prev) = self.seen.get(name) {
            return Err(Error::input(
                loc.clone(),
                format!(
                    "{} '{name}' clashes with the {} of the same name in {}: names must be unique in the composed model; rename one of them",
                    self.what,
                    self.what,
                    describe(prev)
                ),
            ));
        }
        self.seen.insert(name.to_string(), loc.clone());
        Ok(())
    }
}

/// Append the artifact model `artifact` to `base` (see the module doc).
///
/// Errors: gravity differs; the artifact's ground has another name; a body,
/// joint, coordinate, coupler constraint, force or wrap object name, or an
/// offset-frame path, is used by both. Warnings and unsupported elements of
/// both are kept; the composed spec keeps the base model's name, file and
/// document version.
pub fn merge(base: ModelSpec, artifact: ModelSpec) -> Result<ModelSpec> {
    let base_file = base.file.display().to_string();
    let art_file = artifact.file.display().to_string();
    let g = base.gravity;
    if (artifact.gravity - g).norm() > GRAVITY_TOL * g.norm().max(1.0) {
        let loc = artifact
            .gravity_loc
            .clone()
            .unwrap_or_else(|| Location::file(&artifact.file).with_element("<gravity>"));
        let base_where = base
            .gravity_loc
            .as_ref()
            .map(describe)
            .unwrap_or_else(|| format!("{base_file} (OpenSim's default)"));
        return Err(Error::input(
            loc,
            format!(
                "the artifact's gravity ({} {} {}) differs from the model's ({} {} {}, {base_where}); both must be the same",
                artifact.gravity[0], artifact.gravity[1], artifact.gravity[2], g[0], g[1], g[2]
            ),
        ));
    }
    if artifact.ground_name != base.ground_name {
        return Err(Error::input(
            Location::file(&artifact.file).with_element("<Ground>"),
            format!(
                "the artifact's ground is named '{}' but the ground of {base_file} is named '{}'; the artifact's ground is the model's ground, so the names must match",
                artifact.ground_name, base.ground_name
            ),
        ));
    }

    let ground_loc =
        Location::file(&base.file).with_element(format!("<Ground name=\"{}\">", base.ground_name));
    let mut bodies = Names::new("body");
    bodies.add_base(&base.ground_name, &ground_loc);
    for b in &base.bodies {
        bodies.add_base(&b.name, &b.loc);
    }
    for b in &artifact.bodies {
        bodies.add_artifact(&b.name, &b.loc)?;
    }

    let mut joints = Names::new("joint");
    let mut coords = Names::new("coordinate");
    for j in &base.joints {
        joints.add_base(&j.name, &j.loc);
        for c in &j.coordinates {
            coords.add_base(&c.name, &c.loc);
        }
    }
    for j in &artifact.joints {
        joints.add_artifact(&j.name, &j.loc)?;
        for c in &j.coordinates {
            coords.add_artifact(&c.name, &c.loc)?;
        }
    }

    let mut frames = Names::new("frame path");
    for f in &base.frames {
        frames.add_base(&f.path, &f.loc);
    }
    for f in &artifact.frames {
        frames.add_artifact(&f.path, &f.loc)?;
    }

    let mut constraints = Names::new("constraint");
    for c in &base.couplers {
        constraints.add_base(&c.name, &c.loc);
    }
    for c in &artifact.couplers {
        constraints.add_artifact(&c.name, &c.loc)?;
    }

    let mut forces = Names::new("force");
    for f in &base.forces {
        forces.add_base(f.name_attr(), &f.loc());
    }
    for f in &artifact.forces {
        forces.add_artifact(f.name_attr(), &f.loc())?;
    }

    let mut wraps = Names::new("wrap object");
    for (_, w) in &base.wrap_objects {
        wraps.add_base(w.name_attr(), &w.loc());
    }
    for (_, w) in &artifact.wrap_objects {
        wraps.add_artifact(w.name_attr(), &w.loc())?;
    }

    let mut out = base;
    out.bodies.extend(artifact.bodies);
    out.joints.extend(artifact.joints);
    out.frames.extend(artifact.frames);
    out.couplers.extend(artifact.couplers);
    out.forces.extend(artifact.forces);
    out.force_groups.extend(artifact.force_groups);
    out.wrap_objects.extend(artifact.wrap_objects);
    out.unsupported.extend(artifact.unsupported);
    out.warnings.extend(
        artifact
            .warnings
            .into_iter()
            .map(|w| format!("{art_file}: {w}")),
    );
    Ok(out)
}

/// Read `model_file` and merge every artifact file into it, in order.
pub fn read_composed(
    model_file: &std::path::Path,
    artifact_files: &[std::path::PathBuf],
) -> Result<ModelSpec> {
    let mut spec = ModelSpec::read(model_file)?;
    for a in artifact_files {
        spec = merge(spec, ModelSpec::read(a)?)?;
    }
    Ok(spec)
}

#[cfg(test)]
mod tests;
