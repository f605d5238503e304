//! A run reads its motion once (issue 28), and its model once: the driver reads the coordinates
//! file into memory and every reader (each analysis's states stream and its
//! passes, the coupled and the forces-file JointReaction, the in-memory
//! fallbacks) parses those bytes. `storage::times_opened` counts the
//! openings of a path; each test copies the motion to a path of its own, as
//! tests run in parallel.

mod common;

use std::path::{Path, PathBuf};

use statopt::parse::setup::Setup;
use statopt::storage::times_opened;
use statopt::tools::{analyze, RunOptions};

/// `file` copied into `dir` (a path no other test reads).
fn own_copy(file: &Path, dir: &Path) -> PathBuf {
    let p = dir.join(file.file_name().unwrap());
    std::fs::copy(file, &p).unwrap();
    p
}

/// MuscleAnalysis, StaticOptimization, a JointReaction fed by the static
/// optimization and one reading a forces file, in one AnalyzeTool run: the
/// coordinates file is opened once (it was opened 3 times: once by each
/// analysis's stream; a motion longer than a block, once per pass of each).
#[test]
fn analyses_of_one_run_open_the_motion_once() {
    let Some(root) = common::validation_dir("analyses_of_one_run_open_the_motion_once") else {
        return;
    };
    let case = root.join("arm26");
    let out = common::out_dir("motion_read_once_analyses");
    let so = std::fs::read_to_string(case.join("setup_SO.xml")).unwrap();
    let start = so.find("<StaticOptimization").unwrap();
    let end = so.find("</StaticOptimization>").unwrap() + "</StaticOptimization>".len();
    let forces = case.join("results/arm26_StaticOptimization_force.sto");
    let analyses = format!(
        "<MuscleAnalysis name=\"MuscleAnalysis\"><on>true</on><muscle_list>all</muscle_list>\
         <moment_arm_coordinate_list>all</moment_arm_coordinate_list><compute_moments>true</compute_moments></MuscleAnalysis>\
         {}\
         <JointReaction name=\"JR_file\"><on>true</on><forces_file>{}</forces_file><joint_names>All</joint_names>\
         <apply_on_bodies>child</apply_on_bodies><express_in_frame>child</express_in_frame></JointReaction>\
         <JointReaction name=\"JR_so\"><on>true</on><joint_names>All</joint_names>\
         <apply_on_bodies>child</apply_on_bodies><express_in_frame>child</express_in_frame></JointReaction>",
        &so[start..end],
        forces.display()
    );
    let text = format!("{}{analyses}{}", &so[..start], &so[end..])
        .replace(">inputs/", &format!(">{}/inputs/", case.display()));
    let setup_file = out.join("setup.xml");
    std::fs::write(&setup_file, text).unwrap();
    let mut setup = match Setup::read(&setup_file).unwrap() {
        Setup::Analyze(s) => s,
        _ => unreachable!(),
    };
    let motion = own_copy(setup.coordinates_file.as_ref().unwrap(), &out);
    setup.coordinates_file = Some(motion.clone());
    let model = own_copy(&setup.model_file, &out);
    setup.model_file = model.clone();
    let opts = RunOptions {
        results_dir: Some(out.join("results")),
        threads: Some(1),
        ..Default::default()
    };
    let summary = analyze::run(&setup, &opts).unwrap();
    // The model too is parsed once for the three analyses that run on it
    // (it was parsed once by each: 3 times).
    assert_eq!(
        statopt::xml::times_parsed(&model),
        1,
        "parses of {}",
        model.display()
    );
    for table in [
        "arm26_MuscleAnalysis_Length.sto",
        "arm26_StaticOptimization_activation.sto",
        "arm26_JR_file_ReactionLoads.sto",
        "arm26_JR_so_ReactionLoads.sto",
    ] {
        assert!(out.join("results").join(table).is_file(), "{table} written");
    }
    assert!(summary.stopped.is_none());
    assert_eq!(times_opened(&motion), 1, "openings of {}", motion.display());
    let _ = std::fs::remove_dir_all(&out);
}

/// The InverseDynamicsTool's stream makes several passes over a motion
/// longer than a block (length, smallest step, range, values, each opening
/// the file); they parse the bytes read once. The motion: the shipped swing
/// (q1 = 30 sin(pi t), q2 = 45 (1 - cos(pi t)), degrees) at 1 kHz for 5 s.
/// (It was opened 3 times.)
#[test]
fn inverse_dynamics_opens_the_motion_once() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = common::out_dir("motion_read_once_id");
    let mut setup = match Setup::read(&repo.join("setups/double_pendulum_ID.xml")).unwrap() {
        Setup::InverseDynamics(s) => s,
        _ => unreachable!(),
    };
    let mut table = statopt::storage::read(&setup.coordinates_file).unwrap();
    let n = 5001;
    assert!(n > statopt::motion::stream::DEFAULT_BLOCK);
    table.time = (0..n).map(|i| i as f64 * 1e-3).collect();
    table.rows = table
        .time
        .iter()
        .map(|t| {
            let a = std::f64::consts::PI * t;
            vec![30.0 * a.sin(), 45.0 * (1.0 - a.cos())]
        })
        .collect();
    let motion = out.join("swing_1kHz.mot");
    statopt::storage::write(&motion, &table, 10).unwrap();
    setup.coordinates_file = motion.clone();
    setup.time_range = (0.0, 5.0);
    let opts = RunOptions {
        results_dir: Some(out.join("results")),
        ..Default::default()
    };
    statopt::tools::inverse_dynamics::run(&setup, &opts).unwrap();
    assert_eq!(times_opened(&motion), 1, "openings of {}", motion.display());
    let _ = std::fs::remove_dir_all(&out);
}

/// `--resume` on a run whose tables are complete: the knee loads need the
/// knee angles of every frame, which the (empty) pass did not solve, so they
/// come from the motion; the resumed run opens the coordinates file once
/// (the static optimization's stream, then the knee states again).
#[test]
fn a_resumed_run_opens_the_motion_once() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = common::out_dir("motion_read_once_resume");
    let mut setup = match Setup::read(&repo.join("setups/leg_extension_cam1.xml")).unwrap() {
        Setup::Analyze(s) => s,
        _ => unreachable!(),
    };
    let motion = own_copy(setup.coordinates_file.as_ref().unwrap(), &out);
    setup.coordinates_file = Some(motion.clone());
    setup.final_time = setup.initial_time + 0.2;
    setup.figures.clear();
    let mut opts = RunOptions {
        results_dir: Some(out.join("results")),
        threads: Some(1),
        ..Default::default()
    };
    analyze::run(&setup, &opts).unwrap();
    assert_eq!(times_opened(&motion), 1, "openings of {}", motion.display());
    opts.resume = true;
    let s = analyze::run(&setup, &opts).unwrap();
    assert!(
        s.files
            .iter()
            .any(|f| f.to_string_lossy().ends_with("_KneeLoads.sto")),
        "{:?}",
        s.files
    );
    assert_eq!(
        times_opened(&motion),
        2,
        "openings of {} after the resumed run",
        motion.display()
    );
    let _ = std::fs::remove_dir_all(&out);
}
