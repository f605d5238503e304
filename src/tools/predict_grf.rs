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
use crate::error::{Error, Location, Result};
use crate::forces::external_loads::ExternalLoads;
pub use crate::forces::root_residuals::{weak_root_residuals, ROOT_RESIDUAL_OPTIMAL_FORCE};
use crate::parse::setup::AnalyzeSetup;
use crate::tools::{analyze, inputs, RunOptions, RunSummary};
use crate::writers::grf::{
    write_external_loads, write_foot_loads, write_metrics, write_root_residual,
};
use crate::writers::names::{OutputKind, RunKey, Sweep};

use crate::contacts::ground::{flight_frames, keep_frames, plate_samples};
pub use crate::contacts::ground::{
    foot_loads_from_contacts, measured_foot_loads, torque_driven_strength, FootLoads,
    FOOT_CONTACT_WEIGHT, MUSCLE_STRENGTH_REFERENCE,
};
use crate::metrics::grf::n_flight_of;
pub use crate::metrics::grf::{
    compare, judge_root_residual, judge_support, pearson, stance_metrics, AxisMetrics,
    StanceMetrics, REJECT_FRAME_SHARE, REJECT_ROOT_RESIDUAL, STANCE_THRESHOLD,
};

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
    /// The w0 the prediction ran with ([`FOOT_CONTACT_WEIGHT`] unless
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
    let measured_file = setup.take_external_loads_file();
    let reserves = take_reserve_actuators(&mut setup)?;
    // The model is parsed and compiled once: completed with the user's
    // force sets here, with the prediction's for the run below.
    let composed = crate::forces::analysis_model::load_composed_model_of(&setup)?;
    let am = crate::forces::analysis_model::with_force_sets(composed.clone(), &setup)?;
    let strength = torque_driven_strength(&am.forces, &am.model, reserves);
    let toes = crate::contacts::ground::undriven_toe_coordinates(&am.forces, &am.model, reserves);
    let default_weight = match strength {
        Some(s) => FOOT_CONTACT_WEIGHT * (s / MUSCLE_STRENGTH_REFERENCE).powi(2),
        None => FOOT_CONTACT_WEIGHT,
    };
    let (contact_weight, given_weight) = use_contact_weight(&mut setup, default_weight)?;
    let model = am.model;
    // The motion is read once: for the feet here and for the run below.
    let motion = inputs::read_motion(&setup)?;
    let states = inputs::load_motion_states(&setup, &motion, &model, &[])?;
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
        raw.set_lowpass_cutoff(-1.0)?;
        inputs::load_motion_states(&raw, &motion, &model, &[])?
    };
    let gait_events = crate::contacts::events::detect(&model, &raw_states, &states, &contacts);
    let mut contacts = contacts;
    // The step-to-step transition of walking (docs/grf_prediction.md, step
    // 8): a torque-driven model's whole; a muscle-driven model's effort
    // minimum shares the vertical load itself, and it gets the heel-strike
    // impact and the trailing foot's leg line with Ren's mediolateral decay.
    if strength.is_some() {
        crate::contacts::events::apply_transition(
            &model,
            &states,
            &gait_events,
            &mut contacts,
            contact_weight,
            ROOT_RESIDUAL_OPTIMAL_FORCE,
        );
    } else {
        crate::contacts::events::apply_muscle_transition(
            &model,
            &states,
            &gait_events,
            &mut contacts,
            ROOT_RESIDUAL_OPTIMAL_FORCE,
        );
    }
    let dir = inputs::results_dir(&setup, opts)?;
    // The prediction's plan: the user's, its force sets with the root
    // residuals replaced, plus the foot contacts, all in memory (the files
    // written here are the record of what ran, not read back).
    let own = RunKey::setup(&setup.name, Sweep::Single);
    let contacts_file = dir.join(own.file(OutputKind::FootContacts));
    let contacts_xml = contacts.force_set_xml();
    crate::storage::results::write(&contacts_file, contacts_xml.clone().into_bytes())?;
    let (force_sets, mut written) =
        write_weak_root_residuals(&setup, &model, &dir, reserves, &toes)?;
    setup.set_force_set_documents(force_sets);
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
    let so_run = RunKey::analysis(&setup.name, &so_name, Sweep::Single);
    let loads_path = dir.join(so_run.file(OutputKind::ContactExternalLoads));
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
            "contact weight w0 = {contact_weight:.3} (torque-driven model: its actuators make {s:.0} N m per unit of control per coordinate, against {MUSCLE_STRENGTH_REFERENCE:.0} N m of the muscle-driven models w0 = {FOOT_CONTACT_WEIGHT} was chosen on: w0 = {FOOT_CONTACT_WEIGHT} x ({s:.0}/{MUSCLE_STRENGTH_REFERENCE:.0})^2)"
        ),
    });
    if !toes.is_empty() {
        prediction.summary.notes.push(format!(
            "toe joints {} carried by the plantar aponeurosis as well as the toe flexors: an actuator of {:.1} N m each (0.96 BW x 1 cm; docs/grf_prediction.md, step 5)",
            toes.iter().map(|&c| model.coordinates[c].name.as_str()).collect::<Vec<_>>().join(", "),
            crate::contacts::ground::plantar_aponeurosis_strength(&model)
        ));
    }
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
                strength.is_some(),
            ));
    }
    prediction.root_residual = prediction.summary.root_force_series.clone();
    let contact_table = dir.join(so_run.file(OutputKind::ContactForces));
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
    let rr = dir.join(own.file(OutputKind::RootResidual));
    write_root_residual(
        &prediction.root_residual,
        body_weight,
        &rr,
        &setup.setup_file,
    )?;
    prediction.summary.files.push(rr);
    let out = dir.join(own.file(OutputKind::PredictedGrf));
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
        let csv = dir.join(own.file(OutputKind::GrfComparison));
        write_metrics(&prediction.metrics, &prediction.stance, &csv)?;
        prediction.summary.files.push(csv);
        let stem = dir.join(own.file(OutputKind::GrfComparisonFigure));
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
    let times = |v: &[f64], what: &str, none: &str| {
        if v.is_empty() {
            none.to_string()
        } else {
            let t: Vec<String> = v.iter().map(|t| format!("{t:.3}")).collect();
            format!("{what} at {} s", t.join(", "))
        }
    };
    let off = if !torque_driven {
        "its contacts are never switched off (a muscle-driven model's effort minimum shares the vertical load between the feet itself)".to_string()
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
        "gait events of foot {side} on the unfiltered kinematics (walking events: Zeni et al. 2008, strikes refined by O'Connor et al. 2007; a strike only where the foot reaches the floor, so in running, where Zeni's heel extremum falls in late swing, none may be found): {}, {}; {off}",
        times(&f.strikes, "strikes", "no strike"),
        times(&f.offs, "foot-offs", "no foot-off")
    )
}

/// The setup's own `<contact_weight>` when its StaticOptimization has one
/// (then `(w0, true)`); otherwise `default`, written into the setup's
/// analysis (`(default, false)`).
fn use_contact_weight(setup: &mut AnalyzeSetup, default: f64) -> Result<(f64, bool)> {
    for a in setup.analyses.iter_mut() {
        if let crate::parse::setup::Analysis::StaticOptimization(so) = a {
            if so.contact_weights_given {
                if let Some(first) = so.contact_weights.first() {
                    return Ok((*first, true));
                }
            }
            so.set_default_contact_weight(default)?;
            return Ok((default, false));
        }
    }
    Ok((default, false))
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

/// The StaticOptimization's `<reserve_actuators>` (statopt), taken out of
/// the setup: predict-grf adds the reserves itself, on every unconstrained
/// coordinate but the root's, whose actuators follow the one policy of
/// [`weak_root_residuals`] (a reserve of optimal force 10 or 100 on the
/// pelvis would carry the body as cheaply as the feet).
fn take_reserve_actuators(setup: &mut AnalyzeSetup) -> Result<Option<f64>> {
    for a in setup.analyses.iter_mut() {
        if let crate::parse::setup::Analysis::StaticOptimization(so) = a {
            let reserves = so.reserve_actuators;
            so.set_reserve_actuators(None)?;
            return Ok(reserves);
        }
    }
    Ok(None)
}

/// [`weak_root_residuals`]'s documents, its filtered copies and its
/// `<name>_root_residuals.xml` written to the results folder `dir`.
/// Returns the force-set documents of the prediction's plan and the files
/// written.
fn write_weak_root_residuals(
    setup: &AnalyzeSetup,
    model: &crate::model::Model,
    dir: &std::path::Path,
    reserves: Option<f64>,
    toes: &[usize],
) -> Result<(Vec<crate::xml::Element>, Vec<PathBuf>)> {
    let policy = weak_root_residuals(
        &setup.force_set_documents,
        &setup.force_set_files,
        model,
        reserves,
        toes,
        crate::contacts::ground::plantar_aponeurosis_strength(model),
    )?;
    let mut documents = policy.documents;
    let mut written = Vec::new();
    let own = RunKey::setup(&setup.name, Sweep::Single);
    for &k in &policy.filtered {
        let out = dir.join(own.file(OutputKind::ForceSetWithoutRootResiduals(k)));
        let text = crate::tools::scene::to_xml_string(&documents[k]);
        crate::storage::results::write(&out, text.into_bytes())?;
        written.push(out);
    }
    if let Some(xml) = policy.residuals {
        let out = dir.join(own.file(OutputKind::RootResiduals));
        crate::storage::results::write(&out, xml.clone().into_bytes())?;
        documents.push(crate::forces::force_set_document(&xml, &out)?);
        written.push(out);
    }
    Ok((documents, written))
}

#[cfg(test)]
mod tests {
    use super::*;
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

    /// A foot with no strike or no foot-off in the trial is said so in
    /// words ("strikes at none s" before).
    #[test]
    fn the_events_line_says_when_a_foot_has_no_strike_or_foot_off() {
        let none = crate::contacts::events::FootEvents::default();
        let line = events_note('l', &none, &[], true);
        assert!(line.contains("no strike, no foot-off;"), "{line}");
        assert!(!line.contains("none s"), "{line}");
        let f = crate::contacts::events::FootEvents {
            strikes: vec![0.44],
            offs: vec![0.1, 1.25],
            transitions: vec![true],
        };
        let line = events_note('r', &f, &[(0.1, 0.44)], true);
        assert!(
            line.contains("strikes at 0.440 s, foot-offs at 0.100, 1.250 s;"),
            "{line}"
        );
    }
}
