//! `statopt-tool predict-grf SETUP.xml`: ground reactions from kinematics
//! alone (issue 14; docs/grf_prediction.md).
//!
//! A thin driver over static optimization: the setup's `external_loads_file`
//! is not applied but kept as the measured reference; foot contacts built
//! from the model's feet and the motion ([`crate::contacts::feet`]) are
//! written to `<name>_foot_contacts.xml` in the results folder and added to
//! the setup's force-set files, whose root (pelvis) residuals are replaced
//! by weak ones ([`ROOT_RESIDUAL_OPTIMAL_FORCE`]); the setup runs as usual; the contacts'
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
    /// Per foot: centre-of-pressure and event-timing errors over stance.
    pub stance: Vec<StanceMetrics>,
    pub body_weight: f64,
    /// The w0 the prediction ran with ([`DEFAULT_CONTACT_WEIGHT`] unless
    /// the setup gives one).
    pub contact_weight: f64,
}

/// Stance: vertical force above this (N).
pub const STANCE_THRESHOLD: f64 = 20.0;

/// Per foot, over stance: mean centre-of-pressure error in the floor plane
/// (mm, frames where both vertical forces exceed [`STANCE_THRESHOLD`]) and
/// mean timing error of heel strikes and toe-offs (ms, each measured event
/// matched to the nearest predicted one of the same kind).
#[derive(Debug, Clone)]
pub struct StanceMetrics {
    pub side: char,
    pub cop_error_mm: f64,
    pub heel_strike_error_ms: f64,
    pub toe_off_error_ms: f64,
}

/// Times where the vertical force crosses the stance threshold upwards
/// (heel strike) and downwards (toe-off).
fn events(time: &[f64], fy: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let (mut on, mut off) = (Vec::new(), Vec::new());
    for i in 1..fy.len() {
        let (a, b) = (fy[i - 1] > STANCE_THRESHOLD, fy[i] > STANCE_THRESHOLD);
        if !a && b {
            on.push(time[i]);
        } else if a && !b {
            off.push(time[i]);
        }
    }
    (on, off)
}

fn event_error_ms(measured: &[f64], predicted: &[f64]) -> f64 {
    if measured.is_empty() || predicted.is_empty() {
        return f64::NAN;
    }
    let sum: f64 = measured
        .iter()
        .map(|m| {
            predicted
                .iter()
                .map(|p| (p - m).abs())
                .fold(f64::INFINITY, f64::min)
        })
        .sum();
    1000.0 * sum / measured.len() as f64
}

/// [`StanceMetrics`] of foot `s`.
pub fn stance_metrics(side: char, pred: &FootLoads, meas: &FootLoads, s: usize) -> StanceMetrics {
    let (mut sum, mut n) = (0.0, 0usize);
    for i in 0..pred.time.len() {
        if pred.force[s][i].y > STANCE_THRESHOLD && meas.force[s][i].y > STANCE_THRESHOLD {
            let (a, b) = (pred.cop[s][i], meas.cop[s][i]);
            let d = ((a.x - b.x).powi(2) + (a.z - b.z).powi(2)).sqrt();
            if d.is_finite() {
                sum += d;
                n += 1;
            }
        }
    }
    let fy = |l: &FootLoads| l.force[s].iter().map(|f| f.y).collect::<Vec<f64>>();
    let (pon, poff) = events(&pred.time, &fy(pred));
    let (mon, moff) = events(&meas.time, &fy(meas));
    StanceMetrics {
        side,
        cop_error_mm: if n > 0 {
            1000.0 * sum / n as f64
        } else {
            f64::NAN
        },
        heel_strike_error_ms: event_error_ms(&mon, &pon),
        toe_off_error_ms: event_error_ms(&moff, &poff),
    }
}

/// Predicted over measured, one panel per axis, both feet.
fn draw_comparison(
    pred: &FootLoads,
    meas: &FootLoads,
    stem: &std::path::Path,
) -> Result<Vec<PathBuf>> {
    use crate::plots::{Chart, Layout, Series, Style};
    let mut panels = Vec::new();
    for (k, axis) in ["anteroposterior (x)", "vertical (y)", "mediolateral (z)"]
        .iter()
        .enumerate()
    {
        let mut chart = Chart {
            title: format!("Ground reaction, {axis}"),
            x_label: "time (s)".into(),
            y_label: "force (N)".into(),
            ..Chart::default()
        };
        for (s, side) in ["right", "left"].iter().enumerate() {
            let y = |l: &FootLoads| l.force[s].iter().map(|f| f[k]).collect::<Vec<f64>>();
            chart.series.push(Series::new(
                format!("{side}, measured"),
                pred.time.clone(),
                y(meas),
                Style::dashed(s),
            ));
            chart.series.push(Series::new(
                format!("{side}, predicted"),
                pred.time.clone(),
                y(pred),
                Style::color(s),
            ));
        }
        panels.push(chart);
    }
    crate::plots::write_panels(&panels, stem, Layout::column(3))
}

/// `statopt-tool predict-grf SETUP`: read the setup file (or take it as
/// `text`, read as if it were that file; see `Setup::parse`) and run the
/// prediction.
pub fn run_setup(
    setup: &std::path::Path,
    text: Option<&str>,
    opts: &RunOptions,
) -> Result<Prediction> {
    use crate::parse::setup::Setup;
    let read = match text {
        Some(t) => Setup::parse(t, setup)?,
        None => Setup::read(setup)?,
    };
    match read {
        Setup::Analyze(s) => run(&s, opts),
        _ => Err(Error::msg(
            "predict-grf needs an AnalyzeTool setup with a StaticOptimization analysis",
        )),
    }
}

/// Run the prediction for an AnalyzeTool setup with a StaticOptimization;
/// the floor is found from the motion.
pub fn run(setup: &AnalyzeSetup, opts: &RunOptions) -> Result<Prediction> {
    run_with_floor(setup, opts, None)
}

/// [`run`] with the floor's height given (ground y, m; level, at rest):
/// every foot point's contact plane is that floor, and no contact levels or
/// slope are fitted (`statopt-tool predict-grf --floor-height Y`).
pub fn run_with_floor(
    setup: &AnalyzeSetup,
    opts: &RunOptions,
    floor_height: Option<f64>,
) -> Result<Prediction> {
    if let Some(f) = floor_height {
        if !f.is_finite() {
            return Err(Error::msg(format!(
                "the floor height must be a finite number, found {f}"
            )));
        }
    }
    if setup.analysis_element("StaticOptimization").is_none() {
        return Err(Error::input(
            Location::file(&setup.setup_file).with_element("<AnalysisSet>"),
            "predict-grf needs a StaticOptimization analysis in the setup",
        ));
    }
    let mut setup = setup.clone();
    let measured_file = setup.external_loads_file.take();
    let contact_weight = use_contact_weight(&mut setup);
    let am = loading::load_analysis_model(&setup)?;
    let model = am.model;
    let states = analyze::load_states(&setup, &model)?;
    let contacts = feet::build(
        &model,
        &states,
        floor_height,
        FootContactParameters::default(),
    )?;
    let dir = analyze::results_dir(&setup, opts)?;
    let contacts_file = dir.join(format!("{}_foot_contacts.xml", setup.name));
    std::fs::write(&contacts_file, contacts.force_set_xml())
        .map_err(|e| Error::io(&contacts_file, e))?;
    let (force_sets, mut written) = weak_root_residuals(&setup, &model, &dir)?;
    setup.force_set_files = force_sets;
    setup.force_set_files.push(contacts_file.clone());
    let mut summary = analyze::run(&setup, opts)?;
    summary.warnings.extend(contacts.warnings.iter().cloned());
    written.push(contacts_file);
    summary.files.extend(written);
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
        stance: Vec::new(),
        body_weight,
        contact_weight,
    };
    let out = dir.join(format!("{}_predicted_grf.sto", setup.name));
    write_foot_loads(&prediction.predicted, &out, &setup.setup_file)?;
    prediction.summary.files.push(out);
    // The prediction as an OpenSim ExternalLoads pair: the measured file's
    // layout when there is one, else one ExternalForce per foot with
    // OpenSim's usual names.
    let layout = match &measured_file {
        Some(mf) => external_forces_of(mf)?,
        None => default_layout(),
    };
    let (mot, xml) = write_external_loads(&prediction.predicted, &layout, &dir, &setup)?;
    prediction.summary.files.extend([mot, xml]);
    if let Some(mf) = measured_file {
        let setup_dir = setup.dir();
        let loads = ExternalLoads::load(&mf, setup_dir, &model)?;
        let measured = measured_foot_loads(&loads, &model, &states, &prediction.predicted.time)?;
        prediction.metrics = compare(&prediction.predicted, &measured, body_weight);
        prediction.stance = ['r', 'l']
            .into_iter()
            .enumerate()
            .map(|(s, side)| stance_metrics(side, &prediction.predicted, &measured, s))
            .collect();
        let csv = dir.join(format!("{}_grf_comparison.csv", setup.name));
        write_metrics(&prediction.metrics, &prediction.stance, &csv)?;
        prediction.summary.files.push(csv);
        let stem = dir.join(format!("{}_grf_comparison", setup.name));
        prediction
            .summary
            .files
            .extend(draw_comparison(&prediction.predicted, &measured, &stem)?);
        prediction.measured = Some(measured);
    }
    Ok(prediction)
}

/// w0 of the prediction when the setup's StaticOptimization gives none:
/// with the foot contacts' optimal force of 100 N, a body weight spread over
/// a dozen points costs about as much as the muscles' activations, so the
/// contacts' weight w(d) and their sum of squares shape the split between
/// the feet (with w0 = 1000 contacts are almost free and the optimiser
/// squeezes the feet against each other in double support; see
/// docs/grf_prediction.md).
pub const DEFAULT_CONTACT_WEIGHT: f64 = 10.0;

/// The setup's own `<contact_weight>` when its StaticOptimization has one;
/// otherwise [`DEFAULT_CONTACT_WEIGHT`], written into the setup's analysis.
fn use_contact_weight(setup: &mut AnalyzeSetup) -> f64 {
    for a in setup.analyses.iter_mut() {
        if let crate::parse::setup::Analysis::StaticOptimization(so) = a {
            if so.contact_weights_given {
                if let Some(first) = so.contact_weights.first() {
                    return *first;
                }
            }
            so.contact_weights = vec![DEFAULT_CONTACT_WEIGHT];
            return DEFAULT_CONTACT_WEIGHT;
        }
    }
    DEFAULT_CONTACT_WEIGHT
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
    let mut idx: [Vec<([usize; 6], &crate::contacts::feet::FootPoint)>; 2] =
        [Vec::new(), Vec::new()];
    for p in &set.points {
        let s = usize::from(p.side == 'l');
        let mut c = [0usize; 6];
        for (k, suffix) in ["vx", "vy", "vz", "px", "py", "pz"].iter().enumerate() {
            c[k] = col(&format!("{}_point_force_{suffix}", p.name))?;
        }
        idx[s].push((c, p));
    }
    for row in &table.rows {
        for s in 0..2 {
            let mut f = Vector3::zeros();
            let mut moment_y = 0.0;
            let mut weighted = Vector3::zeros();
            for (c, p) in &idx[s] {
                let fi = Vector3::new(row[c[0]], row[c[1]], row[c[2]]);
                // The point's projection on its floor plane (level through
                // its dwell position, the floor's slope).
                let (x, z) = (row[c[3]], row[c[5]]);
                let y = set.floor_height_under(p, x, z);
                let pi = Vector3::new(x, y, z);
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
            let (fe, pe, _) = ef.evaluate(t, &data)?;
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

fn write_foot_loads(
    loads: &FootLoads,
    path: &std::path::Path,
    setup: &std::path::Path,
) -> Result<()> {
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

fn write_metrics(metrics: &[AxisMetrics], stance: &[StanceMetrics], path: &PathBuf) -> Result<()> {
    let err = |e: csv::Error| Error::input(Location::file(path), e.to_string());
    let mut w = csv::Writer::from_path(path).map_err(err)?;
    w.write_record([
        "foot",
        "axis",
        "rho",
        "rmse_N",
        "rmse_percent_bw",
        "peak_error_N",
        "cop_error_mm",
        "heel_strike_error_ms",
        "toe_off_error_ms",
    ])
    .map_err(err)?;
    for m in metrics {
        let st = stance.iter().find(|s| s.side == m.side);
        let f = |v: Option<f64>| v.map(|x| format!("{x:.1}")).unwrap_or_default();
        w.write_record([
            m.side.to_string(),
            m.axis.to_string(),
            format!("{:.4}", m.rho),
            format!("{:.2}", m.rmse_n),
            format!("{:.2}", m.rmse_bw),
            format!("{:.2}", m.peak_error_n),
            f(st.map(|s| s.cop_error_mm)),
            f(st.map(|s| s.heel_strike_error_ms)),
            f(st.map(|s| s.toe_off_error_ms)),
        ])
        .map_err(err)?;
    }
    w.flush().map_err(|e| Error::io(path, e))
}

/// One ExternalForce of a layout: its name, the foot body it is applied to
/// and its data column identifiers.
#[derive(Debug, Clone)]
pub struct ForceLayout {
    pub name: String,
    pub body: String,
    pub force_identifier: String,
    pub point_identifier: String,
    pub torque_identifier: String,
}

/// The ExternalForces of a measured ExternalLoads file (their columns are
/// reused for the prediction).
fn external_forces_of(path: &std::path::Path) -> Result<Vec<ForceLayout>> {
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

/// OpenSim's usual names: right foot `ground_force_v`, left `1_ground_force_v`.
fn default_layout() -> Vec<ForceLayout> {
    [("right", "calcn_r", ""), ("left", "calcn_l", "1_")]
        .iter()
        .map(|(name, body, prefix)| ForceLayout {
            name: name.to_string(),
            body: body.to_string(),
            force_identifier: format!("{prefix}ground_force_v"),
            point_identifier: format!("{prefix}ground_force_p"),
            torque_identifier: format!("{prefix}ground_torque_"),
        })
        .collect()
}

/// Write `<name>_predicted_grf.mot` and `.xml`: per ExternalForce of the
/// layout, the predicted loads of the foot of its body (force and point in
/// ground, the free moment as a torque about the vertical).
fn write_external_loads(
    loads: &FootLoads,
    layout: &[ForceLayout],
    dir: &std::path::Path,
    setup: &AnalyzeSetup,
) -> Result<(PathBuf, PathBuf)> {
    let mot = dir.join(format!("{}_predicted_grf.mot", setup.name));
    let xml = dir.join(format!("{}_predicted_grf.xml", setup.name));
    let mut labels = Vec::new();
    for f in layout {
        for id in [
            &f.force_identifier,
            &f.point_identifier,
            &f.torque_identifier,
        ] {
            if !id.is_empty() {
                labels.extend(["x", "y", "z"].iter().map(|a| format!("{id}{a}")));
            }
        }
    }
    let mut w = StoWriter::create_for_setup(
        &setup.setup_file,
        &mot,
        "predicted_grf",
        "Ground reactions predicted by statopt predict-grf (force N, point m, torque N m; ground frame).\n",
        &labels,
        8,
        false,
    )?;
    for i in 0..loads.time.len() {
        let mut row = Vec::with_capacity(labels.len());
        for f in layout {
            let s = usize::from(f.body.ends_with("_l"));
            let force = loads.force[s][i];
            let cop = loads.cop[s][i].map(|x| if x.is_finite() { x } else { 0.0 });
            if !f.force_identifier.is_empty() {
                row.extend(force.iter());
            }
            if !f.point_identifier.is_empty() {
                row.extend(cop.iter());
            }
            if !f.torque_identifier.is_empty() {
                row.extend([0.0, loads.free_moment[s][i], 0.0]);
            }
        }
        w.write_row(loads.time[i], &row)?;
    }
    w.finish()?;
    let mut objects = String::new();
    for f in layout {
        objects.push_str(&format!(
            "\t\t\t<ExternalForce name=\"{}\">\n\t\t\t\t<applied_to_body>{}</applied_to_body>\n\t\t\t\t<force_expressed_in_body>ground</force_expressed_in_body>\n\t\t\t\t<point_expressed_in_body>ground</point_expressed_in_body>\n\t\t\t\t<force_identifier>{}</force_identifier>\n\t\t\t\t<point_identifier>{}</point_identifier>\n\t\t\t\t<torque_identifier>{}</torque_identifier>\n\t\t\t</ExternalForce>\n",
            f.name, f.body, f.force_identifier, f.point_identifier, f.torque_identifier
        ));
    }
    let datafile = mot
        .file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_default();
    let text = format!(
        "<?xml version=\"1.0\" encoding=\"UTF-8\" ?>\n<!-- Ground reactions predicted by statopt predict-grf; replaces the measured loads in an OpenSim or statopt setup. -->\n<OpenSimDocument Version=\"40000\">\n\t<ExternalLoads name=\"predicted_grf\">\n\t\t<objects>\n{objects}\t\t</objects>\n\t\t<groups />\n\t\t<datafile>{datafile}</datafile>\n\t</ExternalLoads>\n</OpenSimDocument>\n"
    );
    std::fs::write(&xml, text).map_err(|e| Error::io(&xml, e))?;
    Ok((mot, xml))
}

/// Optimal force (N or N·m) of the weak root residuals predict-grf uses: 100 N
/// on the pelvis costs as much as 100 muscles at full activation.
pub const ROOT_RESIDUAL_OPTIMAL_FORCE: f64 = 1.0;

/// One policy for the root (pelvis) residuals, whatever the setup defines:
/// in each force-set file the actuators acting on the root joint only (point
/// and torque actuators on the root body, coordinate actuators on its
/// coordinates) are dropped (a filtered copy is written to the results
/// folder), and one coordinate actuator per root coordinate, named
/// `<coordinate>_residual`, with [`ROOT_RESIDUAL_OPTIMAL_FORCE`], is added
/// in `<name>_root_residuals.xml`. The model's own ForceSet is left as it
/// is. Returns the force-set files to use and the files written.
fn weak_root_residuals(
    setup: &AnalyzeSetup,
    model: &crate::model::Model,
    dir: &std::path::Path,
) -> Result<(Vec<PathBuf>, Vec<PathBuf>)> {
    let roots: Vec<usize> = (0..model.nq())
        .filter(|&c| model.is_root_coordinate(c))
        .collect();
    if roots.is_empty() {
        return Ok((setup.force_set_files.clone(), Vec::new()));
    }
    let root_body = model.bodies[model.coordinates[roots[0]].body].name.clone();
    let root_names: Vec<&str> = roots
        .iter()
        .map(|&c| model.coordinates[c].name.as_str())
        .collect();
    let is_root_residual = |el: &crate::xml::Element| -> bool {
        let text = |n: &str| el.child_text(n).map(str::trim).unwrap_or("");
        let on_root_body = |n: &str| {
            let b = text(n);
            b == root_body || b.rsplit('/').next() == Some(root_body.as_str())
        };
        match el.name.as_str() {
            "CoordinateActuator" => root_names.contains(&text("coordinate")),
            "PointActuator" => on_root_body("body"),
            "TorqueActuator" => on_root_body("bodyA") || on_root_body("bodyB"),
            _ => false,
        }
    };
    let mut files = Vec::new();
    let mut written = Vec::new();
    for (k, f) in setup.force_set_files.iter().enumerate() {
        let mut root = crate::xml::parse_file(f)?;
        let mut removed = 0;
        let mut stack = vec![&mut root];
        while let Some(el) = stack.pop() {
            if el.name == "objects" {
                let before = el.children.len();
                el.children.retain(|c| !is_root_residual(c));
                removed += before - el.children.len();
            }
            stack.extend(el.children.iter_mut());
        }
        if removed == 0 {
            files.push(f.clone());
            continue;
        }
        let out = dir.join(format!(
            "{}_force_set_{k}_without_root_residuals.xml",
            setup.name
        ));
        std::fs::write(&out, crate::tools::scene::to_xml_string(&root))
            .map_err(|e| Error::io(&out, e))?;
        files.push(out.clone());
        written.push(out);
    }
    let mut xml = String::from("<?xml version=\"1.0\" encoding=\"UTF-8\" ?>\n<!-- Weak root residuals of statopt predict-grf (docs/grf_prediction.md). -->\n<OpenSimDocument Version=\"40000\">\n\t<ForceSet name=\"root_residuals\">\n\t\t<objects>\n");
    for name in &root_names {
        xml.push_str(&format!(
            "\t\t\t<CoordinateActuator name=\"{name}_residual\">\n\t\t\t\t<coordinate>{name}</coordinate>\n\t\t\t\t<optimal_force>{ROOT_RESIDUAL_OPTIMAL_FORCE}</optimal_force>\n\t\t\t\t<min_control>-Inf</min_control>\n\t\t\t\t<max_control>Inf</max_control>\n\t\t\t</CoordinateActuator>\n"
        ));
    }
    xml.push_str("\t\t</objects>\n\t</ForceSet>\n</OpenSimDocument>\n");
    let out = dir.join(format!("{}_root_residuals.xml", setup.name));
    std::fs::write(&out, xml).map_err(|e| Error::io(&out, e))?;
    files.push(out.clone());
    written.push(out);
    Ok((files, written))
}
