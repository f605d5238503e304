//! OpenSim's MuscleAnalysis: per frame, each muscle's length, lengthening
//! speed, moment arms about the listed coordinates, and its strength (maximum
//! active fiber force and passive fiber force with a rigid tendon), written
//! as `<name>_<analysis>_Length.sto`, `_LengtheningSpeed.sto`,
//! `_MomentArm_<coordinate>.sto`, `_MaxActiveFiberForceRigidTendon.sto`,
//! `_PassiveFiberForceRigidTendon.sto`. Moment arms are analytic (path
//! Jacobians through the coupling vectors), not perturbations.

use crate::dynamics::kinematics;
use crate::error::Result;
use crate::frame::driver::write_each_frame;
use crate::frame::workspace::Workspace;
use crate::muscles::set::MuscleSet;
use crate::parse::setup::{AnalyzeSetup, MuscleAnalysisSetup};
use crate::storage::StoWriter;
use crate::storage::TableFile;
use crate::tools::inputs::{open_motion_stream, results_dir};
use crate::tools::loading::{load_analysis_model, AnalysisModel};
use crate::tools::{RunOptions, RunSummary};
use crate::writers::names::{MuscleTable, OutputKind, RunKey, Sweep};

fn select<'a>(list: &[String], all: impl Iterator<Item = &'a str>) -> Vec<String> {
    if list.iter().any(|s| s.eq_ignore_ascii_case("all")) {
        all.map(str::to_string).collect()
    } else {
        list.to_vec()
    }
}

pub fn run(
    setup: &AnalyzeSetup,
    ma: &MuscleAnalysisSetup,
    motion: &TableFile,
    model: Option<&AnalysisModel>,
    opts: &RunOptions,
) -> Result<RunSummary> {
    let AnalysisModel {
        model,
        spec,
        forces,
        mut warnings,
    } = match model {
        Some(am) => am.clone(),
        None => load_analysis_model(setup)?,
    };
    let set = MuscleSet::compile(&spec, &forces, &model)?;
    // States streamed block by block (motion::stream): flat memory.
    let mut stream = open_motion_stream(setup, motion, &model, &[])?;
    warnings.extend(stream.motion_warnings(&[]));
    warnings.extend(crate::tools::inputs::missing_columns_warning(
        setup,
        &stream.missing,
    ));
    // Muscles and coordinates to report.
    let names = select(
        &ma.muscle_list,
        set.muscles.iter().map(|m| m.muscle.name.as_str()),
    );
    let mut muscles = Vec::new();
    for n in &names {
        match set.muscles.iter().position(|m| &m.muscle.name == n) {
            Some(i) => muscles.push(i),
            None => warnings.push(format!(
                "MuscleAnalysis: muscle '{n}' is not in the model; skipped"
            )),
        }
    }
    let coord_names = select(
        &ma.moment_arm_coordinate_list,
        model
            .coordinate_set_order
            .iter()
            .map(|&c| model.coordinates[c].name.as_str()),
    );
    let mut coords = Vec::new();
    if ma.compute_moments {
        for n in &coord_names {
            match model.coordinate_index(n) {
                Some(c) => coords.push(c),
                None => warnings.push(format!(
                    "MuscleAnalysis: coordinate '{n}' is not in the model; skipped"
                )),
            }
        }
    }
    let labels: Vec<String> = muscles
        .iter()
        .map(|&m| set.muscles[m].muscle.name.clone())
        .collect();
    let dir = results_dir(setup, opts)?;
    let run = RunKey::analysis(&setup.name, &ma.common.name, Sweep::Single);
    let precision = opts.precision.unwrap_or(setup.output_precision);
    let open = |table: MuscleTable, desc: &str| -> Result<(StoWriter, std::path::PathBuf)> {
        let p = dir.join(run.file(OutputKind::MuscleAnalysis(table.clone())));
        Ok((
            StoWriter::create_for_setup(
                &setup.setup_file,
                &p,
                &table.name(),
                desc,
                &labels,
                precision,
                false,
            )?,
            p,
        ))
    };
    let mut writers = vec![
        open(MuscleTable::Length, "Musculotendon (path) length [m].")?,
        open(
            MuscleTable::LengtheningSpeed,
            "Musculotendon lengthening speed [m/s].",
        )?,
        open(
            MuscleTable::MaxActiveFiberForceRigidTendon,
            "Active fiber force along the tendon at activation 1 with an inextensible tendon [N].",
        )?,
        open(
            MuscleTable::PassiveFiberForceRigidTendon,
            "Passive fiber force along the tendon with an inextensible tendon [N].",
        )?,
    ];
    for &c in &coords {
        let n = &model.coordinates[c].name;
        writers.push(open(
            MuscleTable::MomentArm(n.clone()),
            &format!("Moment arm about coordinate {n} [m] (generalized force per unit tension)."),
        )?);
    }
    let (i0, i1, step) = (stream.first_row, stream.last_row, ma.common.step_interval);
    // The frame driver of every analysis (analyze::for_each_frame): frames
    // in parallel chunks over per-thread workspaces, written in order.
    let (nframes, stopped) = write_each_frame(
        &mut stream,
        i0,
        i1,
        step,
        || Workspace::new(&model, &set),
        |ws, block, b| {
            let (data, frame) = (&mut ws.data, &mut ws.muscles);
            data.q.copy_from_slice(&block.q[b]);
            data.u.copy_from_slice(&block.u[b]);
            data.udot.iter_mut().for_each(|x| *x = 0.0);
            kinematics::full(&model, data);
            frame.evaluate(&set, &model, data);
            let mut rows: Vec<Vec<f64>> = [
                &frame.length,
                &frame.speed,
                &frame.max_active_force,
                &frame.passive_force,
            ]
            .into_iter()
            .map(|values| muscles.iter().map(|&m| values[m]).collect())
            .collect();
            for &c in &coords {
                rows.push(
                    muscles
                        .iter()
                        .map(|&m| frame.moment_arm(&model, &data.q, m, c))
                        .collect(),
                );
            }
            Ok((block.time[b], rows))
        },
        |t, rows| {
            for (w, row) in writers.iter_mut().zip(&rows) {
                w.0.write_row(t, row)?;
            }
            Ok(())
        },
    )?;
    let mut files = Vec::new();
    for (w, p) in writers {
        w.finish()?;
        files.push(p);
    }
    Ok(RunSummary {
        frames: nframes,
        results_dirs: vec![dir],
        files,
        warnings,
        stopped,
        ..Default::default()
    })
}
