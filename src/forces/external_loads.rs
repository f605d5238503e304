//! OpenSim `ExternalLoads` / `ExternalForce` (opensim-semantics.md §8.1):
//! forces, points and torques read from a data file, interpolated in time
//! (constant for 1 row, linear for 2–3, natural cubic GCV spline for ≥ 4)
//! and applied to bodies.
//!
//! A data file of at most [`WINDOW_ROWS`] rows is read whole and each
//! column splined through all of it, as OpenSim does. A longer one (force
//! plates sampled at 1–2 kHz over minutes) is never held whole: its rows are
//! read once to check them and to record where every window of
//! [`WINDOW_ROWS`] rows starts, and the columns the loads use are splined
//! window by window as frames need them ([`Windows`]), a few windows held at
//! a time. A natural interpolating cubic spline's value on a knot interval
//! depends on data k knots away with weight ≈ 0.27ᵏ, so a window fitted
//! [`WINDOW_OVERLAP`] rows past each side of its rows (clipped only at the
//! file's true ends, where the natural end conditions then apply exactly)
//! equals the spline through the whole file to rounding there. Which
//! window serves a time depends on the time alone, so results do not depend
//! on the order frames are computed in or on the thread count.

use std::path::{Path, PathBuf};
use std::sync::{Arc, RwLock};

use nalgebra::Vector3;

use crate::dynamics::{BodyForce, Data};
use crate::error::{Error, Location, Result};
use crate::functions::{GcvSpline, SplineFitter, TransientBasis};
use crate::model::Model;
use crate::storage::{self, RowMark, Storage};
use crate::xml::{self, Element};

/// One column of load data as a function of time.
#[derive(Debug, Clone)]
enum Series {
    Constant(f64),
    /// Linear interpolation with linear extrapolation (PiecewiseLinearFunction).
    Linear(Vec<f64>, Vec<f64>),
    Spline(GcvSpline),
    /// Column `j` of the splines of the window that covers the time
    /// ([`Windows`]).
    Windowed(usize),
}

/// Rows of a data file splined through at once: a file of at most this
/// many rows is splined whole, a longer one window by window.
pub const WINDOW_ROWS: usize = 4096;
/// Rows past each side of a window that its splines are fitted through:
/// 0.27⁶⁰ ≈ 10⁻³⁴.
pub const WINDOW_OVERLAP: usize = 60;
/// Fitted windows held at once (frames solved in parallel are close in
/// time: at most two windows are in use at a time), however many a block
/// of frames spans (a 4096-row motion block at 100 Hz spans 20 windows of
/// force-plate data at 2 kHz).
const WINDOWS_HELD: usize = 3;

impl Series {
    /// `fit`: cubic splines on `t` (one spline system for all columns).
    fn new(t: &[f64], y: &[f64], fit: &mut SplineFitter) -> Result<Series> {
        Ok(match t.len() {
            0 => Series::Constant(0.0),
            1 => Series::Constant(y[0]),
            2 | 3 => Series::Linear(t.to_vec(), y.to_vec()),
            _ => Series::Spline(fit.spline(y)?),
        })
    }
    fn value(&self, x: f64, cache: &mut TransientBasis, window: Option<&Window>) -> f64 {
        match self {
            Series::Constant(c) => *c,
            Series::Linear(t, y) => {
                let n = t.len();
                let k = match t.iter().position(|&ti| ti > x) {
                    Some(0) => 0,
                    Some(i) => i - 1,
                    None => n - 2,
                };
                let slope = (y[k + 1] - y[k]) / (t[k + 1] - t[k]).max(1e-7);
                y[k] + slope * (x - t[k])
            }
            // Frames advance through the data: its segments are rarely
            // revisited, so none is kept.
            Series::Spline(s) => s.value_transient_with(x, cache),
            Series::Windowed(j) => match window.and_then(|w| w.splines.get(*j)) {
                Some(s) => s.value_transient_with(x, cache),
                // (A windowed series is always evaluated with its window,
                // unless it could not be fitted: `ExternalLoads::apply`.)
                None => f64::NAN,
            },
        }
    }
}

#[derive(Debug, Clone)]
struct Vec3Series([Series; 3]);

impl Vec3Series {
    fn value(&self, t: f64, cache: &mut TransientBasis, window: Option<&Window>) -> Vector3<f64> {
        Vector3::new(
            self.0[0].value(t, cache, window),
            self.0[1].value(t, cache, window),
            self.0[2].value(t, cache, window),
        )
    }
}

/// One ExternalForce, resolved against a model.
#[derive(Debug, Clone)]
pub struct ExternalForce {
    pub name: String,
    pub applied_to_body: usize,
    pub force_expressed_in: usize,
    pub point_expressed_in: usize,
    force: Option<Vec3Series>,
    point: Option<Vec3Series>,
    torque: Option<Vec3Series>,
    /// Labels for the force reporter (`<body>_<name>_Fx`, ...).
    pub labels: Vec<String>,
    /// The data file's windows, when it is long.
    windows: Option<Arc<Windows>>,
    /// The factor on its force and torque data ([`ExternalLoads::scale`]).
    scale: f64,
}

#[derive(Debug, Clone, Default)]
pub struct ExternalLoads {
    pub forces: Vec<ExternalForce>,
    pub data_file: PathBuf,
    /// A long data file's windows (None: every series fitted whole).
    windows: Option<Arc<Windows>>,
}

/// The windows of a long data file (see the module documentation): window
/// k serves the times from row k·[`WINDOW_ROWS`] up to the next window's
/// first row (the first window everything before, the last everything
/// after), and is fitted through the rows [`WINDOW_OVERLAP`] past each side.
#[derive(Debug)]
struct Windows {
    path: PathBuf,
    /// Data columns the loads use, in the order of the `Series::Windowed`
    /// indices, and their labels.
    columns: Vec<usize>,
    labels: Vec<String>,
    rows: usize,
    window_rows: usize,
    /// Time of the first row of each window, k·window_rows.
    starts: Vec<f64>,
    /// Positions in the file to read a window's rows from: (row, mark).
    marks: Vec<(usize, RowMark)>,
    held: RwLock<Vec<Arc<Window>>>,
    /// The first error fitting a window outside the prepared range.
    failure: std::sync::Mutex<Option<Error>>,
}

/// Let the windows farthest from window `k` go until at most `keep` are held.
fn let_go(held: &mut Vec<Arc<Window>>, k: usize, keep: usize) {
    while held.len() > keep {
        if let Some(far) = (0..held.len()).max_by_key(|&i| held[i].k.abs_diff(k)) {
            held.swap_remove(far);
        }
    }
}

fn poisoned() -> Error {
    Error::internal("the external loads' windows were poisoned")
}

/// One window's splines, one per used column.
#[derive(Debug)]
struct Window {
    k: usize,
    splines: Vec<GcvSpline>,
}

impl Windows {
    /// The window that serves time `t`.
    fn index(&self, t: f64) -> usize {
        self.starts.partition_point(|&s| s <= t).saturating_sub(1)
    }

    /// The splines of the window that serves `t`, fitted if not held
    /// (then held too, the windows farthest from it let go so that at most
    /// [`WINDOWS_HELD`] are).
    fn at(&self, t: f64) -> Result<Arc<Window>> {
        let k = self.index(t);
        if let Some(w) = self
            .held
            .read()
            .map_err(|_| poisoned())?
            .iter()
            .find(|w| w.k == k)
        {
            return Ok(w.clone());
        }
        let mut held = self.held.write().map_err(|_| poisoned())?;
        if let Some(w) = held.iter().find(|w| w.k == k) {
            return Ok(w.clone());
        }
        let w = Arc::new(self.fit(k)?);
        let_go(&mut held, k, WINDOWS_HELD - 1);
        held.push(w.clone());
        Ok(w)
    }

    /// Hold the window serving `t_first` (fitted here, where its error can
    /// be returned) and let the windows before it go; the later ones a
    /// block reaches are fitted by the frames that need them (`Windows::at`), at
    /// most [`WINDOWS_HELD`] held whatever the block's length and the
    /// data's rate.
    fn prepare(&self, t_first: f64) -> Result<()> {
        let k0 = self.index(t_first);
        let mut held = self.held.write().map_err(|_| poisoned())?;
        held.retain(|w| w.k >= k0);
        if !held.iter().any(|w| w.k == k0) {
            held.push(Arc::new(self.fit(k0)?));
        }
        let_go(&mut held, k0, WINDOWS_HELD);
        Ok(())
    }

    fn keep(&self, e: Error) {
        if let Ok(mut f) = self.failure.lock() {
            f.get_or_insert(e);
        }
    }

    fn check(&self) -> Result<()> {
        match self.failure.lock() {
            Ok(mut f) => f.take().map_or(Ok(()), Err),
            Err(_) => Err(poisoned()),
        }
    }

    /// Read window k's rows and spline its columns.
    fn fit(&self, k: usize) -> Result<Window> {
        let r0 = (k * self.window_rows).saturating_sub(WINDOW_OVERLAP);
        let r1 = ((k + 1) * self.window_rows + WINDOW_OVERLAP + 1).min(self.rows);
        let mut reader = storage::open_rows(&self.path)?;
        reader.seek_row(r0, &self.marks)?;
        let mut time = Vec::with_capacity(r1 - r0);
        let mut cols: Vec<Vec<f64>> = vec![Vec::with_capacity(r1 - r0); self.columns.len()];
        let mut row = Vec::new();
        while time.len() < r1 - r0 {
            let Some(t) = reader.next_row(&mut row)? else {
                return Err(Error::msg(format!(
                    "{}: the file changed while it was read (row {} missing)",
                    self.path.display(),
                    r0 + time.len()
                )));
            };
            time.push(t);
            for (c, &j) in cols.iter_mut().zip(&self.columns) {
                c.push(row[j]);
            }
        }
        let ys: Vec<&[f64]> = cols.iter().map(|c| c.as_slice()).collect();
        let splines = SplineFitter::new(3, &time).splines(&ys).map_err(|(i, e)| {
            e.context(format!(
                "column '{}' of {}, rows {r0} to {}",
                self.labels[i],
                self.path.display(),
                r1 - 1
            ))
        })?;
        Ok(Window { k, splines })
    }
}

fn given(id: Option<&str>) -> Option<&str> {
    id.map(str::trim)
        .filter(|s| !s.is_empty() && *s != "Unassigned")
}

/// An ExternalLoads file and its data file read, and every applied
/// ExternalForce's data fitted, before a model is known: the part of
/// [`ExternalLoads::load`] that can run while the model is being read.
/// [`ExternalLoadsFiles::bind`] finishes it against the model.
#[derive(Debug)]
pub struct ExternalLoadsFiles {
    data_path: PathBuf,
    /// Per ExternalForce element, in order: the element and its series
    /// (None when it applies no force), or the first error reading them.
    forces: Vec<(Element, Result<Option<ForceSeries>>)>,
    /// A long data file's windows.
    windows: Option<Arc<Windows>>,
}

/// What the one pass over a long data file's rows learns. (The row reader
/// refuses values that are not finite numbers and times that do not
/// increase, naming the file, line and column, as it does for a file read
/// whole: what the splines check of their data holds for every window.)
struct Pass {
    rows: usize,
    starts: Vec<f64>,
    marks: Vec<(usize, RowMark)>,
}

/// The windowed series of three data columns, each registered in
/// `columns` (the columns the windows fit) if not already.
fn windowed_series(cols: &[usize], columns: &mut Vec<usize>) -> Vec3Series {
    let mut index = |c: usize| match columns.iter().position(|&u| u == c) {
        Some(j) => Series::Windowed(j),
        None => {
            columns.push(c);
            Series::Windowed(columns.len() - 1)
        }
    };
    Vec3Series([index(cols[0]), index(cols[1]), index(cols[2])])
}

/// The series of three columns of a table held whole: the three cubic
/// splines solved together (at least 4 rows), else constants or linear
/// interpolation; or the column (0, 1, 2) whose data fails.
fn whole_series(
    table: &Storage,
    fit: &mut SplineFitter,
    cols: &[usize],
) -> std::result::Result<Vec3Series, (usize, Error)> {
    if table.time.len() >= 4 {
        let ys: Vec<Vec<f64>> = cols.iter().map(|&c| table.column(c)).collect();
        let ys: Vec<&[f64]> = ys.iter().map(|y| y.as_slice()).collect();
        let splines = fit.splines(&ys)?;
        let mut it = splines.into_iter().map(Series::Spline);
        return match (it.next(), it.next(), it.next()) {
            (Some(a), Some(b), Some(c)) => Ok(Vec3Series([a, b, c])),
            _ => Err((0, Error::internal("three splines for three columns"))),
        };
    }
    let mut mk =
        |i: usize| Series::new(&table.time, &table.column(cols[i]), fit).map_err(|e| (i, e));
    Ok(Vec3Series([mk(0)?, mk(1)?, mk(2)?]))
}

/// What an applied ExternalForce's identifiers name, fitted.
#[derive(Debug)]
struct ForceSeries {
    force: Result<Option<Vec3Series>>,
    point: Result<Option<Vec3Series>>,
    torque: Result<Option<Vec3Series>>,
}

impl ExternalLoadsFiles {
    /// Read an ExternalLoads XML file and its data file. `setup_dir` is the
    /// folder of the setup that named the file (OpenSim looks for the data
    /// file there first, then beside the XML).
    pub fn read(path: &Path, setup_dir: &Path) -> Result<ExternalLoadsFiles> {
        Self::read_with_window(path, setup_dir, WINDOW_ROWS)
    }

    /// [`Self::read`], with data files of more than `window_rows` rows
    /// splined window by window (`window_rows` rows each; see the module
    /// documentation).
    pub fn read_with_window(
        path: &Path,
        setup_dir: &Path,
        window_rows: usize,
    ) -> Result<ExternalLoadsFiles> {
        let mut root = xml::parse_file(path)?;
        let el = if root.name == "ExternalLoads" {
            &mut root
        } else {
            match root.children.iter().position(|c| c.name == "ExternalLoads") {
                Some(i) => &mut root.children[i],
                None => return Err(root.error("no <ExternalLoads> element in file")),
            }
        };
        let datafile = el
            .child_text("datafile")
            .filter(|s| !s.is_empty())
            .ok_or_else(|| el.error("ExternalLoads has no <datafile>"))?;
        let candidates = [
            setup_dir.join(datafile),
            path.parent().unwrap_or(Path::new(".")).join(datafile),
        ];
        let data_path = candidates
            .iter()
            .find(|p| p.is_file())
            .cloned()
            .ok_or_else(|| {
                el.req("datafile")
                    .map(|d| {
                        d.error(format!(
                            "data file '{datafile}' not found (looked in {} and {})",
                            candidates[0].display(),
                            candidates[1].display()
                        ))
                    })
                    .unwrap_or_else(|e| e)
            })?;
        Self::read_rows(el, data_path, window_rows.max(1))
    }

    /// The data file's rows (see [`Self::read_with_window`]) and each
    /// ExternalForce of `el`'s series.
    fn read_rows(el: &mut Element, data_path: PathBuf, window_rows: usize) -> Result<Self> {
        // One pass over the rows: a file of at most `window_rows` rows is
        // kept whole; of a longer one, where each window starts.
        let mut reader = storage::open_rows(&data_path)?;
        let mut table = reader.table.clone();
        let mut pass = Pass {
            rows: 0,
            starts: Vec::new(),
            marks: Vec::new(),
        };
        let mut row = Vec::new();
        let mut whole = true;
        loop {
            let r = pass.rows;
            if r == 0 || (r + WINDOW_OVERLAP) % window_rows == 0 {
                pass.marks.push((r, reader.mark()));
            }
            let Some(t) = reader.next_row(&mut row)? else {
                break;
            };
            if r % window_rows == 0 {
                pass.starts.push(t);
            }
            pass.rows += 1;
            if whole {
                table.time.push(t);
                table.rows.push(row.clone());
                if pass.rows > window_rows {
                    whole = false;
                    table.time = Vec::new();
                    table.rows = Vec::new();
                }
            }
        }
        let mut forces = Vec::new();
        let objects = el.children.iter_mut().find(|c| c.name == "objects");
        let elements: Vec<Element> = objects
            .map(|objs| std::mem::take(&mut objs.children))
            .unwrap_or_default()
            .into_iter()
            .filter(|f| f.name == "ExternalForce")
            .collect();
        if whole {
            let mut fit = SplineFitter::new(3, &table.time);
            for f in elements {
                let series = Self::read_series(&f, &table.labels, &data_path, |cols| {
                    whole_series(&table, &mut fit, cols)
                });
                forces.push((f, series));
            }
            return Ok(ExternalLoadsFiles {
                data_path,
                forces,
                windows: None,
            });
        }
        let mut columns: Vec<usize> = Vec::new();
        for f in elements {
            let series = Self::read_series(&f, &table.labels, &data_path, |cols| {
                Ok(windowed_series(cols, &mut columns))
            });
            forces.push((f, series));
        }
        let labels = columns.iter().map(|&c| table.labels[c].clone()).collect();
        let windows = Windows {
            path: data_path.clone(),
            columns,
            labels,
            rows: pass.rows,
            window_rows,
            starts: pass.starts,
            marks: pass.marks,
            held: RwLock::new(Vec::new()),
            failure: Default::default(),
        };
        Ok(ExternalLoadsFiles {
            data_path,
            forces,
            windows: Some(Arc::new(windows)),
        })
    }

    /// Whether `f` applies its force and, if so, its series (each kept
    /// with its own error: [`Self::bind`] reports them in
    /// [`ExternalLoads::load`]'s order). `make` makes the series of three
    /// data columns, or says which of them (0, 1, 2) it fails on.
    fn read_series(
        f: &Element,
        labels: &[String],
        data_path: &Path,
        mut make: impl FnMut(&[usize]) -> std::result::Result<Vec3Series, (usize, Error)>,
    ) -> Result<Option<ForceSeries>> {
        let applies = match f.child("appliesForce") {
            Some(a) if !a.text().is_empty() => a.bool()?,
            _ => !f.child_bool_or("isDisabled", false)?,
        };
        if !applies {
            return Ok(None);
        }
        let mut series = |id: Option<&str>| -> Result<Option<Vec3Series>> {
            let Some(id) = given(id) else { return Ok(None) };
            let cols: Vec<usize> = labels
                .iter()
                .enumerate()
                .filter(|(_, l)| l.starts_with(id))
                .map(|(i, _)| i)
                .collect();
            if cols.len() != 3 {
                return Err(f.error(format!(
                    "identifier '{id}' matches {} columns of {} (labels must start with it; exactly 3 needed)",
                    cols.len(),
                    data_path.display()
                )));
            }
            make(&cols).map(Some).map_err(|(i, e)| {
                e.context(format!(
                    "column '{}' of {}",
                    labels[cols[i]],
                    data_path.display()
                ))
            })
        };
        // As OpenSim (and ExternalLoads::load before): an identifier's error
        // ends the reading of this force.
        let force = series(f.child_text("force_identifier"));
        let point = match force {
            Ok(_) => series(f.child_text("point_identifier")),
            Err(_) => Ok(None),
        };
        let torque = match (&force, &point) {
            (Ok(_), Ok(_)) => series(f.child_text("torque_identifier")),
            _ => Ok(None),
        };
        Ok(Some(ForceSeries {
            force,
            point,
            torque,
        }))
    }

    /// Bind the loads to `model`: the bodies each force names, then each
    /// force's first error in the order [`ExternalLoads::load`] reports it.
    pub fn bind(self, model: &Model) -> Result<ExternalLoads> {
        let mut forces = Vec::new();
        for (f, series) in self.forces {
            let Some(series) = series? else { continue };
            let mut force = Self::bind_force(&f, series, model)?;
            force.windows = self.windows.clone();
            forces.push(force);
        }
        Ok(ExternalLoads {
            forces,
            data_file: self.data_path,
            windows: self.windows,
        })
    }

    fn bind_force(f: &Element, series: ForceSeries, model: &Model) -> Result<ExternalForce> {
        let name = f.name_attr().to_string();
        let body_name = f.child_text("applied_to_body").unwrap_or("");
        let find_body = |n: &str| -> Option<usize> {
            let n = n.trim_start_matches('/').trim_start_matches("bodyset/");
            model.body_index(n)
        };
        let applied_to_body = find_body(body_name).ok_or_else(|| {
            f.error(format!(
                "applied_to_body '{body_name}' is not a body of model '{}'",
                model.name
            ))
        })?;
        let expressed =
            |prop: &str| -> usize { f.child_text(prop).and_then(find_body).unwrap_or(0) };
        let force = series.force?;
        let point = series.point?;
        let torque = series.torque?;
        if force.is_none() && torque.is_none() {
            return Err(f.error("ExternalForce needs a force_identifier or a torque_identifier"));
        }
        if point.is_some() && force.is_none() {
            return Err(f.error("ExternalForce has a point_identifier but no force_identifier"));
        }
        let body = &model.bodies[applied_to_body].name;
        let mut labels = Vec::new();
        for (present, suffix) in [
            (force.is_some(), ["_Fx", "_Fy", "_Fz"]),
            (point.is_some(), ["_px", "_py", "_pz"]),
            (torque.is_some(), ["_Tx", "_Ty", "_Tz"]),
        ] {
            if present {
                labels.extend(suffix.iter().map(|s| format!("{body}_{name}{s}")));
            }
        }
        Ok(ExternalForce {
            name,
            applied_to_body,
            force_expressed_in: expressed("force_expressed_in_body"),
            point_expressed_in: expressed("point_expressed_in_body"),
            force,
            point,
            torque,
            labels,
            windows: None,
            scale: 1.0,
        })
    }
}

impl ExternalLoads {
    /// Scale the force and torque data (not the points) of the loads
    /// `scales` names: (ExternalForce name or `*` for every one, factor);
    /// the factors of a load multiply. An unknown name is an error naming
    /// the loads there are.
    pub fn scale(&mut self, scales: &[(String, f64)]) -> Result<()> {
        for (name, f) in scales {
            if name == "*" {
                self.forces.iter_mut().for_each(|ef| ef.scale *= f);
                continue;
            }
            let Some(ef) = self.forces.iter_mut().find(|ef| &ef.name == name) else {
                return Err(Error::input(
                    Location::file(&self.data_file),
                    format!(
                        "external load scale of '{name}': the external loads have no ExternalForce '{name}' (names: {}; '*' scales them all)",
                        self.forces.iter().map(|ef| ef.name.as_str()).collect::<Vec<_>>().join(", ")
                    ),
                ));
            };
            ef.scale *= f;
        }
        Ok(())
    }

    /// Read an ExternalLoads XML file and its data file and bind them to `model`.
    /// `setup_dir` is the folder of the setup that named the file (OpenSim
    /// looks for the data file there first, then beside the XML).
    pub fn load(path: &Path, setup_dir: &Path, model: &Model) -> Result<ExternalLoads> {
        ExternalLoadsFiles::read(path, setup_dir)?.bind(model)
    }

    /// Add every load at time `t` to `data.applied` (body positions must
    /// be current). With a long data file, `t` should lie in the range last
    /// [`prepare`](Self::prepare)d; otherwise its window is fitted here,
    /// and if that fails (the file changed or went since it was read) the
    /// loads are NaN and the error is kept for the next `prepare` or
    /// [`check`](Self::check) to return.
    pub fn apply(&self, t: f64, data: &mut Data) {
        let mut cache = TransientBasis::default();
        let window = self.window_or_keep(t);
        for ef in &self.forces {
            let (f_g, p_g, t_g) = ef.evaluate_with(t, data, &mut cache, window.as_deref());
            ef.add_to(data, f_g, p_g, t_g);
        }
    }

    /// The window serving `t`, or None (a file splined whole, or a window
    /// that could not be fitted: its error kept in the windows).
    fn window_or_keep(&self, t: f64) -> Option<Arc<Window>> {
        let w = self.windows.as_ref()?;
        match w.at(t) {
            Ok(window) => Some(window),
            Err(e) => {
                w.keep(e);
                None
            }
        }
    }

    /// Before a block of frames from `t_first` on (the frame drivers call
    /// it: `frame::driver::PreparingLoads`): a long data file's window
    /// serving `t_first` fitted and held, the earlier ones let go (the
    /// later ones are fitted as the frames reach them). Returns the error
    /// of a window an earlier [`apply`](Self::apply) could not fit.
    pub fn prepare(&self, t_first: f64) -> Result<()> {
        let Some(w) = &self.windows else {
            return Ok(());
        };
        w.check()?;
        w.prepare(t_first)
    }

    /// Windows held now (tests).
    #[cfg(test)]
    pub(crate) fn windows_held(&self) -> usize {
        self.windows
            .as_ref()
            .and_then(|w| w.held.read().ok().map(|h| h.len()))
            .unwrap_or(0)
    }

    /// The error an earlier [`apply`](Self::apply) kept, if any.
    pub fn check(&self) -> Result<()> {
        self.windows.as_ref().map_or(Ok(()), |w| w.check())
    }

    /// [`apply`](Self::apply), and append to `record` what the force
    /// reporter records of each load ([`ExternalForce::record`] in order):
    /// the values are evaluated once for both.
    pub fn apply_recording(&self, t: f64, data: &mut Data, record: &mut Vec<f64>) {
        let mut cache = TransientBasis::default();
        let window = self.window_or_keep(t);
        for ef in &self.forces {
            let (f_g, p_g, t_g) = ef.evaluate_with(t, data, &mut cache, window.as_deref());
            ef.record_into(&f_g, &p_g, &t_g, data, record);
            ef.add_to(data, f_g, p_g, t_g);
        }
    }

    /// Whether the data file is splined window by window (it has more than
    /// [`WINDOW_ROWS`] rows, or the window the reader was given).
    pub fn windowed(&self) -> bool {
        self.windows.is_some()
    }
}

/// The window serving `t` of a long data file (None for a file splined
/// whole), or the error fitting it.
fn window_at(windows: &Option<Arc<Windows>>, t: f64) -> Result<Option<Arc<Window>>> {
    windows.as_ref().map(|w| w.at(t)).transpose()
}

impl ExternalForce {
    fn add_to(&self, data: &mut Data, f_g: Vector3<f64>, p_g: Vector3<f64>, t_g: Vector3<f64>) {
        let mut bf = BodyForce::torque(t_g);
        bf.add(&BodyForce::at_point(f_g, p_g));
        data.applied[self.applied_to_body].add(&bf);
    }

    /// The values OpenSim's ForceReporter records (labels in [`Self::labels`]):
    /// force in ground, point in the applied body's frame, torque in ground.
    pub fn record(
        &self,
        f_g: &Vector3<f64>,
        p_g: &Vector3<f64>,
        t_g: &Vector3<f64>,
        data: &Data,
    ) -> Vec<f64> {
        let mut v = Vec::with_capacity(9);
        self.record_into(f_g, p_g, t_g, data, &mut v);
        v
    }

    /// [`record`](Self::record), appended to `out`.
    pub fn record_into(
        &self,
        f_g: &Vector3<f64>,
        p_g: &Vector3<f64>,
        t_g: &Vector3<f64>,
        data: &Data,
        out: &mut Vec<f64>,
    ) {
        if self.force.is_some() {
            out.extend(f_g.iter());
        }
        if self.point.is_some() {
            let b = self.applied_to_body;
            let local = data.rotation[b].transpose() * (p_g - data.position[b]);
            out.extend(local.iter());
        }
        if self.torque.is_some() {
            out.extend(t_g.iter());
        }
    }

    /// How many values [`record`](Self::record) appends.
    pub fn record_size(&self) -> usize {
        3 * (self.force.is_some() as usize
            + self.point.is_some() as usize
            + self.torque.is_some() as usize)
    }

    /// Scale the force and torque of this load's [`record`](Self::record)
    /// values (`record`, of [`record_size`](Self::record_size)) by `s`: the
    /// record of the load with its force and torque data scaled by `s` (the
    /// point stays).
    pub fn scale_record(&self, record: &mut [f64], s: f64) {
        let mut k = 0;
        for (present, scaled) in [
            (self.force.is_some(), true),
            (self.point.is_some(), false),
            (self.torque.is_some(), true),
        ] {
            if present {
                if scaled {
                    record[k..k + 3].iter_mut().for_each(|x| *x *= s);
                }
                k += 3;
            }
        }
    }

    /// The load at time `t` as the spatial force (about the ground origin,
    /// ground frame) [`ExternalLoads::apply`] adds to its body
    /// ([`Self::applied_to_body`]).
    pub fn body_force(&self, t: f64, data: &Data) -> Result<BodyForce> {
        let (f_g, p_g, t_g) = self.evaluate(t, data)?;
        let mut bf = BodyForce::torque(t_g);
        bf.add(&BodyForce::at_point(f_g, p_g));
        Ok(bf)
    }

    /// Force, point of application and torque in ground at time `t`.
    /// Fails only as [`ExternalLoads::apply`] does.
    pub fn evaluate(
        &self,
        t: f64,
        data: &Data,
    ) -> Result<(Vector3<f64>, Vector3<f64>, Vector3<f64>)> {
        let window = window_at(&self.windows, t)?;
        Ok(self.evaluate_with(t, data, &mut TransientBasis::default(), window.as_deref()))
    }

    /// [`evaluate`](Self::evaluate), the splines' segment basis shared
    /// through `cache` (the loads of one file share their time column).
    fn evaluate_with(
        &self,
        t: f64,
        data: &Data,
        cache: &mut TransientBasis,
        window: Option<&Window>,
    ) -> (Vector3<f64>, Vector3<f64>, Vector3<f64>) {
        let r_f = data.rotation[self.force_expressed_in];
        let mut f_g = self
            .force
            .as_ref()
            .map(|s| r_f * s.value(t, cache, window))
            .unwrap_or_else(Vector3::zeros);
        let mut t_g = self
            .torque
            .as_ref()
            .map(|s| r_f * s.value(t, cache, window))
            .unwrap_or_else(Vector3::zeros);
        if self.scale != 1.0 {
            f_g *= self.scale;
            t_g *= self.scale;
        }
        let p_g = match &self.point {
            Some(s) => data.station_position(self.point_expressed_in, &s.value(t, cache, window)),
            None => data.position[self.applied_to_body],
        };
        (f_g, p_g, t_g)
    }
}

/// One ExternalForce of an ExternalLoads file as it is written: its name,
/// the body it is applied to and its data column identifiers (predict-grf
/// writes its prediction with a measured file's layout).
#[derive(Debug, Clone)]
pub struct ForceLayout {
    pub name: String,
    pub body: String,
    pub force_identifier: String,
    pub point_identifier: String,
    pub torque_identifier: String,
}

/// The ExternalForces of an ExternalLoads file, in file order.
pub fn layout(path: &Path) -> Result<Vec<ForceLayout>> {
    let root = crate::xml::parse_file(path)?;
    let mut out = Vec::new();
    let mut visit = vec![&root];
    while let Some(el) = visit.pop() {
        if el.name == "ExternalForce" {
            let text = |n: &str| el.child_text(n).unwrap_or("").trim().to_string();
            out.push(ForceLayout {
                name: el.name_attr().to_string(),
                body: text("applied_to_body"),
                force_identifier: text("force_identifier"),
                point_identifier: text("point_identifier"),
                torque_identifier: text("torque_identifier"),
            });
        }
        visit.extend(el.children.iter());
    }
    out.reverse();
    Ok(out)
}
