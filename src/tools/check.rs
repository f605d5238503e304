//! `statopt-tool SETUP --check`: read and compile everything a setup or a
//! study names (files, models, force sets, external loads, the motion, the
//! analyses' problems, a study's figure references) and report every problem
//! found, without solving a frame.
//!
//! Each stage that does not depend on an earlier one that failed is still
//! checked, so one pass lists everything that would stop a run.

use std::path::Path;

use crate::error::Error;
use crate::parse::figures::FigureOrMetric;
use crate::parse::setup::{
    missing_input_files, results_dir_problem, unknown_elements, Analysis, AnalyzeSetup,
    InverseDynamicsSetup, Setup,
};
use crate::tools::{analyze, joint_reaction, loading, static_optimization, study};

/// What a check found: errors (each would stop a run) and warnings.
#[derive(Debug, Default)]
pub struct CheckReport {
    pub errors: Vec<Error>,
    pub warnings: Vec<String>,
    /// Setups checked (a study's and the study's own document).
    pub checked: Vec<String>,
}

/// Check a setup or a study document; with `allow_unknown`
/// (`--allow-unknown`) elements neither OpenSim nor statopt knows are
/// warnings, as a run would read on past them.
pub fn run(path: &Path, allow_unknown: bool) -> CheckReport {
    let mut report = CheckReport::default();
    if crate::plan::is_study(path) {
        match crate::plan::StudyDocument::read(path) {
            Ok(mut doc) => {
                let unknown = std::mem::take(&mut doc.unknown);
                report.unknown(unknown, allow_unknown);
                if let Some(p) = results_dir_problem(&doc.results_directory) {
                    report.errors.push(Error::input(
                        doc.results_directory_loc.clone(),
                        format!(
                            "<results_directory> names {}, which {p}",
                            doc.results_directory.display()
                        ),
                    ));
                }
                // The study's setups and its force sweeps' setups.
                let mut files = doc.setup_files.clone();
                for p in &doc.sweep_setup_files {
                    if !files.contains(p) {
                        files.push(p.clone());
                    }
                }
                // Unknown elements are reported above and per setup below.
                if let Err(e) = crate::plan::StudyPlan::from_document(doc, true)
                    .and_then(|plan| study::check(&plan))
                {
                    report.errors.push(e);
                }
                // Every setup checked on its own, whatever the study's
                // problems.
                for s in files {
                    check_setup(&s, allow_unknown, &mut report);
                }
            }
            Err(e) => report.errors.push(e),
        }
        report.checked.push(path.display().to_string());
    } else {
        check_setup(path, allow_unknown, &mut report);
    }
    report
}

impl CheckReport {
    fn unknown(&mut self, unknown: Vec<Error>, allow_unknown: bool) {
        if allow_unknown {
            self.warnings.extend(
                unknown
                    .iter()
                    .map(|e| format!("{e} (read on: --allow-unknown)")),
            );
        } else {
            self.errors.extend(unknown);
        }
    }
}

/// A results folder a run could not write to, named with its element.
fn check_results_dir(dir: &Path, loc: &crate::error::Location, report: &mut CheckReport) {
    if let Some(p) = results_dir_problem(dir) {
        report.errors.push(Error::input(
            loc.clone(),
            format!("<results_directory> names {}, which {p}", dir.display()),
        ));
    }
}

fn check_setup(path: &Path, allow_unknown: bool, report: &mut CheckReport) {
    report.checked.push(path.display().to_string());
    match unknown_elements(path) {
        Ok(unknown) => report.unknown(unknown, allow_unknown),
        Err(e) => {
            report.errors.push(e);
            return;
        }
    }
    // Every missing file at once (reading the setup stops at the first).
    match missing_input_files(path) {
        Ok(missing) if !missing.is_empty() => {
            report.errors.extend(missing);
            return;
        }
        Ok(_) => {}
        Err(e) => {
            report.errors.push(e);
            return;
        }
    }
    // Unknown elements were reported above: read on past them here.
    match Setup::read_with(path, true) {
        Ok(Setup::Analyze(a)) => {
            check_results_dir(&a.results_directory, &a.results_directory_loc, report);
            check_analyze(&a, report);
        }
        Ok(Setup::InverseDynamics(i)) => {
            check_results_dir(&i.results_directory, &i.results_directory_loc, report);
            check_inverse_dynamics(&i, report);
        }
        Err(e) => report.errors.push(e),
    }
}

fn check_analyze(setup: &AnalyzeSetup, report: &mut CheckReport) {
    let am = match loading::load_analysis_model(setup) {
        Ok(am) => am,
        Err(e) => {
            report.errors.push(e);
            return;
        }
    };
    report.warnings.extend(am.warnings.iter().cloned());
    match analyze::open_state_stream(setup, &am.model) {
        Ok(stream) => {
            report.warnings.extend(stream.motion_warnings(&[]));
            report
                .warnings
                .extend(analyze::missing_columns_warning(setup, &stream.missing));
        }
        Err(e) => report.errors.push(e),
    }
    check_figure_references(setup, report);
    if !setup.analyses.iter().any(|a| a.common().on) {
        report.errors.push(Error::input(
            crate::error::Location::file(&setup.setup_file).with_element("<AnalysisSet>"),
            "the setup has no analysis that is on",
        ));
    }
    for a in &setup.analyses {
        match a {
            Analysis::StaticOptimization(so) => {
                match static_optimization::SoProblem::build_from(setup, so, am.clone()) {
                    Ok((problem, w)) => {
                        report.warnings.extend(w);
                        check_contact_sides(setup, &problem, report);
                    }
                    Err(e) => report.errors.push(e),
                }
            }
            // Without a forces file the reactions come from the setup's own
            // static optimization (checked above); a forces file from an
            // earlier run need not exist yet.
            Analysis::JointReaction(jr) if jr.forces_file.as_ref().is_some_and(|f| f.exists()) => {
                if let Err(e) = joint_reaction::JointReactionProblem::build(setup, jr) {
                    report.errors.push(e);
                }
            }
            Analysis::Unsupported { element, common } if common.on => {
                report.errors.push(element.error(format!(
                    "the analysis '{}' is not supported yet; supported: MuscleAnalysis, StaticOptimization, JointReaction",
                    element.name
                )));
            }
            _ => {}
        }
    }
}

fn check_inverse_dynamics(setup: &InverseDynamicsSetup, report: &mut CheckReport) {
    let (spec, model) = match loading::load_composed_model(&setup.model_file, &setup.artifact_files)
    {
        Ok(m) => m,
        Err(e) => {
            report.errors.push(e);
            return;
        }
    };
    let mut w = Vec::new();
    if let Err(e) =
        crate::tools::inverse_dynamics::check_forces(&spec, &setup.forces_to_exclude, &mut w)
    {
        report.errors.push(e);
    }
    report.warnings.extend(w);
    if let Some(p) = &setup.external_loads_file {
        let dir = setup.dir();
        if let Err(e) = crate::forces::external_loads::ExternalLoads::load(p, dir, &model) {
            report.errors.push(e);
        }
    }
    match crate::storage::read(&setup.coordinates_file) {
        Ok(raw) => match crate::motion::checks::motion_warnings(
            &model,
            &setup.coordinates_file,
            &raw.labels,
            &crate::motion::checks::TimeSteps::of(&raw.time),
            setup.lowpass_cutoff,
        ) {
            Ok(w) => report.warnings.extend(w),
            Err(e) => report.errors.push(e),
        },
        Err(e) => report.errors.push(e),
    }
}

/// The tables a setup's `<Figure>`s and `<Metric>`s name (relative to its
/// results directory, drawn after the run): each must be one this setup
/// writes (named after it; a w0 its static optimization runs) or exist
/// already.
fn check_figure_references(setup: &AnalyzeSetup, report: &mut CheckReport) {
    use crate::writers::names;
    let tags: Vec<String> = match setup.static_optimization() {
        Some(so) if so.contact_weights.len() > 1 => so
            .contact_weights
            .iter()
            .map(|w| names::w0_tag(*w))
            .chain(names::SWEEP_STATS.map(String::from))
            .collect(),
        _ => Vec::new(),
    };
    for r in setup.figures.iter().flat_map(FigureOrMetric::tables) {
        let (attr, value) = (r.attr, r.value);
        let path = crate::parse::setup::resolve(&setup.results_directory, value);
        let file = path.file_name().and_then(|f| f.to_str()).unwrap_or("");
        let ours = file.starts_with(&format!("{}_", setup.name))
            && path.parent() == Some(setup.results_directory.as_path());
        if !ours {
            if !path.is_file() {
                report.errors.push(Error::input(
                    r.loc.clone(),
                    format!(
                    "{attr}=\"{value}\": {} does not exist and is not a table this setup writes (its tables are named {}_... in its results directory)",
                    path.display(),
                    setup.name
                )));
            }
            continue;
        }
        if let Some(tag) = names::w0_tag_in(file) {
            if !tags.iter().any(|t| t == tag) {
                report.errors.push(Error::input(
                    r.loc.clone(),
                    format!(
                        "{attr}=\"{value}\": names w0 = {tag}, but the setup runs {}",
                        if tags.is_empty() {
                            "a single w0 (its tables carry no w0 in their names)".to_string()
                        } else {
                            format!("w0 = {}", tags[..tags.len() - 3].join(", "))
                        }
                    ),
                ));
            }
        }
    }
}

/// A contact whose plane faces away from its point's body: at the first
/// frame of the motion (the model's default pose when the motion cannot be
/// read), the point body's mass centre lies behind the plane (on the side
/// opposite its normal) by more than [`FACING_MARGIN`]. The contact pushes
/// its point body along the normal, away from the plane, so such a contact
/// would pull the body through it: every frame that needs it fails. A grip
/// is not reported: a contact with a partner between the same two bodies
/// whose normal points the other way and whose point lies within
/// [`GRIP_SPAN`] of its own (a hand holding a bar from both sides, as the
/// leg extension's handle_push and handle_hold do). Each named with the
/// contact's file and line.
fn check_contact_sides(
    setup: &AnalyzeSetup,
    problem: &static_optimization::SoProblem,
    report: &mut CheckReport,
) {
    report.errors.extend(contacts_facing_away(setup, problem));
}

/// The errors of [`check_contact_sides`] (`--check`'s, for a compiled
/// problem).
pub fn contacts_facing_away(
    setup: &AnalyzeSetup,
    problem: &static_optimization::SoProblem,
) -> Vec<Error> {
    let mut errors = Vec::new();
    if problem.contacts.is_empty() {
        return errors;
    }
    let model = &problem.model;
    let mut data = crate::dynamics::Data::new(model);
    let (q, when) = match analyze::open_state_stream_with(setup, model, &problem.contacts)
        .and_then(|mut s| s.next_block())
    {
        Ok(Some(block)) if !block.q.is_empty() => (
            block.q[0].clone(),
            format!(
                "at the first frame (t = {})",
                crate::storage::fmt_time(block.time[0])
            ),
        ),
        _ => (
            model.coordinates.iter().map(|c| c.default_value).collect(),
            "in the model's default pose".to_string(),
        ),
    };
    data.q.copy_from_slice(&q);
    crate::dynamics::kinematics::positions(model, &mut data);
    let ground = |c: &crate::contacts::Contact| {
        (
            data.rotation[c.plane_body] * c.normal,
            data.station_position(c.point_body, &c.point),
        )
    };
    for c in &problem.contacts {
        let Some((d_point, d_com)) = c.sides(model, &data) else {
            continue;
        };
        if d_com >= -FACING_MARGIN {
            continue;
        }
        let (n, p) = ground(c);
        let grip = problem.contacts.iter().any(|o| {
            let (n_o, p_o) = ground(o);
            o.point_body == c.point_body
                && o.plane_body == c.plane_body
                && n_o.dot(&n) < 0.0
                && (p_o - p).norm() <= GRIP_SPAN
        });
        if grip {
            continue;
        }
        errors.push(Error::input(
            c.loc.clone(),
            format!(
                "contact {}: its plane faces away from its point's body {}: {when} the body's mass centre lies {:.1} mm behind the plane (the point {:.1} mm {}), but a contact pushes its point body along the plane normal, away from the plane, so it would pull the body through the plane and every frame that needs it fails; flip <plane_normal> (or check the plane's body and origin)",
                c.name,
                model.bodies[c.point_body].name,
                -1e3 * d_com,
                1e3 * d_point.abs(),
                if d_point >= 0.0 { "in front of it" } else { "behind it" },
            ),
        ));
    }
    errors
}

/// How far (m) behind a contact's plane its point body's mass centre must
/// lie for `--check` to report the plane as facing away from the body: a
/// mass centre within 1 mm of the plane says nothing of the side (the same
/// millimetre the run's summary allows a loaded contact into its plane).
const FACING_MARGIN: f64 = 1e-3;

/// Two contacts of one body on one plane body with opposite normals and
/// points at most this far apart (m) are a grip, not a plane facing away:
/// both sides of a bar a hand holds lie within a hand's breadth (8 cm for
/// an adult, e.g. the hand breadth of ANSUR II, about 8.5–9 cm at the
/// metacarpals; the leg extension's grips use one point for both sides).
const GRIP_SPAN: f64 = 0.05;
