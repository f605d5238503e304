use std::path::Path;

use super::*;
use crate::xml;

/// A 4.0 document with one body `body` on a pin joint `joint` (coordinate
/// `coord`) to ground through a joint offset frame `pivot`, plus `extra`
/// model children (sets) spliced in.
fn doc(body: &str, joint: &str, coord: &str, gravity: &str, extra: &str) -> String {
    format!(
        r#"<?xml version="1.0"?>
<OpenSimDocument Version="40000"><Model name="m">
<gravity>{gravity}</gravity>
<BodySet><objects>
<Body name="{body}"><mass>2</mass><mass_center>0 -0.1 0</mass_center><inertia>0.1 0.1 0.1 0 0 0</inertia>
<components><PhysicalOffsetFrame name="pad"><socket_parent>..</socket_parent><translation>0 -0.2 0</translation></PhysicalOffsetFrame></components>
</Body>
</objects></BodySet>
<JointSet><objects>
<PinJoint name="{joint}"><socket_parent_frame>pivot</socket_parent_frame><socket_child_frame>/bodyset/{body}</socket_child_frame>
<coordinates><Coordinate name="{coord}"><default_value>0.5</default_value></Coordinate></coordinates>
<frames><PhysicalOffsetFrame name="pivot"><socket_parent>/ground</socket_parent><translation>0 1 0</translation></PhysicalOffsetFrame></frames>
</PinJoint>
</objects></JointSet>
{extra}
</Model></OpenSimDocument>"#
    )
}

fn spec(text: &str, file: &str) -> ModelSpec {
    let root = xml::parse_str(text, Path::new(file)).unwrap();
    ModelSpec::from_document(&root, Path::new(file)).unwrap()
}

const G: &str = "0 -9.80665 0";

fn force(name: &str, coord: &str) -> String {
    format!(
        r#"<ForceSet><objects><CoordinateActuator name="{name}"><coordinate>{coord}</coordinate><optimal_force>10</optimal_force></CoordinateActuator></objects></ForceSet>"#
    )
}

#[test]
fn merged_model_compiles_with_both_parts() {
    let base = spec(
        &doc(
            "shank",
            "knee",
            "knee_angle",
            G,
            &force("knee_act", "knee_angle"),
        ),
        "human.osim",
    );
    let art = spec(
        &doc(
            "lever",
            "lever_pin",
            "lever_angle",
            G,
            &force("motor", "lever_angle"),
        ),
        "machine.osim",
    );
    let m = merge(base, art).unwrap();
    assert_eq!(m.bodies.len(), 2);
    assert_eq!(m.joints.len(), 2);
    assert_eq!(m.forces.len(), 2);
    let paths: Vec<&str> = m.frames.iter().map(|f| f.path.as_str()).collect();
    assert!(paths.contains(&"/bodyset/lever/pad"), "{paths:?}");
    assert!(paths.contains(&"/jointset/lever_pin/pivot"), "{paths:?}");
    let model = crate::model::compile(&m).unwrap();
    assert_eq!(model.nq(), 2);
    assert!(model.coordinate_index("lever_angle").is_some());
    // The artifact's pad frame resolves to its own body, 0.2 m below the origin.
    let pad = model.frame("/bodyset/lever/pad").unwrap();
    assert_eq!(model.bodies[pad.body].name, "lever");
    assert!((pad.transform.translation.y + 0.2).abs() < 1e-15);
    let lever = model.body_index("lever").unwrap();
    assert_eq!(model.bodies[lever].parent, Some(0));
    assert_eq!(model.bodies[lever].mass, 2.0);
}

/// Every clash names both files, the element and its line.
#[test]
fn every_clash_names_both_files() {
    let base_text = doc(
        "shank",
        "knee",
        "knee_angle",
        G,
        &format!(
            "{}<ConstraintSet><objects><CoordinateCouplerConstraint name=\"cc\"><coupled_coordinates_function><LinearFunction><coefficients>1 0</coefficients></LinearFunction></coupled_coordinates_function><independent_coordinate_names>knee_angle</independent_coordinate_names><dependent_coordinate_name>knee_angle</dependent_coordinate_name></CoordinateCouplerConstraint></objects></ConstraintSet><components><PhysicalOffsetFrame name=\"mark\"><socket_parent>/ground</socket_parent></PhysicalOffsetFrame></components>",
            force("act", "knee_angle")
        ),
    );
    let cases: Vec<(&str, String, &str)> = vec![
        ("body", doc("shank", "j2", "c2", G, ""), "<Body name=\"shank\">"),
        (
            "body",
            doc("ground", "j2", "c2", G, ""),
            "<Body name=\"ground\">",
        ),
        ("joint", doc("b2", "knee", "c2", G, ""), "<PinJoint name=\"knee\">"),
        (
            "coordinate",
            doc("b2", "j2", "knee_angle", G, ""),
            "<Coordinate name=\"knee_angle\">",
        ),
        (
            "force",
            doc("b2", "j2", "c2", G, &force("act", "c2")),
            "<CoordinateActuator name=\"act\">",
        ),
        (
            "frame path",
            doc(
                "b2",
                "j2",
                "c2",
                G,
                "<components><PhysicalOffsetFrame name=\"mark\"><socket_parent>/ground</socket_parent></PhysicalOffsetFrame></components>",
            ),
            "<PhysicalOffsetFrame name=\"mark\">",
        ),
        (
            "constraint",
            doc(
                "b2",
                "j2",
                "c2",
                G,
                "<ConstraintSet><objects><CoordinateCouplerConstraint name=\"cc\"><coupled_coordinates_function><LinearFunction><coefficients>1 0</coefficients></LinearFunction></coupled_coordinates_function><independent_coordinate_names>c2</independent_coordinate_names><dependent_coordinate_name>c2</dependent_coordinate_name></CoordinateCouplerConstraint></objects></ConstraintSet>",
            ),
            "<CoordinateCouplerConstraint name=\"cc\">",
        ),
    ];
    for (what, art_text, element) in cases {
        let base = spec(&base_text, "dir/human.osim");
        let art = spec(&art_text, "dir/machine_cam1.osim");
        let e = merge(base, art).unwrap_err();
        assert_eq!(e.exit_code(), 2);
        let msg = e.to_string();
        assert!(
            msg.contains("dir/human.osim") && msg.contains("dir/machine_cam1.osim"),
            "{what}: {msg}"
        );
        assert!(msg.contains(what), "{what}: {msg}");
        assert!(msg.contains(element), "{what}: {msg}");
        assert!(msg.contains("line "), "{what}: {msg}");
    }
}

#[test]
fn wrap_object_clash_and_gravity_mismatch() {
    let wrap = |body: &str| {
        format!(
            r#"<?xml version="1.0"?>
<OpenSimDocument Version="40000"><Model name="w"><gravity>{G}</gravity>
<BodySet><objects><Body name="{body}"><mass>1</mass><inertia>1 1 1 0 0 0</inertia>
<WrapObjectSet><objects><WrapCylinder name="cyl"><radius>0.1</radius><length>1</length></WrapCylinder></objects></WrapObjectSet></Body></objects></BodySet>
<JointSet><objects><PinJoint name="{body}_j"><socket_parent_frame>/ground</socket_parent_frame><socket_child_frame>/bodyset/{body}</socket_child_frame><coordinates><Coordinate name="{body}_q"/></coordinates></PinJoint></objects></JointSet>
</Model></OpenSimDocument>"#
        )
    };
    let e = merge(spec(&wrap("a"), "h.osim"), spec(&wrap("b"), "art.osim"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("wrap object 'cyl'") && e.contains("h.osim") && e.contains("art.osim"),
        "{e}"
    );

    let e = merge(
        spec(&doc("a", "ja", "qa", G, ""), "h.osim"),
        spec(&doc("b", "jb", "qb", "0 0 -9.81", ""), "art.osim"),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("gravity") && e.contains("h.osim") && e.contains("art.osim"),
        "{e}"
    );
    assert!(e.contains("line 3"), "{e}");
    // Equal gravity written differently is accepted.
    assert!(merge(
        spec(&doc("a", "ja", "qa", G, ""), "h.osim"),
        spec(&doc("b", "jb", "qb", "0.0 -9.806650 0.0", ""), "art.osim"),
    )
    .is_ok());
}
