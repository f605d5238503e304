//! OpenSim `ExternalLoads` / `ExternalForce` (opensim-semantics.md §8.1):
//! forces, points and torques read from a data file, interpolated in time
//! (constant for 1 row, linear for 2–3, natural cubic GCV spline for ≥ 4)
//! and applied to bodies.

use std::path::{Path, PathBuf};

use nalgebra::Vector3;

use crate::dynamics::{BodyForce, Data};
use crate::error::Result;
use crate::functions::{GcvSpline, SplineFitter, TransientBasis};
use crate::model::Model;
use crate::storage::{self, Storage};
use crate::xml::{self, Element};

/// One column of load data as a function of time.
#[derive(Debug, Clone)]
enum Series {
    Constant(f64),
    /// Linear interpolation with linear extrapolation (PiecewiseLinearFunction).
    Linear(Vec<f64>, Vec<f64>),
    Spline(GcvSpline),
}

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
    fn value(&self, x: f64, cache: &mut TransientBasis) -> f64 {
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
        }
    }
}

#[derive(Debug, Clone)]
struct Vec3Series([Series; 3]);

impl Vec3Series {
    fn value(&self, t: f64, cache: &mut TransientBasis) -> Vector3<f64> {
        Vector3::new(
            self.0[0].value(t, cache),
            self.0[1].value(t, cache),
            self.0[2].value(t, cache),
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
}

#[derive(Debug, Clone, Default)]
pub struct ExternalLoads {
    pub forces: Vec<ExternalForce>,
    pub data_file: PathBuf,
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
        let table = storage::read(&data_path)?;
        let mut fit = SplineFitter::new(3, &table.time);
        let mut forces = Vec::new();
        if let Some(objs) = el.children.iter_mut().find(|c| c.name == "objects") {
            for f in std::mem::take(&mut objs.children) {
                if f.name != "ExternalForce" {
                    continue;
                }
                let series = Self::read_series(&f, &table, &mut fit, &data_path);
                forces.push((f, series));
            }
        }
        Ok(ExternalLoadsFiles { data_path, forces })
    }

    /// Whether `f` applies its force and, if so, its series (each kept
    /// with its own error: [`Self::bind`] reports them in
    /// [`ExternalLoads::load`]'s order).
    fn read_series(
        f: &Element,
        table: &Storage,
        fit: &mut SplineFitter,
        data_path: &Path,
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
            let cols: Vec<usize> = table
                .labels
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
            let context = |c: usize, e: crate::error::Error| {
                e.context(format!(
                    "column '{}' of {}",
                    table.labels[c],
                    data_path.display()
                ))
            };
            if table.time.len() >= 4 {
                // the three cubic splines solved together
                let ys: Vec<Vec<f64>> = cols.iter().map(|&c| table.column(c)).collect();
                let ys: Vec<&[f64]> = ys.iter().map(|y| y.as_slice()).collect();
                let [a, b, c]: [GcvSpline; 3] = fit
                    .splines(&ys)
                    .map_err(|(i, e)| context(cols[i], e))?
                    .try_into()
                    .expect("three columns");
                return Ok(Some(Vec3Series([
                    Series::Spline(a),
                    Series::Spline(b),
                    Series::Spline(c),
                ])));
            }
            let mut mk = |c: usize| {
                Series::new(&table.time, &table.column(c), fit).map_err(|e| context(c, e))
            };
            Ok(Some(Vec3Series([mk(cols[0])?, mk(cols[1])?, mk(cols[2])?])))
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
            forces.push(Self::bind_force(&f, series, model)?);
        }
        Ok(ExternalLoads {
            forces,
            data_file: self.data_path,
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
        })
    }
}

impl ExternalLoads {
    /// Read an ExternalLoads XML file and its data file and bind them to `model`.
    /// `setup_dir` is the folder of the setup that named the file (OpenSim
    /// looks for the data file there first, then beside the XML).
    pub fn load(path: &Path, setup_dir: &Path, model: &Model) -> Result<ExternalLoads> {
        ExternalLoadsFiles::read(path, setup_dir)?.bind(model)
    }

    /// Add every load at time `t` to `data.applied` (body positions must be current).
    pub fn apply(&self, t: f64, data: &mut Data) {
        let mut cache = TransientBasis::default();
        for ef in &self.forces {
            let (f_g, p_g, t_g) = ef.evaluate_with(t, data, &mut cache);
            ef.add_to(data, f_g, p_g, t_g);
        }
    }

    /// [`apply`](Self::apply), and append to `record` what the force
    /// reporter records of each load ([`ExternalForce::record`] in order):
    /// the values are evaluated once for both.
    pub fn apply_recording(&self, t: f64, data: &mut Data, record: &mut Vec<f64>) {
        let mut cache = TransientBasis::default();
        for ef in &self.forces {
            let (f_g, p_g, t_g) = ef.evaluate_with(t, data, &mut cache);
            ef.record_into(&f_g, &p_g, &t_g, data, record);
            ef.add_to(data, f_g, p_g, t_g);
        }
    }
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

    /// Force, point of application and torque in ground at time `t`.
    pub fn evaluate(&self, t: f64, data: &Data) -> (Vector3<f64>, Vector3<f64>, Vector3<f64>) {
        self.evaluate_with(t, data, &mut TransientBasis::default())
    }

    /// [`evaluate`](Self::evaluate), the splines' segment basis shared
    /// through `cache` (the loads of one file share their time column).
    fn evaluate_with(
        &self,
        t: f64,
        data: &Data,
        cache: &mut TransientBasis,
    ) -> (Vector3<f64>, Vector3<f64>, Vector3<f64>) {
        let r_f = data.rotation[self.force_expressed_in];
        let f_g = self
            .force
            .as_ref()
            .map(|s| r_f * s.value(t, cache))
            .unwrap_or_else(Vector3::zeros);
        let t_g = self
            .torque
            .as_ref()
            .map(|s| r_f * s.value(t, cache))
            .unwrap_or_else(Vector3::zeros);
        let p_g = match &self.point {
            Some(s) => data.station_position(self.point_expressed_in, &s.value(t, cache)),
            None => data.position[self.applied_to_body],
        };
        (f_g, p_g, t_g)
    }
}
