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
            "knee_contact_capacity",
            "knee_contact_medial_share",
            "knee_contact_equal_activation",
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
    "off_intervals",
    "off_weight",
    "held_intervals",
    "time_weight",
    "force_target_group",
    "force_target_rows",
    "force_target",
    "force_target_optimal_force",
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
    // OpenSim 3.x setups (e.g. the arm26 example's): 4.x reads the units
    // from the coordinates file's header instead.
    ("InverseDynamicsTool", &["coordinates_in_degrees"]),
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

/// The property lists of one element type, from each table (a type may
/// appear in several).
#[derive(Default)]
struct KnownLists {
    opensim: Vec<&'static [&'static str]>,
    statopt: Vec<&'static [&'static str]>,
    legacy: Vec<&'static [&'static str]>,
    elements: Vec<&'static [&'static str]>,
}

/// The tables by element type, made once: the model walk looks up each of
/// its elements' types (gait2392: about 4,900) by hash instead of scanning
/// the tables (3.5 M instructions of a 190 M whole run).
static KNOWN: std::sync::LazyLock<std::collections::HashMap<&'static str, KnownLists>> =
    std::sync::LazyLock::new(|| {
        let mut map: std::collections::HashMap<&'static str, KnownLists> = Default::default();
        let tables: [(
            &[(&'static str, &'static [&'static str])],
            fn(&mut KnownLists) -> &mut Vec<&'static [&'static str]>,
        ); 4] = [
            (OPENSIM_PROPERTIES, |k| &mut k.opensim),
            (STATOPT_PROPERTIES, |k| &mut k.statopt),
            (LEGACY_PROPERTIES, |k| &mut k.legacy),
            (STATOPT_ELEMENTS, |k| &mut k.elements),
        ];
        for (table, list) in tables {
            for (ty, props) in table {
                list(map.entry(ty).or_default()).push(props);
            }
        }
        map
    });

/// Whether `child` is one of `lists`' properties, by its tag or its `name`.
fn listed(lists: &[&[&str]], tag: &str, name_attr: Option<&str>) -> bool {
    lists
        .iter()
        .any(|props| props.iter().any(|p| *p == tag || name_attr == Some(p)))
}

/// The first bytes of the tables' element types: most elements (the
/// properties, `mass`, `location`, ...) are passed over without hashing
/// their names.
static FIRST_BYTES: std::sync::LazyLock<[bool; 256]> = std::sync::LazyLock::new(|| {
    let mut first = [false; 256];
    for ty in KNOWN.keys() {
        if let Some(&b) = ty.as_bytes().first() {
            first[b as usize] = true;
        }
    }
    first
});

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
    let maybe_known = ty
        .as_bytes()
        .first()
        .map_or_else(|| KNOWN.contains_key(""), |&b| FIRST_BYTES[b as usize]);
    if let Some(known) = maybe_known.then(|| KNOWN.get(ty)).flatten() {
        let opensim = check_opensim && !known.opensim.is_empty();
        let statopt = !known.elements.is_empty();
        if opensim || statopt {
            for c in &el.children {
                let (tag, name_attr) = (c.name.as_str(), c.attr("name"));
                if !listed(&known.opensim, tag, name_attr)
                    && !listed(&known.statopt, tag, name_attr)
                    && !listed(&known.legacy, tag, name_attr)
                    && !listed(&known.elements, tag, name_attr)
                    && !ANY_ELEMENT.contains(&tag)
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
    }
    for c in &el.children {
        walk(c, check_opensim, out);
    }
}

/// Element types of setup documents. An unknown child of one is refused
/// (statopt is stricter than OpenSim here: a misspelled
/// `<contact_wieght>` would otherwise leave w0 at its default, a factor
/// of 1000 in the contact/muscle split), unless the user asks to read on
/// (`--allow-unknown`). Models and force sets keep the warning above.
pub const SETUP_ELEMENT_TYPES: &[&str] = &[
    "AnalyzeTool",
    "InverseDynamicsTool",
    "StaticOptimization",
    "MuscleAnalysis",
    "JointReaction",
    "BodyKinematics",
    "PointKinematics",
];

/// Properties OpenSim 4.6 defines for setup elements that statopt accepts
/// but does not use (the integrator's settings: statopt integrates nothing;
/// an analysis's own time window and units: statopt analyses the tool's
/// time range and writes its tables in the units it documents). A run
/// lists the ones a setup holds once, in its summary.
pub const UNUSED_SETUP_PROPERTIES: &[(&str, &[&str])] = &[
    (
        "AnalyzeTool",
        &[
            "solve_for_equilibrium_for_auxiliary_states",
            "maximum_number_of_integrator_steps",
            "maximum_integrator_step_size",
            "minimum_integrator_step_size",
            "integrator_error_tolerance",
            "ControllerSet",
        ],
    ),
    ("InverseDynamicsTool", &["coordinates_in_degrees"]),
    (
        "StaticOptimization",
        &["start_time", "end_time", "in_degrees"],
    ),
    ("MuscleAnalysis", &["start_time", "end_time", "in_degrees"]),
    ("JointReaction", &["start_time", "end_time", "in_degrees"]),
    ("BodyKinematics", &["start_time", "end_time"]),
    ("PointKinematics", &["start_time", "end_time", "in_degrees"]),
];

/// What checking a setup document's elements found.
#[derive(Debug, Default)]
pub struct SetupElements {
    /// Children neither OpenSim 4.6 nor statopt knows, one error each
    /// (file, line, element and the nearest known name).
    pub unknown: Vec<crate::error::Error>,
    /// OpenSim properties the document holds that statopt does not use,
    /// e.g. `AnalyzeTool <maximum_integrator_step_size>`.
    pub unused: Vec<String>,
}

/// Every name a child of an element of type `ty` may carry.
fn known_names(ty: &str) -> Vec<&'static str> {
    let mut out: Vec<&'static str> = ANY_ELEMENT.to_vec();
    for table in [
        OPENSIM_PROPERTIES,
        STATOPT_PROPERTIES,
        LEGACY_PROPERTIES,
        STATOPT_ELEMENTS,
    ] {
        for (t, props) in table {
            if *t == ty {
                out.extend_from_slice(props);
            }
        }
    }
    out
}

/// The known name nearest to `name` (edit distance, case ignored), if one
/// is near enough to be a misspelling of it.
pub fn nearest<'a>(name: &str, candidates: &[&'a str]) -> Option<&'a str> {
    let lower = name.to_ascii_lowercase();
    candidates
        .iter()
        .map(|c| {
            (
                strsim::damerau_levenshtein(&lower, &c.to_ascii_lowercase()),
                *c,
            )
        })
        .filter(|(d, c)| *d <= (c.len().max(name.len()) / 3).max(2))
        .min_by_key(|(d, _)| *d)
        .map(|(_, c)| c)
}

/// The "did you mean" part of a message about an unknown `name` among
/// `candidates`, with the names known there when none is near.
pub fn suggestion(name: &str, candidates: &[&str]) -> String {
    match nearest(name, candidates) {
        Some(n) => format!("did you mean {n}?"),
        None => {
            let mut all: Vec<&str> = candidates.to_vec();
            all.sort_unstable();
            all.dedup();
            format!("known here: {}", all.join(", "))
        }
    }
}

/// Check every element of a setup document's tool element (see
/// [`SETUP_ELEMENT_TYPES`]).
pub fn setup_elements(tool: &Element) -> SetupElements {
    let mut out = SetupElements::default();
    setup_walk(tool, &mut out);
    out
}

fn setup_walk(el: &Element, out: &mut SetupElements) {
    let ty = el.name.as_str();
    if SETUP_ELEMENT_TYPES.contains(&ty) {
        let names = known_names(ty);
        let unused = UNUSED_SETUP_PROPERTIES
            .iter()
            .find(|(t, _)| *t == ty)
            .map_or(&[][..], |(_, p)| *p);
        for c in &el.children {
            let key = c
                .attr("name")
                .filter(|n| names.contains(n))
                .unwrap_or(c.name.as_str());
            if names.contains(&c.name.as_str()) || names.contains(&key) {
                if matches!(c.name.as_str(), "Figure" | "Metric") {
                    out.unknown.extend(figure_elements(c));
                }
                if unused.contains(&key) {
                    out.unused.push(format!("{ty} <{key}>"));
                }
                continue;
            }
            out.unknown.push(c.error(format!(
                "unknown element <{}> in {}: {} (statopt refuses elements it does not know in setup documents, as a misspelled property would silently take its default; --allow-unknown reads on with a warning)",
                c.name,
                el.describe(),
                suggestion(&c.name, &names)
            )));
        }
        for c in &el.children {
            setup_walk(c, out);
        }
    } else {
        // Sets inside a setup (AnalysisSet, objects): their children are
        // checked by type.
        for c in &el.children {
            setup_walk(c, out);
        }
    }
}

/// statopt's figure and metric elements (in a study or an AnalyzeTool
/// setup) and the attributes each reads; a `<Figure>` holds the others
/// but `<Metric>`.
pub const FIGURE_ELEMENTS: &[(&str, &[&str])] = &[
    (
        "Figure",
        &["name", "title", "x_label", "y_label", "fill_label"],
    ),
    (
        "Series",
        &["file", "column", "label", "color", "dashed", "scale"],
    ),
    (
        "Band",
        &[
            "mean", "min", "max", "column", "label", "color", "dashed", "scale",
        ],
    ),
    ("panel", &["title", "x_label", "y_label", "fill_label"]),
    ("fill_between", &["label"]),
    (
        "Metric",
        &["name", "file", "columns", "op", "where", "value", "scale"],
    ),
];

/// The children of a `<StatoptStudy>`.
pub const STUDY_CHILDREN: &[&str] = &[
    "setups",
    "results_directory",
    "Figure",
    "Metric",
    "ForceSweep",
];

/// Unknown attributes and children of a `<Figure>` or `<Metric>`, one error
/// each, with the nearest known name.
pub fn figure_elements(el: &Element) -> Vec<crate::error::Error> {
    let mut out = Vec::new();
    let Some((_, attrs)) = FIGURE_ELEMENTS.iter().find(|(t, _)| *t == el.name) else {
        return out;
    };
    for (a, _) in &el.attrs {
        if !attrs.contains(&a.as_str()) {
            out.push(el.error(format!(
                "unknown attribute {a}=\"...\" of {}: {}",
                el.describe(),
                suggestion(a, attrs)
            )));
        }
    }
    if el.name == "Figure" {
        let inner: Vec<&str> = FIGURE_ELEMENTS
            .iter()
            .map(|(t, _)| *t)
            .filter(|t| !matches!(*t, "Figure" | "Metric"))
            .collect();
        for c in &el.children {
            if inner.contains(&c.name.as_str()) {
                out.extend(figure_elements(c));
            } else {
                out.push(c.error(format!(
                    "unknown element <{}> in {}: {}",
                    c.name,
                    el.describe(),
                    suggestion(&c.name, &inner)
                )));
            }
        }
    } else {
        for c in &el.children {
            out.push(c.error(format!(
                "unknown element <{}> in {}: it holds no elements",
                c.name,
                el.describe()
            )));
        }
    }
    out
}

/// statopt's `<ForceSweep>` element (in a study) and what it holds: per
/// element, the attributes it reads and the elements it holds.
#[allow(clippy::type_complexity)]
pub const FORCE_SWEEP_ELEMENTS: &[(&str, &[&str], &[&str])] = &[
    (
        "ForceSweep",
        &["name", "setup"],
        &["contact_weight", "write_tables", "Candidate"],
    ),
    ("contact_weight", &[], &[]),
    ("write_tables", &[], &[]),
    (
        "Candidate",
        &["name"],
        &["expression", "optimal_force", "external_scale"],
    ),
    ("expression", &["force"], &[]),
    ("optimal_force", &["actuator"], &[]),
    ("external_scale", &["force"], &[]),
];

/// Unknown attributes and children of a `<ForceSweep>` (and of what it
/// holds), one error each, with the nearest known name.
pub fn force_sweep_elements(el: &Element) -> Vec<crate::error::Error> {
    let mut out = Vec::new();
    let Some((_, attrs, children)) = FORCE_SWEEP_ELEMENTS.iter().find(|(t, _, _)| *t == el.name)
    else {
        return out;
    };
    for (a, _) in &el.attrs {
        if !attrs.contains(&a.as_str()) {
            out.push(el.error(format!(
                "unknown attribute {a}=\"...\" of {}: {}",
                el.describe(),
                if attrs.is_empty() {
                    "it takes no attributes".to_string()
                } else {
                    suggestion(a, attrs)
                }
            )));
        }
    }
    for c in &el.children {
        if children.contains(&c.name.as_str()) {
            out.extend(force_sweep_elements(c));
        } else {
            out.push(c.error(format!(
                "unknown element <{}> in {}: {} (statopt refuses elements it does not know in setup documents; --allow-unknown reads on with a warning)",
                c.name,
                el.describe(),
                if children.is_empty() {
                    "it holds no elements".to_string()
                } else {
                    suggestion(&c.name, children)
                }
            )));
        }
    }
    out
}

/// Unknown children of a `<StatoptStudy>` (and of its figures, metrics
/// and force sweeps).
pub fn study_elements(study: &Element) -> Vec<crate::error::Error> {
    let mut out = Vec::new();
    for c in &study.children {
        if !STUDY_CHILDREN.contains(&c.name.as_str()) {
            out.push(c.error(format!(
                "unknown element <{}> in {}: {} (statopt refuses elements it does not know in setup documents; --allow-unknown reads on with a warning)",
                c.name,
                study.describe(),
                suggestion(&c.name, STUDY_CHILDREN)
            )));
        } else if c.name == "ForceSweep" {
            out.extend(force_sweep_elements(c));
        } else {
            out.extend(figure_elements(c));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The walk by hashed type finds exactly what scanning every table for
    /// every element found: a document with each table's element types,
    /// each holding its first property by tag and by `name`, a legacy
    /// property, `<defaults>` and a misspelling, read both as a 4.x and as
    /// an older document.
    #[test]
    fn hashed_types_warn_as_the_tables_scanned() {
        fn scanned(table: &[(&str, &[&str])], ty: &str, c: &Element) -> bool {
            table.iter().any(|(t, props)| {
                *t == ty
                    && props
                        .iter()
                        .any(|p| *p == c.name || c.attr("name") == Some(p))
            })
        }
        fn reference(el: &Element, check_opensim: bool, out: &mut Vec<String>) {
            let ty = el.name.as_str();
            let opensim = check_opensim && OPENSIM_PROPERTIES.iter().any(|(t, _)| *t == ty);
            let statopt = STATOPT_ELEMENTS.iter().any(|(t, _)| *t == ty);
            if opensim || statopt {
                for c in &el.children {
                    if !scanned(OPENSIM_PROPERTIES, ty, c)
                        && !scanned(STATOPT_PROPERTIES, ty, c)
                        && !scanned(LEGACY_PROPERTIES, ty, c)
                        && !scanned(STATOPT_ELEMENTS, ty, c)
                        && !ANY_ELEMENT.contains(&c.name.as_str())
                    {
                        out.push(format!("{} {} {} {opensim}", el.loc(), c.name, c.line));
                    }
                }
            }
            for c in &el.children {
                reference(c, check_opensim, out);
            }
        }
        let mut doc = String::from("<Model>\n");
        let tables = [
            OPENSIM_PROPERTIES,
            STATOPT_PROPERTIES,
            LEGACY_PROPERTIES,
            STATOPT_ELEMENTS,
        ];
        for table in tables {
            for (ty, props) in table {
                let first = props.first().copied().unwrap_or("none");
                let last = props.last().copied().unwrap_or("none");
                doc.push_str(&format!(
                    "<{ty} name=\"a\">\n<{first}/>\n<Obj name=\"{last}\"/>\n<motion_type/>\n\
                     <defaults/>\n<{first}x/>\n<Obj name=\"{last}x\"/>\n</{ty}>\n"
                ));
            }
        }
        doc.push_str("</Model>\n");
        let root = crate::xml::parse_str(&doc, std::path::Path::new("k.osim")).unwrap();
        for check_opensim in [true, false] {
            let (mut got, mut want) = (Vec::new(), Vec::new());
            walk(&root, check_opensim, &mut got);
            reference(&root, check_opensim, &mut want);
            assert_eq!(got.len(), want.len(), "{check_opensim}");
            assert!(got.len() >= if check_opensim { 100 } else { 6 }, "{got:#?}");
            for (g, w) in got.iter().zip(&want) {
                let mut parts = w.rsplitn(4, ' ');
                let opensim: bool = parts.next().unwrap().parse().unwrap();
                let line = parts.next().unwrap();
                let name = parts.next().unwrap();
                let loc = parts.next().unwrap();
                let why = if opensim {
                    "ignored, as OpenSim ignores it"
                } else {
                    "ignored (its default applies)"
                };
                assert_eq!(
                    *g,
                    format!(
                        "{loc}: unknown property <{name}> (line {line}) {why}; check its spelling"
                    )
                );
            }
        }
    }

    #[test]
    fn nearest_names_a_misspelling_and_nothing_far() {
        let so = known_names("StaticOptimization");
        assert_eq!(nearest("contact_wieght", &so), Some("contact_weight"));
        assert_eq!(
            nearest("activation_exponant", &so),
            Some("activation_exponent")
        );
        assert_eq!(nearest("Contact_Weight", &so), Some("contact_weight"));
        assert_eq!(nearest("frobnicate", &so), None);
        assert!(suggestion("frobnicate", &["b", "a"]).contains("known here: a, b"));
    }

    #[test]
    fn setup_elements_refuse_unknown_and_list_unused() {
        let text = r#"<AnalyzeTool name="t"><model_file>m.osim</model_file>
<maximum_integrator_step_size>1</maximum_integrator_step_size>
<AnalysisSet name="Analyses"><objects><StaticOptimization name="so">
<contact_wieght>1</contact_wieght><start_time>0</start_time></StaticOptimization>
</objects><groups/></AnalysisSet>
<Figure name="f" titel="x"><Series file="a.sto" column="c"/></Figure>
<ControllerSet name="Controllers"><objects/></ControllerSet>
<defaults/></AnalyzeTool>"#;
        let root = crate::xml::parse_str(text, std::path::Path::new("s.xml")).unwrap();
        let found = setup_elements(&root);
        let msgs: Vec<String> = found.unknown.iter().map(|e| e.to_string()).collect();
        assert_eq!(msgs.len(), 2, "{msgs:?}");
        let so = msgs
            .iter()
            .find(|m| m.contains("<contact_wieght>"))
            .unwrap();
        assert!(
            so.contains("s.xml, line 4") && so.contains("did you mean contact_weight"),
            "{so}"
        );
        let fig = msgs.iter().find(|m| m.contains("titel")).unwrap();
        assert!(fig.contains("did you mean title"), "{fig}");
        assert_eq!(
            found.unused,
            vec![
                "AnalyzeTool <maximum_integrator_step_size>",
                "AnalyzeTool <ControllerSet>",
                "StaticOptimization <start_time>"
            ]
        );
    }
}
