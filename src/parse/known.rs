//! Unknown properties in known elements.
//!
//! OpenSim 4.6 reads the properties it defines for an element type and
//! silently ignores any other child element (checked with OpenSim 4.6: a
//! `<frobnicate>` inside a `<Body>` loads without a message). statopt ignores
//! them too, but warns, naming the file, the line and the element: a
//! misspelled property (`<mas>` for `<mass>`) would otherwise silently fall
//! back to its default.
//!
//! A child is known when its tag or its `name` attribute (OpenSim writes
//! object-valued properties as `<Type name="property">`) is one of the
//! element type's properties ([`OPENSIM_PROPERTIES`], generated from OpenSim
//! 4.6), or one of statopt's own extensions ([`STATOPT_PROPERTIES`]), or a
//! property of an older document version that OpenSim still converts
//! ([`LEGACY_PROPERTIES`]). Only element types in these tables are checked.

use super::known_properties::OPENSIM_PROPERTIES;
use crate::xml::Element;

/// statopt's extensions of OpenSim element types.
pub const STATOPT_PROPERTIES: &[(&str, &[&str])] = &[
    (
        "AnalyzeTool",
        &["artifact_files", "close_contacts", "Figure", "Metric"],
    ),
    ("InverseDynamicsTool", &["artifact_files"]),
    (
        "StaticOptimization",
        &[
            "contact_weight",
            "friction_cone",
            "reserve_actuators",
            "passive_fiber_forces",
        ],
    ),
];

/// Properties of older documents that OpenSim still reads and converts.
pub const LEGACY_PROPERTIES: &[(&str, &[&str])] = &[
    ("Coordinate", &["motion_type"]),
    ("CoordinateCouplerConstraint", &["isDisabled"]),
    (
        "Thelen2003Muscle",
        &["isDisabled", "pennation_angle", "GeometryPath"],
    ),
    (
        "Millard2012EquilibriumMuscle",
        &["isDisabled", "GeometryPath"],
    ),
];

fn listed(table: &[(&str, &[&str])], ty: &str, child: &Element) -> bool {
    table.iter().any(|(t, props)| {
        *t == ty
            && props
                .iter()
                .any(|p| *p == child.name || child.attr("name") == Some(p))
    })
}

/// One warning per unknown property under `root` (elements of the types in
/// the tables only), e.g. `m.osim, line 12, <Body name="upper">: unknown
/// property <mas> ignored (OpenSim ignores it too)`.
pub fn unknown_properties(root: &Element) -> Vec<String> {
    let mut out = Vec::new();
    walk(root, &mut out);
    out
}

fn walk(el: &Element, out: &mut Vec<String>) {
    let ty = el.name.as_str();
    if OPENSIM_PROPERTIES.iter().any(|(t, _)| *t == ty) {
        for c in &el.children {
            if !listed(OPENSIM_PROPERTIES, ty, c)
                && !listed(STATOPT_PROPERTIES, ty, c)
                && !listed(LEGACY_PROPERTIES, ty, c)
            {
                out.push(format!(
                    "{}: unknown property <{}> (line {}) ignored, as OpenSim ignores it; check its spelling",
                    el.loc(),
                    c.name,
                    c.line
                ));
            }
        }
    }
    for c in &el.children {
        walk(c, out);
    }
}
