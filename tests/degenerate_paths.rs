//! Degenerate muscle paths give defined results, never NaN: coincident points
//! on different bodies, a path that starts inside a wrap object, and a muscle
//! whose conditional points are all inactive in some pose.

use std::path::Path;

use statopt::dynamics::{kinematics, Data};
use statopt::model::compile;
use statopt::muscles::set::{MuscleFrame, MuscleSet};
use statopt::parse::osim::ModelSpec;
use statopt::xml;

fn muscle(name: &str, points: &str, wraps: &str) -> String {
    format!(
        r#"<Thelen2003Muscle name="{name}">
  <GeometryPath name="path"><PathPointSet><objects>{points}</objects></PathPointSet>
  <PathWrapSet><objects>{wraps}</objects></PathWrapSet></GeometryPath>
  <max_isometric_force>500</max_isometric_force><optimal_fiber_length>0.1</optimal_fiber_length>
  <tendon_slack_length>0.2</tendon_slack_length><pennation_angle_at_optimal>0.1</pennation_angle_at_optimal>
</Thelen2003Muscle>"#
    )
}

fn pt(kind: &str, name: &str, body: &str, loc: &str, extra: &str) -> String {
    format!("<{kind} name=\"{name}\"><location>{loc}</location><socket_parent_frame>/bodyset/{body}</socket_parent_frame>{extra}</{kind}>")
}

fn model() -> String {
    let cond = "<socket_coordinate>/jointset/elbow/q</socket_coordinate><range>0.5 1.0</range>";
    let muscles = [
        // Two points at the same place in ground when q = 0 (the joint centre), on different bodies.
        muscle("coincident", &(pt("PathPoint", "a", "upper", "0 -0.5 0", "") + &pt("PathPoint", "b", "lower", "0 0 0", "")), ""),
        // Starts inside the wrap cylinder on the upper body.
        muscle(
            "inside_wrap",
            &(pt("PathPoint", "a", "upper", "0.001 -0.4 0", "") + &pt("PathPoint", "b", "lower", "0.05 -0.2 0", "")),
            "<PathWrap name=\"pw\"><wrap_object>cyl</wrap_object><method>hybrid</method><range>-1 -1</range></PathWrap>",
        ),
        // Both points conditional: no active point outside q in [0.5, 1].
        muscle("no_active_points", &(pt("ConditionalPathPoint", "a", "upper", "0.02 -0.2 0", cond) + &pt("ConditionalPathPoint", "b", "lower", "0.02 -0.2 0", cond)), ""),
    ]
    .join("\n");
    format!(
        r#"<OpenSimDocument Version="40000"><Model name="arm">
<BodySet><objects>
 <Body name="upper"><mass>2</mass><mass_center>0 -0.25 0</mass_center><inertia>0.02 0.002 0.02 0 0 0</inertia>
  <WrapObjectSet><objects><WrapCylinder name="cyl"><xyz_body_rotation>0 0 0</xyz_body_rotation><translation>0 -0.4 0</translation><radius>0.02</radius><length>0.1</length><quadrant>all</quadrant></WrapCylinder></objects></WrapObjectSet></Body>
 <Body name="lower"><mass>1</mass><mass_center>0 -0.2 0</mass_center><inertia>0.01 0.001 0.01 0 0 0</inertia></Body>
</objects></BodySet>
<JointSet><objects>
 <WeldJoint name="base"><socket_parent_frame>/ground</socket_parent_frame><socket_child_frame>/bodyset/upper</socket_child_frame></WeldJoint>
 <PinJoint name="elbow"><socket_parent_frame>e_p</socket_parent_frame><socket_child_frame>/bodyset/lower</socket_child_frame>
  <coordinates><Coordinate name="q"/></coordinates>
  <frames><PhysicalOffsetFrame name="e_p"><socket_parent>/bodyset/upper</socket_parent><translation>0 -0.5 0</translation><orientation>0 0 0</orientation></PhysicalOffsetFrame></frames></PinJoint>
</objects></JointSet>
<ForceSet><objects>{muscles}</objects></ForceSet>
</Model></OpenSimDocument>"#
    )
}

#[test]
fn degenerate_paths_give_finite_results() {
    let root = xml::parse_str(&model(), Path::new("degenerate.osim")).unwrap();
    let spec = ModelSpec::from_document(&root, Path::new("degenerate.osim")).unwrap();
    let model = compile(&spec).unwrap();
    let set = MuscleSet::compile(&spec, &spec.forces, &model).unwrap();
    assert_eq!(set.len(), 3);
    let mut data = Data::new(&model);
    let mut frame = MuscleFrame::new(&set, &model);
    for q in [0.0, 0.3, 0.7, 1.5, -1.0] {
        data.q[0] = q;
        data.u[0] = 0.8;
        kinematics::full(&model, &mut data);
        frame.evaluate(&set, &model, &data);
        for (m, pm) in set.muscles.iter().enumerate() {
            let name = &pm.muscle.name;
            let ma = frame.moment_arm(&model, &data.q, m, 0);
            for (what, v) in [
                ("length", frame.length[m]),
                ("speed", frame.speed[m]),
                ("moment arm", ma),
                ("max force", frame.max_active_force[m]),
                ("passive", frame.passive_force[m]),
            ] {
                assert!(v.is_finite(), "{name} at q={q}: {what} = {v}");
            }
        }
        // The muscle with no active points has no length and no strength there.
        let k = set
            .muscles
            .iter()
            .position(|m| m.muscle.name == "no_active_points")
            .unwrap();
        if !(0.5..=1.0).contains(&q) {
            assert_eq!(frame.length[k], 0.0);
            assert_eq!(frame.max_active_force[k], 0.0);
            assert_eq!(frame.moment_arm(&model, &data.q, k, 0), 0.0);
        } else {
            assert!(frame.length[k] > 0.0);
        }
    }
    // Coincident points at q = 0: length 0 and no direction, hence no moment arm.
    data.q[0] = 0.0;
    kinematics::full(&model, &mut data);
    frame.evaluate(&set, &model, &data);
    assert!(frame.length[0].abs() < 1e-15);
    assert_eq!(frame.moment_arm(&model, &data.q, 0, 0), 0.0);
}
