//! A setup's or a study's `<Figure>`s and `<Metric>`s drawn and computed
//! from the tables its runs wrote (`plan::figures` values): the helpers the
//! study runner, the AnalyzeTool dispatcher and force sweeps share, so that
//! none of them imports another to draw (`tools::study` documents the
//! elements). Also the check that a setup's figures name tables it writes.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use crate::error::{Error, Location, Result};
use crate::parse::setup::{resolve, AnalyzeSetup};
use crate::plan::figures::{
    self, FigureOrMetric, FigureSpec, MetricSpec, PanelSpec, SeriesData, SeriesSpec,
};
use crate::plots::{self, Chart, Layout, Series, Style};
use crate::storage::{self, Storage};

pub use crate::metrics::series::metric_value;

/// Where figure and metric references point when a study moves its runs'
/// outputs (`-o DIR`): the referenced path (resolved and normalised) and
/// where the run writes that table.
pub type Moved = HashMap<PathBuf, PathBuf>;

/// The tables figures and metrics read (paths relative to `dir`, moved as
/// `moved` says), each read once however many curves and metrics use it.
struct Tables<'a> {
    dir: &'a Path,
    moved: &'a Moved,
    read: std::sync::Mutex<HashMap<PathBuf, std::sync::Arc<Storage>>>,
}

impl<'a> Tables<'a> {
    fn new(dir: &'a Path, moved: &'a Moved) -> Self {
        Tables {
            dir,
            moved,
            read: Default::default(),
        }
    }

    /// Where the table a reference names is.
    fn path(&self, file: &str) -> PathBuf {
        let path = resolve(self.dir, file);
        match self.moved.get(&normalise(&path)) {
            Some(m) => m.clone(),
            None => path,
        }
    }

    fn read(&self, path: &Path) -> Result<std::sync::Arc<Storage>> {
        let cached = self.read.lock().map(|m| m.get(path).cloned());
        if let Ok(Some(t)) = cached {
            return Ok(t);
        }
        let t = std::sync::Arc::new(storage::read(path)?);
        if let Ok(mut m) = self.read.lock() {
            m.insert(path.to_path_buf(), t.clone());
        }
        Ok(t)
    }
}

/// The time column and one data column (or the sum of the space-separated
/// `column`s), times `scale`, of the table `file` that the element at `loc`
/// names.
fn table_column(
    tables: &Tables,
    file: &str,
    column: &str,
    scale: f64,
    loc: &Location,
) -> Result<(Vec<f64>, Vec<f64>)> {
    let path = tables.path(file);
    let t = tables.read(&path).map_err(|e| {
        e.context(format!(
            "{} ({})",
            loc.element.as_deref().unwrap_or_default(),
            file
        ))
    })?;
    let mut y = vec![0.0; t.time.len()];
    for c in column.split_whitespace() {
        let j = t.column_index(c).ok_or_else(|| {
            figures::error(loc, format!("{} has no column '{c}'", path.display()))
        })?;
        for (v, r) in y.iter_mut().zip(&t.rows) {
            *v += r[j];
        }
    }
    Ok((t.time.clone(), y.into_iter().map(|v| v * scale).collect()))
}

fn style(s: &SeriesSpec) -> Style {
    if s.dashed {
        Style::dashed(s.color)
    } else {
        Style::color(s.color)
    }
}

fn chart(p: &PanelSpec, tables: &Tables) -> Result<Chart> {
    let mut chart = Chart {
        title: p.title.clone(),
        x_label: p.x_label.clone(),
        y_label: p.y_label.clone(),
        fill_label: p.fill_label.clone(),
        fill_between: p.fill_between,
        ..Chart::default()
    };
    for s in &p.series {
        let series = match &s.data {
            SeriesData::Line { file } => {
                let (x, y) = table_column(tables, file, &s.column, s.scale, &s.loc)?;
                Series::new(s.label.as_str(), x, y, style(s))
            }
            SeriesData::Band { mean, min, max } => {
                let (x, m) = table_column(tables, mean, &s.column, s.scale, &s.loc)?;
                let (_, lo) = table_column(tables, min, &s.column, s.scale, &s.loc)?;
                let (_, hi) = table_column(tables, max, &s.column, s.scale, &s.loc)?;
                let mut series = Series::new(s.label.as_str(), x, m, style(s));
                series.band = Some((lo, hi));
                series
            }
        };
        chart.series.push(series);
    }
    Ok(chart)
}

fn figure(f: &FigureSpec, tables: &Tables, out: &Path) -> Result<Vec<PathBuf>> {
    let mut panels = f
        .panels
        .iter()
        .map(|p| chart(p, tables))
        .collect::<Result<Vec<Chart>>>()?;
    let stem = out.join(&f.name);
    if panels.len() == 1 {
        // 1600 px wide: read at a page's or screen's width, the text has
        // its normal size.
        panels[0].size = (1600, 900);
        plots::write(&panels[0], &stem)
    } else {
        // Panels stacked, each as wide as a single chart.
        let n = panels.len();
        plots::write_panels(&panels, &stem, Layout::column(n))
    }
}

fn metric(m: &MetricSpec, tables: &Tables) -> Result<(String, f64)> {
    let (t, y) = table_column(tables, &m.file, &m.columns, m.scale, &m.loc)?;
    // The column that locates a value (`where`): e.g. knee_flexion_r.
    let v = metric_value(m.op, &t, &y, || {
        let w = m.where_column.as_deref().unwrap_or_default();
        Ok(table_column(tables, &m.file, w, m.scale, &m.loc)?.1)
    })?;
    Ok((m.name.clone(), v))
}

/// Draw `<Figure>`s and compute `<Metric>`s (file paths relative to `dir`,
/// moved as `moved` says) into `out`; metrics go to `<name>_metrics.csv`.
pub fn draw(
    elements: &[FigureOrMetric],
    dir: &Path,
    out: &Path,
    name: &str,
    moved: &Moved,
) -> Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    if crate::storage::results::writes_file(out) {
        std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    }
    // Figures and metrics are independent: drawn and computed in parallel,
    // listed in the study's order.
    use rayon::prelude::*;
    let tables = Tables::new(dir, moved);
    // The run's outputs (its capture) on whichever worker draws.
    let run = crate::storage::results::context();
    let figures: Vec<Vec<PathBuf>> = elements
        .par_iter()
        .filter_map(|e| match e {
            FigureOrMetric::Figure(f) => Some(run.run(|| figure(f, &tables, out))),
            FigureOrMetric::Metric(_) => None,
        })
        .collect::<Result<_>>()?;
    files.extend(figures.into_iter().flatten());
    let metrics: Vec<(String, f64)> = elements
        .par_iter()
        .filter_map(|e| match e {
            FigureOrMetric::Metric(m) => Some(run.run(|| metric(m, &tables))),
            FigureOrMetric::Figure(_) => None,
        })
        .collect::<Result<_>>()?;
    if !metrics.is_empty() {
        let p = out.join(
            crate::writers::names::RunKey::setup(name, crate::writers::names::Sweep::Single)
                .file(crate::writers::names::OutputKind::Metrics),
        );
        let mut w = csv::Writer::from_writer(Vec::new());
        w.write_record(["metric", "value"])
            .map_err(|e| Error::input(Location::file(&p), e.to_string()))?;
        for (n, v) in &metrics {
            w.write_record([n.as_str(), &format!("{v:.6}")])
                .map_err(|e| Error::input(Location::file(&p), e.to_string()))?;
        }
        let bytes = w
            .into_inner()
            .map_err(|e| Error::input(Location::file(&p), e.to_string()))?;
        crate::storage::results::write(&p, bytes)?;
        files.push(p);
    }
    Ok(files)
}

/// Lexically normalised path (no `.`/`..`), so references and output
/// folders compare whether or not they exist yet.
pub(crate) fn normalise(p: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in p.components() {
        match c {
            std::path::Component::CurDir => {}
            std::path::Component::ParentDir => {
                if !out.pop() {
                    out.push("..");
                }
            }
            c => out.push(c),
        }
    }
    out
}

/// The problems of the tables a setup's `<Figure>`s and `<Metric>`s name
/// (relative to its results folder `dir`, drawn after the run): each must
/// be one this setup writes (one of the names of its plan's outputs,
/// `writers::names::Planned`) or exist already. References to w0 tables the setup does not
/// write are one problem, however many there are (they have one cause).
/// A run checks these before its first frame (`tools::analyze::run`).
pub fn figure_reference_problems(setup: &AnalyzeSetup, dir: &Path) -> Vec<Error> {
    use crate::writers::names::{self, Planned};
    let planned = Planned::of(setup);
    let tags = Planned::w0_tags(setup);
    let weights: Vec<String> = tags
        .iter()
        .take(tags.len().saturating_sub(names::SWEEP_STATS.len()))
        .cloned()
        .collect();
    let mut errors = Vec::new();
    // (location, attribute, value, tag) of references to w0 tables the
    // setup does not write.
    let mut wrong_w0: Vec<(Location, &str, String, String)> = Vec::new();
    for r in setup.figures.iter().flat_map(FigureOrMetric::tables) {
        let (attr, value) = (r.attr, r.value);
        let path = crate::parse::setup::resolve(dir, value);
        let file = path.file_name().and_then(|f| f.to_str()).unwrap_or("");
        let here = path.parent() == Some(dir);
        if here && planned.find(file).is_some() {
            continue;
        }
        let ours = here && file.starts_with(&setup.name);
        if let Some(tag) = names::w0_tag_in(file).filter(|_| ours) {
            if !tags.iter().any(|t| t == tag) {
                wrong_w0.push((r.loc.clone(), attr, value.to_string(), tag.to_string()));
                continue;
            }
        }
        if !path.is_file() {
            errors.push(Error::input(
                r.loc.clone(),
                format!(
                "{attr}=\"{value}\": {} does not exist and is not a table this setup writes (its tables are named {}_... in its results folder, {})",
                path.display(),
                setup.name,
                dir.display()
            )));
        }
    }
    let runs = if weights.is_empty() {
        "a single w0 (its tables carry no w0 in their names)".to_string()
    } else {
        format!("w0 = {}", weights.join(", "))
    };
    match wrong_w0.len() {
        0 => {}
        1 => {
            let (loc, attr, value, tag) = &wrong_w0[0];
            errors.insert(
                0,
                Error::input(
                    loc.clone(),
                    format!("{attr}=\"{value}\": names w0 = {tag}, but the setup runs {runs}"),
                ),
            );
        }
        n => {
            let mut named: Vec<&str> = Vec::new();
            let mut lines: Vec<String> = Vec::new();
            for (loc, _, _, tag) in &wrong_w0 {
                if !named.contains(&tag.as_str()) {
                    named.push(tag);
                }
                if let Some(l) = loc.line {
                    let l = l.to_string();
                    if !lines.contains(&l) {
                        lines.push(l);
                    }
                }
            }
            let (loc, attr, value, _) = &wrong_w0[0];
            errors.insert(
                0,
                Error::input(
                    loc.clone(),
                    format!(
                        "{attr}=\"{value}\" and {} more references (lines {}) name tables of w0 = {}, but the setup runs {runs}",
                        n - 1,
                        lines.join(", "),
                        named.join(", ")
                    ),
                ),
            );
        }
    }
    errors
}

/// Say that the tables `elements` name (relative to `dir`) will be read
/// by this run's figures and metrics: the run keeps them in memory
/// (`storage::results::want`; its capture ends with the run).
pub fn want_tables(elements: &[FigureOrMetric], dir: &Path) {
    for r in elements.iter().flat_map(FigureOrMetric::tables) {
        crate::storage::results::want(&resolve(dir, r.value));
    }
}

/// The figures and metrics of `elements` have read their tables (see
/// [`want_tables`]): the run's capture may drop them.
pub fn tables_read(elements: &[FigureOrMetric], dir: &Path) {
    for r in elements.iter().flat_map(FigureOrMetric::tables) {
        crate::storage::results::done(&resolve(dir, r.value));
    }
}
