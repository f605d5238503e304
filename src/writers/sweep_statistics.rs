//! The statistics of a contact-weight sweep: mean, minimum and maximum of
//! every column over the sweep's runs, frame by frame, as tables beside
//! the runs' own.

use crate::error::{Error, Result};
use crate::storage::StoWriter;

/// Mean, minimum and maximum over the runs of a sweep, per column and frame
/// (the paper's uncertainty band, section 3.2), from the runs' tables
/// `files`: a resumed sweep's, whose tables hold frames it does not solve
/// again. The tables are read row by row in step (memory does not grow with
/// the trial's length) and fed to a [`SweepStatistics`], the sink a pass
/// feeds from its frames. `stat_path` names the table of each statistic
/// (`writers::names`).
pub fn write_sweep_statistics(
    setup_file: &std::path::Path,
    files: &[std::path::PathBuf],
    stat_path: &dyn Fn(crate::writers::names::Stat) -> std::path::PathBuf,
    kind: &str,
    weights: &[f64],
    precision: usize,
) -> Result<Vec<std::path::PathBuf>> {
    let mut readers = files
        .iter()
        .map(|f| crate::storage::open_rows(f))
        .collect::<Result<Vec<_>>>()?;
    let labels = readers[0].table.labels.clone();
    for (r, f) in readers.iter().zip(files).skip(1) {
        if r.table.labels != labels {
            return Err(Error::internal(format!(
                "{}: its columns differ from {}'s",
                f.display(),
                files[0].display()
            )));
        }
    }
    let mut stats = SweepStatistics::new(setup_file, weights, 0, precision);
    let index = stats.add(Source::Given, kind, &labels, stat_path);
    let nl = labels.len();
    let mut rows = vec![Vec::with_capacity(nl); readers.len()];
    'frames: loop {
        let mut time = None;
        for (k, (r, buf)) in readers.iter_mut().zip(rows.iter_mut()).enumerate() {
            match (r.next_row(buf)?, k) {
                (None, 0) => break 'frames,
                (None, _) => {
                    return Err(Error::internal(format!(
                        "{}: fewer rows than {}",
                        files[k].display(),
                        files[0].display()
                    )))
                }
                (Some(t), 0) => time = Some(t),
                (Some(_), _) => {}
            }
        }
        let t = time.expect("the first table's row");
        stats.push_rows(index, t, rows.iter().map(|r| r.as_slice()))?;
    }
    Ok(stats.finish()?.into_iter().next().unwrap_or_default())
}

/// Which values of a frame's outputs one table of a sweep holds.
#[derive(Clone, Copy)]
pub enum Source {
    Activation,
    Force,
    ContactForces,
    ContactBodyForces,
    GeneralizedForcesBySource,
    MusclePower,
    /// The rows of the k-th joint reaction.
    Reaction(usize),
    /// Rows the caller computes and hands over ([`SweepStatistics::push_rows`]:
    /// the knee tables, `writers::knee_tables`).
    Given,
}

impl Source {
    fn row<'r>(
        &self,
        r: &'r crate::frame::problem::FrameResult,
        rows: &'r [Vec<f64>],
        n_controls: usize,
    ) -> &'r [f64] {
        match *self {
            Source::Activation => &r.solution.x[..n_controls],
            Source::Force => &r.force_row,
            Source::ContactForces => &r.contacts.contact,
            Source::ContactBodyForces => &r.contacts.bodies,
            Source::GeneralizedForcesBySource => &r.by_source,
            Source::MusclePower => &r.muscle_power,
            Source::Reaction(k) => &rows[k],
            Source::Given => &[],
        }
    }
}

/// The statistics of a contact-weight sweep as a sink of the frame stream
/// (`frame::so_loop`): each frame's outputs of every w0 arrive together,
/// and the mean, minimum and maximum of every column are written as they
/// do, taken of the values the runs' tables print
/// (`storage::results::as_printed`: what [`write_sweep_statistics`] reads
/// back from those tables, bit for bit, so the tables are the same). No
/// per-w0 table is kept or read for them. The tables are created with the
/// first frame (no file is touched before the pass solves one).
pub struct SweepStatistics {
    setup_file: std::path::PathBuf,
    weights: Vec<f64>,
    tables: Vec<StatTables>,
    n_controls: usize,
    precision: usize,
    /// Reused for each statistic's row.
    row: Vec<f64>,
    printed: Vec<Vec<f64>>,
}

struct StatTables {
    source: Source,
    kind: String,
    labels: Vec<String>,
    paths: Vec<std::path::PathBuf>,
    /// Mean, min, max (none before the first frame).
    writers: Vec<StoWriter>,
}

impl SweepStatistics {
    pub fn new(
        setup_file: &std::path::Path,
        weights: &[f64],
        n_controls: usize,
        precision: usize,
    ) -> SweepStatistics {
        SweepStatistics {
            setup_file: setup_file.to_path_buf(),
            weights: weights.to_vec(),
            tables: Vec::new(),
            n_controls,
            precision,
            row: Vec::new(),
            printed: Vec::new(),
        }
    }

    /// The mean, min and max tables of one kind of table: `kind` its name,
    /// `labels` its columns, `stat_path` the path of each statistic's table
    /// (`writers::names`). Returns the tables' index ([`Self::push_rows`]).
    pub fn add(
        &mut self,
        source: Source,
        kind: &str,
        labels: &[String],
        stat_path: &dyn Fn(crate::writers::names::Stat) -> std::path::PathBuf,
    ) -> usize {
        use crate::writers::names::Stat;
        self.tables.push(StatTables {
            source,
            kind: kind.to_string(),
            labels: labels.to_vec(),
            paths: Stat::ALL.iter().map(|&s| stat_path(s)).collect(),
            writers: Vec::new(),
        });
        self.tables.len() - 1
    }

    /// Create the tables (as [`write_sweep_statistics`] does).
    fn open(&mut self) -> Result<()> {
        use crate::writers::names::Stat;
        let weights = &self.weights;
        for t in self.tables.iter_mut().filter(|t| t.writers.is_empty()) {
            let kind = &t.kind;
            for (stat, path) in Stat::ALL.iter().zip(&t.paths) {
                let stat = stat.as_str();
                let desc = format!("{stat} over contact weights w0 = {weights:?} of the static optimization {kind} results.\n");
                let mut w = StoWriter::create_for_setup(
                    &self.setup_file,
                    path,
                    &format!("{kind} {stat}"),
                    &desc,
                    &t.labels,
                    self.precision,
                    false,
                )?;
                w.batch_rows(32, std::time::Duration::from_millis(200));
                t.writers.push(w);
            }
        }
        Ok(())
    }

    /// One frame's outputs, one per w0 in the sweep's order (the tables
    /// of [`Source::Given`] are fed by [`Self::push_rows`]).
    pub fn push(&mut self, results: &[crate::frame::so_loop::FrameOutput]) -> Result<()> {
        use crate::storage::results::as_printed;
        let Some((first, _)) = results.first() else {
            return Ok(());
        };
        if self.tables.first().is_some_and(|t| t.writers.is_empty()) {
            self.open()?;
        }
        let p = self.precision;
        let t = as_printed(first.time, p);
        let n = results.len();
        self.printed.resize_with(n, Vec::new);
        for table in &mut self.tables {
            if let Source::Given = table.source {
                continue;
            }
            for ((r, rows), printed) in results.iter().zip(self.printed.iter_mut()) {
                printed.clear();
                printed.extend(
                    table
                        .source
                        .row(r, rows, self.n_controls)
                        .iter()
                        .map(|&v| as_printed(v, p)),
                );
            }
            write_stats(table, &self.printed, t, &mut self.row)?;
        }
        Ok(())
    }

    /// One frame's rows of the tables `index` ([`Self::add`], of
    /// [`Source::Given`]), one per w0 in the sweep's order, at `time`:
    /// taken as their tables print them, as [`Self::push`] does.
    pub fn push_rows<'r>(
        &mut self,
        index: usize,
        time: f64,
        rows: impl Iterator<Item = &'r [f64]>,
    ) -> Result<()> {
        use crate::storage::results::as_printed;
        if self.tables[index].writers.is_empty() {
            self.open()?;
        }
        let p = self.precision;
        let mut n = 0;
        for row in rows {
            if self.printed.len() <= n {
                self.printed.push(Vec::new());
            }
            let printed = &mut self.printed[n];
            printed.clear();
            printed.extend(row.iter().map(|&v| as_printed(v, p)));
            n += 1;
        }
        write_stats(
            &mut self.tables[index],
            &self.printed[..n],
            as_printed(time, p),
            &mut self.row,
        )
    }

    /// The tables finished, their paths per kind in the order added.
    pub fn finish(mut self) -> Result<Vec<Vec<std::path::PathBuf>>> {
        self.open()?;
        let mut out = Vec::new();
        for t in self.tables {
            for w in t.writers {
                w.finish()?;
            }
            out.push(t.paths);
        }
        Ok(out)
    }

    /// A sweep stopped before its last frame has no statistics: the tables
    /// begun are removed.
    pub fn abandon(self) {
        for t in self.tables {
            let begun = !t.writers.is_empty();
            drop(t.writers);
            if begun {
                for p in t.paths {
                    if crate::storage::results::writes_file(&p) {
                        let _ = std::fs::remove_file(p);
                    }
                }
            }
        }
    }
}

/// The mean, min and max rows of one frame of `table` from the runs'
/// printed rows `printed`, at the printed time `t`.
fn write_stats(
    table: &mut StatTables,
    printed: &[Vec<f64>],
    t: f64,
    row: &mut Vec<f64>,
) -> Result<()> {
    use crate::writers::names::Stat;
    let n = printed.len();
    let nl = table.labels.len();
    for (stat, w) in Stat::ALL.iter().zip(table.writers.iter_mut()) {
        row.clear();
        for j in 0..nl {
            let vals = printed.iter().map(|r| r[j]);
            row.push(match *stat {
                Stat::Mean => vals.sum::<f64>() / n as f64,
                Stat::Min => vals.fold(f64::INFINITY, f64::min),
                Stat::Max => vals.fold(f64::NEG_INFINITY, f64::max),
            });
        }
        w.write_row(t, row)?;
    }
    Ok(())
}
