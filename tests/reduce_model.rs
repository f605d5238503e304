//! `<reduce_model>`: the reduced problem equals the full problem with the
//! static coordinates locked; what is dropped follows from the model's
//! structure; JointReaction joints are never dropped; a bad value is a
//! located error.
//!
//! The model (planar, gravity −y): ground –hip (pin z)→ thigh –knee (pin z)→
//! shank, and ground –lumbar (pin z)→ torso –weld→ box. The motion moves
//! only the knee (hip held at 0.3 rad, lumbar at 0). Muscles: knee extensor
//! and flexor (thigh–shank), a biarticular one (ground–shank), hip flexor and
//! extensor (ground–thigh), a back muscle (ground–torso); a CoordinateActuator
//! on the lumbar; contacts: the torso against a ground wall (engaged) and the
//! shank tip against a floor 5 m below (never engaged).

mod common;
use common::col;

use std::path::{Path, PathBuf};

use statopt::parse::setup::Setup;
use statopt::storage::{self, Storage};
use statopt::tools::{analyze, RunOptions};

fn muscle(name: &str, a: (&str, &str), b: (&str, &str)) -> String {
    format!(
        r#"<Thelen2003Muscle name="{name}"><GeometryPath name="path"><PathPointSet><objects>
<PathPoint name="p1"><location>{}</location><socket_parent_frame>{}</socket_parent_frame></PathPoint>
<PathPoint name="p2"><location>{}</location><socket_parent_frame>{}</socket_parent_frame></PathPoint>
</objects></PathPointSet></GeometryPath>
<max_isometric_force>2000</max_isometric_force><optimal_fiber_length>0.1</optimal_fiber_length>
<tendon_slack_length>0.2</tendon_slack_length><pennation_angle_at_optimal>0</pennation_angle_at_optimal></Thelen2003Muscle>"#,
        a.1, a.0, b.1, b.0
    )
}

fn contact(name: &str, point_body: &str, point: &str, origin: &str, normal: &str) -> String {
    format!(
        r#"<PointOnPlaneContact name="{name}"><point_body>{point_body}</point_body><point_location>{point}</point_location>
<plane_body>ground</plane_body><plane_origin>{origin}</plane_origin><plane_normal>{normal}</plane_normal>
<static_friction>0.8</static_friction><kinetic_friction>0.5</kinetic_friction><contact_tolerance>0.005</contact_tolerance>
<contact_transition_zone>0.01</contact_transition_zone><optimal_force>100</optimal_force></PointOnPlaneContact>"#
    )
}

/// The model; `lock` marks the hip (at 0.3) and the lumbar (at 0) locked.
fn model(lock: bool) -> String {
    let locked = |v: f64| {
        if lock {
            format!("<default_value>{v}</default_value><locked>true</locked>")
        } else {
            String::new()
        }
    };
    let (g, th, sh, to) = (
        "/ground",
        "/bodyset/thigh",
        "/bodyset/shank",
        "/bodyset/torso",
    );
    let forces = [
        muscle("knee_ext", (th, "0.04 -0.3 0"), (sh, "0.04 -0.05 0")),
        muscle("knee_flex", (th, "-0.04 -0.3 0"), (sh, "-0.04 -0.08 0")),
        muscle("biarticular", (g, "0.05 0.02 0"), (sh, "0.03 -0.06 0")),
        muscle("hip_flex", (g, "0.06 0 0"), (th, "0.05 -0.12 0")),
        muscle("hip_ext", (g, "-0.06 0 0"), (th, "-0.05 -0.12 0")),
        muscle("back", (g, "-0.05 0 0"), (to, "-0.05 0.2 0")),
        r#"<CoordinateActuator name="lumbar_motor"><coordinate>lumbar</coordinate><optimal_force>100</optimal_force></CoordinateActuator>"#.to_string(),
        contact("torso_wall", "torso", "0 0 0", "0 0.1 0", "0 -1 0"),
        contact("foot_floor", "shank", "0 -0.4 0", "0 -5 0", "0 1 0"),
    ]
    .join("\n");
    format!(
        r#"<OpenSimDocument Version="40000"><Model name="reduce_test"><gravity>0 -9.80665 0</gravity>
<BodySet><objects>
 <Body name="thigh"><mass>5</mass><mass_center>0.02 -0.2 0</mass_center><inertia>0.05 0.01 0.05 0 0 0</inertia></Body>
 <Body name="shank"><mass>3</mass><mass_center>0 -0.2 0</mass_center><inertia>0.03 0.005 0.03 0 0 0</inertia></Body>
 <Body name="torso"><mass>20</mass><mass_center>0 0.3 0</mass_center><inertia>0.5 0.2 0.5 0 0 0</inertia></Body>
 <Body name="box"><mass>1</mass><mass_center>0 0 0</mass_center><inertia>0.01 0.01 0.01 0 0 0</inertia></Body>
</objects></BodySet>
<JointSet><objects>
 <PinJoint name="hip"><socket_parent_frame>/ground</socket_parent_frame><socket_child_frame>/bodyset/thigh</socket_child_frame>
  <coordinates><Coordinate name="hip"><range>-3 3</range>{}</Coordinate></coordinates></PinJoint>
 <PinJoint name="knee"><socket_parent_frame>k_p</socket_parent_frame><socket_child_frame>/bodyset/shank</socket_child_frame>
  <coordinates><Coordinate name="knee"><range>-3 3</range></Coordinate></coordinates>
  <frames><PhysicalOffsetFrame name="k_p"><socket_parent>/bodyset/thigh</socket_parent><translation>0 -0.4 0</translation><orientation>0 0 0</orientation></PhysicalOffsetFrame></frames></PinJoint>
 <PinJoint name="lumbar"><socket_parent_frame>l_p</socket_parent_frame><socket_child_frame>/bodyset/torso</socket_child_frame>
  <coordinates><Coordinate name="lumbar"><range>-3 3</range>{}</Coordinate></coordinates>
  <frames><PhysicalOffsetFrame name="l_p"><socket_parent>/ground</socket_parent><translation>0 0.1 0</translation><orientation>0 0 0</orientation></PhysicalOffsetFrame></frames></PinJoint>
 <WeldJoint name="box_weld"><socket_parent_frame>b_p</socket_parent_frame><socket_child_frame>/bodyset/box</socket_child_frame>
  <frames><PhysicalOffsetFrame name="b_p"><socket_parent>/bodyset/torso</socket_parent><translation>0 0.5 0</translation><orientation>0 0 0</orientation></PhysicalOffsetFrame></frames></WeldJoint>
</objects></JointSet>
<ForceSet><objects>{forces}</objects></ForceSet>
</Model></OpenSimDocument>"#,
        locked(0.3),
        locked(0.0)
    )
}

/// The knee swings from 0 to 1 rad (minimum jerk over 1 s); hip 0.3, lumbar 0.
fn motion() -> String {
    let mut s = String::from(
        "motion\nversion=1\nnRows=41\nnColumns=4\ninDegrees=no\nendheader\ntime\thip\tknee\tlumbar\n",
    );
    for i in 0..=40 {
        let t = i as f64 / 40.0;
        let knee = 10.0 * t.powi(3) - 15.0 * t.powi(4) + 6.0 * t.powi(5);
        s.push_str(&format!("{t}\t0.3\t{knee}\t0\n"));
    }
    s
}

/// Write model, motion and setup into `dir`; returns the setup path.
fn write_case(dir: &Path, lock: bool, reduce: &str, jr_joints: &str) -> PathBuf {
    std::fs::write(dir.join("model.osim"), model(lock)).unwrap();
    std::fs::write(dir.join("motion.mot"), motion()).unwrap();
    let reduce = if reduce.is_empty() {
        String::new()
    } else {
        format!("<reduce_model>{reduce}</reduce_model>")
    };
    let jr = if jr_joints.is_empty() {
        String::new()
    } else {
        format!(
            "<JointReaction name=\"JR\"><on>true</on><joint_names>{jr_joints}</joint_names><apply_on_bodies>child</apply_on_bodies><express_in_frame>child</express_in_frame></JointReaction>"
        )
    };
    let setup = format!(
        r#"<OpenSimDocument Version="40000"><AnalyzeTool name="case">
<model_file>model.osim</model_file><results_directory>out</results_directory>
<initial_time>0</initial_time><final_time>1</final_time>
<coordinates_file>motion.mot</coordinates_file>
<lowpass_cutoff_frequency_for_coordinates>-1</lowpass_cutoff_frequency_for_coordinates>
{reduce}
<AnalysisSet name="Analyses"><objects>
<StaticOptimization name="SO"><on>true</on><use_muscle_physiology>false</use_muscle_physiology><contact_weight>1</contact_weight></StaticOptimization>
{jr}
</objects></AnalysisSet></AnalyzeTool></OpenSimDocument>"#
    );
    let p = dir.join("setup.xml");
    std::fs::write(&p, setup).unwrap();
    p
}

fn run(setup: &Path) -> statopt::Result<statopt::tools::RunSummary> {
    let s = match Setup::read(setup)? {
        Setup::Analyze(s) => s,
        _ => unreachable!(),
    };
    analyze::run(
        &s,
        &RunOptions {
            threads: Some(1),
            ..Default::default()
        },
    )
}

fn table(dir: &Path, what: &str) -> Storage {
    storage::read(&dir.join("out").join(format!("case_{what}"))).unwrap()
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

const KEPT: [&str; 3] = ["knee_ext", "knee_flex", "biarticular"];
const DROPPED: [&str; 3] = ["hip_flex", "hip_ext", "back"];

/// (a) + (b): reduced = full with the static coordinates locked (the
/// never-engaged and the cannot-act contacts skipped included); the full
/// model without locks differs because the hip's equation of motion now needs
/// the hip muscles.
#[test]
fn reduced_equals_full_with_locks() {
    let reduced = common::out_dir("reduce_reduced");
    let locked = common::out_dir("reduce_locked");
    let free = common::out_dir("reduce_free");
    run(&write_case(&reduced, false, "true", "knee")).unwrap();
    run(&write_case(&locked, true, "", "knee")).unwrap();
    run(&write_case(&free, false, "", "knee")).unwrap();
    let (ar, al, af) = (
        table(&reduced, "SO_activation.sto"),
        table(&locked, "SO_activation.sto"),
        table(&free, "SO_activation.sto"),
    );
    assert_eq!(ar.time.len(), 41);
    for m in KEPT {
        let d = max_diff(&col(&ar, m), &col(&al, m));
        assert!(d < 1e-6, "{m}: reduced vs locked differ by {d}");
    }
    // Dropped muscles are absent from the reduced tables; in the locked full
    // model they cannot act and rest at their lower bound (Thelen2003Muscle's
    // default min_control, 0.01).
    for m in DROPPED {
        assert!(ar.column_index(m).is_none(), "{m} should be absent");
        let worst = col(&al, m)
            .iter()
            .fold(0.0f64, |a, x| a.max((x - 0.01).abs()));
        assert!(worst < 1e-6, "{m} in the locked model: {worst} from 0.01");
    }
    assert!(ar.column_index("lumbar_motor").is_none());
    // Knee reactions and the knee's generalized-force split are those of the locked model.
    let (jr, jl) = (
        table(&reduced, "JR_ReactionLoads.sto"),
        table(&locked, "JR_ReactionLoads.sto"),
    );
    // Activations agree to ~1e-7 (solver tolerance), i.e. muscle forces to
    // ~1e-4 N of 2000 N muscles.
    for l in &jl.labels {
        let (a, b) = (col(&jr, l), col(&jl, l));
        let scale = b.iter().fold(1.0f64, |s, x| s.max(x.abs()));
        assert!(max_diff(&a, &b) < 1e-5 * scale, "{l}: {}", max_diff(&a, &b));
    }
    // Contacts: the reduced run has none left (one cannot act, one never engages).
    assert!(!reduced.join("out/case_SO_ContactForces.sto").exists());
    let cl = table(&locked, "SO_ContactForces.sto");
    for c in ["torso_wall", "foot_floor"] {
        let peak = col(&cl, &format!("{c}_lambda_n"))
            .iter()
            .fold(0.0f64, |a, x| a.max(x.abs()));
        assert!(peak < 1e-4, "{c} carries {peak} in the locked model");
    }
    assert!(col(&cl, "foot_floor_weight").iter().all(|w| *w == 0.0));
    assert!(col(&cl, "torso_wall_weight").iter().all(|w| *w > 0.99)); // engaged (d = 0)
                                                                      // Without locks the hip row needs a hip moment: gravity on thigh and
                                                                      // shank about the hip is not zero (centres of mass off the vertical at hip = 0.3).
    let hip_muscles: f64 = ["hip_flex", "hip_ext"]
        .iter()
        .map(|m| col(&af, m).iter().fold(0.0f64, |a, x| a.max(x.abs())))
        .fold(0.0, f64::max);
    assert!(
        hip_muscles > 1e-3,
        "hip muscles idle without the lock: {hip_muscles}"
    );
    let d = max_diff(&col(&af, "biarticular"), &col(&al, "biarticular"));
    assert!(
        d > 1e-4,
        "the biarticular muscle should change without the lock ({d})"
    );
}

/// (b) alone: with nothing static (no coordinate to lock), skipping the
/// contact that never engages changes nothing.
#[test]
fn never_engaged_contact_skipped_changes_nothing() {
    let dir_r = common::out_dir("reduce_contacts_reduced");
    let dir_f = common::out_dir("reduce_contacts_full");
    for (dir, reduce) in [(&dir_r, "true"), (&dir_f, "false")] {
        write_case(dir, false, reduce, "");
        // Let the hip and lumbar move a little so that nothing is locked.
        let m = motion()
            .lines()
            .map(|l| match l.split('\t').collect::<Vec<_>>()[..] {
                [t, _, k, _] if t.parse::<f64>().is_ok() => {
                    let t: f64 = t.parse().unwrap();
                    format!("{t}\t{}\t{k}\t{}", 0.3 + 0.05 * t, 0.02 * t)
                }
                _ => l.to_string(),
            })
            .collect::<Vec<_>>()
            .join("\n");
        std::fs::write(dir.join("motion.mot"), m + "\n").unwrap();
        run(&dir.join("setup.xml")).unwrap();
    }
    let report = std::fs::read_to_string(dir_r.join("out/case_SO_reduction.txt")).unwrap();
    assert!(report.contains("[locked coordinates] 0"), "{report}");
    assert!(
        report.contains("[skipped contacts (never engaged)] 1\nfoot_floor"),
        "{report}"
    );
    assert!(report.contains("[dropped bodies] 0"), "{report}");
    let (ar, af) = (
        table(&dir_r, "SO_activation.sto"),
        table(&dir_f, "SO_activation.sto"),
    );
    assert_eq!(ar.labels, af.labels);
    for l in &af.labels {
        let d = max_diff(&col(&ar, l), &col(&af, l));
        assert!(d < 1e-6, "{l}: {d}");
    }
    let (cr, cf) = (
        table(&dir_r, "SO_ContactForces.sto"),
        table(&dir_f, "SO_ContactForces.sto"),
    );
    // Forces within 1e-2 N: multipliers at their bound come out of the
    // interior-point solve at up to ~1e-4 (optimal_force 100).
    for l in &cr.labels {
        let d = max_diff(&col(&cr, l), &col(&cf, l));
        assert!(d < 1e-2, "{l}: {d}");
    }
    assert!(cr.column_index("foot_floor_fx").is_none());
}

fn section(report: &str, title: &str) -> Vec<String> {
    let start = report
        .find(&format!("[{title}]"))
        .unwrap_or_else(|| panic!("no [{title}] in\n{report}"));
    let mut lines: Vec<String> = report[start..]
        .lines()
        .skip(1)
        .take_while(|l| !l.is_empty())
        .map(|l| l.split('\t').next().unwrap_or("").to_string())
        .collect();
    lines.sort();
    lines
}

/// (c): only the knee moves, so ground, thigh, torso and box are one rigid
/// cluster; hip_flex, hip_ext and back lie inside it (dropped), the lumbar
/// motor acts on a static coordinate (dropped), the torso–wall contact joins
/// two bodies of the cluster and the floor is 5 m away (skipped); torso and
/// box carry nothing kept and no free coordinate lies below them (dropped,
/// with the lumbar); the hip stays, locked at 0.3.
#[test]
fn dropped_elements_follow_from_the_structure() {
    let dir = common::out_dir("reduce_structure");
    let summary = run(&write_case(&dir, false, "true", "")).unwrap();
    let report = std::fs::read_to_string(dir.join("out/case_SO_reduction.txt")).unwrap();
    assert_eq!(section(&report, "free coordinates"), ["knee"]);
    assert_eq!(section(&report, "locked coordinates"), ["hip"]);
    assert!(report.contains("hip\t2.99999999999999989e-1"), "{report}");
    assert_eq!(
        section(&report, "dropped muscles"),
        ["back", "hip_ext", "hip_flex"]
    );
    assert_eq!(section(&report, "dropped actuators"), ["lumbar_motor"]);
    assert_eq!(
        section(
            &report,
            "skipped contacts (cannot act on a free coordinate)"
        ),
        ["torso_wall"]
    );
    assert_eq!(
        section(&report, "skipped contacts (never engaged)"),
        ["foot_floor"]
    );
    assert_eq!(section(&report, "dropped bodies"), ["box", "torso"]);
    assert_eq!(
        section(&report, "coordinates dropped with their bodies"),
        ["lumbar"]
    );
    for cat in ["locked", "dropped", "skipped", "bodies dropped"] {
        assert!(
            summary
                .warnings
                .iter()
                .any(|w| w.starts_with("reduce_model:") && w.contains(cat)),
            "no summary line for {cat}: {:?}",
            summary.warnings
        );
    }
    let act = table(&dir, "SO_activation.sto");
    assert_eq!(act.labels, KEPT);
    let src = table(&dir, "SO_GeneralizedForcesBySource.sto");
    assert_eq!(
        src.labels,
        [
            "knee_required",
            "knee_muscles",
            "knee_actuators",
            "knee_contacts"
        ]
    );
}

/// (d): a JointReaction on the lumbar keeps torso and box (the lumbar's child
/// subtree), the lumbar's crossing muscle and contact, and gives the locked
/// model's lumbar reaction.
#[test]
fn joint_reaction_joints_are_never_dropped() {
    let reduced = common::out_dir("reduce_jr_reduced");
    let locked = common::out_dir("reduce_jr_locked");
    run(&write_case(&reduced, false, "true", "lumbar knee")).unwrap();
    run(&write_case(&locked, true, "", "lumbar knee")).unwrap();
    let report = std::fs::read_to_string(reduced.join("out/case_SO_reduction.txt")).unwrap();
    assert!(section(&report, "dropped bodies").is_empty(), "{report}");
    assert_eq!(section(&report, "locked coordinates"), ["hip", "lumbar"]);
    assert_eq!(section(&report, "dropped muscles"), ["hip_ext", "hip_flex"]);
    let (jr, jl) = (
        table(&reduced, "JR_ReactionLoads.sto"),
        table(&locked, "JR_ReactionLoads.sto"),
    );
    assert_eq!(jr.labels, jl.labels);
    assert!(jr.labels.iter().any(|l| l.starts_with("lumbar_on_torso")));
    // Within the solver's tolerance: a contact multiplier whose optimum sits
    // on its bound 0 (the wall cannot act on the knee) comes out of the
    // interior-point solve at up to ~1e-4, i.e. 1e-2 N for optimal_force 100.
    for l in &jl.labels {
        let (a, b) = (col(&jr, l), col(&jl, l));
        assert!(max_diff(&a, &b) < 1e-2, "{l}: {}", max_diff(&a, &b));
    }
    // The lumbar reaction holds the torso and box (21 kg) against gravity and
    // against the back muscle, which cannot act on the knee and so rests at
    // its min_control 0.01: 20 N pulling the torso straight down (its points
    // are vertically aligned with lumbar = 0). The wall contact carries nothing.
    let fy = col(&jr, "lumbar_on_torso_in_torso_fy");
    let expected = 21.0 * 9.80665 + 0.01 * 2000.0;
    for v in fy {
        assert!((v - expected).abs() < 1e-2, "{v} vs {expected}");
    }
}

/// (e): reduce_model must be a boolean; the error names file, element and line.
#[test]
fn bad_reduce_model_value_is_a_located_error() {
    let dir = common::out_dir("reduce_bad_value");
    let setup = write_case(&dir, false, "maybe", "");
    let e = run(&setup).err().expect("an error").to_string();
    assert!(e.contains("setup.xml"), "{e}");
    assert!(e.contains("reduce_model"), "{e}");
    assert!(e.contains("line 6"), "{e}");
    assert!(e.contains("maybe"), "{e}");
}

/// The `<reduce_model>` scan of the motion and the static optimization after
/// it read the motion the run read once: the coordinates file is opened
/// once (the scan opened it, then the static optimization's stream again).
#[test]
fn a_reduced_run_opens_the_motion_once() {
    let dir = common::out_dir("reduce_motion_read_once");
    let setup = write_case(&dir, false, "true", "knee");
    run(&setup).unwrap();
    let motion = match Setup::read(&setup).unwrap() {
        Setup::Analyze(s) => s.coordinates_file.unwrap(),
        _ => unreachable!(),
    };
    assert!(dir.join("out/case_SO_activation.sto").is_file());
    assert_eq!(
        storage::times_opened(&motion),
        1,
        "openings of {}",
        motion.display()
    );
    let _ = std::fs::remove_dir_all(&dir);
}
