//! What a run reads, opened for the frames: the setup's motion (read once,
//! [`read_motion`]), its states and state streams (filtered as OpenSim
//! filters them, the setup's `<close_contacts>` applied), with the time
//! range checked. The tools, the force-sweep engine (`sweep`) and the Python
//! binding open a run's motion here.

use crate::contacts::Contact;
use crate::error::{Error, Location, Result};
use crate::forces::analysis_model::{force_kind, load_analysis_model, ForceKind};
use crate::motion::filter::load_coordinates_in;
use crate::motion::states::States;
use crate::motion::stream::StateStream;
use crate::parse::setup::AnalyzeSetup;
use crate::storage::TableFile;

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
                    None => am.insert(load_analysis_model(setup)?),
                };
                let el = am
                    .forces
                    .iter()
                    .find(|f| {
                        f.attr("name") == Some(contact.as_str())
                            && force_kind(f) == ForceKind::Contact
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
