//! OpenSim's AnalyzeTool: build the states from the coordinates file, select
//! the frames (rows i0..=i1 of the states table; opensim-semantics.md §9.3),
//! and run each analysis of the setup on them.

use crate::contacts::Contact;
use crate::error::{Error, Location, Result};
pub use crate::frame::driver::{for_each_frame, frame_rows, is_frame};
use crate::motion::states::States;
use crate::motion::stream::StateStream;
use crate::parse::setup::{Analysis, AnalyzeSetup};
use crate::storage::TableFile;
use crate::tools::loading::{load_coordinates_in, AnalysisModel};
use crate::tools::{joint_reaction, muscle_analysis, static_optimization, RunOptions, RunSummary};

/// The setup's coordinates file, refusing states and speeds files.
fn coordinates_file(setup: &AnalyzeSetup) -> Result<&std::path::Path> {
    if let Some(sf) = &setup.states_file {
        return Err(Error::input(
            Location::file(&setup.setup_file).with_element("<states_file>"),
            format!(
                "states files ({}) are not supported yet; give a <coordinates_file>",
                sf.display()
            ),
        ));
    }
    if let Some(sp) = &setup.speeds_file {
        return Err(Error::input(
            Location::file(&setup.setup_file).with_element("<speeds_file>"),
            format!(
                "speeds files ({}) are not supported yet; speeds are computed from the coordinates",
                sp.display()
            ),
        ));
    }
    setup
        .coordinates_file
        .as_deref()
        .ok_or_else(|| Error::input(Location::file(&setup.setup_file), "no <coordinates_file>"))
}

fn check_time_range(
    setup: &AnalyzeSetup,
    file: &std::path::Path,
    first: f64,
    last: f64,
) -> Result<()> {
    if setup.initial_time > last || setup.final_time < first {
        return Err(Error::input(
            Location::file(&setup.setup_file).with_element("<initial_time>/<final_time>"),
            format!(
                "[{}, {}] lies outside the data of {} ([{first}, {last}])",
                setup.initial_time,
                setup.final_time,
                file.display()
            ),
        ));
    }
    Ok(())
}

/// The setup's coordinates file, read once for the whole run
/// ([`TableFile::read`]): the driver of a run ([`run`], predict-grf, force
/// sweeps) reads it and hands it to every reader of the motion.
pub fn read_motion(setup: &AnalyzeSetup) -> Result<TableFile> {
    TableFile::read(coordinates_file(setup)?)
}

/// Read the setup's motion into states.
pub fn load_states(setup: &AnalyzeSetup, model: &crate::model::Model) -> Result<States> {
    load_states_with(setup, model, &[])
}

/// [`load_states`], taking the contacts `<close_contacts>` names from
/// `contacts` (compiled against `model`) when they are there, rather than
/// reading the model's force elements again.
pub fn load_states_with(
    setup: &AnalyzeSetup,
    model: &crate::model::Model,
    contacts: &[Contact],
) -> Result<States> {
    load_motion_states(setup, &read_motion(setup)?, model, contacts)
}

/// [`load_states_with`] on the run's motion, `motion` (the setup's
/// coordinates file, [`read_motion`]).
pub fn load_motion_states(
    setup: &AnalyzeSetup,
    motion: &TableFile,
    model: &crate::model::Model,
    contacts: &[Contact],
) -> Result<States> {
    let file = motion.path();
    let mut table = load_coordinates_in(motion, setup.lowpass_cutoff)?;
    if !setup.close_contacts.is_empty() {
        close_setup_contacts(setup, model, contacts, &mut table)?;
    }
    let states =
        States::from_coordinates_with_degree(model, &table, file, setup.coordinate_spline)?;
    let (first, last) = (states.time[0], states.time[states.time.len() - 1]);
    check_time_range(setup, file, first, last)?;
    Ok(states)
}

/// The setup's motion as a [`StateStream`] over the frames from
/// `initial_time` to `final_time` (the same states as [`load_states`] and
/// `States::speed_derivatives`, block by block; see `motion::stream`).
/// With `<close_contacts>` the closure is applied to the rows as they are
/// streamed (`contacts::closure::StreamClosure`, from the file's first row:
/// a coordinate the file lacks starts each row from the row before); only a
/// resampled motion (non-uniform times, filtered) computes its states in
/// memory ([`load_states`]) and hands them out as one block.
pub fn open_state_stream<'m>(
    setup: &AnalyzeSetup,
    model: &'m crate::model::Model,
) -> Result<StateStream<'m>> {
    open_state_stream_with(setup, model, &[])
}

/// [`open_state_stream`] with the run's compiled contacts (see
/// [`load_states_with`]).
pub fn open_state_stream_with<'m>(
    setup: &AnalyzeSetup,
    model: &'m crate::model::Model,
    contacts: &[Contact],
) -> Result<StateStream<'m>> {
    open_motion_stream(setup, &read_motion(setup)?, model, contacts)
}

/// [`open_state_stream_with`] on the run's motion, `motion` (the setup's
/// coordinates file, [`read_motion`]): the stream, and the in-memory
/// fallback, parse its bytes; the file is not opened again.
pub fn open_motion_stream<'m>(
    setup: &AnalyzeSetup,
    motion: &TableFile,
    model: &'m crate::model::Model,
    contacts: &[Contact],
) -> Result<StateStream<'m>> {
    let file = motion.path();
    let opened = StateStream::open_in(
        model,
        motion,
        setup.lowpass_cutoff,
        setup.initial_time,
        setup.final_time,
    )?
    .with_spline_degree(setup.coordinate_spline);
    check_time_range(setup, file, opened.first_time, opened.last_time)?;
    let mut stream = if setup.close_contacts.is_empty() {
        opened
    } else {
        // The closure streamed with the states (`contacts::closure::
        // StreamClosure`), unless the motion is resampled (then in memory).
        let closures = setup_closures(setup, model, contacts)?;
        let continued: Vec<bool> = closures
            .iter()
            .map(|(_, c)| opened.carried_columns()[*c].is_none())
            .collect();
        let added: Vec<usize> = closures.iter().map(|(_, c)| *c).collect();
        let context = format!("{}: <close_contacts>", setup.setup_file.display());
        let streamed = opened.with_row_transform(&added, move |columns| {
            Box::new(crate::contacts::closure::StreamClosure::new(
                model,
                closures,
                continued,
                columns.to_vec(),
                context,
            ))
        });
        match streamed {
            Ok(stream) => stream,
            Err(_) => {
                let states = load_motion_states(setup, motion, model, contacts)?;
                let udot = states.speed_derivatives(file)?;
                let mut stream = StateStream::in_memory(
                    model,
                    states,
                    udot,
                    setup.initial_time,
                    setup.final_time,
                );
                let raw = crate::storage::read_file(motion)?;
                stream.warnings = crate::motion::checks::time_warnings(
                    file,
                    &crate::motion::checks::TimeSteps::of(&raw.time),
                    setup.lowpass_cutoff,
                )?;
                stream.unmatched_columns =
                    crate::motion::checks::unmatched_columns(model, &raw.labels);
                stream
            }
        }
    };
    let range = crate::motion::checks::time_range_warnings(
        &setup.setup_file,
        file,
        setup.initial_time,
        setup.final_time,
        stream.first_time,
        stream.last_time,
    );
    stream.warnings.extend(range);
    Ok(stream)
}

/// Run the setup's analyses. The coordinates file is read once
/// ([`read_motion`]) and every analysis reads the motion from those bytes.
pub fn run(setup: &AnalyzeSetup, opts: &RunOptions) -> Result<RunSummary> {
    run_in(setup, None, None, opts)
}

/// [`run`] on the run's motion, `motion`, already read by the caller (the
/// setup's coordinates file, [`read_motion`]; predict-grf reads it once
/// for its feet and its run).
pub fn run_motion(
    setup: &AnalyzeSetup,
    motion: &TableFile,
    opts: &RunOptions,
) -> Result<RunSummary> {
    run_in(setup, Some(motion), None, opts)
}

/// [`run_motion`] on the model the caller loaded for this setup (its force
/// sets included: `forces::analysis_model::with_force_sets`), which every
/// analysis then runs on (predict-grf loads its model once).
pub fn run_prepared(
    setup: &AnalyzeSetup,
    motion: &TableFile,
    model: AnalysisModel,
    opts: &RunOptions,
) -> Result<RunSummary> {
    run_in(setup, Some(motion), Some(model), opts)
}

fn run_in(
    setup: &AnalyzeSetup,
    motion: Option<&TableFile>,
    model: Option<AnalysisModel>,
    opts: &RunOptions,
) -> Result<RunSummary> {
    // The tables the setup's figures and metrics name, before the first
    // frame (a figure naming a table the run does not write used to fail
    // only after every table was written).
    let out = opts
        .results_dir
        .clone()
        .unwrap_or_else(|| setup.results_directory.clone());
    if let Some(e) = crate::tools::check::figure_reference_problems(setup, &out)
        .into_iter()
        .next()
    {
        return Err(e);
    }
    // The figures and metrics read them from the run's kept outputs.
    crate::tools::study::want_tables(&setup.figures, &out);
    let run =
        crate::frame::threads::in_pool(opts.threads, || run_analyses(setup, motion, model, opts));
    run.and_then(|mut summary| {
        if !setup.figures.is_empty() && summary.stopped.is_none() {
            // Figures read the run's tables: their paths are relative to the results directory.
            let out = results_dir(setup, opts)?;
            summary.files.extend(crate::tools::study::draw(
                &setup.figures,
                &out,
                &out,
                &setup.name,
                &Default::default(),
            )?);
            crate::tools::study::tables_read(&setup.figures, &out);
        }
        Ok(summary)
    })
}

/// The JointReactions of `analyses` that take each frame's
/// StaticOptimization solution directly: those without a forces_file, when
/// the setup runs a StaticOptimization (`has_so`).
pub fn coupled_reactions<'a>(
    analyses: impl IntoIterator<Item = &'a Analysis>,
    has_so: bool,
) -> Vec<joint_reaction::JointReactionSetup> {
    analyses
        .into_iter()
        .filter_map(|a| match a {
            Analysis::JointReaction(jr) if has_so && jr.forces_file.is_none() => {
                Some((**jr).clone())
            }
            _ => None,
        })
        .collect()
}

fn run_analyses(
    setup: &AnalyzeSetup,
    motion: Option<&TableFile>,
    model: Option<AnalysisModel>,
    opts: &RunOptions,
) -> Result<RunSummary> {
    let mut summary = RunSummary {
        warnings: setup.warnings.clone(),
        unused_properties: setup.unused_properties.clone(),
        ..Default::default()
    };
    let active: Vec<&Analysis> = setup.analyses.iter().filter(|a| a.common().on).collect();
    if active.is_empty() {
        return Err(Error::input(
            Location::file(&setup.setup_file).with_element("<AnalysisSet>"),
            "the setup has no analysis that is on",
        ));
    }
    // A JointReaction without a forces_file in a setup that also runs
    // StaticOptimization takes each frame's solution directly.
    let has_so = active
        .iter()
        .any(|a| matches!(a, Analysis::StaticOptimization(_)));
    let coupled = coupled_reactions(active.iter().copied(), has_so);
    // The motion, read once for every analysis below.
    let motion = match motion {
        Some(m) => m.clone(),
        None => read_motion(setup)?,
    };
    // The model with its force set, loaded once when several analyses run
    // on it; a single analysis loads its own (static optimization reads
    // the external loads on a second thread meanwhile).
    let on_model = active
        .iter()
        .filter(|a| match a {
            Analysis::MuscleAnalysis(_)
            | Analysis::StaticOptimization(_)
            | Analysis::Kinematics(_) => true,
            Analysis::JointReaction(jr) => !coupled.iter().any(|c| c.common.name == jr.common.name),
            Analysis::Unsupported { .. } => false,
        })
        .count();
    let shared = match model {
        Some(am) => Some(am),
        None if on_model > 1 => Some(crate::tools::loading::load_analysis_model(setup)?),
        None => None,
    };
    let model = shared.as_ref();
    // A JointReaction's forces file may be this run's force table: kept
    // in memory until the JointReaction has read it (`storage::results`).
    let forces_file = |a: &Analysis| match a {
        Analysis::JointReaction(jr) => jr.forces_file.clone(),
        _ => None,
    };
    let forces_files: Vec<_> = active.iter().filter_map(|a| forces_file(a)).collect();
    forces_files
        .iter()
        .for_each(|f| crate::storage::results::want(f));
    for a in active {
        match a {
            Analysis::MuscleAnalysis(m) => {
                let s = muscle_analysis::run(setup, m, &motion, model, opts)?;
                summary.absorb(s, None);
                if summary.stopped.is_some() {
                    return Ok(summary);
                }
            }
            Analysis::StaticOptimization(so) => {
                let s = static_optimization::run(setup, so, &coupled, &motion, model, opts)?;
                summary.absorb(s, None);
                if summary.stopped.is_some() {
                    return Ok(summary);
                }
            }
            Analysis::JointReaction(jr) => {
                if coupled.iter().any(|c| c.common.name == jr.common.name) {
                    continue; // computed inside static optimization
                }
                let s = joint_reaction::run(setup, jr, &motion, model, opts)?;
                if let Some(f) = &jr.forces_file {
                    crate::storage::results::done(f);
                }
                summary.absorb(s, None);
                if summary.stopped.is_some() {
                    return Ok(summary);
                }
            }
            Analysis::Kinematics(k) => {
                let s = crate::tools::kinematics::run(setup, k, &motion, model, opts)?;
                summary.absorb(s, None);
                if summary.stopped.is_some() {
                    return Ok(summary);
                }
            }
            Analysis::Unsupported { element, .. } => {
                return Err(element.error(format!(
                    "the analysis '{}' is not supported yet; supported: MuscleAnalysis, StaticOptimization, JointReaction, BodyKinematics, PointKinematics",
                    element.name
                )));
            }
        }
    }
    Ok(summary)
}

/// The warning for the model's coordinates the motion file has no column
/// for (None: it has them all), naming the file.
pub fn missing_columns_warning(setup: &AnalyzeSetup, missing: &[String]) -> Option<String> {
    if missing.is_empty() {
        return None;
    }
    let file = setup
        .coordinates_file
        .as_ref()
        .or(setup.states_file.as_ref())
        .map(|f| f.display().to_string())
        .unwrap_or_default();
    Some(format!(
        "{file}: no column for the coordinate{} {}; {} set to 0 on every row, as OpenSim's AnalyzeTool does",
        if missing.len() == 1 { "" } else { "s" },
        missing.join(", "),
        if missing.len() == 1 { "it is" } else { "they are" }
    ))
}

/// The results directory: the command-line override or the setup's.
pub fn results_dir(setup: &AnalyzeSetup, opts: &RunOptions) -> Result<std::path::PathBuf> {
    let dir = opts
        .results_dir
        .clone()
        .unwrap_or_else(|| setup.results_directory.clone());
    crate::parse::setup::create_results_dir(
        &dir,
        &setup.results_directory_loc,
        opts.results_dir.is_some(),
    )?;
    Ok(dir)
}

/// Apply the setup's `<close_contacts>`: the contacts come from `known`
/// (the run's compiled contacts) or else from the model's and the force-set
/// files' force elements, read only when needed.
fn close_setup_contacts(
    setup: &AnalyzeSetup,
    model: &crate::model::Model,
    known: &[Contact],
    table: &mut crate::storage::Storage,
) -> Result<()> {
    let closures = setup_closures(setup, model, known)?;
    crate::contacts::closure::close_contacts(model, table, &closures)
        .map_err(|e| e.context(format!("{}: <close_contacts>", setup.setup_file.display())))
}

/// The setup's `<close_contacts>`: each contact (from `known`, the run's
/// compiled contacts, or else from the model's and the force-set files'
/// force elements, read only when needed) and the coordinate it closes.
fn setup_closures(
    setup: &AnalyzeSetup,
    model: &crate::model::Model,
    known: &[Contact],
) -> Result<Vec<(Contact, usize)>> {
    let at = || {
        setup
            .close_contacts_loc
            .clone()
            .unwrap_or_else(|| Location::file(&setup.setup_file).with_element("<close_contacts>"))
    };
    let mut am = None;
    let mut closures = Vec::new();
    for (contact, coordinate) in &setup.close_contacts {
        let c = match known.iter().find(|c| &c.name == contact) {
            Some(c) => c.clone(),
            None => {
                let am = match &am {
                    Some(am) => am,
                    None => am.insert(crate::tools::loading::load_analysis_model(setup)?),
                };
                let el = am
                    .forces
                    .iter()
                    .find(|f| {
                        f.attr("name") == Some(contact.as_str())
                            && crate::tools::loading::force_kind(f)
                                == crate::tools::loading::ForceKind::Contact
                    })
                    .ok_or_else(|| {
                        Error::input(
                            at(),
                            format!(
                                "no contact named '{contact}' in the model or its force-set files"
                            ),
                        )
                    })?;
                crate::contacts::Contact::from_xml(el, model)?
                    .ok_or_else(|| Error::input(at(), format!("'{contact}' is not a contact")))?
            }
        };
        let k = model
            .coordinate_index(coordinate)
            .ok_or_else(|| Error::input(at(), format!("no coordinate named '{coordinate}'")))?;
        closures.push((c, k));
    }
    Ok(closures)
}
