//! Contacts that tell the truth: the run's summary names every contact that
//! slid or went more than 1 mm into its plane while loaded (more than 10 N),
//! and every contact that carried nothing (with the reason when a body held
//! by reserve actuators only explains it), exactly as its own ContactForces
//! table shows; an unsolved frame's line names the coordinates whose
//! equations were not balanced and the contacts at a limit. Small scenes
//! whose truth is known (docs/contact_model.md, "What the summary says
//! about contacts").

mod common;
use common::{col, run_setup};

use std::path::Path;

use statopt::parse::setup::Setup;
use statopt::storage::{self, Storage};
use statopt::tools::{RunOptions, RunSummary};
use statopt::writers::contact_findings::{
    ContactFinding, FindingKind, LOADED_FORCE, PENETRATION_LIMIT, UNLOADED_FORCE,
};

const G: f64 = common::G;

/// A motion of the named coordinates, `rows` rows over `span` seconds.
fn motion(names: &[&str], rows: usize, span: f64, f: impl Fn(f64) -> Vec<f64>) -> String {
    let mut s = format!(
        "motion\nversion=1\nnRows={rows}\nnColumns={}\ninDegrees=no\nendheader\ntime\t{}\n",
        names.len() + 1,
        names.join("\t")
    );
    for k in 0..rows {
        let t = k as f64 * span / (rows - 1) as f64;
        let v: Vec<String> = f(t).iter().map(|x| format!("{x:.15}")).collect();
        s.push_str(&format!("{t:.6}\t{}\n", v.join("\t")));
    }
    s
}

fn setup(name: &str, so_extra: &str, span: f64) -> String {
    format!(
        r#"<?xml version="1.0"?>
<OpenSimDocument Version="40000"><AnalyzeTool name="{name}">
<model_file>model.osim</model_file><results_directory>out</results_directory><output_precision>14</output_precision>
<initial_time>0</initial_time><final_time>{span}</final_time>
<AnalysisSet name="Analyses"><objects><StaticOptimization name="SO">{so_extra}</StaticOptimization></objects></AnalysisSet>
<coordinates_file>motion.mot</coordinates_file><lowpass_cutoff_frequency_for_coordinates>-1</lowpass_cutoff_frequency_for_coordinates>
</AnalyzeTool></OpenSimDocument>"#
    )
}

/// Write a case and run it: (its output folder, the summary).
fn run_case(
    name: &str,
    model: &str,
    motion_text: &str,
    so_extra: &str,
    span: f64,
) -> (std::path::PathBuf, RunSummary) {
    let dir = common::out_dir(&format!("contact_truth_{name}"));
    std::fs::write(dir.join("model.osim"), model).unwrap();
    std::fs::write(dir.join("motion.mot"), motion_text).unwrap();
    std::fs::write(dir.join("setup.xml"), setup(name, so_extra, span)).unwrap();
    let s = run_setup(&dir.join("setup.xml"));
    (dir.join("out"), s)
}

/// The block of tests/common on a floor contact (its origin on the ground
/// plane y = 0; `floor` its extra properties) and a wall contact whose
/// plane at x = 5 m is out of reach (w = 0 on every frame).
fn block_on_floor(floor: &str) -> String {
    common::block_model(&format!(
        r#"<PointOnPlaneContact name="floor"><point_body>block</point_body><point_location>0 0 0</point_location>
<plane_body>ground</plane_body><plane_origin>0 0 0</plane_origin><plane_normal>0 1 0</plane_normal>
<kinetic_friction>0.5</kinetic_friction><optimal_force>100</optimal_force>{floor}</PointOnPlaneContact>
<PointOnPlaneContact name="wall"><point_body>block</point_body><point_location>0 0 0</point_location>
<plane_body>ground</plane_body><plane_origin>5 0 0</plane_origin><plane_normal>-1 0 0</plane_normal>
<contact_tolerance>0</contact_tolerance><contact_transition_zone>0.01</contact_transition_zone></PointOnPlaneContact>"#
    ))
}

/// What a contact's table shows, computed here from the table alone: frames
/// sliding (regime > 0) while loaded (|f| > 10 N) with the largest slip
/// speed; frames more than 1 mm deep while loaded with the deepest
/// distance; the largest force.
struct TableTruth {
    slid: usize,
    slip_max: f64,
    deep: usize,
    deepest: f64,
    force_max: f64,
}

fn table_truth(cf: &Storage, c: &str) -> TableTruth {
    let (fx, fy, fz) = (
        col(cf, &format!("{c}_fx")),
        col(cf, &format!("{c}_fy")),
        col(cf, &format!("{c}_fz")),
    );
    let d = col(cf, &format!("{c}_distance"));
    let slip = col(cf, &format!("{c}_slip_speed"));
    let regime = col(cf, &format!("{c}_regime"));
    let mut t = TableTruth {
        slid: 0,
        slip_max: 0.0,
        deep: 0,
        deepest: 0.0,
        force_max: 0.0,
    };
    for i in 0..cf.time.len() {
        let f = (fx[i] * fx[i] + fy[i] * fy[i] + fz[i] * fz[i]).sqrt();
        t.force_max = t.force_max.max(f);
        if f > LOADED_FORCE && regime[i] > 0.0 {
            t.slid += 1;
            t.slip_max = t.slip_max.max(slip[i]);
        }
        if f > LOADED_FORCE && d[i] < -PENETRATION_LIMIT {
            t.deep += 1;
            t.deepest = t.deepest.min(d[i]);
        }
    }
    t
}

fn finding<'a>(
    s: &'a RunSummary,
    run: Option<&str>,
    c: &str,
    kind: FindingKind,
) -> Option<&'a ContactFinding> {
    s.contacts
        .iter()
        .find(|f| f.run.as_deref() == run && f.contact == c && f.kind == kind)
}

/// Every finding is also a warning line of the summary.
fn assert_in_warnings(s: &RunSummary) {
    for f in &s.contacts {
        assert!(
            s.warnings.iter().any(|w| w.ends_with(&f.message)),
            "finding not among the warnings: {}",
            f.message
        );
    }
}

/// The summary names a contact exactly when its table shows it sliding or
/// deeper than 1 mm while loaded, with the same frame counts and extreme
/// values; per w0 of a sweep (at w0 = 0.001 the floor carries about 0.1 N:
/// it is not loaded, so it did not slide, and it carried nothing).
#[test]
fn summary_names_exactly_the_contacts_the_table_shows_sliding_or_too_deep() {
    // Speed 0.5 t: static below t = 0.2 s (v_trans 0.1 m/s), kinetic above;
    // depth 4 mm/s: more than 1 mm deep after t = 0.25 s.
    let model = block_on_floor("<v_trans>0.1</v_trans>");
    let text = motion(&["tx", "ty", "tz"], 41, 2.0, |t| {
        vec![0.25 * t * t, -0.004 * t, 0.0]
    });
    let (out, s) = run_case(
        "sweep",
        &model,
        &text,
        "<contact_weight>0.001 1000</contact_weight>",
        2.0,
    );
    assert_in_warnings(&s);
    for (w0, tag) in [(0.001, "0.001"), (1000.0, "1000")] {
        let run = format!("w0 = {w0}");
        let cf = storage::read(&out.join(format!("sweep_SO_w0_{tag}_ContactForces.sto"))).unwrap();
        for c in ["floor", "wall"] {
            let truth = table_truth(&cf, c);
            let slid = finding(&s, Some(&run), c, FindingKind::Slid);
            let deep = finding(&s, Some(&run), c, FindingKind::TooDeep);
            let nothing = finding(&s, Some(&run), c, FindingKind::CarriedNothing);
            println!(
                "{run} {c}: table slid {} (max {:.4} m/s), deep {} (deepest {:.5} m), max force {:.4} N",
                truth.slid, truth.slip_max, truth.deep, truth.deepest, truth.force_max
            );
            assert_eq!(slid.map_or(0, |f| f.frames), truth.slid, "{run} {c} slid");
            assert_eq!(deep.map_or(0, |f| f.frames), truth.deep, "{run} {c} deep");
            if let Some(f) = slid {
                assert!((f.value - truth.slip_max).abs() <= 1e-9 * (1.0 + truth.slip_max));
                assert!(f.message.contains(c) && f.message.contains("slid"));
            }
            if let Some(f) = deep {
                assert!((f.value - truth.deepest).abs() <= 1e-9);
                assert!(f
                    .message
                    .contains(&format!("{:.1} mm", -1e3 * truth.deepest)));
            }
            assert_eq!(
                nothing.is_some(),
                truth.force_max <= UNLOADED_FORCE,
                "{run} {c} carried nothing"
            );
        }
    }
    // The truth of this scene, from its physics: at w0 = 1000 the floor
    // carries nearly the block's weight, slides from t = 0.25 s (slip speed
    // 0.5 t > 0.1 m/s on 36 of 41 frames) and is more than 1 mm deep from
    // t = 0.3 s (35 frames; exactly 1 mm at 0.25 s), 8 mm at t = 2 s; the
    // wall carries nothing.
    let hi = Some("w0 = 1000");
    let slid = finding(&s, hi, "floor", FindingKind::Slid).expect("the floor slid");
    assert_eq!(slid.frames, 36);
    assert!((slid.value - 1.0).abs() < 1e-6, "slip speed {}", slid.value);
    let deep = finding(&s, hi, "floor", FindingKind::TooDeep).expect("the floor too deep");
    assert_eq!(deep.frames, 35);
    assert!((deep.value + 0.008).abs() < 1e-9, "deepest {}", deep.value);
    let wall = finding(&s, hi, "wall", FindingKind::CarriedNothing).expect("the wall");
    assert!(
        wall.message.contains("out of reach on every frame"),
        "{}",
        wall.message
    );
    // Said alike at both w0: one line for both (the structured list keeps
    // one entry per w0).
    let lines: Vec<&String> = s
        .warnings
        .iter()
        .filter(|w| w.contains("contact wall"))
        .collect();
    assert_eq!(lines.len(), 1, "{lines:?}");
    assert!(lines[0].starts_with("every w0 (0.001, 1000): contact wall carried nothing"));
    assert!(finding(&s, Some("w0 = 0.001"), "wall", FindingKind::CarriedNothing).is_some());
    let lo = Some("w0 = 0.001");
    assert!(finding(&s, lo, "floor", FindingKind::Slid).is_none());
    let floor = finding(&s, lo, "floor", FindingKind::CarriedNothing).expect("floor at 0.001");
    assert!(floor.value < 0.2 && floor.frames == 41, "{floor:?}");
    // The block is a root joint: no reserve is blamed.
    assert!(floor.reserve_body.is_none());
    // A resumed run reads its kept frames back from the tables
    // (RunStatistics::observe_tables): the same findings, from the same rows.
    let (_, _, problem) = common::so_case(&out.join("../setup.xml"), None);
    let mut stats = statopt::writers::run_statistics::RunStatistics::new(&problem);
    stats
        .observe_tables(
            &problem,
            &out,
            &statopt::writers::names::RunKey::analysis(
                "sweep",
                "SO",
                statopt::writers::names::Sweep::Weight(1000.0),
            ),
            41,
        )
        .unwrap();
    let again = stats.contact_findings(&problem);
    let run: Vec<ContactFinding> = s
        .contacts
        .iter()
        .filter(|f| f.run.as_deref() == hi)
        .map(|f| ContactFinding {
            run: None,
            ..f.clone()
        })
        .collect();
    // (Values as the tables hold them: rounded to 14 digits.)
    assert_eq!(again.len(), run.len());
    for (a, b) in again.iter().zip(&run) {
        assert_eq!(
            (&a.contact, a.kind, a.frames, &a.message),
            (&b.contact, b.kind, b.frames, &b.message)
        );
        assert!((a.value - b.value).abs() <= 1e-12 * (1.0 + b.value.abs()));
    }
}

/// A block at rest on the floor, static and on the surface: the summary
/// says nothing of the floor (no false alarm); the wall carried nothing.
#[test]
fn a_static_contact_on_its_surface_is_not_named() {
    let model = block_on_floor("<v_trans>0.1</v_trans>");
    let text = motion(&["tx", "ty", "tz"], 21, 1.0, |_| vec![0.0, -0.0005, 0.0]);
    let (_, s) = run_case("rest", &model, &text, "", 1.0);
    assert_in_warnings(&s);
    let named: Vec<_> = s.contacts.iter().map(|f| (&f.contact, f.kind)).collect();
    assert_eq!(
        named,
        vec![(&"wall".to_string(), FindingKind::CarriedNothing)],
        "{:?}",
        s.warnings
    );
}

/// A leg-press-like scene: a pelvis (planar, tx and ty) on a seat with
/// friction, pushed back by the legs (a fixed 200 N), and an upright trunk
/// (its mass centre at the lumbar joint) on a lumbar pin held by a reserve
/// actuator of 1 N m; a backrest contact 0.4 m above the lumbar joint; an
/// arm (3 kg) on a shoulder pin held by a reserve, resting on a frictionless
/// handle (with friction, the handle's horizontal force at the shoulder's
/// height balances the backrest's lumbar moment without any reserve, and
/// the backrest carries 12.6 N: no such line then). A
/// backrest force F would need F · 0.4 N m from the reserve: the optimum
/// gives the backrest of the order of 200/(1 + 0.4² · 100² · 1000) =
/// 1.2e-4 N (measured 9.3e-4 N: the formula counts the backrest's normal
/// force alone) and the seat's friction the rest, and the summary says why. With a
/// TorqueActuator (not a reserve) on the lumbar joint it names the contact
/// without that reason.
#[test]
fn a_backrest_on_a_trunk_held_by_reserves_is_named_with_the_reason() {
    const FRICTIONLESS: &str =
        "<static_friction>0</static_friction><kinetic_friction>0</kinetic_friction>";
    let scene = |lumbar_actuator: &str, handle_friction: &str| {
        format!(
            r#"<?xml version="1.0"?>
<OpenSimDocument Version="40000"><Model name="press"><gravity>0 -{G} 0</gravity>
<BodySet><objects>
<Body name="pelvis"><mass>10</mass><mass_center>0 0 0</mass_center><inertia>0.1 0.1 0.1 0 0 0</inertia></Body>
<Body name="trunk"><mass>30</mass><mass_center>0 0 0</mass_center><inertia>1 1 1 0 0 0</inertia></Body>
<Body name="arm"><mass>3</mass><mass_center>0.15 0 0</mass_center><inertia>0.01 0.01 0.01 0 0 0</inertia></Body>
</objects></BodySet>
<JointSet><objects>
<CustomJoint name="seat_slide"><socket_parent_frame>/ground</socket_parent_frame><socket_child_frame>/bodyset/pelvis</socket_child_frame>
<coordinates><Coordinate name="pelvis_tx"><range>-1 1</range></Coordinate><Coordinate name="pelvis_ty"><range>-1 1</range></Coordinate></coordinates>
<SpatialTransform>
<TransformAxis name="rotation1"><coordinates/><axis>1 0 0</axis></TransformAxis>
<TransformAxis name="rotation2"><coordinates/><axis>0 1 0</axis></TransformAxis>
<TransformAxis name="rotation3"><coordinates/><axis>0 0 1</axis></TransformAxis>
<TransformAxis name="translation1"><coordinates>pelvis_tx</coordinates><axis>1 0 0</axis><LinearFunction name="function"><coefficients>1 0</coefficients></LinearFunction></TransformAxis>
<TransformAxis name="translation2"><coordinates>pelvis_ty</coordinates><axis>0 1 0</axis><LinearFunction name="function"><coefficients>1 0</coefficients></LinearFunction></TransformAxis>
<TransformAxis name="translation3"><coordinates/><axis>0 0 1</axis></TransformAxis>
</SpatialTransform></CustomJoint>
<PinJoint name="lumbar_joint"><socket_parent_frame>pelvis_offset</socket_parent_frame><socket_child_frame>trunk_offset</socket_child_frame>
<coordinates><Coordinate name="lumbar"><range>-1 1</range></Coordinate></coordinates>
<frames>
<PhysicalOffsetFrame name="pelvis_offset"><socket_parent>/bodyset/pelvis</socket_parent><translation>0 0.1 0</translation><orientation>0 0 0</orientation></PhysicalOffsetFrame>
<PhysicalOffsetFrame name="trunk_offset"><socket_parent>/bodyset/trunk</socket_parent><translation>0 0 0</translation><orientation>0 0 0</orientation></PhysicalOffsetFrame>
</frames></PinJoint>
<PinJoint name="shoulder_joint"><socket_parent_frame>trunk_top</socket_parent_frame><socket_child_frame>arm_offset</socket_child_frame>
<coordinates><Coordinate name="shoulder"><range>-1 1</range></Coordinate></coordinates>
<frames>
<PhysicalOffsetFrame name="trunk_top"><socket_parent>/bodyset/trunk</socket_parent><translation>0 0.4 0</translation><orientation>0 0 0</orientation></PhysicalOffsetFrame>
<PhysicalOffsetFrame name="arm_offset"><socket_parent>/bodyset/arm</socket_parent><translation>0 0 0</translation><orientation>0 0 0</orientation></PhysicalOffsetFrame>
</frames></PinJoint>
</objects></JointSet>
<ForceSet><objects>
<PointActuator name="legs"><body>pelvis</body><point>0 0 0</point><direction>-1 0 0</direction><force_is_global>true</force_is_global><optimal_force>200</optimal_force><min_control>1</min_control><max_control>1</max_control></PointActuator>
{lumbar_actuator}
<CoordinateActuator name="shoulder_reserve"><coordinate>shoulder</coordinate><optimal_force>1</optimal_force><min_control>-Inf</min_control><max_control>Inf</max_control></CoordinateActuator>
<PointOnPlaneContact name="handle"><point_body>arm</point_body><point_location>0.3 0 0</point_location>
<plane_body>ground</plane_body><plane_origin>0 0.5 0</plane_origin><plane_normal>0 1 0</plane_normal>{handle_friction}<optimal_force>100</optimal_force></PointOnPlaneContact>
<PointOnPlaneContact name="seat"><point_body>pelvis</point_body><point_location>0 0 0</point_location>
<plane_body>ground</plane_body><plane_origin>0 0 0</plane_origin><plane_normal>0 1 0</plane_normal><optimal_force>100</optimal_force></PointOnPlaneContact>
<PointOnPlaneContact name="backrest"><point_body>trunk</point_body><point_location>-0.1 0.4 0</point_location>
<plane_body>ground</plane_body><plane_origin>-0.1 0 0</plane_origin><plane_normal>1 0 0</plane_normal><optimal_force>100</optimal_force></PointOnPlaneContact>
</objects></ForceSet></Model></OpenSimDocument>"#
        )
    };
    let text = motion(
        &["pelvis_tx", "pelvis_ty", "lumbar", "shoulder"],
        21,
        1.0,
        |_| vec![0.0; 4],
    );
    let reserve = r#"<CoordinateActuator name="lumbar_reserve"><coordinate>lumbar</coordinate><optimal_force>1</optimal_force><min_control>-Inf</min_control><max_control>Inf</max_control></CoordinateActuator>"#;
    let (out, s) = run_case("backrest", &scene(reserve, FRICTIONLESS), &text, "", 1.0);
    assert_eq!(s.failed, 0);
    assert_in_warnings(&s);
    let cf = storage::read(&out.join("backrest_SO_ContactForces.sto")).unwrap();
    let truth = table_truth(&cf, "backrest");
    println!("backrest: max force {:.3e} N", truth.force_max);
    // Within reach (w = 1) and pressed by nothing but the optimum's choice:
    // of the order of 200/(1 + 0.4² · 100² · 1000) = 1.2e-4 N, far below 1 N.
    assert!(
        truth.force_max > 0.0 && truth.force_max < 1e-3,
        "backrest carried {} N",
        truth.force_max
    );
    let f = finding(&s, None, "backrest", FindingKind::CarriedNothing).expect("backrest named");
    assert_eq!(f.reserve_body.as_deref(), Some("trunk"));
    assert!(
        f.message.contains("lumbar") && f.message.contains("lumbar_reserve"),
        "{}",
        f.message
    );
    // The seat carried the push, the handle half the arm's weight (14.7 N):
    // not named; the handle, beyond the shoulder held by a reserve too, is
    // named as another way to balance the lumbar joint.
    assert!(
        s.contacts
            .iter()
            .all(|f| f.contact != "seat" && f.contact != "handle"),
        "{:?}",
        s.contacts
    );
    let handle = table_truth(&cf, "handle").force_max;
    assert!((handle - 0.5 * 3.0 * G).abs() < 1e-3, "handle {handle} N");
    assert!(
        f.message.contains("or by the forces of handle"),
        "{}",
        f.message
    );
    // A handle with friction (μs 0.8) pulls back at the shoulder's height:
    // that balances the backrest's lumbar moment with no reserve, and the
    // backrest carries load; nothing is said of it.
    let (out, s2) = run_case("backrest_grip", &scene(reserve, ""), &text, "", 1.0);
    let cf = storage::read(&out.join("backrest_grip_SO_ContactForces.sto")).unwrap();
    let carried = table_truth(&cf, "backrest").force_max;
    println!("backrest beside a handle with friction: max force {carried:.3} N");
    assert!(carried > LOADED_FORCE, "{carried} N");
    assert!(
        s2.contacts.iter().all(|f| f.contact != "backrest"),
        "{:?}",
        s2.contacts
    );
    // Not a reserve: the contact is named, the reason is not given.
    let torque = r#"<TorqueActuator name="lumbar_torque"><bodyA>trunk</bodyA><bodyB>pelvis</bodyB><axis>0 0 1</axis><torque_is_global>true</torque_is_global><optimal_force>1</optimal_force><min_control>-Inf</min_control><max_control>Inf</max_control></TorqueActuator>"#;
    let (_, s) = run_case(
        "backrest_torque",
        &scene(torque, FRICTIONLESS),
        &text,
        "",
        1.0,
    );
    let f = finding(&s, None, "backrest", FindingKind::CarriedNothing).expect("backrest named");
    assert!(f.reserve_body.is_none(), "{}", f.message);
    assert!(!f.message.contains("reserve"), "{}", f.message);
}

/// Too weak an actuator: the push (at most 100 N) cannot give the 10 kg
/// block its 20 m/s². Every frame but the first is unsolved (at t = 0 static
/// friction pushes too); the best point lets the lift actuator hold the
/// block, so that no kinetic friction opposes the slide: the floor's normal
/// force is at zero and tx lacks exactly 200 − 100 = 100 N. The first
/// unsolved frame's line names tx with that residual, and the floor's limit.
#[test]
fn an_unsolved_frame_names_its_coordinate_and_the_contacts_at_a_limit() {
    let model = block_on_floor("<v_trans>0.1</v_trans>").replacen(
        "<min_control>-Inf</min_control><max_control>Inf</max_control>",
        "<min_control>0</min_control><max_control>1</max_control>",
        1,
    );
    let text = motion(&["tx", "ty", "tz"], 21, 1.0, |t| {
        vec![10.0 * t * t, 0.0, 0.0]
    });
    let (out, s) = run_case("weak", &model, &text, "", 1.0);
    assert!(s.failed > 0, "frames should fail");
    let first = s.first_failure.clone().expect("a failure line");
    println!("{first}");
    let src = storage::read(&out.join("weak_SO_GeneralizedForcesBySource.sto")).unwrap();
    let diag = storage::read(&out.join("weak_SO_diagnostics.sto")).unwrap();
    let i = col(&diag, "status").iter().position(|&v| v < 0.0).unwrap();
    let unbalanced =
        ["required", "muscles", "actuators", "contacts"].map(|k| col(&src, &format!("tx_{k}"))[i]);
    let r = unbalanced[0] - unbalanced[1] - unbalanced[2] - unbalanced[3];
    let missing = 10.0 * 20.0 - 100.0;
    assert!(
        (r - missing).abs() < 1e-3 * missing,
        "tx residual {r} vs {missing}"
    );
    assert!(
        first.contains(&format!("tx {r:.3e} N")),
        "the line should name tx with {r:.3e} N: {first}"
    );
    assert!(first.contains("floor normal force at zero"), "{first}");
    assert!(!first.contains("ty ") && !first.contains("tz "), "{first}");
}

/// `--check` on a copy of a shipped leg extension setup whose backrest
/// normal is flipped (the torso's mass centre then lies 90 mm behind the
/// plane): exit 2, naming the contact, the contacts file and the line of its
/// element. The shipped setups themselves (a grip's hold contact, whose hand
/// lies behind its plane, included) pass.
#[test]
fn check_reports_a_plane_facing_away_from_its_body() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = common::out_dir("contact_truth_check");
    for sub in ["setups", "models/leg_extension", "motions"] {
        std::fs::create_dir_all(dir.join(sub)).unwrap();
    }
    let copy = |rel: &str| {
        std::fs::copy(root.join(rel), dir.join(rel)).unwrap();
    };
    copy("setups/leg_extension_cam1.xml");
    copy("models/leg_extension/human_seated.osim");
    copy("models/leg_extension/machine_cam1.osim");
    copy("motions/leg_extension.mot");
    let contacts = std::fs::read_to_string(root.join("models/leg_extension/contacts.xml")).unwrap();
    let start = contacts
        .find(r#"<PointOnPlaneContact name="torso_backrest_r">"#)
        .unwrap();
    let line = contacts[..start].matches('\n').count() + 1;
    let normal = start
        + contacts[start..]
            .find("<plane_normal>1 0 0</plane_normal>")
            .unwrap();
    let flipped = format!(
        "{}<plane_normal>-1 0 0</plane_normal>{}",
        &contacts[..normal],
        &contacts[normal + "<plane_normal>1 0 0</plane_normal>".len()..]
    );
    let file = dir.join("models/leg_extension/contacts.xml");
    std::fs::write(&file, flipped).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_statopt-tool"))
        .arg(dir.join("setups/leg_extension_cam1.xml"))
        .arg("--check")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    println!("{err}");
    assert_eq!(out.status.code(), Some(2), "{err}");
    let said: Vec<&str> = err.lines().filter(|l| l.contains("faces away")).collect();
    assert_eq!(said.len(), 1, "{err}");
    assert!(
        said[0].contains(&format!(
            "contacts.xml, line {line}, <PointOnPlaneContact name=\"torso_backrest_r\">"
        )) && said[0].contains("contact torso_backrest_r")
            && said[0].contains("90.0 mm behind the plane"),
        "{}",
        said[0]
    );
    // The shipped setups: no contact reported.
    for entry in std::fs::read_dir(root.join("setups")).unwrap() {
        let p = entry.unwrap().path();
        if p.extension().is_some_and(|e| e == "xml") {
            let report = statopt::tools::check::run(&p, false);
            let facing: Vec<String> = report
                .errors
                .iter()
                .map(|e| e.to_string())
                .filter(|e| e.contains("faces away"))
                .collect();
            assert!(facing.is_empty(), "{}: {facing:?}", p.display());
        }
    }
}

/// predict-grf's foot contacts (calcaneus and toes points on the floor
/// found from the motion) face their feet: `--check`'s test names none.
#[test]
fn predict_grf_foot_contacts_face_their_feet() {
    use statopt::tools::predict_grf;
    let Some(root) = common::validation_dir("predict-grf foot contacts' sides") else {
        return;
    };
    let mut setup = match Setup::read(&root.join("gait10dof18musc_walk/setup_SO.xml")).unwrap() {
        Setup::Analyze(s) => s,
        _ => unreachable!(),
    };
    let out = common::out_dir("contact_truth_predict_grf");
    setup.final_time = setup.initial_time + 0.1;
    let opts = RunOptions {
        results_dir: Some(out.clone()),
        verbose: false,
        ..Default::default()
    };
    predict_grf::run(&setup, &opts).unwrap();
    let feet = out.join(format!("{}_foot_contacts.xml", setup.name));
    // The user's setup with the written foot contacts added.
    setup.force_set_files.push(feet);
    let am = statopt::forces::analysis_model::load_analysis_model(&setup).unwrap();
    let so = setup.static_optimization().unwrap().clone();
    let (problem, _) =
        statopt::tools::static_optimization::SoProblem::build_from(&setup, &so, am.clone())
            .unwrap();
    assert!(
        problem.contacts.len() >= 4,
        "{} contacts",
        problem.contacts.len()
    );
    let errors = statopt::tools::check::contacts_facing_away(&setup, &problem);
    assert!(errors.is_empty(), "{errors:?}");
}

/// A contact that carried nothing at every w0 of a sweep is named once, with
/// the largest force of any w0 (which bounds every w0's), not once per w0:
/// the leg extension's handle_hold contacts carried at most 0.000, 0.431 and
/// 0.975 N at w0 = 1, 500 and 1000, and the sweep said so in six lines.
#[test]
fn a_contact_idle_at_every_w0_is_named_once() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = common::out_dir("contact_truth_idle_sweep");
    let s = statopt::tools::run_setup(
        &root.join("setups/leg_extension_rajagopal_cam1.xml"),
        &RunOptions {
            results_dir: Some(out),
            ..Default::default()
        },
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let per_w0: Vec<&ContactFinding> = s
        .contacts
        .iter()
        .filter(|f| f.contact == "handle_hold_r" && f.kind == FindingKind::CarriedNothing)
        .collect();
    assert_eq!(per_w0.len(), 3, "{:?}", s.contacts);
    let most = per_w0.iter().map(|f| f.value).fold(0.0, f64::max);
    let lines: Vec<&String> = s
        .warnings
        .iter()
        .filter(|w| w.contains("contact handle_hold_r carried nothing"))
        .collect();
    assert_eq!(lines.len(), 1, "{:#?}", s.warnings);
    assert!(
        lines[0].contains("every w0 (1, 500, 1000)")
            && lines[0].contains(&format!("at most {most:.3} N")),
        "{} (largest {most})",
        lines[0]
    );
}

/// A group force target (`force_target_*`, statopt, issue 36) holds: a
/// block of 10 kg resting on two floor contacts that cost the same. The
/// effort minimum shares its weight equally; with contact `a`'s vertical
/// force held to 30 N from 0.2 to 0.8 s (and to 0 N of force across a
/// tilted axis: a force along (0.2, 1, 0)), `a` carries 30 N there and `b`
/// the rest, and outside the target the two share equally again. A second
/// contact of the group with another target is an error naming both.
#[test]
fn a_force_target_holds_the_group_force_and_only_within_its_knots() {
    let floor = |name: &str, x: f64, extra: &str| {
        format!(
            r#"<PointOnPlaneContact name="{name}"><point_body>block</point_body><point_location>{x} 0 0</point_location>
<plane_body>ground</plane_body><plane_normal>0 1 0</plane_normal><static_friction>0.8</static_friction><v_trans>0.1</v_trans>{extra}</PointOnPlaneContact>"#
        )
    };
    // Across (0.2, 1, 0): the unit axis (1, -0.2, 0)/|.|.
    let k = 1.0 / (1.0f64 + 0.04).sqrt();
    let rows = |t: f64, on: u8| format!("{t} {on} 0 1 0 30 {} {} 0 0", k, -0.2 * k);
    let target = format!(
        "<force_target_group>a</force_target_group><force_target_rows>2</force_target_rows><force_target>{} {}</force_target>",
        rows(0.2, 1),
        rows(0.8, 1)
    );
    let model = common::block_model(&(floor("a", -0.1, &target) + &floor("b", 0.1, "")));
    let text = motion(&["tx", "ty", "tz"], 11, 1.0, |_| vec![0.0, -0.0005, 0.0]);
    let (out, s) = run_case("target", &model, &text, "", 1.0);
    assert_eq!(s.failed, 0);
    let cf = storage::read(&out.join("target_SO_ContactForces.sto")).unwrap();
    let (ax, ay, by) = (col(&cf, "a_fx"), col(&cf, "a_fy"), col(&cf, "b_fy"));
    let w = 10.0 * G;
    for (i, &t) in cf.time.iter().enumerate() {
        let (a, b) = (ay[i].abs(), by[i].abs());
        assert!(
            (a + b - w).abs() < 1e-3 * w,
            "t = {t}: {a} + {b} against {w}"
        );
        if (0.2..=0.8).contains(&t) {
            assert!((a - 30.0).abs() < 0.05, "t = {t}: a carries {a} N, not 30");
            assert!(
                (ax[i].abs() - 0.2 * a).abs() < 0.05,
                "t = {t}: a's shear {} against 0.2 x {a}",
                ax[i]
            );
        } else {
            assert!((a - b).abs() < 1e-3 * w, "t = {t}: {a} against {b}");
        }
    }
    // One group, two targets: an error with both names.
    let other = target.replace("0 1 0 30", "0 1 0 20");
    let model = common::block_model(&(floor("a", -0.1, &target) + &floor("b", 0.1, &other)));
    let dir = common::out_dir("contact_truth_target_mismatch");
    std::fs::write(dir.join("model.osim"), model).unwrap();
    std::fs::write(dir.join("motion.mot"), &text).unwrap();
    std::fs::write(dir.join("setup.xml"), setup("mismatch", "", 1.0)).unwrap();
    let Setup::Analyze(a) = Setup::read(&dir.join("setup.xml")).unwrap() else {
        unreachable!()
    };
    let e = statopt::tools::analyze::run(&a, &RunOptions::default())
        .err()
        .expect("two targets in one group")
        .to_string();
    assert!(
        e.contains("'b'") && e.contains("'a'") && e.contains("force_target_group"),
        "{e}"
    );
}
