//! Unknown properties in known elements.
//!
//! OpenSim 4.6 reads the properties it defines for an element type and
//! silently ignores any other child element (checked with OpenSim 4.6: a
//! `<frobnicate>` inside a `<Body>` loads without a message). statopt ignores
//! them too, but warns, naming the file, the line and the element: a
//! misspelled property (`<mass_centre>` for `<mass_center>`) would otherwise silently fall
//! back to its default.
//!
//! A child is known when its tag or its `name` attribute (OpenSim writes
//! object-valued properties as `<Type name="property">`) is one of the
//! element type's properties ([`OPENSIM_PROPERTIES`], generated from OpenSim
//! 4.6), or one of statopt's own extensions ([`STATOPT_PROPERTIES`]), or a
//! property of an older document version that OpenSim still converts
//! ([`LEGACY_PROPERTIES`]). Element types statopt defines itself
//! ([`STATOPT_ELEMENTS`], e.g. `PointOnPlaneContact`) are checked the same
//! way, in models and in force-set files. Only element types in these tables
//! are checked.

use super::known_properties::OPENSIM_PROPERTIES;
use crate::xml::Element;

/// statopt's extensions of OpenSim element types.
pub const STATOPT_PROPERTIES: &[(&str, &[&str])] = &[
    (
        "AnalyzeTool",
        &[
            "artifact_files",
            "close_contacts",
            "Figure",
            "Metric",
            "coordinate_spline",
            "reduce_model",
        ],
    ),
    ("InverseDynamicsTool", &["artifact_files"]),
    ("JointReaction", &["knee_loads"]),
    (
        "StaticOptimization",
        &[
            "contact_weight",
            "friction_cone",
            "reserve_actuators",
            "passive_fiber_forces",
            "constraint_matrix",
            "solver_tolerance",
            "solver",
            "knee_contact",
        ],
    ),
];

/// Element types statopt defines, with every property it reads. Their
/// unknown children are reported the same way as OpenSim elements'.
pub const STATOPT_ELEMENTS: &[(&str, &[&str])] = &[
    ("PointOnPlaneContact", CONTACT_PROPERTIES),
    ("ContactPointOnPlane", CONTACT_PROPERTIES),
];

const CONTACT_PROPERTIES: &[&str] = &[
    "point_body",
    "socket_point_frame",
    "point_location",
    "plane_body",
    "socket_plane_frame",
    "plane_origin",
    "plane_normal",
    "static_friction",
    "kinetic_friction",
    "contact_tolerance",
    "contact_transition_zone",
    "v_trans",
    "optimal_force",
    "regime_blend",
    "speed_weight",
    "plane_velocity",
    "appliesForce",
    "isDisabled",
];

/// Children OpenSim reads in any object it serialises: `<defaults>` holds
/// default objects (OpenSim's stock setups, e.g. gait2392's, carry one).
const ANY_ELEMENT: &[&str] = &["defaults"];

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
/// property <mass_centre> ignored (OpenSim ignores it too)`.
pub fn unknown_properties(root: &Element) -> Vec<String> {
    let mut out = Vec::new();
    walk(root, true, &mut out);
    out
}

/// [`unknown_properties`] for an element of a document of OpenSim version
/// `version`: OpenSim's element types are checked only in 4.0 documents
/// (40000 and later; older ones carry properties OpenSim converts), statopt's
/// own element types always.
pub fn unknown_properties_in_version(root: &Element, version: Option<u32>) -> Vec<String> {
    let mut out = Vec::new();
    walk(root, version.is_some_and(|v| v >= 40000), &mut out);
    out
}

fn walk(el: &Element, check_opensim: bool, out: &mut Vec<String>) {
    let ty = el.name.as_str();
    let opensim = check_opensim && OPENSIM_PROPERTIES.iter().any(|(t, _)| *t == ty);
    let statopt = STATOPT_ELEMENTS.iter().any(|(t, _)| *t == ty);
    if opensim || statopt {
        for c in &el.children {
            if !listed(OPENSIM_PROPERTIES, ty, c)
                && !listed(STATOPT_PROPERTIES, ty, c)
                && !listed(LEGACY_PROPERTIES, ty, c)
                && !listed(STATOPT_ELEMENTS, ty, c)
                && !ANY_ELEMENT.contains(&c.name.as_str())
            {
                let why = if opensim {
                    "ignored, as OpenSim ignores it"
                } else {
                    "ignored (its default applies)"
                };
                out.push(format!(
                    "{}: unknown property <{}> (line {}) {why}; check its spelling",
                    el.loc(),
                    c.name,
                    c.line
                ));
            }
        }
    }
    for c in &el.children {
        walk(c, check_opensim, out);
    }
}
