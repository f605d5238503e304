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

/// With several closures, one [`Chain`] over all of them: solved together,
/// so that closing one contact cannot reopen another (issue 35). A single
/// closure keeps [`close_contact`]'s Newton iteration.
fn chain_of(closures: &[(Contact, usize)]) -> Option<Chain> {
    if closures.len() < 2 {
        return None;
    }
    let mut chain = Chain {
        contacts: Vec::new(),
        anchors: Vec::new(),
        unknowns: Vec::new(),
    };
    for (c, i) in closures {
        if !chain.contacts.iter().any(|k| k.name == c.name) {
            chain.contacts.push(c.clone());
            chain.anchors.push(None);
        }
        if !chain.unknowns.contains(i) {
            chain.unknowns.push(*i);
        }
    }
    Some(chain)
}

/// Close a row's contacts from the values in `q`: the chain when there is
/// one, else each closure's Newton iteration.
fn close_row(
    model: &Model,
    data: &mut Data,
    closures: &[(Contact, usize)],
    chain: Option<&Chain>,
    q: &mut [f64],
    t: f64,
) -> Result<()> {
    match chain {
        Some(chain) => chain.solve(model, data, q, &|_: &mut [f64]| {}, t),
        None => {
            for (contact, c) in closures {
                close_contact(model, data, contact, *c, q, t)?;
            }
            Ok(())
        }
    }
}

/// Solve, on every row of `table` (in the file's units), each coordinate of
/// `closures` so that its contact is closed (several closures together, as
/// one [`Chain`]). Columns missing from the table
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
    let chain = chain_of(closures);
    for i in 0..table.time.len() {
        for (c, col) in cols.iter().enumerate() {
            q[c] = match col {
                Some(j) => table.rows[i][*j] * scale(c),
                None => model.coordinates[c].default_value,
            };
        }
        let t = table.time[i];
        for (k, (_, c)) in closures.iter().enumerate() {
            if continued[k] && i > 0 {
                q[*c] = table.rows[i - 1][cols[*c].unwrap_or(0)] * scale(*c);
            }
        }
        close_row(model, &mut data, closures, chain.as_ref(), &mut q, t)?;
        for (_, c) in closures {
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
    /// Several closures: solved together ([`chain_of`]).
    chain: Option<Chain>,
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
            chain: chain_of(&closures),
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
        for (k, (_, c)) in self.closures.iter().enumerate() {
            let (_, scale) = self.columns[*c].expect("a closed coordinate has a column");
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
        }
        close_row(
            model,
            &mut self.data,
            &self.closures,
            self.chain.as_ref(),
            &mut self.q,
            t,
        )
        .map_err(|e| e.context(self.context.clone()))?;
        for (k, (_, c)) in self.closures.iter().enumerate() {
            let (j, scale) = self.columns[*c].expect("a closed coordinate has a column");
            values[j] = self.q[*c] / scale;
            match self.solved.get_mut(at + k) {
                Some(v) => *v = values[j],
                None => self.solved.push_back(values[j]),
            }
        }
        Ok(())
    }
}

/// A closed chain solved as one system: every contact's point on its plane
/// (distance 0) and, for a planted contact, its point held at an in-plane
/// position on the plane body (along the contact's body-fixed axes e1, e2),
/// by changing the `unknowns` coordinates together (`statopt-tool motion
/// --touch/--plant`).
#[derive(Debug, Clone)]
pub struct Chain {
    pub contacts: Vec<Contact>,
    /// Per contact: its in-plane position (m, along e1 and e2 from the
    /// plane's origin, in the plane body) is held at this value.
    pub anchors: Vec<Option<[f64; 2]>>,
    /// The coordinates solved (indices into the model's coordinates).
    pub unknowns: Vec<usize>,
}

/// The tolerance every closed row is held to (m): distance and in-plane
/// drift of every contact of a [`Chain`].
pub const CHAIN_TOLERANCE: f64 = 1e-9;

/// Which quantity a residual of a [`Chain`] is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ResidualKind {
    /// The distance of the contact's point from its plane.
    Distance,
    /// The in-plane drift along the contact's axis e1 or e2 (1 or 2).
    Drift(u8),
}

/// The worst residual of a row: which contact, what, how much (m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Worst {
    pub contact: usize,
    pub kind: ResidualKind,
    pub value: f64,
}

impl Chain {
    /// The number of residuals (a distance per contact, two per anchor).
    pub fn residual_count(&self) -> usize {
        self.contacts.len() + 2 * self.anchors.iter().filter(|a| a.is_some()).count()
    }

    /// The in-plane position (along e1, e2 in the plane body) of contact
    /// `k`'s point at the current positions of `data`.
    pub fn in_plane(&self, data: &Data, k: usize) -> [f64; 2] {
        let rel = self.relative(data, k);
        let c = &self.contacts[k];
        [rel.dot(&c.e1), rel.dot(&c.e2)]
    }

    /// Contact k's point relative to its plane's origin, in the plane body.
    fn relative(&self, data: &Data, k: usize) -> nalgebra::Vector3<f64> {
        let c = &self.contacts[k];
        let p = data.station_position(c.point_body, &c.point);
        let o = data.station_position(c.plane_body, &c.origin);
        data.rotation[c.plane_body].transpose() * (p - o)
    }

    /// Positions at `q` (after `prepare`, which sets the coordinates that
    /// follow others, e.g. coupler dependents), then the residuals into
    /// `out` (resized), each with its contact and kind.
    pub fn residuals(
        &self,
        model: &Model,
        data: &mut Data,
        q: &mut [f64],
        prepare: &dyn Fn(&mut [f64]),
        out: &mut Vec<(usize, ResidualKind, f64)>,
    ) {
        prepare(q);
        data.q.copy_from_slice(q);
        kinematics::positions(model, data);
        out.clear();
        for (k, c) in self.contacts.iter().enumerate() {
            let rel = self.relative(data, k);
            out.push((k, ResidualKind::Distance, rel.dot(&c.normal)));
            if let Some(a) = self.anchors[k] {
                out.push((k, ResidualKind::Drift(1), rel.dot(&c.e1) - a[0]));
                out.push((k, ResidualKind::Drift(2), rel.dot(&c.e2) - a[1]));
            }
        }
    }

    /// The largest residual at `q` (see [`Chain::residuals`]).
    pub fn worst(
        &self,
        model: &Model,
        data: &mut Data,
        q: &mut [f64],
        prepare: &dyn Fn(&mut [f64]),
    ) -> Option<Worst> {
        let mut r = Vec::new();
        self.residuals(model, data, q, prepare, &mut r);
        r.iter()
            .max_by(|a, b| a.2.abs().total_cmp(&b.2.abs()))
            .map(|&(contact, kind, value)| Worst {
                contact,
                kind,
                value,
            })
    }

    /// Say a residual: "contact 'heel' is 2e-3 m from its plane".
    pub fn describe(&self, w: &Worst) -> String {
        let name = &self.contacts[w.contact].name;
        match w.kind {
            ResidualKind::Distance => {
                format!("contact '{name}' is {:e} m from its plane", w.value)
            }
            ResidualKind::Drift(a) => format!(
                "contact '{name}' has moved {:e} m along its plane's axis e{a} from where it was planted",
                w.value
            ),
        }
    }

    /// Solve the chain at one row: Gauss–Newton on all residuals together
    /// over all unknowns, from the values in `q`, with a central-difference
    /// Jacobian (step 1e-7) and each step the minimum-norm least-squares
    /// solution (nalgebra's SVD), so that with fewer residuals than
    /// unknowns the coordinates move as little as they must from where
    /// they start (rad and m weighed alike), and with more the system is
    /// solved when it is consistent (e.g. a planar model's out-of-plane
    /// drift, zero whatever the coordinates). Steps are limited to 0.2
    /// (rad or m) so that the solution nearest the start is followed.
    /// Stops when every residual is below 1e-12 m or no step reduces them;
    /// an error (naming the row's time `t`, the contact and its residual)
    /// unless every residual is within [`CHAIN_TOLERANCE`].
    pub fn solve(
        &self,
        model: &Model,
        data: &mut Data,
        q: &mut [f64],
        prepare: &dyn Fn(&mut [f64]),
        t: f64,
    ) -> Result<()> {
        let n = self.unknowns.len();
        let mut r = Vec::new();
        let (mut rp, mut rm) = (Vec::new(), Vec::new());
        let h = 1e-7;
        let norm = |r: &[(usize, ResidualKind, f64)]| r.iter().map(|x| x.2 * x.2).sum::<f64>();
        for _ in 0..100 {
            self.residuals(model, data, q, prepare, &mut r);
            let m = r.len();
            if m == 0 || r.iter().all(|x| x.2.abs() < 1e-12) || n == 0 {
                break;
            }
            let mut jac = nalgebra::DMatrix::<f64>::zeros(m, n);
            for (j, &i) in self.unknowns.iter().enumerate() {
                let x = q[i];
                q[i] = x + h;
                self.residuals(model, data, q, prepare, &mut rp);
                q[i] = x - h;
                self.residuals(model, data, q, prepare, &mut rm);
                q[i] = x;
                for k in 0..m {
                    jac[(k, j)] = (rp[k].2 - rm[k].2) / (2.0 * h);
                }
            }
            let rhs = nalgebra::DVector::from_iterator(m, r.iter().map(|x| -x.2));
            let svd = jac.svd(true, true);
            let cut = 1e-10 * svd.singular_values.max();
            let Ok(mut step) = svd.solve(&rhs, cut) else {
                break;
            };
            if !step.iter().all(|s| s.is_finite()) || step.amax() == 0.0 {
                break;
            }
            let big = step.amax();
            if big > 0.2 {
                step *= 0.2 / big;
            }
            // Keep a step only if it reduces the residuals (halving it up
            // to 30 times): near a least-squares minimum that does not
            // close, this ends the iteration instead of cycling.
            let before = norm(&r);
            let start: Vec<f64> = self.unknowns.iter().map(|&i| q[i]).collect();
            let mut accepted = false;
            for _ in 0..30 {
                for (j, &i) in self.unknowns.iter().enumerate() {
                    q[i] = start[j] + step[j];
                }
                self.residuals(model, data, q, prepare, &mut rp);
                if norm(&rp) < before {
                    accepted = true;
                    break;
                }
                step *= 0.5;
            }
            if !accepted {
                for (j, &i) in self.unknowns.iter().enumerate() {
                    q[i] = start[j];
                }
                break;
            }
        }
        match self.worst(model, data, q, prepare) {
            Some(w) if !(w.value.abs() <= CHAIN_TOLERANCE) => {
                let names: Vec<&str> = self
                    .unknowns
                    .iter()
                    .map(|&i| model.coordinates[i].name.as_str())
                    .collect();
                Err(Error::msg(format!(
                    "closing contacts: at t = {t}, {} (tolerance {CHAIN_TOLERANCE:e} m); the chain has {} residual(s) (a distance per contact, two in-plane per planted contact) and {} unknown coordinate(s): {}",
                    self.describe(&w),
                    self.residual_count(),
                    n,
                    if names.is_empty() { "none".to_string() } else { names.join(", ") }
                )))
            }
            _ => Ok(()),
        }
    }
}
