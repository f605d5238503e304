//! What a static-optimization run writes besides the activations: joint
//! reactions from each frame's own solution, the MCAP log (read back with the
//! mcap crate), and files that stay valid when the run is killed midway.

mod common;

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use statopt::parse::setup::Setup;
use statopt::storage;
use statopt::tools::{analyze, RunOptions};

const G: f64 = 9.80665;

/// A block on a level floor (translations only), pushed along x and held by
/// one point-on-plane contact; the joint `slide` reports reactions.
fn model() -> String {
    common::block_model(
        r#"<PointOnPlaneContact name="floor"><point_body>block</point_body><point_location>0 0 0</point_location><plane_body>ground</plane_body><plane_normal>0 1 0</plane_normal></PointOnPlaneContact>"#,
    )
}

fn motion(rows: usize, dt: f64) -> String {
    let mut s = format!(
        "block\nversion=1\nnRows={rows}\nnColumns=4\ninDegrees=no\nendheader\ntime\ttx\tty\ttz\n"
    );
    for k in 0..rows {
        let t = k as f64 * dt;
        s.push_str(&format!("{t:.6}\t{:.12}\t0\t0\n", 0.2 * (t * 0.5).sin()));
    }
    s
}

fn write_case(name: &str, rows: usize, analyses: &str) -> (PathBuf, PathBuf) {
    let dir = common::out_dir(name);
    std::fs::write(dir.join("block.osim"), model()).unwrap();
    std::fs::write(dir.join("motion.mot"), motion(rows, 0.01)).unwrap();
    let setup = format!(
        r#"<OpenSimDocument Version="40000"><AnalyzeTool name="block"><model_file>block.osim</model_file><results_directory>out</results_directory>
<initial_time>0</initial_time><final_time>100000</final_time><output_precision>12</output_precision>
<AnalysisSet name="Analyses"><objects>{analyses}</objects></AnalysisSet>
<coordinates_file>motion.mot</coordinates_file></AnalyzeTool></OpenSimDocument>"#
    );
    std::fs::write(dir.join("setup.xml"), setup).unwrap();
    (dir.join("setup.xml"), dir.join("out"))
}

fn run(setup: &Path, opts: RunOptions) {
    let s = match Setup::read(setup).unwrap() {
        Setup::Analyze(s) => s,
        _ => unreachable!(),
    };
    analyze::run(&s, &opts).unwrap_or_else(|e| panic!("{e}"));
}

/// Reactions computed inside static optimization equal a separate
/// JointReaction run on the force file that static optimization wrote.
#[test]
fn reactions_in_one_setup_equal_a_separate_run_on_the_force_file() {
    let so = "<StaticOptimization name=\"SO\"><contact_weight>1000</contact_weight></StaticOptimization>";
    let jr = "<JointReaction name=\"JR\"><joint_names>slide</joint_names><apply_on_bodies>child</apply_on_bodies><express_in_frame>ground</express_in_frame></JointReaction>";
    let (setup, out) = write_case("outputs_so_jr", 61, &format!("{so}{jr}"));
    run(&setup, RunOptions::default());
    let combined = storage::read(&out.join("block_JR_ReactionLoads.sto")).unwrap();
    // The separate run needs the contact forces as external loads too: the
    // exported ExternalLoads carry them.
    let dir = setup.parent().unwrap();
    let standalone = format!(
        r#"<OpenSimDocument Version="40000"><AnalyzeTool name="sep"><model_file>block_free.osim</model_file><results_directory>out_sep</results_directory>
<initial_time>0</initial_time><final_time>100000</final_time><output_precision>12</output_precision>
<AnalysisSet name="Analyses"><objects><JointReaction name="JR"><forces_file>out/block_SO_force.sto</forces_file><joint_names>slide</joint_names><apply_on_bodies>child</apply_on_bodies><express_in_frame>ground</express_in_frame></JointReaction></objects></AnalysisSet>
<external_loads_file>out/block_SO_ContactExternalLoads.xml</external_loads_file>
<coordinates_file>motion.mot</coordinates_file></AnalyzeTool></OpenSimDocument>"#
    );
    let free = model();
    let a = free.find("<PointOnPlaneContact").unwrap();
    let b = free.find("</PointOnPlaneContact>").unwrap() + "</PointOnPlaneContact>".len();
    std::fs::write(
        dir.join("block_free.osim"),
        format!("{}{}", &free[..a], &free[b..]),
    )
    .unwrap();
    std::fs::write(dir.join("setup_sep.xml"), standalone).unwrap();
    run(&dir.join("setup_sep.xml"), RunOptions::default());
    let separate = storage::read(&dir.join("out_sep/sep_JR_ReactionLoads.sto")).unwrap();
    assert_eq!(combined.labels, separate.labels);
    assert_eq!(combined.time.len(), separate.time.len());
    let mut worst = 0.0f64;
    for i in 0..combined.time.len() {
        for j in 0..combined.labels.len() {
            worst = worst.max((combined.rows[i][j] - separate.rows[i][j]).abs());
        }
    }
    println!("combined vs separate reactions: worst difference {worst:.2e}");
    assert!(
        worst < 1e-6,
        "combined and separate reactions differ by {worst}"
    );
    // Generalized forces by source add up to what the motion requires.
    let src = storage::read(&out.join("block_SO_GeneralizedForcesBySource.sto")).unwrap();
    for c in ["tx", "ty", "tz"] {
        let col = |s: &str| src.column(src.column_index(&format!("{c}_{s}")).unwrap());
        let (req, mus, act, con) = (
            col("required"),
            col("muscles"),
            col("actuators"),
            col("contacts"),
        );
        for i in 0..src.time.len() {
            assert!(
                (req[i] - mus[i] - act[i] - con[i]).abs() < 1e-6 * req[i].abs().max(1.0),
                "{c} frame {i}"
            );
        }
    }
    let ty_contacts = src.column(src.column_index("ty_contacts").unwrap());
    assert!(
        ty_contacts.iter().all(|v| *v > 0.5 * 10.0 * G),
        "at w0 = 1000 the floor should carry most of the weight"
    );
    // The reaction holds the block's weight minus what the contact and lift carry: check it is not trivially zero.
    let fy = combined.column(
        combined
            .column_index("slide_on_block_in_ground_fy")
            .unwrap(),
    );
    assert!(fy.iter().all(|v| v.is_finite()));
}

/// The MCAP log of a run: every channel, schema and message count.
#[test]
fn mcap_log_has_every_channel_schema_and_frame() {
    let so = "<StaticOptimization name=\"SO\"><contact_weight>1000</contact_weight></StaticOptimization>";
    let jr = "<JointReaction name=\"JR\"><joint_names>slide</joint_names></JointReaction>";
    let (setup, out) = write_case("outputs_mcap", 101, &format!("{so}{jr}"));
    run(&setup, RunOptions::default());
    let frames = storage::read(&out.join("block_SO_activation.sto"))
        .unwrap()
        .time
        .len();
    let bytes = std::fs::read(out.join("block_SO_log.mcap")).unwrap();
    let summary = mcap::Summary::read(&bytes).unwrap().expect("summary");
    let topics: HashMap<String, u16> = summary
        .channels
        .values()
        .map(|c| (c.topic.clone(), c.id))
        .collect();
    for t in [
        "/kinematics",
        "/activations",
        "/muscle_forces",
        "/contacts",
        "/joint_reactions",
        "/solver",
    ] {
        let id = topics.get(t).unwrap_or_else(|| panic!("no channel {t}"));
        let ch = &summary.channels[id];
        assert_eq!(ch.message_encoding, "json");
        let schema = ch.schema.as_ref().unwrap();
        assert_eq!(schema.encoding, "jsonschema");
        let _: serde_json::Value = serde_json::from_slice(&schema.data).expect("schema is JSON");
        assert_eq!(
            summary.stats.as_ref().unwrap().channel_message_counts[id],
            frames as u64,
            "{t}"
        );
    }
    // Messages decode and carry the values of the tables.
    let act = storage::read(&out.join("block_SO_activation.sto")).unwrap();
    let mut k = 0;
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        let v: serde_json::Value = serde_json::from_slice(&m.data).unwrap();
        if m.channel.topic == "/activations" {
            let push = v["push"].as_f64().unwrap();
            assert!((push - act.rows[k][act.column_index("push").unwrap()]).abs() < 1e-9);
            k += 1;
        }
        if m.channel.topic == "/contacts" {
            assert!(v["floor"]["force"]["y"].as_f64().is_some(), "{v}");
        }
    }
    assert_eq!(k, frames);
}

/// Kill a long run midway: the .sto rows written so far are complete and
/// readable, and so are the MCAP's completed chunks.
#[test]
fn a_killed_run_leaves_readable_tables_and_log() {
    let so = "<StaticOptimization name=\"SO\"><contact_weight>1000</contact_weight></StaticOptimization>";
    let (setup, out) = write_case("outputs_killed", 400_000, so);
    let act_path = out.join("block_SO_activation.sto");
    let log_path = out.join("block_SO_log.mcap");
    let mut child = spawn_until(&setup, &act_path, 3000, || {
        std::fs::metadata(&log_path).map(|m| m.len()).unwrap_or(0) > 400_000
    });
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    // Tables: every row the header announces is there, complete and finite.
    let act = storage::read(&act_path).expect("activation table readable after kill");
    let diag = storage::read(&out.join("block_SO_diagnostics.sto"))
        .expect("diagnostics readable after kill");
    assert!(act.time.len() >= 3000);
    assert!(act.time.windows(2).all(|w| w[1] > w[0]));
    assert!(act.rows.iter().flatten().all(|v| v.is_finite()));
    assert!(diag.time.len() + 300 >= act.time.len());
    // MCAP: no summary, but every completed chunk reads with the linear reader.
    let bytes = std::fs::read(&log_path).unwrap();
    let mut count = 0usize;
    let stream =
        mcap::MessageStream::new_with_options(&bytes, mcap::read::Options::IgnoreEndMagic.into())
            .unwrap();
    for m in stream {
        match m {
            Ok(m) => {
                let _: serde_json::Value =
                    serde_json::from_slice(&m.data).expect("complete messages are JSON");
                count += 1;
            }
            Err(_) => break, // the torn chunk at the end
        }
    }
    println!(
        "killed after {} table rows; {count} MCAP messages readable",
        act.time.len()
    );
    assert!(count > 0, "no complete MCAP chunk survived");
}

/// Start the tool on `setup` (one thread, quiet, stderr captured) and wait
/// until its activation table holds `rows` rows and `more()` holds.
fn spawn_until(
    setup: &Path,
    act_path: &Path,
    rows: usize,
    more: impl Fn() -> bool,
) -> std::process::Child {
    spawn_with(setup, act_path, rows, more, &["--quiet"])
}

/// [`spawn_until`] with `args` instead of `--quiet`.
fn spawn_with(
    setup: &Path,
    act_path: &Path,
    rows: usize,
    more: impl Fn() -> bool,
    args: &[&str],
) -> std::process::Child {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_statopt-tool"));
    cmd.arg(setup).args(args);
    if !args.contains(&"--threads") {
        cmd.arg("--threads").arg("1");
    }
    let mut child = cmd.stderr(std::process::Stdio::piped()).spawn().unwrap();
    let start = Instant::now();
    loop {
        if let Ok(Some(status)) = child.try_wait() {
            panic!("the run finished ({status}) too early; make the motion longer");
        }
        let n = storage::read(act_path).map(|t| t.time.len()).unwrap_or(0);
        if n >= rows && more() {
            return child;
        }
        assert!(
            start.elapsed() < Duration::from_secs(240),
            "the run made too little progress ({n} rows)"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// The force file's labels stand over their own values when a force-set file
/// adds an actuator after a passive force (it used to put every actuator's
/// value first, so the header ended `spring_Force extra` over the values
/// `extra spring_Force`), with reserves after the ForceSet.
#[test]
fn force_file_columns_match_their_values_with_a_passive_force_among_actuators() {
    let spring = r#"<SpringGeneralizedForce name="spring"><coordinate>tx</coordinate><stiffness>50</stiffness><rest_length>0</rest_length><viscosity>0</viscosity></SpringGeneralizedForce>"#;
    let dir = common::out_dir("outputs_force_columns");
    std::fs::write(dir.join("block.osim"), common::block_model(spring)).unwrap();
    // A coordinate actuator of optimal force 10 on tz added by a force-set file.
    std::fs::write(
        dir.join("extra.xml"),
        r#"<OpenSimDocument Version="40000"><ForceSet name="extra"><objects><CoordinateActuator name="extra"><coordinate>tz</coordinate><optimal_force>10</optimal_force><min_control>-Inf</min_control><max_control>Inf</max_control></CoordinateActuator></objects></ForceSet></OpenSimDocument>"#,
    )
    .unwrap();
    // tx = 0.2 sin(t/2); tz = 0.1 t² (so the extra actuator carries m·0.2 = 2 N
    // against the side actuator's share).
    let mut mot =
        "block\nversion=1\nnRows=31\nnColumns=4\ninDegrees=no\nendheader\ntime\ttx\tty\ttz\n"
            .to_string();
    for k in 0..31 {
        let t = k as f64 * 0.01;
        mot.push_str(&format!(
            "{t:.6}\t{:.12}\t0\t{:.12}\n",
            0.2 * (t * 0.5).sin(),
            0.1 * t * t
        ));
    }
    std::fs::write(dir.join("motion.mot"), mot).unwrap();
    let setup = r#"<OpenSimDocument Version="40000"><AnalyzeTool name="block"><model_file>block.osim</model_file><replace_force_set>false</replace_force_set><force_set_files>extra.xml</force_set_files><results_directory>out</results_directory>
<initial_time>0</initial_time><final_time>100000</final_time><output_precision>12</output_precision>
<AnalysisSet name="Analyses"><objects><StaticOptimization name="SO"><reserve_actuators>1</reserve_actuators></StaticOptimization></objects></AnalysisSet>
<coordinates_file>motion.mot</coordinates_file></AnalyzeTool></OpenSimDocument>"#;
    std::fs::write(dir.join("setup.xml"), setup).unwrap();
    run(&dir.join("setup.xml"), RunOptions::default());
    let forces = storage::read(&dir.join("out/block_SO_force.sto")).unwrap();
    let act = storage::read(&dir.join("out/block_SO_activation.sto")).unwrap();
    let motion = storage::read(&dir.join("motion.mot")).unwrap();
    let labels: Vec<&str> = forces.labels.iter().map(String::as_str).collect();
    assert_eq!(
        labels,
        [
            "push",
            "lift",
            "side",
            "spring_Force",
            "extra",
            "tx_reserve",
            "ty_reserve",
            "tz_reserve"
        ],
        "force file columns in ForceSet order, reserves last"
    );
    let col = |s: &storage::Storage, name: &str| s.column_index(name).unwrap();
    let tx_col = col(&motion, "tx");
    for (r, &t) in forces.time.iter().enumerate() {
        let m = motion
            .time
            .iter()
            .position(|&u| (u - t).abs() < 1e-9)
            .unwrap();
        // The spring's generalized force −k·tx, under its own label.
        let spring = forces.rows[r][col(&forces, "spring_Force")];
        let expect = -50.0 * motion.rows[m][tx_col];
        assert!(
            (spring - expect).abs() < 1e-9,
            "t={t}: spring_Force {spring} vs -k·tx {expect}"
        );
        // Every actuator's force is its activation times its optimal force.
        for (name, fopt) in [
            ("push", 100.0),
            ("side", 100.0),
            ("extra", 10.0),
            ("tz_reserve", 1.0),
        ] {
            let f = forces.rows[r][col(&forces, name)];
            let a = act.rows[r][col(&act, name)];
            assert!(
                (f - a * fopt).abs() < 1e-9 * (1.0 + f.abs()),
                "t={t}: {name} force {f} vs activation {a} x {fopt}"
            );
        }
    }
}

/// SIGINT or SIGTERM stops a run at a frame boundary: every solved frame is
/// written, the tables and the MCAP log are closed (a standard reader opens
/// the log without recovery), the tool says where it stopped and exits 130
/// or 143. (A signal used to kill the process like SIGKILL.) On one solving
/// thread and on two, whose frames are solved in parallel chunks.
#[test]
fn a_signal_stops_the_run_cleanly() {
    for (signal, code, threads) in [("INT", 130, "1"), ("TERM", 143, "1"), ("INT", 130, "2")] {
        let so = "<StaticOptimization name=\"SO\"><contact_weight>1000</contact_weight></StaticOptimization>";
        let (setup, out) = write_case(&format!("outputs_signal_{signal}_{threads}"), 400_000, so);
        let act_path = out.join("block_SO_activation.sto");
        let log_path = out.join("block_SO_log.mcap");
        // Not quiet: the summary is printed too.
        let child = spawn_with(&setup, &act_path, 2000, || true, &["--threads", threads]);
        let sent = Instant::now();
        let ok = Command::new("kill")
            .arg(format!("-{signal}"))
            .arg(child.id().to_string())
            .status()
            .unwrap();
        assert!(ok.success());
        let output = child.wait_with_output().unwrap();
        let stopped_in = sent.elapsed();
        let err = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(code), "SIG{signal}: {err}");
        assert!(
            stopped_in < Duration::from_secs(3),
            "SIG{signal}: took {stopped_in:?} to stop"
        );
        // Tables: complete, and every table holds the same frames.
        let act = storage::read(&act_path).unwrap();
        let diag = storage::read(&out.join("block_SO_diagnostics.sto")).unwrap();
        assert_eq!(
            act.time, diag.time,
            "SIG{signal}: tables disagree on the frames written"
        );
        assert!(act.rows.iter().flatten().all(|v| v.is_finite()));
        let last = *act.time.last().unwrap();
        assert!(
            err.contains(&format!(
                "stopped by a signal after the frame at t = {}",
                statopt::storage::fmt_time(last)
            )),
            "SIG{signal}: {err}"
        );
        // The summary counts the frames written (it used to say every frame
        // of the motion was solved) and says how to go on.
        let n = act.time.len();
        assert!(
            err.contains(&format!(
                "{n} frames; static optimization: {n} of {n} frame problems solved"
            )),
            "SIG{signal}: {err}"
        );
        assert!(
            err.contains(&format!("hold the {n} frames solved so far")) && err.contains("--resume"),
            "SIG{signal}: {err}"
        );
        // MCAP: closed properly, read by the standard reader, one activation
        // message per frame written.
        let bytes = std::fs::read(&log_path).unwrap();
        let mut activations = 0usize;
        for m in mcap::MessageStream::new(&bytes).expect("a closed MCAP file") {
            let m = m.expect("every message reads");
            if m.channel.topic == "/activations" {
                activations += 1;
            }
        }
        assert_eq!(activations, act.time.len(), "SIG{signal}");
        println!(
            "SIG{signal}, {threads} thread(s): stopped after {} frames in {stopped_in:?}",
            act.time.len()
        );
    }
}

/// Every table says what wrote it: the statopt version and the setup.
#[test]
fn output_headers_carry_the_version_and_the_setup() {
    let so = "<StaticOptimization name=\"SO\"><contact_weight>1000</contact_weight></StaticOptimization>";
    let jr = "<JointReaction name=\"JR\"><joint_names>slide</joint_names><apply_on_bodies>child</apply_on_bodies><express_in_frame>ground</express_in_frame></JointReaction>";
    let (setup, out) = write_case("outputs_headers", 11, &format!("{so}{jr}"));
    run(&setup, RunOptions::default());
    let setup_abs = std::path::absolute(&setup).unwrap();
    let mut n = 0;
    for e in std::fs::read_dir(&out).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "sto") {
            let t = storage::read(&p).unwrap();
            let get = |k: &str| {
                t.metadata
                    .iter()
                    .find(|(key, _)| key == k)
                    .map(|(_, v)| v.clone())
            };
            assert_eq!(
                get("statopt_version").as_deref(),
                Some(env!("CARGO_PKG_VERSION")),
                "{}",
                p.display()
            );
            assert_eq!(
                get("statopt_setup"),
                Some(setup_abs.display().to_string()),
                "{}",
                p.display()
            );
            n += 1;
        }
    }
    assert!(n >= 7, "only {n} tables");
}

/// What residual actuators on the root joint carried is reported in N and as
/// a share of body weight, with a warning above 5 %: here the block's three
/// point actuators are its only support, so they carry all its weight.
#[test]
fn root_residuals_are_reported_against_body_weight() {
    let dir = common::out_dir("outputs_root_residuals");
    std::fs::write(dir.join("block.osim"), common::block_model("")).unwrap();
    std::fs::write(dir.join("motion.mot"), motion(21, 0.01)).unwrap();
    let setup = r#"<OpenSimDocument Version="40000"><AnalyzeTool name="block"><model_file>block.osim</model_file><results_directory>out</results_directory>
<AnalysisSet name="Analyses"><objects><StaticOptimization name="SO"/></objects></AnalysisSet>
<coordinates_file>motion.mot</coordinates_file></AnalyzeTool></OpenSimDocument>"#;
    std::fs::write(dir.join("setup.xml"), setup).unwrap();
    let s = match Setup::read(&dir.join("setup.xml")).unwrap() {
        Setup::Analyze(s) => s,
        _ => unreachable!(),
    };
    let summary = analyze::run(&s, &RunOptions::default()).unwrap();
    let bw = summary.root_body_weight.expect("the block's weight");
    assert!((bw - 10.0 * G).abs() < 1e-9, "{bw}");
    let (f, _) = summary.root_force_peak.clone().expect("root residual peak");
    // The lift actuator holds the weight (the motion has no vertical part).
    assert!((f - 10.0 * G).abs() < 1e-3 * f, "{f}");
    assert!(summary
        .report()
        .iter()
        .any(|l| l.contains("% of body weight")));
    assert!(
        summary
            .warnings
            .iter()
            .any(|w| w.contains("% of body weight") && w.contains("more than 5 %")),
        "{:?}",
        summary.warnings
    );
}

/// `--resume` after a kill: the run keeps the frames its tables and log hold
/// completely, computes the rest, and its tables equal an uninterrupted
/// run's bit for bit (the diagnostics' solve times aside), its log message
/// for message. (The log's chunks close by wall-clock age, so two
/// uninterrupted runs' logs already differ in their bytes.)
#[test]
fn resume_after_a_kill_equals_an_uninterrupted_run() {
    // Reserves: the summary's reserve and root residual peaks are checked.
    let so = "<StaticOptimization name=\"SO\"><contact_weight>1000</contact_weight><reserve_actuators>1</reserve_actuators></StaticOptimization><JointReaction name=\"JR\"><joint_names>slide</joint_names><apply_on_bodies>child</apply_on_bodies><express_in_frame>ground</express_in_frame></JointReaction>";
    let rows = 60_000;
    let (full_setup, full_out) = write_case("outputs_resume_full", rows, so);
    let full = Command::new(env!("CARGO_BIN_EXE_statopt-tool"))
        .arg(&full_setup)
        .output()
        .unwrap();
    assert!(full.status.success());
    let (setup, out) = write_case("outputs_resume_killed", rows, so);
    let act_path = out.join("block_SO_activation.sto");
    let mut child = spawn_until(&setup, &act_path, 3000, || true);
    child.kill().unwrap();
    child.wait().unwrap();
    let kept = storage::read(&act_path).map(|t| t.time.len()).unwrap_or(0);
    assert!(kept >= 3000 && kept < rows, "killed after {kept} rows");
    let resumed = Command::new(env!("CARGO_BIN_EXE_statopt-tool"))
        .arg(&setup)
        .arg("--resume")
        .output()
        .unwrap();
    assert!(
        resumed.status.success(),
        "{}",
        String::from_utf8_lossy(&resumed.stderr)
    );
    // The resumed run's summary covers the whole run, the frames the
    // killed run wrote included: frames, problems, and the reserve and
    // residual peaks with where they were (they used to describe only the
    // frames computed again). The worst equation residual is left out: read
    // back from the tables it is rounded to their precision.
    let summary = |out: &std::process::Output| -> Vec<String> {
        String::from_utf8_lossy(&out.stderr)
            .lines()
            .filter(|l| {
                l.starts_with("reserve actuators carried")
                    || l.starts_with("residual actuators on the root")
                    || l.contains(" frames; static optimization: ")
            })
            .map(|l| {
                l.split("; worst equation residual")
                    .next()
                    .unwrap()
                    .to_string()
            })
            .collect()
    };
    let (a, b) = (summary(&full), summary(&resumed));
    assert!(a.len() >= 3, "{a:?}");
    assert_eq!(
        a, b,
        "the resumed run's summary differs from the uninterrupted one's"
    );
    for name in [
        "block_SO_activation.sto",
        "block_SO_force.sto",
        "block_SO_ContactForces.sto",
        "block_SO_ContactBodyForces.sto",
        "block_SO_ContactExternalLoads.mot",
        "block_SO_GeneralizedForcesBySource.sto",
        "block_SO_MusclePower.sto",
        "block_JR_ReactionLoads.sto",
    ] {
        let a = std::fs::read(full_out.join(name)).unwrap();
        let b = std::fs::read(out.join(name)).unwrap();
        // The header names the setup file, which differs between the folders.
        let body = |x: &[u8]| {
            let s = String::from_utf8_lossy(x).to_string();
            s.lines()
                .filter(|l| !l.starts_with("statopt_setup="))
                .collect::<Vec<_>>()
                .join("\n")
        };
        assert!(
            body(&a) == body(&b),
            "{name} differs from the uninterrupted run"
        );
    }
    let diag = |d: &Path| {
        let t = storage::read(&d.join("block_SO_diagnostics.sto")).unwrap();
        let j = t.column_index("solve_time_ms").unwrap();
        (
            t.time.clone(),
            t.rows
                .iter()
                .map(|r| {
                    let mut r = r.clone();
                    r.remove(j);
                    r
                })
                .collect::<Vec<_>>(),
        )
    };
    assert!(diag(&full_out) == diag(&out), "diagnostics differ");
    let messages = |d: &Path| {
        let bytes = std::fs::read(d.join("block_SO_log.mcap")).unwrap();
        mcap::MessageStream::new(&bytes)
            .expect("a closed log")
            .map(|m| {
                let m = m.unwrap();
                let v: serde_json::Value = serde_json::from_slice(&m.data).unwrap();
                (m.channel.topic.clone(), m.log_time, v)
            })
            .collect::<Vec<_>>()
    };
    let (ma, mb) = (messages(&full_out), messages(&out));
    assert_eq!(ma.len(), mb.len(), "log message count");
    // The solver channel carries the solve time; every other field is equal.
    for (x, y) in ma.iter().zip(&mb) {
        let strip = |v: &serde_json::Value| {
            let mut v = v.clone();
            if let Some(o) = v.as_object_mut() {
                o.remove("solve_time_ms");
                o.remove("solve_time");
            }
            v
        };
        assert!(
            x.0 == y.0 && x.1 == y.1 && strip(&x.2) == strip(&y.2),
            "log differs at {} {}",
            x.0,
            x.1
        );
    }
    println!("killed after {kept} of {rows} frames; resumed run equals the uninterrupted one");
}

/// `--sync` waits for the files to reach the disk and changes nothing in
/// them: the tables of a synced run equal an unsynced run's (solve times
/// aside), and a file that cannot be synced is an error naming it.
#[test]
fn sync_writes_the_same_tables_and_names_a_file_it_cannot_sync() {
    let so = "<StaticOptimization name=\"SO\"><contact_weight>1000</contact_weight></StaticOptimization>";
    let (plain_setup, plain_out) = write_case("outputs_sync_plain", 400, so);
    let (synced_setup, synced_out) = write_case("outputs_sync_synced", 400, so);
    let cli = |setup: &Path, extra: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_statopt-tool"))
            .arg(setup)
            .arg("-q")
            .args(extra)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    };
    cli(&plain_setup, &[]);
    cli(&synced_setup, &["--sync"]);
    for table in ["activation", "force", "ContactForces"] {
        let name = format!("block_SO_{table}.sto");
        let a = std::fs::read(plain_out.join(&name)).unwrap();
        let b = std::fs::read(synced_out.join(&name)).unwrap();
        let strip = |v: &[u8]| {
            String::from_utf8_lossy(v)
                .lines()
                .filter(|l| !l.starts_with("statopt_setup="))
                .collect::<Vec<_>>()
                .join("\n")
        };
        assert_eq!(strip(&a), strip(&b), "{name}");
    }
    let missing = synced_out.join("no_such_file.sto");
    let e = statopt::tools::sync_files(&[synced_out.join("block_SO_activation.sto"), missing])
        .unwrap_err()
        .to_string();
    assert!(e.contains("no_such_file.sto"), "{e}");
}

/// The motion is read once per run: the knee loads (and the knee contact
/// table) take the knee angles of the frames the static-optimization pass
/// solved, instead of reading the motion again after it (they read it a
/// second time). Checked by moving the motion away once the pass is done.
#[test]
fn knee_loads_take_the_frames_of_the_pass_without_reading_the_motion_again() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let mut setup = match Setup::read(&root.join("setups/leg_extension_cam1.xml")).unwrap() {
        Setup::Analyze(s) => s,
        _ => unreachable!(),
    };
    let out = common::out_dir("knee_loads_motion_once");
    let motion = out.join("motion.mot");
    std::fs::copy(setup.coordinates_file.as_ref().unwrap(), &motion).unwrap();
    setup.coordinates_file = Some(motion.clone());
    setup.final_time = setup.initial_time + 0.5;
    setup.figures.clear();
    let moved = out.join("motion_moved_away.mot");
    let (from, to) = (motion.clone(), moved.clone());
    let opts = RunOptions {
        results_dir: Some(out.clone()),
        threads: Some(1),
        progress: Some(statopt::tools::progress::ProgressHook(std::sync::Arc::new(
            move |_label: &str, done, total| {
                if total > 0 && done == total && from.exists() {
                    std::fs::rename(&from, &to).unwrap();
                }
            },
        ))),
        ..Default::default()
    };
    let s = analyze::run(&setup, &opts).unwrap();
    assert!(
        moved.exists() && !motion.exists(),
        "the motion was moved away"
    );
    let knee: Vec<&PathBuf> = s
        .files
        .iter()
        .filter(|f| f.to_string_lossy().ends_with("_KneeLoads.sto"))
        .collect();
    // One per w0 (1, 500, 1000) and the sweep's mean, min and max.
    assert_eq!(knee.len(), 6, "{:?}", s.files);
    let t = storage::read(knee[0]).unwrap();
    assert_eq!(t.time.len(), s.frames);
    assert!(s.frames > 5);
}
