//! Results stay in memory; files are one of their outputs (issue 37): a
//! run reads back no file it wrote. The leg extension study's consumers of
//! its own tables (the w0 sweep's statistics, the knee loads and knee
//! contact tables from the ReactionLoads, the figures and metrics) take
//! them from the run's kept outputs (`storage::results`). Before, the study
//! opened 266 of its output files for reading.

mod common;

use std::path::{Component, Path, PathBuf};

use statopt::tools::{run_setup, RunOptions};

/// `p` absolute, `.` and `..` resolved by its text.
fn normal(p: &Path) -> PathBuf {
    let abs = std::path::absolute(p).unwrap();
    let mut out = PathBuf::new();
    for c in abs.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => {
                out.pop();
            }
            c => out.push(c),
        }
    }
    out
}

/// Every file under `dir`.
fn files_under(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            out.extend(files_under(&p));
        } else {
            out.push(p);
        }
    }
    out
}

#[test]
fn the_leg_extension_study_reads_back_no_file_it_wrote() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let out = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("result_stream_study");
    let _ = std::fs::remove_dir_all(&out);
    // The run's capture, held past the run to see what it keeps.
    let capture = statopt::storage::results::Capture::new(Some(&out));
    let summary = run_setup(
        &root.join("setups/leg_extension_study.xml"),
        &RunOptions {
            results_dir: Some(out.clone()),
            ..Default::default()
        },
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let written = files_under(&out);
    // It keeps only what the run's consumers read, until read: at the end,
    // the tables the study's own figures and metrics draw (a few of its
    // 54 MB of tables; it kept them all before).
    let (kept, kept_bytes) = capture.kept();
    let ever = capture.ever_kept();
    drop(capture);
    // Of the per-w0 tables, only those the study's figures draw were ever
    // kept (a few SO tables): none for the knee tables, which are sinks of
    // the frame stream (before, every per-w0 ReactionLoads, KneeLoads and
    // KneeContact table was kept for a post-pass).
    let knee_inputs: Vec<&PathBuf> = ever
        .iter()
        .filter(|p| {
            let n = p.file_name().unwrap().to_string_lossy().into_owned();
            let per_w0 = n
                .split("_w0_")
                .nth(1)
                .is_some_and(|r| r.starts_with(|c: char| c.is_ascii_digit()));
            per_w0
                && (n.ends_with("_ReactionLoads.sto")
                    || n.ends_with("_KneeLoads.sto")
                    || n.ends_with("_KneeContact.sto"))
        })
        .collect();
    assert!(knee_inputs.is_empty(), "kept: {knee_inputs:?}");
    let table_bytes: u64 = written
        .iter()
        .filter(|p| p.extension().is_some_and(|e| e == "sto"))
        .map(|p| std::fs::metadata(p).unwrap().len())
        .sum();
    println!("kept at the end: {kept} outputs, {kept_bytes} of {table_bytes} bytes of tables");
    assert!(
        kept_bytes * 20 < table_bytes,
        "kept {kept} outputs, {kept_bytes} of {table_bytes} bytes of tables"
    );
    // The study wrote its tables, statistics, knee tables, figures and metrics.
    let count = |end: &str| {
        written
            .iter()
            .filter(|p| p.to_string_lossy().ends_with(end))
            .count()
    };
    assert!(count("_w0_mean_force.sto") >= 7, "{written:?}");
    assert!(count("_w0_mean_KneeLoads.sto") >= 4);
    assert!(count("_KneeContact.sto") >= 2);
    assert!(count(".png") >= 10);
    assert!(count("_metrics.csv") >= 1);
    assert!(summary.files.len() >= written.len() / 2);
    // Every opening of a table by the readers, under the output folder.
    let o = normal(&out);
    let read_back: Vec<(PathBuf, usize)> = statopt::storage::opened()
        .into_iter()
        .filter(|(p, _)| normal(p).starts_with(&o))
        .collect();
    assert!(
        read_back.is_empty(),
        "{} output files opened for reading during the run, e.g. {:?}",
        read_back.len(),
        &read_back[..read_back.len().min(5)]
    );
    // `--resume` is the one reader of earlier output, and the count sees
    // it: the finished cam 1 run resumed reads its tables and its logs.
    let cam1 = out.join("leg_extension_cam1");
    run_setup(
        &root.join("setups/leg_extension_cam1.xml"),
        &RunOptions {
            results_dir: Some(cam1.clone()),
            resume: true,
            ..Default::default()
        },
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let c = normal(&cam1);
    let resumed: Vec<PathBuf> = statopt::storage::opened()
        .into_iter()
        .map(|(p, _)| normal(&p))
        .filter(|p| p.starts_with(&c))
        .collect();
    assert!(
        resumed
            .iter()
            .any(|p| p.to_string_lossy().ends_with("_log.mcap"))
            && resumed
                .iter()
                .any(|p| p.to_string_lossy().ends_with("_force.sto")),
        "{resumed:?}"
    );
    // And the readers still open a file of an earlier run (after the run).
    let one = written
        .iter()
        .find(|p| p.to_string_lossy().ends_with("_w0_mean_force.sto"))
        .unwrap();
    statopt::storage::read(one).unwrap();
    assert_eq!(statopt::storage::times_opened(one), 1);
}

#[test]
fn two_runs_in_memory_at_once_in_one_process_keep_apart() {
    // Two threads of one process each run the cam 1 setup in memory (as
    // two Python threads or Dask workers in threads would): each run's
    // capture holds its own outputs only, under its own folder name, and
    // the two hold the same tables; no file is created.
    use statopt::storage::results::{Capture, Output};
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let setup = root.join("setups/leg_extension_cam1.xml");
    let both = std::sync::Barrier::new(2);
    let run = || {
        let c = Capture::in_memory();
        let dir = c.root().unwrap().to_path_buf();
        both.wait(); // both runs hold their captures
        run_setup(
            &setup,
            &RunOptions {
                results_dir: Some(dir.clone()),
                ..Default::default()
            },
        )
        .unwrap_or_else(|e| panic!("{e}"));
        assert!(!dir.exists(), "{} was created", dir.display());
        let outputs: Vec<(PathBuf, Output)> = c
            .outputs()
            .into_iter()
            .map(|(p, o)| {
                assert!(p.starts_with(&dir), "{} is not this run's", p.display());
                (p.strip_prefix(&dir).unwrap().to_path_buf(), o)
            })
            .collect();
        outputs
    };
    let (a, b) = std::thread::scope(|s| {
        let a = s.spawn(run);
        let b = s.spawn(run);
        (a.join().unwrap(), b.join().unwrap())
    });
    let tables = |o: &[(PathBuf, Output)]| -> Vec<(PathBuf, statopt::storage::Storage)> {
        o.iter()
            .filter_map(|(p, o)| match o {
                Output::Table(t) => Some((p.clone(), t.table(p).unwrap().clone())),
                Output::Bytes(_) => None,
            })
            .filter(|(p, _)| !p.to_string_lossy().contains("diagnostics"))
            .collect()
    };
    let (ta, tb) = (tables(&a), tables(&b));
    assert!(ta.len() >= 20, "{} tables", ta.len());
    assert_eq!(a.len(), b.len());
    let mut ta = ta;
    let mut tb = tb;
    ta.sort_by(|x, y| x.0.cmp(&y.0));
    tb.sort_by(|x, y| x.0.cmp(&y.0));
    assert!(ta == tb, "the two runs' tables differ");
}

#[test]
fn a_sweeps_statistics_from_the_frame_stream_equal_those_of_its_tables() {
    // The cam 1 sweep (w0 = 1, 500, 1000) makes its mean, min and max
    // tables as the frames arrive (`writers::sweep_statistics::
    // SweepStatistics`); made again afterwards from its per-w0 tables on
    // the disk, the way they were made before, they are the same bytes.
    use statopt::writers::names::Stat;
    use statopt::writers::sweep_statistics::write_sweep_statistics;
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let setup = root.join("setups/leg_extension_cam1.xml");
    let out = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("result_stream_sweep_stats");
    let again = out.join("again");
    let _ = std::fs::remove_dir_all(&out);
    run_setup(
        &setup,
        &RunOptions {
            results_dir: Some(out.clone()),
            ..Default::default()
        },
    )
    .unwrap_or_else(|e| panic!("{e}"));
    std::fs::create_dir_all(&again).unwrap();
    let weights = [1.0, 500.0, 1000.0];
    let mut compared = 0;
    for (run, kind) in [
        ("SO", "activation"),
        ("SO", "force"),
        ("SO", "ContactForces"),
        ("SO", "ContactBodyForces"),
        ("SO", "GeneralizedForcesBySource"),
        ("SO", "MusclePower"),
        ("JR", "ReactionLoads"),
    ] {
        let name = |tag: &str| format!("leg_extension_cam1_{run}_w0_{tag}_{kind}.sto");
        let files: Vec<PathBuf> = ["1", "500", "1000"]
            .iter()
            .map(|t| out.join(name(t)))
            .collect();
        let streamed = std::fs::read_to_string(out.join(name("mean"))).unwrap();
        let table = streamed.lines().next().unwrap().trim_end_matches(" mean");
        let row = streamed.lines().find(|l| l.starts_with(' ')).unwrap();
        let value = row.split('\t').next().unwrap().trim();
        let precision = value.len() - value.find('.').unwrap() - 1;
        write_sweep_statistics(
            &setup,
            &files,
            &|stat: Stat| again.join(name(stat.as_str())),
            table,
            &weights,
            precision,
        )
        .unwrap();
        for stat in Stat::ALL {
            let a = std::fs::read(out.join(name(stat.as_str()))).unwrap();
            let b = std::fs::read(again.join(name(stat.as_str()))).unwrap();
            assert!(
                a == b,
                "{} differs from the tables' statistics",
                name(stat.as_str())
            );
            compared += 1;
        }
    }
    assert_eq!(compared, 21);
}

#[test]
fn a_joint_reaction_reading_another_setups_forces_is_declared_ahead() {
    // A study of two setups: `jr.xml` (listed first) runs a JointReaction
    // on the force table that `so.xml`'s static optimization writes. The
    // study knows it before it runs: `so.xml` runs first, keeps the table
    // in memory until the JointReaction has read it, and with `-o` the
    // JointReaction reads it where it was moved. No output file is opened
    // for reading; the reactions are those of the two setups run one after
    // the other, the second reading the first's file.
    let dir = common::out_dir("result_stream_cross_setup_jr");
    let setup = |name: &str, analysis: &str| cross_setup(&dir, name, analysis);
    let so = setup("so", r#"<StaticOptimization name="SO"/>"#);
    let jr = setup(
        "jr",
        r#"<JointReaction name="JR"><forces_file>out_so/so_SO_force.sto</forces_file><joint_names>slide</joint_names><apply_on_bodies>child</apply_on_bodies><express_in_frame>ground</express_in_frame></JointReaction>"#,
    );
    std::fs::write(
        dir.join("study.xml"),
        r#"<OpenSimDocument Version="40000"><StatoptStudy name="cross"><setups>jr.xml so.xml</setups><results_directory>out_study</results_directory></StatoptStudy></OpenSimDocument>"#,
    )
    .unwrap();
    let moved = dir.join("moved");
    run_setup(
        &dir.join("study.xml"),
        &RunOptions {
            results_dir: Some(moved.clone()),
            ..Default::default()
        },
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let m = normal(&moved);
    let read_back: Vec<(PathBuf, usize)> = statopt::storage::opened()
        .into_iter()
        .filter(|(p, _)| normal(p).starts_with(&m))
        .collect();
    assert!(
        read_back.is_empty(),
        "output files opened for reading: {read_back:?}"
    );
    assert!(!dir.join("out_so").exists(), "the study wrote outside -o");
    // The same two setups run one after the other, into their own folders.
    for s in [&so, &jr] {
        run_setup(s, &RunOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    }
    let table = "jr_JR_ReactionLoads.sto";
    let study = std::fs::read(moved.join("out_jr").join(table)).unwrap();
    let alone = std::fs::read(dir.join("out_jr").join(table)).unwrap();
    assert!(
        study == alone,
        "the study's reactions differ from the setups run alone"
    );
}

/// A setup `name`.xml in `dir` (the block model and its motion written
/// beside it) running `analysis`, its tables in `out_<name>`.
fn cross_setup(dir: &Path, name: &str, analysis: &str) -> PathBuf {
    std::fs::write(dir.join("block.osim"), common::block_model("")).unwrap();
    let mut motion = String::from(
        "block\nversion=1\nnRows=41\nnColumns=4\ninDegrees=no\nendheader\ntime\ttx\tty\ttz\n",
    );
    for k in 0..41 {
        let t = k as f64 * 0.01;
        motion.push_str(&format!("{t:.6}\t{:.12}\t0\t0\n", 0.2 * (t * 0.5).sin()));
    }
    std::fs::write(dir.join("motion.mot"), motion).unwrap();
    let text = format!(
        r#"<OpenSimDocument Version="40000"><AnalyzeTool name="{name}"><model_file>block.osim</model_file><results_directory>out_{name}</results_directory>
<initial_time>0</initial_time><final_time>100000</final_time><output_precision>12</output_precision>
<AnalysisSet name="Analyses"><objects>{analysis}</objects></AnalysisSet>
<coordinates_file>motion.mot</coordinates_file></AnalyzeTool></OpenSimDocument>"#
    );
    std::fs::write(dir.join(format!("{name}.xml")), text).unwrap();
    dir.join(format!("{name}.xml"))
}

#[test]
fn a_cycle_of_joint_reactions_across_setups_is_found_by_check_as_by_a_run() {
    // Setup a's JointReaction reads b's forces and b's reads a's: neither
    // can run first. A run of the study refuses it before running anything;
    // `--check` says the same (it did not look before).
    let dir = common::out_dir("result_stream_cross_setup_cycle");
    let jr = |other: &str| {
        format!(
            r#"<StaticOptimization name="SO"/><JointReaction name="JR"><forces_file>out_{other}/{other}_SO_force.sto</forces_file><joint_names>slide</joint_names><apply_on_bodies>child</apply_on_bodies><express_in_frame>ground</express_in_frame></JointReaction>"#
        )
    };
    cross_setup(&dir, "a", &jr("b"));
    cross_setup(&dir, "b", &jr("a"));
    let study = dir.join("study.xml");
    std::fs::write(
        &study,
        r#"<OpenSimDocument Version="40000"><StatoptStudy name="cycle"><setups>a.xml b.xml</setups><results_directory>out_study</results_directory></StatoptStudy></OpenSimDocument>"#,
    )
    .unwrap();
    let said = "waits, in turn, for this one's tables";
    let err = run_setup(&study, &RunOptions::default())
        .err()
        .expect("a cycle must not run");
    assert!(err.to_string().contains(said), "{err}");
    assert!(!dir.join("out_a").exists() && !dir.join("out_b").exists());
    let report = statopt::tools::check::run(&study, false);
    assert!(
        report.errors.iter().any(|e| e.to_string().contains(said)),
        "--check missed the cycle: {:?}",
        report
            .errors
            .iter()
            .map(|e| e.to_string())
            .collect::<Vec<_>>()
    );
}

#[test]
fn a_sweeps_knee_tables_are_a_sink_of_its_frames() {
    // The Rajagopal cam 1 sweep with the knee contact method (w0 = 1, 500,
    // 1000; its JointReaction with knee loads) makes its KneeLoads and
    // KneeContact tables, and their mean, min and max, as the frames arrive
    // (`writers::knee_tables`): its capture keeps no per-w0 table for them
    // (before, every per-w0 ReactionLoads, KneeLoads and KneeContact table
    // was kept for a post-pass that averaged them). Made again by a resumed
    // run, which feeds the same sink from its ReactionLoads files, they are
    // the same bytes.
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let setup = root.join("setups/leg_extension_rajagopal_cam1_kc.xml");
    let out = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("result_stream_knee_sink");
    let again = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("result_stream_knee_again");
    let _ = std::fs::remove_dir_all(&out);
    let _ = std::fs::remove_dir_all(&again);
    let capture = statopt::storage::results::Capture::new(Some(&out));
    run_setup(
        &setup,
        &RunOptions {
            results_dir: Some(out.clone()),
            ..Default::default()
        },
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let ever = capture.ever_kept();
    drop(capture);
    let per_w0 = |p: &Path| {
        let n = p.file_name().unwrap().to_string_lossy().into_owned();
        n.split("_w0_")
            .nth(1)
            .is_some_and(|rest| rest.starts_with(|c: char| c.is_ascii_digit()))
    };
    let kept_per_w0: Vec<&PathBuf> = ever.iter().filter(|p| per_w0(p)).collect();
    assert!(
        kept_per_w0.is_empty(),
        "per-w0 tables kept for a consumer: {kept_per_w0:?}"
    );
    // The knee tables again, from the ReactionLoads files.
    let knee_table = |p: &Path| {
        let n = p.to_string_lossy();
        n.ends_with("_KneeLoads.sto") || n.ends_with("_KneeContact.sto")
    };
    std::fs::create_dir_all(&again).unwrap();
    let mut knee = Vec::new();
    for p in files_under(&out) {
        let name = p.file_name().unwrap().to_owned();
        if knee_table(&p) {
            knee.push(name);
        } else {
            std::fs::copy(&p, again.join(name)).unwrap();
        }
    }
    // Per w0 and mean/min/max, KneeLoads and KneeContact.
    assert_eq!(knee.len(), 12, "{knee:?}");
    run_setup(
        &setup,
        &RunOptions {
            results_dir: Some(again.clone()),
            resume: true,
            ..Default::default()
        },
    )
    .unwrap_or_else(|e| panic!("{e}"));
    for name in &knee {
        let a = std::fs::read(out.join(name)).unwrap();
        let b = std::fs::read(again.join(name)).unwrap();
        assert!(a == b, "{name:?} differs from the post-pass's");
    }
}
