//! What a static-optimization run reports besides its tables: the frames
//! the optimiser could not solve, the worst equation residual of a solved
//! frame, activations at their upper bound, what reserve actuators and the
//! root joint's residual actuators carried at most, and the last frame
//! written. Gathered frame by frame, in frame order, by the table writer;
//! turned into the run's warnings at its end.

use crate::frame::problem::{FrameResult, SoProblem, CONTACT_COLUMNS};
use crate::writers::contact_findings::{contacts_at_limits, ContactFinding, ContactTally};

/// Root residual force, as a share of body weight, above which a run warns.
pub const ROOT_RESIDUAL_WARNING: f64 = 0.05;

/// A run's statistics so far (see the module documentation).
pub struct RunStatistics {
    /// One line per unsolved frame: time, status, equation residual.
    pub failures: Vec<String>,
    /// Largest equation residual of a solved frame (N or N·m).
    pub worst_residual: f64,
    /// Reserve actuators' variables, and the largest force one carried
    /// (N or N·m) with where.
    reserve_vars: Vec<usize>,
    reserve_peak: (f64, String),
    /// Rows of the root joint's coordinates (a joint on ground with three
    /// or more coordinates: a person's pelvis, not a machine's lever), with
    /// whether they translate, their names, and what residual actuators
    /// supplied there at most: force (N), moment (N·m), with where.
    root_rows: Vec<(usize, bool)>,
    root_names: Vec<String>,
    pub root_peaks: [Option<(f64, String)>; 2],
    /// Per frame: time and the size of the summed force (N) non-muscle
    /// actuators (residuals, reserves) apply on the root joint's
    /// translations (empty without a root joint).
    pub root_force_series: Vec<(f64, f64)>,
    /// Controls at their upper bound: name, frames, first time.
    at_bound: Vec<(String, usize, f64)>,
    /// Time of the last frame observed.
    pub last: Option<f64>,
    /// Frames observed (a resumed run's kept frames included).
    pub frames: usize,
    /// What the contacts did (writers::contact_findings).
    contacts: ContactTally,
}

impl RunStatistics {
    pub fn new(problem: &SoProblem) -> RunStatistics {
        let reserve_vars: Vec<usize> = problem
            .labels
            .iter()
            .enumerate()
            .filter(|(_, l)| problem.options.reserve_actuators.is_some() && l.ends_with("_reserve"))
            .map(|(i, _)| i)
            .collect();
        let root_rows: Vec<(usize, bool)> = problem
            .rows
            .iter()
            .enumerate()
            .filter(|(_, &c)| problem.model.is_root_coordinate(c))
            .map(|(k, &c)| {
                (
                    k,
                    problem.model.coordinates[c].motion_type
                        == crate::model::MotionType::Translational,
                )
            })
            .collect();
        let root_names: Vec<String> = root_rows
            .iter()
            .map(|&(k, _)| problem.model.coordinates[problem.rows[k]].name.clone())
            .collect();
        RunStatistics {
            failures: Vec::new(),
            worst_residual: 0.0,
            reserve_vars,
            reserve_peak: (0.0, String::new()),
            root_rows,
            root_names,
            root_peaks: [None, None],
            root_force_series: Vec::new(),
            at_bound: Vec::new(),
            last: None,
            frames: 0,
            contacts: ContactTally::new(problem),
        }
    }

    /// Take in one frame's result (frames in order).
    pub fn observe(&mut self, problem: &SoProblem, r: &FrameResult) {
        let failed = (!r.solution.status.is_ok()).then(|| format!("{:?}", r.solution.status));
        self.observe_values(
            problem,
            r.time,
            failed,
            r.solution.eq_residual,
            &r.solution.x,
            |v| r.forces[v],
            &r.by_source,
            &r.contacts.contact,
        );
    }

    /// Take in one frame: its time, why it failed (None: solved), its
    /// equation residual, controls `x`, each control's force, the
    /// generalized forces by source (4 per row of the problem) and the
    /// contacts' row of the ContactForces table.
    #[allow(clippy::too_many_arguments)]
    fn observe_values(
        &mut self,
        problem: &SoProblem,
        time: f64,
        failed: Option<String>,
        eq_residual: f64,
        x: &[f64],
        force: impl Fn(usize) -> f64,
        by_source: &[f64],
        contacts: &[f64],
    ) {
        let at = crate::storage::fmt_time(time);
        self.frames += 1;
        self.contacts.observe(time, contacts, by_source);
        if let Some(status) = failed {
            self.failures.push(format!(
                "t={at}: {status}, equation residual {eq_residual:.3e}{}",
                unsolved_detail(problem, by_source, contacts)
            ));
        } else {
            self.worst_residual = self.worst_residual.max(eq_residual);
        }
        let mut root_force2 = 0.0;
        for (k, &(row, translational)) in self.root_rows.iter().enumerate() {
            // by_source holds, per row: required, muscles, actuators, contacts.
            let v = by_source[4 * row + 2].abs();
            if translational {
                root_force2 += v * v;
            }
            let peak = &mut self.root_peaks[usize::from(!translational)];
            if v > peak.as_ref().map_or(0.0, |p| p.0) {
                *peak = Some((v, format!("{} at t={at}", self.root_names[k])));
            }
        }
        if self.root_rows.iter().any(|r| r.1) {
            self.root_force_series.push((time, root_force2.sqrt()));
        }
        let nv = problem.controls.len();
        for v in 0..nv {
            let up = problem.upper[v];
            if up.is_finite() && x[v] >= up - 1e-6 {
                match self
                    .at_bound
                    .iter_mut()
                    .find(|(n, _, _)| *n == problem.labels[v])
                {
                    Some(e) => e.1 += 1,
                    None => self.at_bound.push((problem.labels[v].clone(), 1, time)),
                }
            }
        }
        for &v in &self.reserve_vars {
            let f = force(v).abs();
            if f > self.reserve_peak.0 {
                self.reserve_peak = (f, format!("{} at t={at}", problem.labels[v]));
            }
        }
        self.last = Some(time);
    }

    /// Take in the first `keep` frames of the tables of run `run` (in
    /// `dir`) as written: a resumed run's summary then covers the whole run, the frames an earlier run wrote included (values as
    /// the tables hold them, rounded to their precision).
    pub fn observe_tables(
        &mut self,
        problem: &SoProblem,
        dir: &std::path::Path,
        run: &crate::writers::names::RunKey,
        keep: usize,
    ) -> crate::error::Result<()> {
        use crate::error::{Error, Location};
        use crate::writers::names::OutputKind;
        let read = |kind: OutputKind| crate::storage::read(&dir.join(run.file(kind)));
        let act = read(OutputKind::Activation)?;
        let force = read(OutputKind::Force)?;
        let diag = read(OutputKind::Diagnostics)?;
        let src = read(OutputKind::GeneralizedForcesBySource)?;
        let column = |t: &crate::storage::Storage, label: &str, kind: OutputKind| {
            t.column_index(label).ok_or_else(|| {
                Error::input(
                    Location::file(dir.join(run.file(kind))),
                    format!("the table to resume lacks its column '{label}'"),
                )
            })
        };
        let status = column(&diag, "status", OutputKind::Diagnostics)?;
        let residual = column(&diag, "equation_residual", OutputKind::Diagnostics)?;
        let force_cols: Vec<Option<usize>> = problem
            .labels
            .iter()
            .map(|l| force.column_index(l))
            .collect();
        // The contacts' columns, in the table's own order of the run's.
        let contact = if problem.contacts.is_empty() {
            None
        } else {
            let table = read(OutputKind::ContactForces)?;
            let cols = problem
                .contact_labels()
                .iter()
                .map(|l| column(&table, l, OutputKind::ContactForces))
                .collect::<crate::error::Result<Vec<usize>>>()?;
            Some((table, cols))
        };
        let mut contact_row = Vec::new();
        let rows = keep
            .min(act.rows.len())
            .min(force.rows.len())
            .min(diag.rows.len())
            .min(src.rows.len())
            .min(contact.as_ref().map_or(usize::MAX, |(t, _)| t.rows.len()));
        for i in 0..rows {
            let d = &diag.rows[i];
            let failed = (d[status] < 0.0).then(|| "failed (status -1)".to_string());
            let f = &force.rows[i];
            contact_row.clear();
            if let Some((t, cols)) = &contact {
                contact_row.extend(cols.iter().map(|&j| t.rows[i][j]));
            }
            self.observe_values(
                problem,
                diag.time[i],
                failed,
                d[residual],
                &act.rows[i],
                |v| force_cols[v].map_or(0.0, |j| f[j]),
                &src.rows[i],
                &contact_row,
            );
        }
        Ok(())
    }

    /// What reserve actuators carried at most, and where (None: the run
    /// has none).
    pub fn reserve_peak(&self) -> Option<(f64, String)> {
        (!self.reserve_vars.is_empty()).then(|| self.reserve_peak.clone())
    }

    /// The weight (N) of what the root joint carries, the body weight the
    /// residual forces are compared with (None: no root joint).
    pub fn root_body_weight(&self, problem: &SoProblem) -> Option<f64> {
        self.root_rows.first().map(|&(k, _)| {
            let body = problem.model.coordinates[problem.rows[k]].body;
            problem.model.subtree_mass(body) * problem.model.gravity.norm()
        })
    }

    /// What the run's contacts did that its user must be told
    /// (writers::contact_findings): contacts that slid or went more than
    /// 1 mm into their plane while loaded, contacts that carried nothing.
    pub fn contact_findings(&self, problem: &SoProblem) -> Vec<ContactFinding> {
        self.contacts.findings(problem)
    }

    /// The run's warnings: unsolved frames (of `nframes`; their
    /// diagnostics in `diagnostics`), activations at their upper bound,
    /// root residual forces above [`ROOT_RESIDUAL_WARNING`] of body weight.
    pub fn warnings(
        &self,
        problem: &SoProblem,
        nframes: usize,
        diagnostics: &std::path::Path,
    ) -> Vec<String> {
        let mut warnings = Vec::new();
        if !self.failures.is_empty() {
            warnings.push(format!(
                "static optimization failed on {} of {} frames (first: {}); their rows hold the solver's best point, see {}",
                self.failures.len(),
                nframes,
                self.failures[0],
                diagnostics.display()
            ));
        }
        if !self.at_bound.is_empty() {
            let list: Vec<String> = self
                .at_bound
                .iter()
                .map(|(n, k, t)| {
                    format!(
                        "{n} ({k} frames, first at t={})",
                        crate::storage::fmt_time(*t)
                    )
                })
                .collect();
            warnings.push(format!(
                "activations at their upper bound: {}",
                list.join(", ")
            ));
        }
        // Residual forces on the root above a few % of body weight mean the
        // motion and the model's forces do not balance: say so.
        if let (Some(bw), Some((f, at))) = (self.root_body_weight(problem), &self.root_peaks[0]) {
            if bw > 0.0 && *f > ROOT_RESIDUAL_WARNING * bw {
                warnings.push(format!(
                    "residual actuators on the root joint carried up to {f:.1} N = {:.1} % of body weight ({at}; more than {:.0} %): the motion and the model's forces do not balance there, so muscle and contact forces near those frames are doubtful",
                    100.0 * f / bw,
                    100.0 * ROOT_RESIDUAL_WARNING
                ));
            }
        }
        warnings.extend(
            self.contact_findings(problem)
                .into_iter()
                .map(|f| f.message),
        );
        warnings
    }
}

/// What an unsolved frame's line adds to its equation residual: the
/// coordinates whose equations were furthest from balanced (the three
/// largest |b − A x| of the frame's rows, at least 1e-3 of the largest,
/// from its generalized forces by
/// source: required − muscles − actuators − contacts), and the contacts
/// at a limit of their friction model.
fn unsolved_detail(problem: &SoProblem, by_source: &[f64], contacts: &[f64]) -> String {
    let mut rows: Vec<(f64, usize)> = by_source
        .chunks_exact(4)
        .enumerate()
        .map(|(k, s)| (s[0] - s[1] - s[2] - s[3], k))
        .filter(|(r, _)| *r != 0.0)
        .collect();
    rows.sort_by(|a, b| b.0.abs().total_cmp(&a.0.abs()));
    // Rows a thousand times below the largest are rounding, not the reason.
    let largest = rows.first().map_or(0.0, |r| r.0.abs());
    rows.retain(|r| r.0.abs() >= 1e-3 * largest);
    let mut out = String::new();
    if !rows.is_empty() {
        let list: Vec<String> = rows
            .iter()
            .take(3)
            .map(|&(r, k)| {
                let c = &problem.model.coordinates[problem.rows[k]];
                let unit = match c.motion_type {
                    crate::model::MotionType::Translational => "N",
                    crate::model::MotionType::Rotational => "N m",
                    crate::model::MotionType::Coupled => "N or N m",
                };
                format!("{} {r:.3e} {unit}", c.name)
            })
            .collect();
        out.push_str(&format!(
            "; unbalanced (required − supplied generalized force): {}",
            list.join(", ")
        ));
    }
    if contacts.len() == CONTACT_COLUMNS.len() * problem.contacts.len() {
        let at = contacts_at_limits(problem, contacts);
        if !at.is_empty() {
            out.push_str(&format!("; contacts at a limit: {}", at.join(", ")));
        }
    }
    out
}
