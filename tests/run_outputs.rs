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
    let mut child = Command::new(env!("CARGO_BIN_EXE_statopt-tool"))
        .arg(&setup)
        .arg("--quiet")
        .arg("--threads")
        .arg("1")
        .spawn()
        .unwrap();
    let act_path = out.join("block_SO_activation.sto");
    let log_path = out.join("block_SO_log.mcap");
    let start = Instant::now();
    loop {
        if let Ok(Some(status)) = child.try_wait() {
            panic!("the run finished ({status}) before it could be killed; make the motion longer");
        }
        let rows = storage::read(&act_path).map(|t| t.time.len()).unwrap_or(0);
        let log_size = std::fs::metadata(&log_path).map(|m| m.len()).unwrap_or(0);
        if rows >= 3000 && log_size > 400_000 {
            break;
        }
        assert!(
            start.elapsed() < Duration::from_secs(240),
            "the run made too little progress ({rows} rows)"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
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
