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

/// [`close_contacts`] as the state stream's row transform
/// (`motion::stream::RowTransform`): each row of the (filtered) table is
/// closed as it is streamed, with the same arithmetic as [`close_contacts`]
/// on the whole table. A coordinate the file lacks starts each row from the
/// row before's solution (its first row from its default value), so the
/// solutions of the current window are kept: a window starts within the
/// previous one and takes its first row's start from there.
pub struct StreamClosure<'m> {
    model: &'m Model,
    closures: Vec<(Contact, usize)>,
    /// Per closure: its coordinate is not in the file.
    continued: Vec<bool>,
    /// Per model coordinate: its column in a row's values and the factor
    /// to model units (`StateStream::carried_columns`).
    columns: Vec<Option<(usize, f64)>>,
    data: Data,
    q: Vec<f64>,
    /// Rows `base..` of the current window: each closure's value (file
    /// units), `closures.len()` per row.
    base: usize,
    solved: std::collections::VecDeque<f64>,
    context: String,
}

impl<'m> StreamClosure<'m> {
    /// `columns`: the stream's carried columns after the continued
    /// coordinates were added; `continued[k]`: closure k's coordinate is not
    /// in the file; `context` is prefixed to errors.
    pub fn new(
        model: &'m Model,
        closures: Vec<(Contact, usize)>,
        continued: Vec<bool>,
        columns: Vec<Option<(usize, f64)>>,
        context: String,
    ) -> Self {
        StreamClosure {
            model,
            closures,
            continued,
            columns,
            data: Data::new(model),
            q: vec![0.0; model.nq()],
            base: 0,
            solved: std::collections::VecDeque::new(),
            context,
        }
    }
}

impl crate::motion::stream::RowTransform for StreamClosure<'_> {
    fn begin_window(&mut self, first: usize) {
        // Keep the row before the window's first: its solution starts it.
        let drop =
            (first.saturating_sub(self.base + 1) * self.closures.len()).min(self.solved.len());
        self.solved.drain(..drop);
        self.base += drop / self.closures.len().max(1);
    }

    fn apply(&mut self, row: usize, t: f64, values: &mut [f64]) -> Result<()> {
        let model = self.model;
        for (c, col) in self.columns.iter().enumerate() {
            self.q[c] = match col {
                Some((j, scale)) => values[*j] * scale,
                None => model.coordinates[c].default_value,
            };
        }
        let n = self.closures.len();
        if self.solved.is_empty() {
            self.base = row;
        }
        // This row's place in `solved` (overwritten when a window gives it again).
        let at = match row.checked_sub(self.base) {
            Some(i) if i * n <= self.solved.len() => i * n,
            _ => {
                return Err(Error::internal(format!(
                    "closing contacts: row {row} out of order"
                )))
            }
        };
        for (k, (contact, c)) in self.closures.iter().enumerate() {
            let (j, scale) = self.columns[*c].expect("a closed coordinate has a column");
            if self.continued[k] && row > 0 {
                let prev = at
                    .checked_sub(n)
                    .and_then(|i| self.solved.get(i + k))
                    .ok_or_else(|| {
                        Error::internal(format!(
                            "closing contacts: row {row} came without the row before it"
                        ))
                    })?;
                self.q[*c] = prev * scale;
            }
            close_contact(model, &mut self.data, contact, *c, &mut self.q, t)
                .map_err(|e| e.context(self.context.clone()))?;
            values[j] = self.q[*c] / scale;
            match self.solved.get_mut(at + k) {
                Some(v) => *v = values[j],
                None => self.solved.push_back(values[j]),
            }
        }
        Ok(())
    }
}
