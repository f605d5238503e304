//! The knee contact method's table, `<name>_KneeContact.sto` (per knee:
//! flexion, total, medial and lateral force), and the reactions it is made
//! from: written by static optimization and force sweeps as well as by the
//! `knee-contact` subcommand (`tools::knee_contact`, which documents the
//! columns), so that they need not import the subcommand.

use std::path::{Path, PathBuf};

use crate::dynamics::{kinematics, Data};
use crate::error::{Error, Result};
use crate::frame::knee_contact::{compartments, Knee};
use crate::model::Model;
use crate::reactions::knee_loads::flexion_degrees;
use crate::storage::{self, StoWriter};

pub use crate::reactions::knee_contact::{labels, reaction_specs, REACTIONS_NAME};

pub use crate::writers::knee_tables::CONTACT_DESCRIPTION as DESCRIPTION;

/// Write `out` from the knees' reaction table `reactions` (from
/// [`reaction_specs`]), knee angles from the positions `q` at `time` at the
/// table's times.
#[allow(clippy::too_many_arguments)]
pub fn write(
    model: &Model,
    knees: &[Knee],
    time: &[f64],
    q: &[Vec<f64>],
    reactions: &Path,
    out: &Path,
    setup_file: &Path,
    precision: usize,
) -> Result<PathBuf> {
    let table = storage::read(reactions)?;
    let specs = reaction_specs(model, knees);
    let cols: Vec<[usize; 3]> = specs
        .iter()
        .map(|s| {
            let c = |x: &str| {
                table
                    .column_index(&format!("{}_{x}", s.label_root))
                    .ok_or_else(|| {
                        Error::msg(format!(
                            "{}: no column {}_{x}",
                            reactions.display(),
                            s.label_root
                        ))
                    })
            };
            Ok([c("fx")?, c("fy")?, c("fz")?])
        })
        .collect::<Result<_>>()?;
    let mx: Vec<usize> = specs
        .iter()
        .map(|s| {
            table
                .column_index(&format!("{}_mx", s.label_root))
                .ok_or_else(|| Error::msg(format!("{}: no mx column", reactions.display())))
        })
        .collect::<Result<_>>()?;
    let mut w = StoWriter::create_for_setup(
        setup_file,
        out,
        "Knee contact",
        DESCRIPTION,
        &labels(knees),
        precision,
        false,
    )?;
    let mut data = Data::new(model);
    let mut row = Vec::with_capacity(4 * knees.len());
    for (i, &t) in table.time.iter().enumerate() {
        let k = crate::motion::coordinates::find_index(time, t);
        data.q.copy_from_slice(&q[k]);
        data.u.iter_mut().for_each(|x| *x = 0.0);
        kinematics::full(model, &mut data);
        row.clear();
        let r = &table.rows[i];
        for ((knee, [x, y, z]), &m) in knees.iter().zip(&cols).zip(&mx) {
            let (med, lat) = compartments(knee, r[*y], r[m]);
            row.push(flexion_degrees(&data, knee.femur, knee.tibia));
            row.push((r[*x] * r[*x] + r[*y] * r[*y] + r[*z] * r[*z]).sqrt());
            row.push(med);
            row.push(lat);
        }
        w.write_row(t, &row)?;
    }
    w.finish()?;
    Ok(out.to_path_buf())
}
