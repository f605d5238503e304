//! Closing contacts in a motion: a coordinate solved on every row so that a
//! point-on-plane contact's point lies on its plane — e.g. a machine's lever
//! angle following from the pad on the shin. Used by `statopt-tool motion
//! --touch` and by the AnalyzeTool property `<close_contacts>`.

use crate::contacts::Contact;
use crate::dynamics::{kinematics, Data};
use crate::error::{Error, Result};
use crate::model::{Model, MotionType};
use crate::motion::coordinates::column_for;
use crate::storage::Storage;

/// Signed distance of a contact's point from its plane at coordinates `q`
/// (model units).
pub fn contact_distance(model: &Model, data: &mut Data, c: &Contact, q: &[f64]) -> f64 {
    data.q.copy_from_slice(q);
    kinematics::positions(model, data);
    let p = data.station_position(c.point_body, &c.point);
    let o = data.station_position(c.plane_body, &c.origin);
    (p - o).dot(&(data.rotation[c.plane_body] * c.normal))
}

/// Newton's method on the distance as a function of coordinate `i`
/// (central-difference slope), from the value in `q`.
pub fn close_contact(
    model: &Model,
    data: &mut Data,
    c: &Contact,
    i: usize,
    q: &mut [f64],
    t: f64,
) -> Result<()> {
    let name = &model.coordinates[i].name;
    let h = 1e-7;
    for _ in 0..60 {
        let d = contact_distance(model, data, c, q);
        if d.abs() < 1e-12 {
            return Ok(());
        }
        let x = q[i];
        q[i] = x + h;
        let dp = contact_distance(model, data, c, q);
        q[i] = x - h;
        let dm = contact_distance(model, data, c, q);
        let slope = (dp - dm) / (2.0 * h);
        if slope.is_nan() || slope.abs() <= 1e-9 {
            q[i] = x;
            return Err(Error::msg(format!(
                "closing contact: at t = {t}, coordinate '{name}' does not move contact '{}' towards its plane (distance {d} m)",
                c.name
            )));
        }
        // Limit a step to 0.2 rad (or m) so Newton stays on its branch.
        q[i] = x - (d / slope).clamp(-0.2, 0.2);
    }
    Err(Error::msg(format!(
        "closing contact: at t = {t}, no value of '{name}' brings contact '{}' onto its plane",
        c.name
    )))
}

/// Solve, on every row of `table` (in the file's units), each coordinate of
/// `closures` so that its contact is closed. Columns missing from the table
/// are added (starting from the default value). Newton starts from the table's value.
pub fn close_contacts(
    model: &Model,
    table: &mut Storage,
    closures: &[(Contact, usize)],
) -> Result<()> {
    let deg =
        |c: usize| table.in_degrees && model.coordinates[c].motion_type == MotionType::Rotational;
    let scale = |c: usize| {
        if deg(c) {
            std::f64::consts::PI / 180.0
        } else {
            1.0
        }
    };
    // Coordinates the table lacks start each row from the previous row's
    // solution (the first from their default value): the closure follows
    // the motion continuously instead of jumping to another root (a lever
    // turned half a turn, its pad meeting the point from behind).
    let mut continued = vec![false; closures.len()];
    for (k, (_, c)) in closures.iter().enumerate() {
        if column_for(table, &model.coordinates[*c].name).is_none() {
            continued[k] = true;
            let v = model.coordinates[*c].default_value / scale(*c);
            table.labels.push(model.coordinates[*c].name.clone());
            table.rows.iter_mut().for_each(|r| r.push(v));
        }
    }
    let cols: Vec<Option<usize>> = model
        .coordinates
        .iter()
        .map(|c| column_for(table, &c.name))
        .collect();
    let mut data = Data::new(model);
    let mut q = vec![0.0; model.nq()];
    for i in 0..table.time.len() {
        for (c, col) in cols.iter().enumerate() {
            q[c] = match col {
                Some(j) => table.rows[i][*j] * scale(c),
                None => model.coordinates[c].default_value,
            };
        }
        let t = table.time[i];
        for (k, (contact, c)) in closures.iter().enumerate() {
            if continued[k] && i > 0 {
                q[*c] = table.rows[i - 1][cols[*c].unwrap_or(0)] * scale(*c);
            }
            close_contact(model, &mut data, contact, *c, &mut q, t)?;
            let j = cols[*c].unwrap_or(0);
            table.rows[i][j] = q[*c] / scale(*c);
        }
    }
    Ok(())
}
