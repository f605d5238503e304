//! Knee loads from a frame's joint reactions (issue 15), the rows of
//! `<reaction table prefix>KneeLoads.sto` (written by
//! `writers::knee_tables` as the frames stream; `tools::knee_loads`
//! documents the frame and signs): per side, the knee flexion angle,
//! tibiofemoral compression and shear, and patellofemoral compression.

use std::path::Path;

use nalgebra::Vector3;

use crate::dynamics::Data;
use crate::error::{Error, Result};
use crate::model::Model;
use crate::storage;

/// Column labels of the table, per side r then l; `pf_compression_<s>`
/// only with a patella.
pub fn labels(patella: bool) -> Vec<String> {
    let mut cols = vec!["knee_flexion", "tf_compression", "tf_shear"];
    if patella {
        cols.push("pf_compression");
    }
    ['r', 'l']
        .iter()
        .flat_map(|s| cols.iter().map(move |c| format!("{c}_{s}")))
        .collect()
}

pub struct Side {
    femur: usize,
    tibia: usize,
    /// Columns fx, fy of the knee reaction on the tibia in the tibia frame.
    tf: [usize; 2],
    /// Columns fx, fy, fz of the patellofemoral reaction on the patella.
    pf: Option<[usize; 3]>,
}

fn side_columns(model: &Model, table: &storage::Storage, path: &Path, s: char) -> Result<Side> {
    let body = |name: &str| {
        model.body_index(name).ok_or_else(|| {
            Error::msg(format!(
                "knee loads: the model has no body {name} (they are reported for models with femur_<s>, tibia_<s> and optionally patella_<s> bodies, as gait2392 and Rajagopal have)"
            ))
        })
    };
    let (femur, tibia) = (body(&format!("femur_{s}"))?, body(&format!("tibia_{s}"))?);
    let knee = &model.joints[tibia].name;
    let tibia_name = &model.bodies[tibia].name;
    let root = format!("{knee}_on_{tibia_name}_in_{tibia_name}");
    let col = |suffix: &str| table.column_index(&format!("{root}_{suffix}"));
    let (Some(fx), Some(fy)) = (col("fx"), col("fy")) else {
        return Err(Error::msg(format!(
            "knee loads: {} has no columns {root}_fx/_fy: the JointReaction must report joint {knee} on its child ({tibia_name}) in the child's frame (apply_on_bodies child, express_in_frame child)",
            path.display()
        )));
    };
    let pf = match model.body_index(&format!("patella_{s}")) {
        None => None,
        Some(p) => {
            let joint = &model.joints[p].name;
            let prefix = format!("{joint}_on_{}_in_", model.bodies[p].name);
            let fx = table
                .labels
                .iter()
                .position(|l| l.starts_with(&prefix) && l.ends_with("_fx"))
                .ok_or_else(|| {
                    Error::msg(format!(
                        "knee loads: {} has no reaction of {joint} on {}: add {joint} to the JointReaction's joint_names with apply_on_bodies child",
                        path.display(),
                        model.bodies[p].name
                    ))
                })?;
            let stem = &table.labels[fx][..table.labels[fx].len() - 3];
            let c = |suffix: &str| {
                table
                    .column_index(&format!("{stem}_{suffix}"))
                    .ok_or_else(|| {
                        Error::msg(format!(
                            "knee loads: {} lacks {stem}_{suffix}",
                            path.display()
                        ))
                    })
            };
            Some([fx, c("fy")?, c("fz")?])
        }
    };
    Ok(Side {
        femur,
        tibia,
        tf: [fx, fy],
        pf,
    })
}

/// Knee flexion (degrees, flexion positive) from the femur's and the
/// tibia's rotations: the angle from the femur's long axis to the tibia's,
/// about the femur's z axis, with the sign of flexion (the tibia's long axis
/// turning towards the femur's anterior x axis).
pub fn flexion_degrees(data: &Data, femur: usize, tibia: usize) -> f64 {
    let rf = data.rotation[femur];
    let yt = rf.transpose() * (data.rotation[tibia] * Vector3::y());
    // In the femur frame: straight leg yt = +y; flexion turns it towards +x.
    yt.x.atan2(yt.y).to_degrees()
}

/// Both sides' columns in a reaction table (`table`'s labels; `path` names
/// it in errors), and whether both have a patella.
pub fn sides(model: &Model, table: &storage::Storage, path: &Path) -> Result<([Side; 2], bool)> {
    let sides = [
        side_columns(model, table, path, 'r')?,
        side_columns(model, table, path, 'l')?,
    ];
    let patella = sides[0].pf.is_some() && sides[1].pf.is_some();
    Ok((sides, patella))
}

/// One row of the table (into `row`, cleared) from a frame's reaction row
/// `r`, `data` at the frame's positions.
pub fn knee_row(data: &Data, sides: &[Side; 2], patella: bool, r: &[f64], row: &mut Vec<f64>) {
    row.clear();
    for s in sides {
        row.push(flexion_degrees(data, s.femur, s.tibia));
        row.push(-r[s.tf[1]]);
        row.push(r[s.tf[0]]);
        if patella {
            if let Some([x, y, z]) = s.pf {
                row.push((r[x] * r[x] + r[y] * r[y] + r[z] * r[z]).sqrt());
            }
        }
    }
}
