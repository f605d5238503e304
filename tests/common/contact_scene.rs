//! The ten-contact gait2392 scene shared by `tests/contact_scene.rs` and
//! `benches/contacts.rs`: ten PointOnPlaneContacts on the feet, pelvis and
//! thighs against the ground plane, added to subject01's model, with the
//! walking setup pointed at that model.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

pub const CONTACTS: [(&str, &str); 10] = [
    ("calcn_r", "0 -0.01 0"),
    ("calcn_r", "0.18 -0.01 0.02"),
    ("toes_r", "0.04 -0.005 0"),
    ("calcn_l", "0 -0.01 0"),
    ("calcn_l", "0.18 -0.01 -0.02"),
    ("toes_l", "0.04 -0.005 0"),
    ("pelvis", "-0.1 -0.1 0.08"),
    ("pelvis", "-0.1 -0.1 -0.08"),
    ("femur_r", "0 -0.3 0"),
    ("femur_l", "0 -0.3 0"),
];

/// Writes the scene's model and setup into `dir` (created) and returns the
/// setup file; None (with a SKIP line naming `who`) when ../shared/models is
/// absent.
pub fn write_scene(who: &str, dir: &Path) -> Option<PathBuf> {
    let root =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/models/gait2392/subject01_walk");
    if !root.is_dir() {
        eprintln!("SKIP {who}: ../shared/models is absent");
        return None;
    }
    std::fs::create_dir_all(dir).unwrap();
    let model =
        std::fs::read_to_string(root.join("inputs/subject01_simbody_adjusted.osim")).unwrap();
    let contacts: String = CONTACTS
        .iter()
        .enumerate()
        .map(|(k, (body, p))| {
            format!(
                "<PointOnPlaneContact name=\"c{k}\"><point_body>{body}</point_body><point_location>{p}</point_location><plane_body>ground</plane_body><plane_origin>0 0 0</plane_origin><plane_normal>0 1 0</plane_normal></PointOnPlaneContact>"
            )
        })
        .collect();
    let pos = model
        .find("</objects>\n\t\t</ForceSet>")
        .or_else(|| {
            model
                .rfind("</ForceSet>")
                .map(|p| model[..p].rfind("</objects>").unwrap())
        })
        .unwrap();
    std::fs::write(
        dir.join("model.osim"),
        format!("{}{}{}", &model[..pos], contacts, &model[pos..]),
    )
    .unwrap();
    let setup_text = std::fs::read_to_string(root.join("setup_SO.xml")).unwrap();
    let setup_text = setup_text
        .replace(
            "<model_file>inputs/subject01_simbody_adjusted.osim</model_file>",
            &format!(
                "<model_file>{}</model_file>",
                dir.join("model.osim").display()
            ),
        )
        .replace(">inputs/", &format!(">{}/inputs/", root.display()))
        .replace(" inputs/", &format!(" {}/inputs/", root.display()));
    let file = dir.join("setup.xml");
    std::fs::write(&file, setup_text).unwrap();
    Some(file)
}
