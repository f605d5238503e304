//! OpenSim's InverseDynamicsTool: q, u, u̇ from one quintic spline per
//! coordinate (S, S', S''), external loads and gravity applied, generalized
//! forces from RNEA ignoring constraints, written in multibody-tree order as
//! `<coordinate>_moment` (rotational) or `<coordinate>_force`. The states are
//! streamed window by window (`motion::stream`, `StatesKind::InverseDynamics`):
//! memory does not grow with the trial.

use crate::dynamics::{kinematics, rnea, Data};
use crate::error::{Error, Result};
use crate::forces::external_loads::ExternalLoads;
use crate::model::{Model, MotionType};
use crate::motion::coordinates::CoordinateSplines;
use crate::motion::stream::StateStream;
use crate::parse::osim::ModelSpec;
use crate::parse::setup::InverseDynamicsSetup;
use crate::storage::StoWriter;
use crate::tools::loading::{applies_force, force_kind, load_composed_model, ForceKind};
use crate::tools::{RunOptions, RunSummary};

/// Output column labels, tree order.
pub fn labels(model: &Model) -> Vec<String> {
    model
        .coordinates
        .iter()
        .map(|c| {
            format!(
                "{}{}",
                c.name,
                if c.motion_type == MotionType::Rotational {
                    "_moment"
                } else {
                    "_force"
                }
            )
        })
        .collect()
}

/// Check which model forces remain after `forces_to_exclude` and refuse those
/// this tool cannot evaluate. Returns whether external loads stay included.
pub(crate) fn check_forces(
    spec: &ModelSpec,
    exclude: &[String],
    warnings: &mut Vec<String>,
) -> Result<bool> {
    let upper: Vec<String> = exclude.iter().map(|s| s.to_uppercase()).collect();
    // OpenSim: "could not find Force or ForceSet group named ... to be excluded".
    for name in exclude {
        let known = ["ALL", "MUSCLES", "ACTUATORS"].contains(&name.to_uppercase().as_str())
            || spec.forces.iter().any(|f| f.name_attr() == name)
            || spec.force_groups.iter().any(|g| g == name);
        if !known {
            warnings.push(format!(
                "forces_to_exclude: '{name}' matches no force and no ForceSet group of the model (nor All, Muscles, Actuators), so it excludes nothing; check its spelling"
            ));
        }
    }
    if upper.iter().any(|s| s == "ALL") {
        return Ok(false);
    }
    for f in &spec.forces {
        if !applies_force(f)? {
            continue;
        }
        let kind = force_kind(f);
        let excluded = exclude.iter().any(|n| n == f.name_attr())
            || (kind == ForceKind::Muscle
                && upper.iter().any(|s| s == "MUSCLES" || s == "ACTUATORS"))
            || (kind == ForceKind::Actuator && upper.iter().any(|s| s == "ACTUATORS"));
        if excluded {
            continue;
        }
        match kind {
            // Without controls an actuator produces no force, as in OpenSim.
            ForceKind::Actuator => {}
            ForceKind::Muscle => {
                return Err(f.error(
                    "muscles must be excluded from inverse dynamics (forces_to_exclude: Muscles); statopt does not evaluate muscle forces from default states",
                ))
            }
            ForceKind::Contact => {
                return Err(f.error("contact elements have no force in inverse dynamics; exclude them or run static optimization"))
            }
            ForceKind::Other => {
                return Err(f.error(format!("force type '{}' is not supported by statopt's inverse dynamics yet; exclude it with forces_to_exclude", f.name)))
            }
        }
    }
    Ok(true)
}

pub fn run(setup: &InverseDynamicsSetup, opts: &RunOptions) -> Result<RunSummary> {
    let (spec, model) = load_composed_model(&setup.model_file, &setup.artifact_files)?;
    let mut warnings: Vec<String> = setup.warnings.clone();
    warnings.extend(model.warnings.iter().cloned());
    for (what, loc) in &spec.unsupported {
        warnings.push(format!("{loc}: {what} is not supported and was ignored"));
    }
    let use_loads = check_forces(&spec, &setup.forces_to_exclude, &mut warnings)?;
    let setup_dir = setup.dir();
    let loads = match (&setup.external_loads_file, use_loads) {
        (Some(p), true) => {
            let mut l = ExternalLoads::load(p, setup_dir, &model)?;
            l.scale(&setup.external_load_scales)?;
            Some(l)
        }
        _ if !setup.external_load_scales.is_empty() => {
            return Err(crate::Error::input(
                crate::Location::file(&setup.setup_file).with_element("external_loads_file"),
                "external load scales: the setup applies no external loads",
            ))
        }
        _ => None,
    };
    // q, u, u̇ streamed window by window from the (filtered) coordinates'
    // quintic splines (`StatesKind::InverseDynamics`): memory stays flat
    // however long the trial.
    let (t0, t1) = setup.time_range;
    // The coordinates file is read once; the stream's passes parse its bytes.
    let motion = crate::storage::TableFile::read(&setup.coordinates_file)?;
    let mut stream =
        StateStream::open_in(&model, &motion, setup.lowpass_cutoff, t0, t1)?.for_inverse_dynamics();
    warnings.extend(stream.motion_warnings(&[]));
    let (file_first, file_last) = stream.file_times;
    warnings.extend(crate::motion::checks::time_range_warnings(
        &setup.setup_file,
        &setup.coordinates_file,
        t0,
        t1,
        file_first,
        file_last,
    ));
    if !stream.missing.is_empty() {
        warnings.push(format!(
            "{}: no column for coordinates {:?}; using their default values, as OpenSim's InverseDynamicsTool does",
            setup.coordinates_file.display(),
            stream.missing
        ));
    }
    let (first, last) = (stream.first_time, stream.last_time);
    if t0 > last || t1 < first {
        return Err(Error::input(
            crate::Location::file(&setup.setup_file).with_element("<time_range>"),
            format!(
                "time_range [{t0}, {t1}] lies outside the data of {} ([{first}, {last}])",
                setup.coordinates_file.display()
            ),
        ));
    }
    let (i0, i1) = (stream.first_row, stream.last_row);
    // The first block before the output file is created: what the splines
    // refuse is said before an earlier run's table is overwritten.
    let first_block = stream.next_block()?;
    let mut frames = crate::frame::driver::PreparingLoads::new(
        crate::frame::driver::Prefetched::new(first_block, &mut stream),
        loads.as_ref(),
    );

    let dir = opts
        .results_dir
        .clone()
        .unwrap_or_else(|| setup.results_directory.clone());
    crate::parse::setup::create_results_dir(
        &dir,
        &setup.results_directory_loc,
        opts.results_dir.is_some(),
    )?;
    use crate::writers::names::{file_name, OutputKind, RunKey, Sweep};
    let key = RunKey::setup(&setup.name, Sweep::Single).key(OutputKind::InverseDynamics {
        file: setup.output_gen_force_file.clone(),
    });
    let out = dir.join(file_name(&key));
    let mut writer = StoWriter::create_for_setup(
        &setup.setup_file,
        &out,
        "Inverse Dynamics Generalized Forces",
        "",
        &labels(&model),
        opts.precision.unwrap_or(8),
        false,
    )?;
    if !setup.joints_to_report_body_forces.is_empty() && setup.output_body_forces_file.is_some() {
        warnings.push("joints_to_report_body_forces: the body-forces-at-joints file is not written by statopt yet".into());
    }
    // The frame driver every analysis uses: frames in parallel chunks,
    // written in order; a stop request ends the run after a whole chunk.
    let mut last_t = None;
    let mut written = 0usize;
    let completed = crate::frame::driver::for_each_frame(
        &mut frames,
        i0,
        i1,
        1,
        || Data::new(&model),
        |data, block, k| {
            let t = block.time[k];
            data.q.copy_from_slice(&block.q[k]);
            data.u.copy_from_slice(&block.u[k]);
            data.udot.copy_from_slice(&block.udot[k]);
            inverse_dynamics_at_state(&model, loads.as_ref(), t, data);
            Ok((t, data.tau.clone()))
        },
        |(t, tau)| {
            last_t = Some(t);
            written += 1;
            writer.write_row(t, &tau)
        },
    )?;
    writer.finish()?;
    let stopped =
        (!completed).then(|| (crate::frame::interrupt::requested().unwrap_or(130), last_t));
    Ok(RunSummary {
        // After a stop, the frames written (the table holds them).
        frames: if completed { i1 + 1 - i0 } else { written },
        stopped,
        results_dirs: vec![dir.clone()],
        files: vec![out],
        warnings,
        unused_properties: setup.unused_properties.clone(),
        ..Default::default()
    })
}

/// One frame of the InverseDynamicsTool: result in `data.tau`.
pub fn inverse_dynamics_frame(
    model: &Model,
    loads: Option<&ExternalLoads>,
    splines: &CoordinateSplines,
    t: f64,
    data: &mut Data,
) {
    splines.eval(t, &mut data.q, &mut data.u, &mut data.udot);
    inverse_dynamics_at_state(model, loads, t, data);
}

/// One frame of the InverseDynamicsTool at the q, u, u̇ already in `data`.
pub fn inverse_dynamics_at_state(
    model: &Model,
    loads: Option<&ExternalLoads>,
    t: f64,
    data: &mut Data,
) {
    kinematics::full(model, data);
    data.clear_applied();
    if let Some(l) = loads {
        l.apply(t, data);
    }
    rnea::inverse_dynamics_after_kinematics(model, data, true);
}
