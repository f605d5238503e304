//! The JointReaction element of an AnalyzeTool setup (opensim-semantics.md
//! §7.1), and the reactions it asks for resolved against the model as
//! OpenSim's `JointReaction::setupReactionList` does.

use crate::error::Result;
use crate::model::{Model, Transform};
use crate::reactions::joint::ReactionSpec;

pub use crate::parse::analyses::JointReactionSetup;

/// Resolve joint_names / apply_on_bodies / express_in_frame as
/// `JointReaction::setupReactionList` does (§7.1). Unknown joints are
/// skipped with a warning; a bad body keyword or frame name is an error.
pub fn resolve_reactions(
    model: &Model,
    jr: &JointReactionSetup,
) -> Result<(Vec<ReactionSpec>, Vec<String>)> {
    let el = &jr.element;
    let at = |prop: &str| el.child(prop).unwrap_or(el);
    let mut warnings = Vec::new();
    let set: Vec<usize> = model
        .joint_set_order
        .iter()
        .copied()
        .filter(|&b| b != 0)
        .collect();
    let names: Vec<String> = if jr.joint_names[0].eq_ignore_ascii_case("ALL") {
        set.iter().map(|&b| model.joints[b].name.clone()).collect()
    } else {
        jr.joint_names.clone()
    };
    let n = names.len();
    for (prop, v) in [
        ("apply_on_bodies", &jr.apply_on_bodies),
        ("express_in_frame", &jr.express_in_frame),
    ] {
        if v.len() != 1 && v.len() != n {
            return Err(at(prop).error(format!(
                "{prop} has {} entries; it must have 1 or one per joint ({n})",
                v.len()
            )));
        }
    }
    let mut specs = Vec::new();
    // OpenSim's JointSet::getIndex(name, start): search from start, wrapping.
    let mut last: Option<usize> = None;
    for (i, name) in names.iter().enumerate() {
        let start = last.map(|l| l + 1).unwrap_or(0);
        let found = (0..set.len())
            .map(|k| (start + k) % set.len().max(1))
            .find(|&k| model.joints[set[k]].name == *name);
        let Some(k) = found else {
            warnings.push(format!(
                "JointReaction '{}': '{name}' is not a joint of the model; ignored",
                jr.common.name
            ));
            continue;
        };
        last = Some(k);
        let b = set[k];
        let joint = &model.joints[b];
        let on = if jr.apply_on_bodies.len() == 1 {
            &jr.apply_on_bodies[0]
        } else {
            &jr.apply_on_bodies[i]
        };
        let on_child = match on.to_ascii_lowercase().as_str() {
            "child" => true,
            "parent" => false,
            _ => {
                return Err(at("apply_on_bodies").error(format!(
                    "apply_on_bodies entry '{on}' must be 'child' or 'parent'"
                )))
            }
        };
        let on_body = if on_child { b } else { joint.parent_body };
        let ex = if jr.express_in_frame.len() == 1 {
            &jr.express_in_frame[0]
        } else {
            &jr.express_in_frame[i]
        };
        let (frame_body, frame, frame_name) = match find_named_frame(model, ex) {
            Some(f) => (f.body, f.transform, f.name.clone()),
            None => {
                let body = match ex.to_ascii_lowercase().as_str() {
                    "child" => b,
                    "parent" => joint.parent_body,
                    _ => {
                        return Err(at("express_in_frame").error(format!(
                            "express_in_frame entry '{ex}' is neither a frame of the model nor 'child' or 'parent'"
                        )))
                    }
                };
                (body, Transform::identity(), model.bodies[body].name.clone())
            }
        };
        specs.push(ReactionSpec {
            joint: b,
            on_child,
            frame_body,
            frame,
            label_root: format!(
                "{}_on_{}_in_{frame_name}",
                joint.name, model.bodies[on_body].name
            ),
        });
    }
    Ok((specs, warnings))
}

/// A frame named as OpenSim's JointReaction looks it up: a path relative to
/// the model, then to the BodySet, then to the JointSet.
fn find_named_frame<'m>(model: &'m Model, name: &str) -> Option<&'m crate::model::Frame> {
    let rel = name.trim_start_matches("./");
    let candidates = if rel.starts_with('/') {
        vec![rel.to_string()]
    } else {
        vec![
            format!("/{rel}"),
            format!("/bodyset/{rel}"),
            format!("/jointset/{rel}"),
        ]
    };
    candidates
        .iter()
        .find_map(|p| model.frames.iter().find(|f| &f.path == p))
}
