//! The knee contact method's reactions (each knee's reaction on its
//! tibia) and the rows of its table, `<name>_KneeContact.sto` (per knee:
//! flexion, total, medial and lateral force; written by
//! `writers::knee_tables` as the frames stream).

use crate::dynamics::Data;
use crate::frame::knee_contact::{compartments, Knee};
use crate::model::{Model, Transform};
use crate::reactions::knee_loads::flexion_degrees;
use crate::reactions::ReactionSpec;

/// The name of the reactions the method reports (`<name>_KneeContact_ReactionLoads.sto`).
pub const REACTIONS_NAME: &str = "KneeContact";

/// Each knee's reaction on its tibia, in the tibia's body frame, at the joint centre.
pub fn reaction_specs(model: &Model, knees: &[Knee]) -> Vec<ReactionSpec> {
    knees
        .iter()
        .map(|k| {
            let tibia = &model.bodies[k.tibia].name;
            ReactionSpec {
                joint: k.tibia,
                on_child: true,
                frame_body: k.tibia,
                frame: Transform::identity(),
                label_root: format!("{}_on_{tibia}_in_{tibia}", k.name),
            }
        })
        .collect()
}

/// Column labels of `<name>_KneeContact.sto`.
pub fn labels(knees: &[Knee]) -> Vec<String> {
    knees
        .iter()
        .flat_map(|k| {
            ["flexion_deg", "total_N", "medial_N", "lateral_N"].map(|c| format!("{}_{c}", k.name))
        })
        .collect()
}

/// One row of the table (into `row`, cleared) from the reactions of
/// [`reaction_specs`] at a frame (`reactions`: 9 values per knee, in the
/// order of `ReactionSpec`'s columns), `data` at the frame's positions.
pub fn row_into(data: &Data, knees: &[Knee], reactions: &[f64], row: &mut Vec<f64>) {
    row.clear();
    for (ki, knee) in knees.iter().enumerate() {
        let r = &reactions[9 * ki..9 * ki + 9];
        let (med, lat) = compartments(knee, r[1], r[3]);
        row.push(flexion_degrees(data, knee.femur, knee.tibia));
        row.push((r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt());
        row.push(med);
        row.push(lat);
    }
}
