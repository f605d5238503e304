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
pub use crate::contacts::floor::FloorMotion;
use crate::dynamics::{kinematics, Data};
use crate::error::{Error, Location, Result};
use crate::forces::external_loads::ExternalLoads;
use crate::parse::setup::AnalyzeSetup;
use crate::storage::{self, StoWriter};
use crate::tools::{analyze, RunOptions, RunSummary};

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
    /// Foot strikes and foot-offs found on the raw kinematics, and which
    /// strikes take over from the other foot ([`crate::contacts::events`]).
    pub events: crate::contacts::events::GaitEvents,
    pub predicted: FootLoads,
    pub measured: Option<FootLoads>,
    pub metrics: Vec<AxisMetrics>,
    /// Per foot: centre-of-pressure and event-timing errors over stance.
    pub stance: Vec<StanceMetrics>,
    pub body_weight: f64,
    /// The w0 the prediction ran with ([`DEFAULT_CONTACT_WEIGHT`] unless
    /// the setup gives one).
    pub contact_weight: f64,
    /// Per frame: time (s) and the root residual, the size of the summed
    /// force (N) of every actuator on the pelvis translations, residuals
    /// and reserves included.
    pub root_residual: Vec<(f64, f64)>,
    /// Set when the physics rejects the prediction (the root residual above
    /// [`REJECT_ROOT_RESIDUAL`] of body weight on more than
    /// [`REJECT_FRAME_SHARE`] of the frames): the line that says so. The
    /// tool then exits with status 3 ([`crate::tools::EXIT_FRAMES_FAILED`]).
    pub rejected: Option<String>,
}

/// A root residual above this share of body weight means the contacts did
/// not carry the body on that frame (issue 27).
pub const REJECT_ROOT_RESIDUAL: f64 = 0.25;
/// More than this share of the frames with such a root residual: the
/// prediction is not a result (exit status 3).
pub const REJECT_FRAME_SHARE: f64 = 0.05;

/// The frames whose root residual exceeds [`REJECT_ROOT_RESIDUAL`] of
/// `body_weight`, and the line that rejects the prediction when they are more
/// than [`REJECT_FRAME_SHARE`] of all frames (None: accepted). Every frame is
/// judged, flight included: in free fall the body needs no force, so a root
/// residual there means the motion asks for a force no contact can give (a
/// low-pass filter smears the stance's acceleration into the flight), and a
/// trial whose pelvis carries a quarter of body weight on more than 5 % of
/// its frames is not a result, whatever the cause (issue 27's bar).
/// `flight[i]`: no foot point of frame i is within reach of the floor; it
/// only splits the count in the message.
pub fn judge_root_residual(
    series: &[(f64, f64)],
    flight: &[bool],
    body_weight: f64,
) -> (Vec<f64>, Option<String>) {
    let judged = series;
    let over: Vec<(f64, f64)> = judged
        .iter()
        .copied()
        .filter(|&(_, f)| !(f <= REJECT_ROOT_RESIDUAL * body_weight))
        .collect();
    let over_in_flight = judged
        .iter()
        .enumerate()
        .filter(|&(i, &(_, f))| {
            flight.get(i).copied().unwrap_or(false) && !(f <= REJECT_ROOT_RESIDUAL * body_weight)
        })
        .count();
    let times: Vec<f64> = over.iter().map(|x| x.0).collect();
    if judged.is_empty() || (over.len() as f64) <= REJECT_FRAME_SHARE * judged.len() as f64 {
        return (times, None);
    }
    let worst = over.iter().copied().fold((f64::NAN, 0.0f64), |m, x| {
        if x.1 > m.1 || m.0.is_nan() {
            x
        } else {
            m
        }
    });
    let line = format!(
        "the prediction is rejected by the physics: on {} of {} frames ({:.0} %, more than {:.0} %) the root residual (every actuator on the pelvis translations) carried more than {:.0} % of body weight, up to {:.0} % at t = {:.3} s (first at t = {:.3} s, last at t = {:.3} s): {}; the comparison is written, but these forces are not a result; exit status {}",
        over.len(),
        judged.len(),
        100.0 * over.len() as f64 / judged.len() as f64,
        100.0 * REJECT_FRAME_SHARE,
        100.0 * REJECT_ROOT_RESIDUAL,
        100.0 * worst.1 / body_weight,
        worst.0,
        times[0],
        times[times.len() - 1],
        if 2 * over_in_flight > over.len() {
            format!(
                "the kinematics, not the contacts: {over_in_flight} of them are in flight, where no foot is within reach of the floor and a body in free fall needs no force, yet the filtered motion asks for it (its whole-body acceleration is not free fall there)"
            )
        } else if over_in_flight > 0 {
            format!(
                "the foot contacts did not carry the body there ({over_in_flight} of them in flight, where no foot is within reach of the floor: the filtered motion asks for force the body cannot get in free fall)"
            )
        } else {
            "the foot contacts did not carry the body there".to_string()
        },
        crate::tools::EXIT_FRAMES_FAILED
    );
    (times, Some(line))
}

fn n_flight_of(flight: &[bool]) -> usize {
    flight.iter().filter(|&&f| f).count()
}

/// The feet must carry the body over the trial: the mean over its frames of
/// the predicted vertical force of both feet is body weight (over a gait
/// cycle the body's mean vertical acceleration is nil; over one step within
/// a few %). Below (1 − [`REJECT_ROOT_RESIDUAL`]) of it the contacts did not
/// carry the body, whatever the frames judged one by one say (a floor put
/// too low makes every frame look like flight): the line that rejects the
/// prediction, else None.
pub fn judge_support(pred: &FootLoads, body_weight: f64, flight_frames: usize) -> Option<String> {
    let n = pred.time.len();
    if n == 0 || body_weight <= 0.0 {
        return None;
    }
    let mean = (0..n)
        .map(|i| pred.force[0][i].y + pred.force[1][i].y)
        .sum::<f64>()
        / n as f64;
    let share = mean / body_weight;
    (!(share >= 1.0 - REJECT_ROOT_RESIDUAL)).then(|| {
        format!(
            "the prediction is rejected by the physics: over the trial the feet carried {:.0} % of body weight on average (less than {:.0} %; {} of {} frames had no foot within reach of the floor): the foot contacts did not carry the body, the pelvis did; the comparison is written, but these forces are not a result; exit status {}",
            100.0 * share,
            100.0 * (1.0 - REJECT_ROOT_RESIDUAL),
            flight_frames,
            n,
            crate::tools::EXIT_FRAMES_FAILED
        )
    })
}

/// Per row of the contacts' table (`..._ContactForces.sto`): whether every
/// foot point is farther from its floor plane than the contact band
/// (d_tol + d_trans), where its weight w(d) is nil: nothing can touch.
fn flight_frames(path: &std::path::Path, set: &FootContactSet) -> Result<Vec<bool>> {
    let table = storage::read(path)?;
    let reach = set.parameters.contact_tolerance + set.parameters.transition_zone;
    let cols: Vec<usize> = set
        .points
        .iter()
        .map(|p| {
            table
                .column_index(&format!("{}_distance", p.name))
                .ok_or_else(|| {
                    Error::internal(format!("{}: no column {}_distance", path.display(), p.name))
                })
        })
        .collect::<Result<_>>()?;
    Ok(table
        .rows
        .iter()
        .map(|r| cols.iter().all(|&c| r[c] > reach))
        .collect())
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
    /// NaN when no frame has both feet's forces over the threshold.
    pub cop_error_mm: f64,
    /// NaN unless both the plates and the prediction have one.
    pub heel_strike_error_ms: f64,
    pub toe_off_error_ms: f64,
    /// How many heel strikes (toe-offs) the plates and the prediction show
    /// in the trial: (measured, predicted).
    pub heel_strikes: (usize, usize),
    pub toe_offs: (usize, usize),
}

impl StanceMetrics {
    /// The run's line for this foot, saying in words what has no number
    /// (e.g. a heel strike before the trial's first frame).
    pub fn summary(&self) -> String {
        let event = |what: &str, ms: f64, (measured, predicted): (usize, usize)| match (
            measured, predicted,
        ) {
            (0, 0) => format!("no {what} in the trial"),
            (0, n) => format!("{what}: none on the plates, {n} predicted"),
            (n, 0) => format!("{what}: {n} on the plates, none predicted"),
            _ => format!("{what} {ms:.0} ms"),
        };
        let cop = if self.cop_error_mm.is_finite() {
            format!(
                "centre of pressure off by {:.0} mm over stance",
                self.cop_error_mm
            )
        } else {
            "centre of pressure: no frame where both the plates and the prediction load the foot"
                .to_string()
        };
        format!(
            "foot {}: {cop}; {}, {}",
            self.side,
            event("heel strike", self.heel_strike_error_ms, self.heel_strikes),
            event("toe-off", self.toe_off_error_ms, self.toe_offs)
        )
    }
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
        heel_strikes: (mon.len(), pon.len()),
        toe_offs: (moff.len(), poff.len()),
    }
}

/// Predicted over measured, one panel per axis, both feet, and a fourth
/// panel with the root residual (% body weight) over time, the rejection
/// threshold and the measured stance windows of each foot (shaded); the
/// titles say which floor and belt were used.
fn draw_comparison(
    pred: &FootLoads,
    meas: &FootLoads,
    root_residual: &[(f64, f64)],
    body_weight: f64,
    floor: &str,
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
    let mut chart = Chart {
        title: format!("Root residual; floor: {floor}"),
        x_label: "time (s)".into(),
        y_label: "% body weight".into(),
        ..Chart::default()
    };
    let t: Vec<f64> = root_residual.iter().map(|x| x.0).collect();
    let limit = 100.0 * REJECT_ROOT_RESIDUAL;
    for (s, side) in ["right", "left"].iter().enumerate() {
        // Measured stance (vertical force above the stance threshold),
        // shaded from 0 to the rejection threshold.
        let on: Vec<bool> = meas.force[s]
            .iter()
            .map(|f| f.y > STANCE_THRESHOLD)
            .collect();
        let mut band = Series::new(
            format!("{side} stance, measured"),
            pred.time.clone(),
            vec![f64::NAN; pred.time.len()],
            Style::color(s),
        );
        band.band = Some((
            on.iter().map(|&o| if o { 0.0 } else { f64::NAN }).collect(),
            on.iter()
                .map(|&o| if o { limit } else { f64::NAN })
                .collect(),
        ));
        chart.series.push(band);
    }
    chart.series.push(Series::new(
        "root residual",
        t.clone(),
        root_residual
            .iter()
            .map(|x| 100.0 * x.1 / body_weight)
            .collect(),
        Style::color(2),
    ));
    if let (Some(&a), Some(&b)) = (t.first(), t.last()) {
        chart.series.push(Series::new(
            format!("rejection threshold ({limit:.0} %)"),
            vec![a, b],
            vec![limit, limit],
            Style::dashed(3),
        ));
    }
    panels.push(chart);
    crate::plots::write_panels(&panels, stem, Layout::column(4))
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
        Some(t) => Setup::parse_with(t, setup, opts.allow_unknown)?,
        None => Setup::read_with(setup, opts.allow_unknown)?,
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
    run_with(
        setup,
        opts,
        &FloorOptions {
            height: floor_height,
            motion: FloorMotion::Auto,
        },
    )
}

/// What the user says of the floor: its height (level, at rest) and how it
/// moves (`--floor-height`, `--overground`, `--treadmill`).
#[derive(Debug, Clone, Copy)]
pub struct FloorOptions {
    pub height: Option<f64>,
    pub motion: FloorMotion,
}

impl Default for FloorOptions {
    fn default() -> Self {
        FloorOptions {
            height: None,
            motion: FloorMotion::Auto,
        }
    }
}

/// `--treadmill SPEED` (m/s backward along the walking direction) or
/// `--treadmill VX,VY,VZ` (the belt's velocity in ground, m/s; commas or
/// spaces between).
pub fn parse_treadmill(text: &str) -> Result<FloorMotion> {
    let parts: Vec<&str> = text
        .split(|c: char| c == ',' || c.is_whitespace())
        .filter(|p| !p.is_empty())
        .collect();
    let nums: std::result::Result<Vec<f64>, _> = parts.iter().map(|p| p.parse::<f64>()).collect();
    let bad = || {
        Error::msg(format!(
            "--treadmill takes a speed (m/s, backward along the walking direction) or a velocity VX,VY,VZ (m/s, ground), found '{text}'"
        ))
    };
    match nums.map_err(|_| bad())?.as_slice() {
        [v] if v.is_finite() => Ok(FloorMotion::TreadmillSpeed(*v)),
        [x, y, z] if x.is_finite() && y.is_finite() && z.is_finite() => {
            Ok(FloorMotion::TreadmillVelocity(Vector3::new(*x, *y, *z)))
        }
        _ => Err(bad()),
    }
}

/// [`run`] with what the user says of the floor.
pub fn run_with(
    setup: &AnalyzeSetup,
    opts: &RunOptions,
    floor: &FloorOptions,
) -> Result<Prediction> {
    let floor_height = floor.height;
    if let FloorMotion::TreadmillSpeed(v) = floor.motion {
        if !v.is_finite() {
            return Err(Error::msg(format!(
                "the treadmill speed must be a finite number, found {v}"
            )));
        }
    }
    if let FloorMotion::TreadmillVelocity(v) = floor.motion {
        if !v.iter().all(|x| x.is_finite()) {
            return Err(Error::msg(format!(
                "the treadmill belt velocity must be finite, found ({}, {}, {})",
                v.x, v.y, v.z
            )));
        }
    }
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
    let reserves = take_reserve_actuators(&mut setup)?;
    // The model is parsed and compiled once: completed with the user's
    // force sets here, with the prediction's for the run below.
    let composed = crate::forces::analysis_model::load_composed_model_of(&setup)?;
    let am = crate::forces::analysis_model::with_force_sets(composed.clone(), &setup)?;
    let strength = torque_driven_strength(&am.forces, &am.model, reserves);
    let default_weight = match strength {
        Some(s) => DEFAULT_CONTACT_WEIGHT * (s / MUSCLE_STRENGTH_REFERENCE).powi(2),
        None => DEFAULT_CONTACT_WEIGHT,
    };
    let (contact_weight, given_weight) = use_contact_weight(&mut setup, default_weight);
    let model = am.model;
    // The motion is read once: for the feet here and for the run below.
    let motion = analyze::read_motion(&setup)?;
    let states = analyze::load_motion_states(&setup, &motion, &model, &[])?;
    let contacts = feet::build(
        &model,
        &states,
        (setup.initial_time, setup.final_time),
        floor_height,
        floor.motion,
        FootContactParameters::default(),
    )?;
    // Gait events on the raw (unfiltered) motion: when each foot lands.
    let raw_states = {
        let mut raw = setup.clone();
        raw.lowpass_cutoff = -1.0;
        analyze::load_motion_states(&raw, &motion, &model, &[])?
    };
    let gait_events = crate::contacts::events::detect(&model, &raw_states, &states, &contacts);
    let mut contacts = contacts;
    // The step-to-step transition of walking, for torque-driven models: a
    // muscle-driven model's effort minimum shares the load itself
    // (docs/grf_prediction.md, step 8).
    if strength.is_some() {
        crate::contacts::events::apply_transition(
            &model,
            &states,
            &gait_events,
            &mut contacts,
            contact_weight,
            ROOT_RESIDUAL_OPTIMAL_FORCE,
        );
    }
    let dir = analyze::results_dir(&setup, opts)?;
    // The prediction's plan: the user's, its force sets with the root
    // residuals replaced, plus the foot contacts, all in memory (the files
    // written here are the record of what ran, not read back).
    let contacts_file = dir.join(format!("{}_foot_contacts.xml", setup.name));
    let contacts_xml = contacts.force_set_xml();
    std::fs::write(&contacts_file, &contacts_xml).map_err(|e| Error::io(&contacts_file, e))?;
    let (force_sets, mut written) = weak_root_residuals(&setup, &model, &dir, reserves)?;
    setup.force_set_files.clear();
    setup.force_set_documents = force_sets;
    setup
        .force_set_documents
        .push(crate::forces::force_set_document(
            &contacts_xml,
            &contacts_file,
        )?);
    let run_model = crate::forces::analysis_model::with_force_sets(composed, &setup)?;
    let mut summary = analyze::run_prepared(&setup, &motion, run_model, opts)?;
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
        events: gait_events,
        predicted,
        measured: None,
        metrics: Vec::new(),
        stance: Vec::new(),
        body_weight,
        contact_weight,
        root_residual: Vec::new(),
        rejected: None,
    };
    prediction.summary.notes.push(match (given_weight, strength) {
        (true, _) => format!("contact weight w0 = {contact_weight} (the setup's <contact_weight>)"),
        (false, None) => format!("contact weight w0 = {contact_weight} (muscle-driven model: the default)"),
        (false, Some(s)) => format!(
            "contact weight w0 = {contact_weight:.3} (torque-driven model: its actuators make {s:.0} N m per unit of control per coordinate, against {MUSCLE_STRENGTH_REFERENCE:.0} N m of the muscle-driven models w0 = {DEFAULT_CONTACT_WEIGHT} was chosen on: w0 = {DEFAULT_CONTACT_WEIGHT} x ({s:.0}/{MUSCLE_STRENGTH_REFERENCE:.0})^2)"
        ),
    });
    for (s, side) in ['r', 'l'].into_iter().enumerate() {
        prediction.summary.notes.push(events_note(
            side,
            &prediction.events.feet[s],
            &prediction.contacts.off_intervals[s],
            strength.is_some(),
        ));
        prediction
            .summary
            .notes
            .extend(crate::contacts::events::targets_note(
                side,
                &prediction.contacts.force_target[s],
            ));
    }
    prediction.root_residual = prediction.summary.root_force_series.clone();
    let contact_table = dir.join(format!("{}_{}_ContactForces.sto", setup.name, so_name));
    let flight = flight_frames(&contact_table, &prediction.contacts)?;
    if flight.len() != prediction.root_residual.len() {
        return Err(Error::internal(format!(
            "{}: {} rows, {} frames solved",
            contact_table.display(),
            flight.len(),
            prediction.root_residual.len()
        )));
    }
    let (over, rejected) = judge_root_residual(&prediction.root_residual, &flight, body_weight);
    prediction.rejected = rejected
        .or_else(|| judge_support(&prediction.predicted, body_weight, n_flight_of(&flight)));
    let n_flight = flight.iter().filter(|&&f| f).count();
    let n = prediction.root_residual.len() - n_flight;
    let peak = |in_flight: bool| {
        prediction
            .root_residual
            .iter()
            .zip(&flight)
            .filter(|(_, &f)| f == in_flight)
            .fold(0.0f64, |m, (x, _)| m.max(x.1))
    };
    prediction.summary.notes.push(format!(
        "root residual (every actuator on the pelvis translations): above {:.0} % of body weight on {} of {} frames ({:.1} %); at most {:.1} % of body weight on the {} frames with a foot on the floor, {:.1} % on the {} frames in flight (no foot point within {:.3} m of the floor; in free fall nothing is required, so a residual there is what the filtered motion asks)",
        100.0 * REJECT_ROOT_RESIDUAL,
        over.len(),
        prediction.root_residual.len(),
        100.0 * over.len() as f64 / prediction.root_residual.len().max(1) as f64,
        100.0 * peak(false) / body_weight,
        n,
        100.0 * peak(true) / body_weight,
        n_flight,
        prediction.contacts.parameters.contact_tolerance + prediction.contacts.parameters.transition_zone,
    ));
    let rr = dir.join(format!("{}_root_residual.sto", setup.name));
    {
        let mut w = StoWriter::create_for_setup(
            &setup.setup_file,
            &rr,
            "Root residual",
            "Per frame: the size of the summed force of every actuator on the pelvis translations (N; residuals and reserves included) and as a share of body weight (%).\n",
            &["root_residual_force".to_string(), "root_residual_percent_bw".to_string()],
            8,
            false,
        )?;
        for &(t, f) in &prediction.root_residual {
            w.write_row(t, &[f, 100.0 * f / body_weight])?;
        }
        w.finish()?;
    }
    prediction.summary.files.push(rr);
    let out = dir.join(format!("{}_predicted_grf.sto", setup.name));
    write_foot_loads(&prediction.predicted, &out, &setup.setup_file)?;
    prediction.summary.files.push(out);
    // The prediction as an OpenSim ExternalLoads pair: the measured file's
    // layout when there is one, else one ExternalForce per foot with
    // OpenSim's usual names.
    let layout = match &measured_file {
        Some(mf) => crate::forces::external_loads::layout(mf)?,
        None => default_layout(),
    };
    let (mot, xml) = write_external_loads(
        &prediction.predicted,
        &layout,
        &dir,
        &setup.name,
        &setup.setup_file,
    )?;
    prediction.summary.files.extend([mot, xml]);
    if let Some(mf) = measured_file {
        let setup_dir = setup.dir();
        let loads = ExternalLoads::load(&mf, setup_dir, &model)?;
        let measured = measured_foot_loads(&loads, &model, &states, &prediction.predicted.time)?;
        // Steps on the wrong plate (a step across a split belt's seam) are
        // found and left out of the scores.
        let (samples, feet) = plate_samples(
            &loads,
            &model,
            &states,
            &prediction.predicted.time,
            &prediction.contacts.points,
        )?;
        let misplaced = crate::contacts::plates::misplaced_steps(&samples, &feet);
        let mut kept = vec![true; prediction.predicted.time.len()];
        for m in &misplaced {
            kept[m.first..=m.last].iter_mut().for_each(|k| *k = false);
        }
        if !misplaced.is_empty() {
            let t = &prediction.predicted.time;
            let steps: Vec<String> = misplaced
                .iter()
                .map(|m| {
                    format!(
                        "the plate of foot {} ({}) from t = {:.3} to {:.3} s",
                        if m.foot == 0 { 'r' } else { 'l' },
                        loads.forces[m.plate].name,
                        t[m.first],
                        t[m.last]
                    )
                })
                .collect();
            prediction.summary.warnings.push(format!(
                "measured plates: {} step(s) where a plate's centre of pressure lies under the other foot, so that it holds that foot's load or part of it (a step across the belts' seam): {}; the comparison leaves out those {} frames",
                misplaced.len(),
                steps.join("; "),
                kept.iter().filter(|k| !**k).count()
            ));
        }
        prediction.metrics = compare(
            &keep_frames(&prediction.predicted, &kept),
            &keep_frames(&measured, &kept),
            body_weight,
        );
        prediction.stance = ['r', 'l']
            .into_iter()
            .enumerate()
            .map(|(s, side)| stance_metrics(side, &prediction.predicted, &measured, s))
            .collect();
        let csv = dir.join(format!("{}_grf_comparison.csv", setup.name));
        write_metrics(&prediction.metrics, &prediction.stance, &csv)?;
        prediction.summary.files.push(csv);
        let stem = dir.join(format!("{}_grf_comparison", setup.name));
        prediction.summary.files.extend(draw_comparison(
            &prediction.predicted,
            &measured,
            &prediction.root_residual,
            body_weight,
            &prediction.contacts.decision.label(),
            &stem,
        )?);
        prediction.measured = Some(measured);
    }
    Ok(prediction)
}

/// The run's line on foot `side`'s gait events and the intervals its
/// contacts were off.
fn events_note(
    side: char,
    f: &crate::contacts::events::FootEvents,
    off: &[(f64, f64)],
    torque_driven: bool,
) -> String {
    let times = |v: &[f64]| {
        if v.is_empty() {
            "none".to_string()
        } else {
            v.iter()
                .map(|t| format!("{t:.3}"))
                .collect::<Vec<_>>()
                .join(", ")
        }
    };
    let off = if !torque_driven {
        "no step-to-step transition model (a muscle-driven model's effort minimum shares the load between the feet itself)".to_string()
    } else if off.is_empty() {
        "its contacts are never switched off (no strike takes over from a foot on the floor)"
            .to_string()
    } else {
        format!(
            "its contacts carry nothing over {} s (the swing before a strike that takes over from the other foot)",
            off.iter().map(|(a, b)| format!("[{a:.3}, {b:.3})")).collect::<Vec<_>>().join(", ")
        )
    };
    format!(
        "gait events of foot {side} on the unfiltered kinematics (walking events: Zeni et al. 2008, strikes refined by O'Connor et al. 2007; a strike only where the foot reaches the floor, so in running, where Zeni's heel extremum falls in late swing, none may be found): strikes at {} s, foot-offs at {} s; {off}",
        times(&f.strikes),
        times(&f.offs)
    )
}

/// w0 of the prediction when the setup's StaticOptimization gives none:
/// with the foot contacts' optimal force of 100 N, a body weight spread over
/// a dozen points costs about as much as the muscles' activations, so the
/// contacts' weight w(d) and their sum of squares shape the split between
/// the feet (with w0 = 1000 contacts are almost free and the optimiser
/// squeezes the feet against each other in double support; see
/// docs/grf_prediction.md).
pub const DEFAULT_CONTACT_WEIGHT: f64 = 10.0;

/// The strength of the muscles of the models [`DEFAULT_CONTACT_WEIGHT`]
/// was chosen on, per coordinate (N·m per unit of control): the size of the
/// generalized forces their muscles make at full activation,
/// sqrt(Σ (r_i F_max,i)²), over the lower limb's ten coordinates of the
/// Rajagopal model (moco_walk3d, OpenSim's moment arms over the trial):
/// 57 (hip rotation) to 354 N·m (ankle), geometric mean 188, rounded to 200.
pub const MUSCLE_STRENGTH_REFERENCE: f64 = 200.0;

/// A model whose joints are carried by coordinate actuators only (no
/// muscles: torque-driven, reserves only): the geometric mean over its
/// unconstrained coordinates but the root's of the actuators' strength
/// per coordinate, sqrt(Σ F_opt²) (N·m or N per unit of control; the
/// setup's reserves included). None when the model has muscles, or no such
/// actuator.
///
/// The objective weighs an actuator's generalized force τ as (τ/S)² and a
/// contact force f as (f/F0)²/w0: to keep the balance between the feet and
/// the joints that w0 was chosen with on muscle-driven models, a model
/// whose actuators are k times weaker gets w0/k² (see
/// docs/grf_prediction.md).
fn torque_driven_strength(
    forces: &[crate::xml::Element],
    model: &crate::model::Model,
    reserves: Option<f64>,
) -> Option<f64> {
    if forces.iter().any(|f| f.name.contains("Muscle")) {
        return None;
    }
    let mut sum2 = vec![0.0; model.nq()];
    for f in forces.iter().filter(|f| f.name == "CoordinateActuator") {
        let applies = f
            .child_text("appliesForce")
            .map(|t| t.trim() != "false")
            .unwrap_or(true);
        let coordinate = f.child_text("coordinate").unwrap_or("").trim();
        let fo: f64 = f
            .child_text("optimal_force")
            .and_then(|t| t.trim().parse().ok())
            .unwrap_or(1.0);
        if let (true, Some(c)) = (applies, model.coordinate_index(coordinate)) {
            sum2[c] += fo * fo;
        }
    }
    let (mut log_sum, mut n) = (0.0, 0usize);
    for c in 0..model.nq() {
        if model.coordinates[c].is_constrained() || model.is_root_coordinate(c) {
            continue;
        }
        let s2 = sum2[c] + reserves.map_or(0.0, |r| r * r);
        if s2 > 0.0 {
            log_sum += 0.5 * s2.ln();
            n += 1;
        }
    }
    (n > 0).then(|| (log_sum / n as f64).exp())
}

/// The setup's own `<contact_weight>` when its StaticOptimization has one
/// (then `(w0, true)`); otherwise `default`, written into the setup's
/// analysis (`(default, false)`).
fn use_contact_weight(setup: &mut AnalyzeSetup, default: f64) -> (f64, bool) {
    for a in setup.analyses.iter_mut() {
        if let crate::parse::setup::Analysis::StaticOptimization(so) = a {
            if so.contact_weights_given {
                if let Some(first) = so.contact_weights.first() {
                    return (*first, true);
                }
            }
            so.contact_weights = vec![default];
            return (default, false);
        }
    }
    (default, false)
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

/// Pose `data` at time `t`: the row of `states` at `t` (to 1e-9 s), else the
/// row `find_index` picks, and its full kinematics.
fn pose_at(
    model: &crate::model::Model,
    states: &crate::motion::states::States,
    t: f64,
    data: &mut Data,
) {
    let i = states
        .time
        .iter()
        .position(|&s| (s - t).abs() < 1e-9)
        .unwrap_or_else(|| crate::motion::coordinates::find_index(&states.time, t));
    data.q.copy_from_slice(&states.q[i]);
    data.u.copy_from_slice(&states.u[i]);
    kinematics::full(model, data);
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
        pose_at(model, states, t, &mut data);
        let mut plates = Vec::with_capacity(loads.forces.len());
        for ef in &loads.forces {
            let name = &model.bodies[ef.applied_to_body].name;
            let s = usize::from(name.ends_with("_l"));
            let (fe, pe, _) = ef.evaluate(t, &data)?;
            plates.push((s, fe, pe));
        }
        let (f, cop) = per_foot(&plates);
        for s in 0..2 {
            out.force[s].push(f[s]);
            out.cop[s].push(cop[s]);
            out.free_moment[s].push(0.0);
        }
    }
    Ok(out)
}

/// Per frame of `times`: every plate of `loads` (the foot of its body,
/// force and centre of pressure, ground) and the ground positions of each
/// foot's contact `points`, for [`crate::contacts::plates::misplaced_steps`].
#[allow(clippy::type_complexity)]
fn plate_samples(
    loads: &ExternalLoads,
    model: &crate::model::Model,
    states: &crate::motion::states::States,
    times: &[f64],
    points: &[crate::contacts::feet::FootPoint],
) -> Result<(
    Vec<Vec<crate::contacts::plates::PlateSample>>,
    Vec<[Vec<Vector3<f64>>; 2]>,
)> {
    let mut data = Data::new(model);
    let (mut plates, mut feet) = (
        Vec::with_capacity(times.len()),
        Vec::with_capacity(times.len()),
    );
    for &t in times {
        pose_at(model, states, t, &mut data);
        let mut row = Vec::with_capacity(loads.forces.len());
        for ef in &loads.forces {
            let name = &model.bodies[ef.applied_to_body].name;
            let (force, cop, _) = ef.evaluate(t, &data)?;
            row.push(crate::contacts::plates::PlateSample {
                foot: usize::from(name.ends_with("_l")),
                force,
                cop,
            });
        }
        plates.push(row);
        let mut f: [Vec<Vector3<f64>>; 2] = [Vec::new(), Vec::new()];
        for p in points {
            f[usize::from(p.side == 'l')].push(data.station_position(p.body, &p.local));
        }
        feet.push(f);
    }
    Ok((plates, feet))
}

/// `loads` at the frames where `kept` is true.
fn keep_frames(loads: &FootLoads, kept: &[bool]) -> FootLoads {
    let pick = |v: &[Vector3<f64>]| -> Vec<Vector3<f64>> {
        v.iter()
            .zip(kept)
            .filter(|(_, k)| **k)
            .map(|(x, _)| *x)
            .collect()
    };
    FootLoads {
        time: loads
            .time
            .iter()
            .zip(kept)
            .filter(|(_, k)| **k)
            .map(|(t, _)| *t)
            .collect(),
        force: [pick(&loads.force[0]), pick(&loads.force[1])],
        cop: [pick(&loads.cop[0]), pick(&loads.cop[1])],
        free_moment: [0, 1].map(|s| {
            loads.free_moment[s]
                .iter()
                .zip(kept)
                .filter(|(_, k)| **k)
                .map(|(x, _)| *x)
                .collect()
        }),
    }
}

/// Plates (foot 0 right / 1 left, force, centre of pressure; ground) summed
/// per foot: the forces added, the centres of pressure weighted by the
/// plates' vertical forces (NaN without vertical force).
fn per_foot(
    plates: &[(usize, Vector3<f64>, Vector3<f64>)],
) -> ([Vector3<f64>; 2], [Vector3<f64>; 2]) {
    let mut f = [Vector3::zeros(); 2];
    let mut weighted = [Vector3::zeros(); 2];
    let mut fy = [0.0; 2];
    for &(s, fe, pe) in plates {
        f[s] += fe;
        if pe.iter().all(|x| x.is_finite()) && fe.y.abs() > 1e-9 {
            weighted[s] += pe * fe.y;
            fy[s] += fe.y;
        }
    }
    let cop = [0, 1].map(|s| {
        if fy[s].abs() > 1e-9 {
            weighted[s] / fy[s]
        } else {
            Vector3::repeat(f64::NAN)
        }
    });
    (f, cop)
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

pub use crate::forces::external_loads::ForceLayout;

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
    name: &str,
    setup_file: &std::path::Path,
) -> Result<(PathBuf, PathBuf)> {
    let mot = dir.join(format!("{name}_predicted_grf.mot"));
    let xml = dir.join(format!("{name}_predicted_grf.xml"));
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
        setup_file,
        &mot,
        "predicted_grf",
        "Ground reactions predicted by statopt predict-grf (force N, point m, torque N m; ground frame).\n",
        &labels,
        8,
        false,
    )?;
    // Several plates under one foot: the first of them carries the foot's
    // loads, the others nothing (else the foot would be loaded twice).
    let first_of_foot: Vec<bool> = layout
        .iter()
        .enumerate()
        .map(|(k, f)| {
            let side = f.body.ends_with("_l");
            !layout[..k].iter().any(|g| g.body.ends_with("_l") == side)
        })
        .collect();
    for i in 0..loads.time.len() {
        let mut row = Vec::with_capacity(labels.len());
        for (f, &first) in layout.iter().zip(&first_of_foot) {
            let s = usize::from(f.body.ends_with("_l"));
            let gain = if first { 1.0 } else { 0.0 };
            let force = loads.force[s][i] * gain;
            let cop = loads.cop[s][i].map(|x| if x.is_finite() { x } else { 0.0 });
            if !f.force_identifier.is_empty() {
                row.extend(force.iter());
            }
            if !f.point_identifier.is_empty() {
                row.extend(cop.iter());
            }
            if !f.torque_identifier.is_empty() {
                row.extend([0.0, gain * loads.free_moment[s][i], 0.0]);
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

/// The StaticOptimization's `<reserve_actuators>` (statopt), taken out of
/// the setup: predict-grf adds the reserves itself, on every unconstrained
/// coordinate but the root's, whose actuators follow the one policy of
/// [`weak_root_residuals`] (a reserve of optimal force 10 or 100 on the
/// pelvis would carry the body as cheaply as the feet).
fn take_reserve_actuators(setup: &mut AnalyzeSetup) -> Result<Option<f64>> {
    for a in setup.analyses.iter_mut() {
        if let crate::parse::setup::Analysis::StaticOptimization(so) = a {
            // Checked (positive, finite) when the setup was read.
            return Ok(so.reserve_actuators.take());
        }
    }
    Ok(None)
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
/// is. Returns the force-set documents of the prediction's plan (each
/// file read once) and the files written.
fn weak_root_residuals(
    setup: &AnalyzeSetup,
    model: &crate::model::Model,
    dir: &std::path::Path,
    reserves: Option<f64>,
) -> Result<(Vec<crate::xml::Element>, Vec<PathBuf>)> {
    let mut documents = setup.force_set_documents.clone();
    for f in &setup.force_set_files {
        documents.push(crate::forces::read_force_set_document(f)?);
    }
    let roots: Vec<usize> = (0..model.nq())
        .filter(|&c| model.is_root_coordinate(c))
        .collect();
    if roots.is_empty() && reserves.is_none() {
        return Ok((documents, Vec::new()));
    }
    let root_body = roots
        .first()
        .map(|&c| model.bodies[model.coordinates[c].body].name.clone())
        .unwrap_or_default();
    let root_names: Vec<&str> = roots
        .iter()
        .map(|&c| model.coordinates[c].name.as_str())
        .collect();
    let mut written = Vec::new();
    for (k, doc) in documents.iter_mut().enumerate() {
        let Some(filtered) = crate::forces::without_root_actuators(doc, &root_names, &root_body)
        else {
            continue;
        };
        let out = dir.join(format!(
            "{}_force_set_{k}_without_root_residuals.xml",
            setup.name
        ));
        std::fs::write(&out, crate::tools::scene::to_xml_string(&filtered))
            .map_err(|e| Error::io(&out, e))?;
        written.push(out);
        *doc = filtered;
    }
    let mut xml = String::from("<?xml version=\"1.0\" encoding=\"UTF-8\" ?>\n<!-- Weak root residuals of statopt predict-grf (docs/grf_prediction.md). -->\n<OpenSimDocument Version=\"40000\">\n\t<ForceSet name=\"root_residuals\">\n\t\t<objects>\n");
    for name in &root_names {
        xml.push_str(&format!(
            "\t\t\t<CoordinateActuator name=\"{name}_residual\">\n\t\t\t\t<coordinate>{name}</coordinate>\n\t\t\t\t<optimal_force>{ROOT_RESIDUAL_OPTIMAL_FORCE}</optimal_force>\n\t\t\t\t<min_control>-Inf</min_control>\n\t\t\t\t<max_control>Inf</max_control>\n\t\t\t</CoordinateActuator>\n"
        ));
    }
    // The setup's <reserve_actuators>, on every unconstrained coordinate
    // but the root's (those are the weak residuals above).
    if let Some(f) = reserves {
        for c in (0..model.nq())
            .filter(|&c| !model.coordinates[c].is_constrained() && !model.is_root_coordinate(c))
        {
            let name = &model.coordinates[c].name;
            xml.push_str(&format!(
                "\t\t\t<CoordinateActuator name=\"{name}_reserve\">\n\t\t\t\t<coordinate>{name}</coordinate>\n\t\t\t\t<optimal_force>{f}</optimal_force>\n\t\t\t\t<min_control>-Inf</min_control>\n\t\t\t\t<max_control>Inf</max_control>\n\t\t\t</CoordinateActuator>\n"
            ));
        }
    }
    xml.push_str("\t\t</objects>\n\t</ForceSet>\n</OpenSimDocument>\n");
    let out = dir.join(format!("{}_root_residuals.xml", setup.name));
    std::fs::write(&out, &xml).map_err(|e| Error::io(&out, e))?;
    documents.push(crate::forces::force_set_document(&xml, &out)?);
    written.push(out);
    Ok((documents, written))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A foot already on the plate at the trial's first frame has no heel
    /// strike to time: the line says so in words, never "NaN ms".
    #[test]
    fn stance_line_says_what_has_no_number() {
        let time: Vec<f64> = (0..10).map(|i| 0.01 * i as f64).collect();
        let fy = |on: &dyn Fn(usize) -> bool| -> Vec<Vector3<f64>> {
            (0..10)
                .map(|i| Vector3::new(0.0, if on(i) { 500.0 } else { 0.0 }, 0.0))
                .collect()
        };
        let loads = |off_at: usize| FootLoads {
            time: time.clone(),
            force: [fy(&|i| i < off_at), fy(&|i| i >= 3)],
            cop: [vec![Vector3::zeros(); 10], vec![Vector3::zeros(); 10]],
            free_moment: [vec![0.0; 10], vec![0.0; 10]],
        };
        let (meas, pred) = (loads(6), loads(5));
        let right = stance_metrics('r', &pred, &meas, 0);
        assert_eq!(right.heel_strikes, (0, 0));
        assert_eq!(right.toe_offs, (1, 1));
        let line = right.summary();
        assert!(!line.contains("NaN"), "{line}");
        assert!(line.contains("no heel strike in the trial"), "{line}");
        assert!(line.contains("toe-off 10 ms"), "{line}");
        let left = stance_metrics('l', &pred, &meas, 1).summary();
        assert!(
            left.contains("heel strike 0 ms") && left.contains("no toe-off in the trial"),
            "{left}"
        );
        // Predicted but not measured.
        let mut late = loads(6);
        late.force[0] = fy(&|i| (2..6).contains(&i));
        let line = stance_metrics('r', &late, &meas, 0).summary();
        assert!(
            line.contains("heel strike: none on the plates, 1 predicted"),
            "{line}"
        );
    }

    /// The honesty bar: more than 5 % of the frames with a root residual
    /// above 25 % body weight rejects the prediction and names times of the
    /// trial; flight frames, where nothing is required, pass; so do a few
    /// bad frames.
    #[test]
    fn root_residual_judgement() {
        let bw = 700.0;
        // Running: stance carried by the feet, flight in free fall.
        let ok: Vec<(f64, f64)> = (0..100)
            .map(|i| (0.17 + 0.01 * i as f64, if i % 3 == 0 { 0.0 } else { 20.0 }))
            .collect();
        let none = vec![false; 100];
        let (over, rejected) = judge_root_residual(&ok, &none, bw);
        assert!(over.is_empty() && rejected.is_none());
        // Five bad frames in 100: accepted, the frames named.
        let mut few = ok.clone();
        for f in few.iter_mut().take(5) {
            f.1 = 300.0;
        }
        let (over, rejected) = judge_root_residual(&few, &none, bw);
        assert_eq!(over.len(), 5);
        assert!(rejected.is_none());
        // Six: rejected, and the line names times inside the trial.
        let mut bad = few.clone();
        bad[50].1 = 2000.0;
        let (_, rejected) = judge_root_residual(&bad, &none, bw);
        let line = rejected.expect("rejected");
        assert!(line.contains("6 of 100"), "{line}");
        assert!(line.contains("at t = 0.670 s"), "{line}");
        assert!(line.contains("first at t = 0.170 s"), "{line}");
        // A NaN residual counts as over.
        let mut nan = ok.clone();
        for f in nan.iter_mut().take(6) {
            f.1 = f64::NAN;
        }
        assert!(judge_root_residual(&nan, &none, bw).1.is_some());
        // Flight frames (no foot within reach of the floor) are judged too:
        // a filtered motion that asks 40 % of body weight there is not a
        // body in free fall, and the message says how many were in flight.
        let flight: Vec<bool> = (0..100).map(|i| i % 3 == 0).collect();
        let mut run = ok.clone();
        for (f, &fl) in run.iter_mut().zip(&flight) {
            if fl {
                f.1 = 0.4 * bw;
            }
        }
        assert!(judge_root_residual(&run, &none, bw).1.is_some());
        let line = judge_root_residual(&run, &flight, bw).1.expect("rejected");
        assert!(line.contains("34 of them are in flight"), "{line}");
        // Most of the frames over the line are in flight: the message
        // blames the kinematics, not the contacts (issue 36).
        assert!(line.contains("the kinematics, not the contacts"), "{line}");
        assert!(!line.contains("the foot contacts did not carry"), "{line}");
        // Flight frames asking nothing pass.
        assert!(judge_root_residual(&ok, &flight, bw).1.is_none());
        // A prediction with no force on feet that stand on the floor is
        // judged (those frames are not flight), and rejected.
        let collapsed: Vec<(f64, f64)> = (0..100).map(|i| (0.01 * i as f64, bw)).collect();
        let line = judge_root_residual(&collapsed, &none, bw)
            .1
            .expect("rejected");
        assert!(line.contains("100 of 100"), "{line}");
        assert!(
            line.contains("the foot contacts did not carry the body"),
            "{line}"
        );
    }

    /// Two plates under the right foot, one under the left: the foot's
    /// force is their sum and its centre of pressure the plates' weighted
    /// by their vertical forces (it was the last plate's).
    #[test]
    fn plates_under_one_foot_are_combined() {
        let plates = [
            (
                0,
                Vector3::new(10.0, 300.0, 0.0),
                Vector3::new(0.0, 0.0, 0.1),
            ),
            (
                0,
                Vector3::new(5.0, 100.0, 0.0),
                Vector3::new(0.4, 0.0, 0.1),
            ),
            (1, Vector3::new(0.0, 0.0, 0.0), Vector3::new(9.0, 0.0, 9.0)),
        ];
        let (f, cop) = per_foot(&plates);
        assert_eq!(f[0], Vector3::new(15.0, 400.0, 0.0));
        assert!(
            (cop[0] - Vector3::new(0.1, 0.0, 0.1)).norm() < 1e-12,
            "{cop:?}"
        );
        assert!(cop[1].x.is_nan(), "no load: no centre of pressure");
    }

    /// The predicted loads in a measured layout with three plates under the
    /// right foot (`ground_force_calcn_r` style names) and one under the
    /// left: each foot is loaded once (the first of its plates carries it),
    /// not once per plate.
    #[test]
    fn predicted_loads_load_each_foot_once_whatever_its_plates() {
        let tmp = crate::test_dir::TempDir::new("plates");
        let dir = tmp.path().to_path_buf();
        let plate = |name: &str, body: &str, id: &str| ForceLayout {
            name: name.into(),
            body: body.into(),
            force_identifier: format!("{id}_v"),
            point_identifier: format!("{id}_p"),
            torque_identifier: format!("{id}_m"),
        };
        let layout = [
            plate("r1", "calcn_r", "ground_force_calcn_r"),
            plate("r2", "calcn_r", "1_ground_force"),
            plate("l1", "calcn_l", "L_ground_force"),
            plate("r3", "calcn_r", "3_ground_force"),
        ];
        let loads = FootLoads {
            time: vec![0.0, 0.01],
            force: [
                vec![Vector3::new(1.0, 700.0, 2.0); 2],
                vec![Vector3::new(-1.0, 100.0, 0.0); 2],
            ],
            cop: [
                vec![Vector3::new(0.1, 0.0, 0.2); 2],
                vec![Vector3::zeros(); 2],
            ],
            free_moment: [vec![0.5; 2], vec![0.0; 2]],
        };
        let (mot, _) =
            write_external_loads(&loads, &layout, &dir, "t", &dir.join("setup.xml")).unwrap();
        let t = storage::read(&mot).unwrap();
        let sum = |ids: &[&str]| -> f64 {
            ids.iter()
                .map(|id| t.rows[0][t.column_index(&format!("{id}_vy")).unwrap()])
                .sum()
        };
        assert_eq!(
            sum(&["ground_force_calcn_r", "1_ground_force", "3_ground_force"]),
            700.0
        );
        assert_eq!(sum(&["L_ground_force"]), 100.0);
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// Feet that carry the body on average pass; a prediction whose every
    /// frame looks like flight (a floor put too low: no contact reaches it)
    /// is rejected by the mean support.
    #[test]
    fn the_feet_must_carry_the_body_on_average() {
        let bw = 700.0;
        let loads = |fy: f64| FootLoads {
            time: vec![0.0, 0.01, 0.02, 0.03],
            force: [
                vec![
                    Vector3::new(0.0, fy, 0.0),
                    Vector3::zeros(),
                    Vector3::new(0.0, 2.0 * fy, 0.0),
                    Vector3::zeros(),
                ],
                vec![
                    Vector3::new(0.0, fy, 0.0),
                    Vector3::new(0.0, fy, 0.0),
                    Vector3::zeros(),
                    Vector3::zeros(),
                ],
            ],
            ..Default::default()
        };
        // Mean (2 + 1 + 2 + 0) fy / 4 = 1.25 fy.
        assert!(judge_support(&loads(bw / 1.25), bw, 1).is_none());
        assert!(judge_support(&loads(0.8 * bw / 1.25), bw, 1).is_none());
        let line = judge_support(&loads(0.0), bw, 4).expect("rejected");
        assert!(
            line.contains("carried 0 %") && line.contains("4 of 4 frames"),
            "{line}"
        );
        // Everything in flight with the pelvis carrying the body: rejected
        // frame by frame as well.
        let series: Vec<(f64, f64)> = (0..4).map(|i| (0.01 * i as f64, bw)).collect();
        assert!(judge_root_residual(&series, &[true; 4], bw).1.is_some());
    }

    #[test]
    fn treadmill_option_reads_a_speed_or_a_vector() {
        assert_eq!(
            parse_treadmill("3").unwrap(),
            FloorMotion::TreadmillSpeed(3.0)
        );
        assert_eq!(
            parse_treadmill("-3,0,0.1").unwrap(),
            FloorMotion::TreadmillVelocity(Vector3::new(-3.0, 0.0, 0.1))
        );
        assert_eq!(
            parse_treadmill("-3 0 0").unwrap(),
            FloorMotion::TreadmillVelocity(Vector3::new(-3.0, 0.0, 0.0))
        );
        for bad in ["", "fast", "1,2", "nan", "1,2,inf"] {
            assert!(parse_treadmill(bad).is_err(), "{bad}");
        }
    }
}
