//! `statopt-tool predict-grf SETUP.xml`: ground reactions from kinematics
//! alone (issue 14; docs/grf_prediction.md).
//!
//! A thin driver over static optimization: the setup's `external_loads_file`
//! is not applied but kept as the measured reference; foot contacts built
//! from the model's feet and the motion ([`crate::contacts::feet`]) are
//! written to `<name>_foot_contacts.xml` in the results folder and added to
//! the setup's force-set files; the setup runs as usual; the contacts'
//! forces are summed per foot into `<name>_predicted_grf.sto` (per foot:
//! force, centre of pressure on the floor, free moment about the floor
//! normal) and, with measured loads, compared in `<name>_grf_comparison.csv`.

use std::path::PathBuf;

use nalgebra::Vector3;

use crate::contacts::feet::{self, FootContactParameters, FootContactSet};
use crate::dynamics::{kinematics, Data};
use crate::error::{Error, Location, Result};
use crate::forces::external_loads::ExternalLoads;
use crate::parse::setup::AnalyzeSetup;
use crate::storage::{self, StoWriter};
use crate::tools::{analyze, loading, RunOptions, RunSummary};

/// Per frame and foot: force on the foot (N, ground), centre of pressure
/// on the floor (m) and free moment about the floor normal (N·m).
#[derive(Debug, Clone, Default)]
pub struct FootLoads {
    pub time: Vec<f64>,
    /// `[side][frame]`, side 0 right, 1 left.
    pub force: [Vec<Vector3<f64>>; 2],
    pub cop: [Vec<Vector3<f64>>; 2],
    pub free_moment: [Vec<f64>; 2],
}

/// Agreement of the prediction with the measured loads, per foot and axis.
#[derive(Debug, Clone)]
pub struct AxisMetrics {
    pub side: char,
    pub axis: char,
    pub rho: f64,
    pub rmse_n: f64,
    pub rmse_bw: f64,
    pub peak_error_n: f64,
}

/// What a prediction produced.
pub struct Prediction {
    pub summary: RunSummary,
    pub contacts: FootContactSet,
    pub predicted: FootLoads,
    pub measured: Option<FootLoads>,
    pub metrics: Vec<AxisMetrics>,
    pub body_weight: f64,
}

/// Run the prediction for an AnalyzeTool setup with a StaticOptimization.
pub fn run(setup: &AnalyzeSetup, opts: &RunOptions) -> Result<Prediction> {
    if setup.analysis_element("StaticOptimization").is_none() {
        return Err(Error::input(
            Location::file(&setup.setup_file).with_element("<AnalysisSet>"),
            "predict-grf needs a StaticOptimization analysis in the setup",
        ));
    }
    let mut setup = setup.clone();
    let measured_file = setup.external_loads_file.take();
    let am = loading::load_analysis_model(&setup)?;
    let model = am.model;
    let states = analyze::load_states(&setup, &model)?;
    let contacts = feet::build(&model, &states, None, FootContactParameters::default())?;
    let dir = analyze::results_dir(&setup, opts)?;
    let contacts_file = dir.join(format!("{}_foot_contacts.xml", setup.name));
    std::fs::write(&contacts_file, contacts.force_set_xml())
        .map_err(|e| Error::io(&contacts_file, e))?;
    setup.force_set_files.push(contacts_file.clone());
    let mut summary = analyze::run(&setup, opts)?;
    summary.files.push(contacts_file);
    let (el, common) = setup
        .analysis_element("StaticOptimization")
        .expect("checked above");
    let so_name = common.name.clone();
    let _ = el;
    let loads_path = dir.join(format!(
        "{}_{}_ContactExternalLoads.mot",
        setup.name, so_name
    ));
    let predicted = foot_loads_from_contacts(&loads_path, &contacts)?;
    let body_weight = model.bodies.iter().map(|b| b.mass).sum::<f64>() * model.gravity.norm();
    let mut prediction = Prediction {
        summary,
        contacts,
        predicted,
        measured: None,
        metrics: Vec::new(),
        body_weight,
    };
    let out = dir.join(format!("{}_predicted_grf.sto", setup.name));
    write_foot_loads(&prediction.predicted, &out, &setup.setup_file)?;
    prediction.summary.files.push(out);
    if let Some(mf) = measured_file {
        let setup_dir = setup
            .setup_file
            .parent()
            .unwrap_or(std::path::Path::new("."));
        let loads = ExternalLoads::load(&mf, setup_dir, &model)?;
        let measured = measured_foot_loads(&loads, &model, &states, &prediction.predicted.time)?;
        prediction.metrics = compare(&prediction.predicted, &measured, body_weight);
        let csv = dir.join(format!("{}_grf_comparison.csv", setup.name));
        write_metrics(&prediction.metrics, &csv)?;
        prediction.summary.files.push(csv);
        prediction.measured = Some(measured);
    }
    Ok(prediction)
}

/// Per-foot loads from the contact forces a static-optimization run wrote
/// (`..._ContactExternalLoads.mot`: each contact's force on its point body
/// at the point).
pub fn foot_loads_from_contacts(path: &std::path::Path, set: &FootContactSet) -> Result<FootLoads> {
    let table = storage::read(path)?;
    let col = |name: &str| {
        table
            .column_index(name)
            .ok_or_else(|| Error::internal(format!("{}: no column {name}", path.display())))
    };
    let mut out = FootLoads {
        time: table.time.clone(),
        ..Default::default()
    };
    let mut idx: [Vec<[usize; 6]>; 2] = [Vec::new(), Vec::new()];
    for p in &set.points {
        let s = usize::from(p.side == 'l');
        let mut c = [0usize; 6];
        for (k, suffix) in ["vx", "vy", "vz", "px", "py", "pz"].iter().enumerate() {
            c[k] = col(&format!("{}_point_force_{suffix}", p.name))?;
        }
        idx[s].push(c);
    }
    for row in &table.rows {
        for s in 0..2 {
            let mut f = Vector3::zeros();
            let mut moment_y = 0.0;
            let mut weighted = Vector3::zeros();
            for c in &idx[s] {
                let fi = Vector3::new(row[c[0]], row[c[1]], row[c[2]]);
                let pi = Vector3::new(row[c[3]], set.floor_height, row[c[5]]);
                f += fi;
                weighted += pi * fi.y;
                // Moment about the vertical through the origin of the floor.
                moment_y += pi.z * fi.x - pi.x * fi.z;
            }
            let cop = if f.y.abs() > 1e-9 {
                weighted / f.y
            } else {
                Vector3::new(f64::NAN, set.floor_height, f64::NAN)
            };
            // Free moment: the vertical moment left about the COP.
            let free = if f.y.abs() > 1e-9 {
                moment_y - (cop.z * f.x - cop.x * f.z)
            } else {
                0.0
            };
            out.force[s].push(f);
            out.cop[s].push(cop);
            out.free_moment[s].push(free);
        }
    }
    Ok(out)
}

/// The measured loads per foot at `times`: each ExternalForce is assigned
/// to the foot of the body it is applied to (`*_r` or `*_l`).
pub fn measured_foot_loads(
    loads: &ExternalLoads,
    model: &crate::model::Model,
    states: &crate::motion::states::States,
    times: &[f64],
) -> Result<FootLoads> {
    let mut data = Data::new(model);
    let mut out = FootLoads {
        time: times.to_vec(),
        ..Default::default()
    };
    for &t in times {
        let i = states
            .time
            .iter()
            .position(|&s| (s - t).abs() < 1e-9)
            .unwrap_or_else(|| crate::motion::coordinates::find_index(&states.time, t));
        data.q.copy_from_slice(&states.q[i]);
        data.u.copy_from_slice(&states.u[i]);
        kinematics::full(model, &mut data);
        let mut f = [Vector3::zeros(); 2];
        let mut cop = [Vector3::repeat(f64::NAN); 2];
        for ef in &loads.forces {
            let name = &model.bodies[ef.applied_to_body].name;
            let s = if name.ends_with("_l") { 1 } else { 0 };
            let (fe, pe, _) = ef.evaluate(t, &data);
            f[s] += fe;
            cop[s] = pe;
        }
        for s in 0..2 {
            out.force[s].push(f[s]);
            out.cop[s].push(cop[s]);
            out.free_moment[s].push(0.0);
        }
    }
    Ok(out)
}

/// Pearson rho, RMSE (N and % body weight) and peak error per foot and axis.
pub fn compare(pred: &FootLoads, meas: &FootLoads, body_weight: f64) -> Vec<AxisMetrics> {
    let mut out = Vec::new();
    for (s, side) in ['r', 'l'].into_iter().enumerate() {
        for (k, axis) in ['x', 'y', 'z'].into_iter().enumerate() {
            let a: Vec<f64> = pred.force[s].iter().map(|v| v[k]).collect();
            let b: Vec<f64> = meas.force[s].iter().map(|v| v[k]).collect();
            let n = a.len().max(1) as f64;
            let rmse = (a.iter().zip(&b).map(|(x, y)| (x - y).powi(2)).sum::<f64>() / n).sqrt();
            let peak = |v: &[f64]| {
                v.iter()
                    .fold(0.0f64, |m, x| if x.abs() > m.abs() { *x } else { m })
            };
            out.push(AxisMetrics {
                side,
                axis,
                rho: pearson(&a, &b),
                rmse_n: rmse,
                rmse_bw: 100.0 * rmse / body_weight,
                peak_error_n: peak(&a) - peak(&b),
            });
        }
    }
    out
}

/// Pearson's correlation coefficient (NaN for a constant series).
pub fn pearson(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma).powi(2);
        sbb += (y - mb).powi(2);
    }
    sab / (saa * sbb).sqrt()
}

fn write_foot_loads(loads: &FootLoads, path: &PathBuf, setup: &std::path::Path) -> Result<()> {
    let mut labels = Vec::new();
    for side in ['r', 'l'] {
        for what in [
            "force_vx",
            "force_vy",
            "force_vz",
            "cop_px",
            "cop_py",
            "cop_pz",
            "free_moment_ty",
        ] {
            labels.push(format!("{side}_{what}"));
        }
    }
    let mut w = StoWriter::create_for_setup(
        setup,
        path,
        "Predicted ground reactions",
        "Per foot: force on the foot (N, ground), centre of pressure on the floor (m, ground; NaN without load) and free moment about the floor normal (N m).\n",
        &labels,
        8,
        false,
    )?;
    for i in 0..loads.time.len() {
        let mut row = Vec::with_capacity(14);
        for s in 0..2 {
            let (f, p) = (loads.force[s][i], loads.cop[s][i]);
            let p = p.map(|x| if x.is_finite() { x } else { 0.0 });
            row.extend([f.x, f.y, f.z, p.x, p.y, p.z, loads.free_moment[s][i]]);
        }
        w.write_row(loads.time[i], &row)?;
    }
    w.finish()
}

fn write_metrics(metrics: &[AxisMetrics], path: &PathBuf) -> Result<()> {
    let err = |e: csv::Error| Error::input(Location::file(path), e.to_string());
    let mut w = csv::Writer::from_path(path).map_err(err)?;
    w.write_record([
        "foot",
        "axis",
        "rho",
        "rmse_N",
        "rmse_percent_bw",
        "peak_error_N",
    ])
    .map_err(err)?;
    for m in metrics {
        w.write_record([
            m.side.to_string(),
            m.axis.to_string(),
            format!("{:.4}", m.rho),
            format!("{:.2}", m.rmse_n),
            format!("{:.2}", m.rmse_bw),
            format!("{:.2}", m.peak_error_n),
        ])
        .map_err(err)?;
    }
    w.flush().map_err(|e| Error::io(path, e))
}
