//! Reading OpenSim model documents (`.osim`) into a [`ModelSpec`]: the
//! document's content with names still unresolved, in file order.
//!
//! Both layouts found in the wild are accepted (opensim-semantics.md §2, §2.8):
//! - 4.0 (document versions 40000..40600): `JointSet` with `socket_parent_frame`
//!   / `socket_child_frame` and `PhysicalOffsetFrame`s;
//! - 3.x (versions 30000..30516): joints nested inside bodies with
//!   `parent_body`, `location_in_parent`, `orientation_in_parent`, converted
//!   here exactly as OpenSim converts them, including its rounding of offsets
//!   and inertias to 6 significant digits.
//!
//! Elements that do not change dynamics (geometry, markers, display, probes,
//! controllers) are skipped. Anything else the reader does not know is kept
//! in [`ModelSpec::unsupported`] with its location, so that an analysis that
//! needs it can refuse with a clear message.

use std::path::Path;

use nalgebra::Vector3;

use crate::error::{Error, Location, Result};
use crate::functions::Function;
use crate::xml::{self, Element};

/// A model document, as written, with names unresolved.
#[derive(Debug, Clone)]
pub struct ModelSpec {
    pub name: String,
    pub file: std::path::PathBuf,
    pub version: u32,
    pub gravity: Vector3<f64>,
    /// Where gravity was given (None: OpenSim's default was used).
    pub gravity_loc: Option<Location>,
    pub ground_name: String,
    pub bodies: Vec<BodySpec>,
    pub joints: Vec<JointSpec>,
    /// Every PhysicalOffsetFrame, keyed by its absolute component path.
    pub frames: Vec<FrameSpec>,
    pub couplers: Vec<CouplerSpec>,
    /// Force elements (muscles, actuators, contacts, ...) kept as XML for the
    /// modules that read them.
    pub forces: Vec<Element>,
    /// Names of the ForceSet's groups (`<groups><ObjectGroup name=...>`).
    pub force_groups: Vec<String>,
    /// Wrap objects per body (and ground), kept as XML.
    pub wrap_objects: Vec<(String, Element)>,
    /// Elements that may affect dynamics but that this reader does not support.
    pub unsupported: Vec<(String, Location)>,
    /// Non-fatal remarks for the user.
    pub warnings: Vec<String>,
}

#[derive(Debug, Clone)]
pub struct BodySpec {
    pub name: String,
    pub mass: f64,
    pub mass_center: Vector3<f64>,
    /// `[Ixx Iyy Izz Ixy Ixz Iyz]` about the mass center, body axes.
    pub inertia: [f64; 6],
    pub loc: Location,
}

#[derive(Debug, Clone)]
pub struct CoordinateSpec {
    pub name: String,
    pub default_value: f64,
    pub default_speed: f64,
    pub range: [f64; 2],
    pub clamped: bool,
    pub locked: bool,
    pub prescribed: bool,
    pub prescribed_function: Option<Function>,
    pub free_to_satisfy_constraints: bool,
    pub loc: Location,
}

#[derive(Debug, Clone)]
pub struct AxisSpec {
    /// Coordinate names listed on the axis.
    pub coordinates: Vec<String>,
    pub axis: Vector3<f64>,
    /// `None` when the element has no function: OpenSim then uses Constant(0).
    pub function: Option<Function>,
    pub loc: Location,
}

#[derive(Debug, Clone)]
pub struct JointSpec {
    pub name: String,
    /// Element tag: `PinJoint`, `CustomJoint`, ...
    pub kind: String,
    /// Socket paths exactly as written (relative to the joint's own path).
    pub parent_frame: String,
    pub child_frame: String,
    /// `/jointset/<name>`: the path sockets are resolved against.
    pub path: String,
    pub coordinates: Vec<CoordinateSpec>,
    /// rotation1..3, translation1..3 for CustomJoint.
    pub spatial_transform: Option<Vec<AxisSpec>>,
    pub loc: Location,
}

#[derive(Debug, Clone)]
pub struct FrameSpec {
    /// Absolute path, e.g. `/jointset/hip_r/pelvis_offset`.
    pub path: String,
    pub name: String,
    /// Socket path as written, relative to `path`.
    pub parent: String,
    pub translation: Vector3<f64>,
    /// Body-fixed X-Y-Z Euler angles (rad).
    pub orientation: Vector3<f64>,
    pub loc: Location,
}

#[derive(Debug, Clone)]
pub struct CouplerSpec {
    pub name: String,
    pub enforced: bool,
    pub function: Function,
    pub independent: Vec<String>,
    pub dependent: String,
    pub scale_factor: f64,
    pub loc: Location,
}

/// Elements with no effect on dynamics; skipped silently.
const IGNORED: &[&str] = &[
    "credits",
    "publications",
    "length_units",
    "force_units",
    "assembly_accuracy",
    "MarkerSet",
    "ContactGeometrySet",
    "ProbeSet",
    "ControllerSet",
    "defaults",
    "ModelVisualPreferences",
    "attached_geometry",
    "FrameGeometry",
    "Appearance",
    "validationFlag",
];

impl ModelSpec {
    pub fn read(path: &Path) -> Result<ModelSpec> {
        let mut root = xml::parse_file(path)?;
        let spec = Self::from_owned_document(&mut root, path);
        // The document's tree is freed here, on the thread that allocated
        // it. (Freed on a thread of its own, each of its blocks went back
        // to this thread's malloc arena under the arena's lock while this
        // thread allocated the compiled model from it: gait2392's whole run
        // took about 1 ms more CPU and wall time.)
        drop(root);
        spec
    }

    pub fn from_document(root: &Element, path: &Path) -> Result<ModelSpec> {
        Self::read_document(root, path, None)
    }

    /// [`from_document`](Self::from_document) on a document the caller
    /// frees next: the force elements (most of a model's tree: gait2392's
    /// 92 muscles) are moved out of `root` instead of copied (gait2392:
    /// 3.2 M instructions less; the same spec). `root`'s force sets are
    /// left empty.
    pub fn from_owned_document(root: &mut Element, path: &Path) -> Result<ModelSpec> {
        let mut force_sets = Vec::new();
        let mut spec = Self::read_document(root, path, Some(&mut force_sets))?;
        if force_sets.is_empty() {
            return Ok(spec);
        }
        let model = root
            .children
            .iter_mut()
            .find(|c| c.name == "Model")
            .ok_or_else(|| Error::internal("the model element vanished"))?;
        for i in force_sets {
            if let Some(objects) = model.children[i]
                .children
                .iter_mut()
                .find(|c| c.name == "objects")
            {
                spec.forces.append(&mut objects.children);
            }
        }
        Ok(spec)
    }

    /// Read the document; with `force_sets`, a 4.x document's force sets
    /// are not copied into the spec but their indices among the model's
    /// children are pushed there, in order, for the caller to move them
    /// (`from_owned_document`).
    fn read_document(
        root: &Element,
        path: &Path,
        force_sets: Option<&mut Vec<usize>>,
    ) -> Result<ModelSpec> {
        if root.name != "OpenSimDocument" {
            return Err(
                root.error("not an OpenSim document: root element must be <OpenSimDocument>")
            );
        }
        let version: u32 = match root.attr("Version") {
            Some(v) => v
                .trim()
                .parse()
                .map_err(|_| root.error(format!("Version attribute '{v}' is not a number")))?,
            None => return Err(root.error("missing Version attribute")),
        };
        let model = root
            .child("Model")
            .ok_or_else(|| root.error("document holds no <Model> element"))?;
        let mut spec = ModelSpec {
            name: model.name_attr().to_string(),
            file: path.to_path_buf(),
            version,
            gravity: model.child_vec3_or("gravity", [0.0, -9.80665, 0.0])?,
            gravity_loc: model.child("gravity").map(Element::loc),
            ground_name: "ground".into(),
            bodies: Vec::new(),
            joints: Vec::new(),
            frames: Vec::new(),
            couplers: Vec::new(),
            forces: Vec::new(),
            force_groups: Vec::new(),
            wrap_objects: Vec::new(),
            unsupported: Vec::new(),
            warnings: Vec::new(),
        };
        if version >= 40000 {
            spec.warnings
                .extend(super::known::unknown_properties(model));
        }
        if version >= 30505 {
            read_40(&mut spec, model, force_sets)?;
        } else if version >= 30000 {
            read_3x(&mut spec, model)?;
        } else {
            return Err(root.error(format!(
                "document version {version} is older than OpenSim 3.0 (30000); open and save it with OpenSim first"
            )));
        }
        Ok(spec)
    }
}

/// With `force_sets`, the force sets' members are left in the document and
/// their sets' indices among `model`'s children pushed there (see
/// `ModelSpec::from_owned_document`).
fn read_40(
    spec: &mut ModelSpec,
    model: &Element,
    mut force_sets: Option<&mut Vec<usize>>,
) -> Result<()> {
    for (index, child) in model.children.iter().enumerate() {
        match child.name.as_str() {
            "Ground" => {
                spec.ground_name = child.attr("name").unwrap_or("ground").to_string();
                collect_wraps(spec, "ground", child);
            }
            "gravity" => {}
            "BodySet" => {
                for b in objects(child) {
                    if b.name != "Body" {
                        unsupported(spec, b, "body type");
                        continue;
                    }
                    let body = read_body(b, &mut spec.warnings)?;
                    spec.bodies.push(body);
                    collect_wraps(spec, b.name_attr(), b);
                    for c in &b.children {
                        if c.name == "components" || c.name == "frames" {
                            for f in &c.children {
                                if f.name == "PhysicalOffsetFrame" {
                                    let base = format!("/bodyset/{}", b.name_attr());
                                    spec.frames.push(read_frame(f, &base)?);
                                }
                            }
                        }
                    }
                }
            }
            "JointSet" => {
                for j in objects(child) {
                    let joint = read_joint_40(spec, j)?;
                    spec.joints.push(joint);
                }
            }
            "ConstraintSet" => read_constraints(spec, child)?,
            "ForceSet" => {
                match force_sets.as_deref_mut() {
                    Some(sets) => sets.push(index),
                    None => spec.forces.extend(objects(child).cloned()),
                }
                if let Some(groups) = child.child("groups") {
                    spec.force_groups
                        .extend(groups.children.iter().map(|g| g.name_attr().to_string()));
                }
            }
            "components" | "ComponentSet" => {
                for c in components(child) {
                    if c.name == "PhysicalOffsetFrame" {
                        let base = if child.name == "ComponentSet" {
                            "/componentset".to_string()
                        } else {
                            String::new()
                        };
                        spec.frames.push(read_frame(c, &base)?);
                    } else {
                        unsupported(spec, c, "component");
                    }
                }
            }
            name if IGNORED.contains(&name) => {}
            _ if is_empty_set(child) => {}
            _ => unsupported(spec, child, "model element"),
        }
    }
    Ok(())
}

/// A set with no members (`<XSet><objects/><groups/></XSet>`): there is
/// nothing in it to ignore, so nothing is said.
fn is_empty_set(el: &Element) -> bool {
    el.name.ends_with("Set")
        && el.children.iter().all(|c| match c.name.as_str() {
            "objects" | "groups" => c.children.is_empty(),
            _ => false,
        })
}

fn components(el: &Element) -> impl Iterator<Item = &Element> {
    let inner: Vec<&Element> = match el.child("objects") {
        Some(o) => o.children.iter().collect(),
        None => el.children.iter().filter(|c| c.name != "groups").collect(),
    };
    inner.into_iter()
}

/// The members of a `<XSet><objects>...</objects></XSet>`.
fn objects(set: &Element) -> impl Iterator<Item = &Element> {
    set.child("objects")
        .into_iter()
        .flat_map(|o| o.children.iter())
}

fn unsupported(spec: &mut ModelSpec, el: &Element, what: &str) {
    spec.unsupported
        .push((format!("{what} {}", el.describe()), el.loc()));
}

fn collect_wraps(spec: &mut ModelSpec, body: &str, el: &Element) {
    if let Some(set) = el.child("WrapObjectSet") {
        for w in objects(set) {
            spec.wrap_objects.push((body.to_string(), w.clone()));
        }
    }
}

fn read_body(b: &Element, warnings: &mut Vec<String>) -> Result<BodySpec> {
    // OpenSim's Body mass defaults to NaN and a model without one is refused
    // ("unspecified or negative mass", Body::extendFinalizeFromProperties).
    let mass = match b.child("mass") {
        Some(m) => m.f64()?,
        None => {
            return Err(b.error(
                "body has no <mass>: OpenSim 4.6 refuses a body with unspecified mass; give its mass in kg (0 for a massless body)",
            ))
        }
    };
    let inertia = match b.child("inertia") {
        Some(i) if !i.text().is_empty() => {
            let v = i.numbers_n(6)?;
            [v[0], v[1], v[2], v[3], v[4], v[5]]
        }
        _ => {
            // 3.x spelling: inertia_xx ... inertia_yz (defaults 1 1 1 0 0 0).
            let names = [
                "inertia_xx",
                "inertia_yy",
                "inertia_zz",
                "inertia_xy",
                "inertia_xz",
                "inertia_yz",
            ];
            let defaults = [1.0, 1.0, 1.0, 0.0, 0.0, 0.0];
            let mut v = [0.0; 6];
            for k in 0..6 {
                v[k] = b.child_f64_or(names[k], defaults[k])?;
            }
            v
        }
    };
    if !(mass.is_finite() && mass >= 0.0) {
        return Err(b.req("mass")?.error(format!(
            "body mass must be a finite, non-negative number, found {mass}"
        )));
    }
    if inertia.iter().any(|x| !x.is_finite()) {
        return Err(b.error("body inertia holds a non-finite value"));
    }
    if let Some((fatal, why)) = invalid_inertia(&inertia) {
        let el = b.child("inertia").unwrap_or(b);
        let msg = format!(
            "body '{}' inertia [Ixx Iyy Izz Ixy Ixz Iyz] = {inertia:?} is not physically possible: {why}",
            b.name_attr()
        );
        if fatal {
            return Err(el.error(format!("{msg} (a sign error or wrong units?)")));
        }
        // OpenSim's own planar models (leg6dof9musc) hold such inertias and
        // OpenSim 4.6 accepts them: warn only. (A massless body's inertia
        // is not used: model::compile takes zero, as OpenSim does, and says so.)
        // OpenSim's Body::getInertia would replace it by a spherical inertia
        // only if SimTK::Inertia's constructor threw, but that check
        // (`Inertia::errChk`) is compiled out of release builds (NDEBUG): the
        // released OpenSim 4.6 keeps the invalid matrix as given (verified:
        // `Model('leg6dof9musc.osim').getBodySet().get('toes_r').getInertia()`
        // returns moments [0, 0, 0.00090462] in the opensim 4.6 Python package,
        // and its joint reactions match only with that matrix).
        if mass != 0.0 {
            warnings.push(format!(
                "{}: {msg}; used as given, as OpenSim 4.6 release builds do",
                el.loc()
            ));
        }
    }
    Ok(BodySpec {
        name: b.name_attr().to_string(),
        mass,
        mass_center: b.child_vec3_or("mass_center", [0.0; 3])?,
        inertia,
        loc: b.loc(),
    })
}

/// Why an inertia `[Ixx Iyy Izz Ixy Ixz Iyz]` about the mass center cannot
/// belong to a rigid body (None when it can), and whether that is fatal: its
/// principal moments must be non-negative (fatal: the mass matrix would not be
/// positive semi-definite) and satisfy the triangle inequality (a warning:
/// OpenSim 4.6 checks this only in debug builds and its planar example models
/// violate it). Tolerance: 1e-9 of the largest moment.
pub fn invalid_inertia(i: &[f64; 6]) -> Option<(bool, String)> {
    let m = nalgebra::Matrix3::new(i[0], i[3], i[4], i[3], i[1], i[5], i[4], i[5], i[2]);
    let mut p: Vec<f64> = m.symmetric_eigenvalues().iter().copied().collect();
    p.sort_by(f64::total_cmp);
    let tol = 1e-9 * p.iter().fold(0.0f64, |a, x| a.max(x.abs()));
    if p[0] < -tol {
        return Some((
            true,
            format!("a principal moment is negative ({:.6e})", p[0]),
        ));
    }
    if p[0] + p[1] < p[2] - tol {
        return Some((
            false,
            format!(
                "principal moments {:.6e}, {:.6e}, {:.6e} violate the triangle inequality",
                p[0], p[1], p[2]
            ),
        ));
    }
    None
}

fn read_frame(f: &Element, owner: &str) -> Result<FrameSpec> {
    let name = f.name_attr().to_string();
    Ok(FrameSpec {
        path: format!("{owner}/{name}"),
        parent: f
            .child_text("socket_parent")
            .filter(|s| !s.is_empty())
            .ok_or_else(|| f.error("PhysicalOffsetFrame has no <socket_parent>"))?
            .to_string(),
        name,
        translation: f.child_vec3_or("translation", [0.0; 3])?,
        orientation: f.child_vec3_or("orientation", [0.0; 3])?,
        loc: f.loc(),
    })
}

fn read_coordinate(c: &Element) -> Result<CoordinateSpec> {
    let range = match c.child("range") {
        Some(r) if !r.text().is_empty() => {
            let v = r.numbers_allow_inf()?;
            if v.len() != 2 {
                return Err(r.error(format!("expected 2 numbers, found {}", v.len())));
            }
            if v[0] > v[1] {
                return Err(r.error(format!(
                    "coordinate range lower bound {} exceeds its upper bound {}",
                    v[0], v[1]
                )));
            }
            [v[0], v[1]]
        }
        _ => [-10.0, 10.0],
    };
    let prescribed_function = Function::find_property(c, "prescribed_function")?;
    let prescribed = c.child_bool_or("prescribed", false)? && prescribed_function.is_some();
    Ok(CoordinateSpec {
        name: c.name_attr().to_string(),
        default_value: c.child_f64_or("default_value", 0.0)?,
        default_speed: c.child_f64_or("default_speed_value", 0.0)?,
        range,
        clamped: c.child_bool_or("clamped", false)?,
        locked: c.child_bool_or("locked", false)?,
        prescribed,
        prescribed_function,
        free_to_satisfy_constraints: c.child_bool_or("is_free_to_satisfy_constraints", false)?,
        loc: c.loc(),
    })
}

fn read_spatial_transform(j: &Element) -> Result<Option<Vec<AxisSpec>>> {
    let Some(st) = j.child("SpatialTransform") else {
        return Ok(None);
    };
    let names = [
        "rotation1",
        "rotation2",
        "rotation3",
        "translation1",
        "translation2",
        "translation3",
    ];
    let mut axes = Vec::with_capacity(6);
    for n in names {
        let ax = st
            .children_named("TransformAxis")
            .find(|a| a.name_attr() == n)
            .ok_or_else(|| st.error(format!("SpatialTransform lacks TransformAxis '{n}'")))?;
        let axis = ax.req("axis")?.vec3()?;
        if axis.norm() < 1e-12 || !axis.iter().all(|x| x.is_finite()) {
            return Err(ax
                .req("axis")?
                .error("transform axis must be a finite, non-zero vector"));
        }
        axes.push(AxisSpec {
            coordinates: ax
                .child("coordinates")
                .map(|c| c.words())
                .unwrap_or_default(),
            axis: axis.normalize(),
            function: Function::find_property(ax, "function")?,
            loc: ax.loc(),
        });
    }
    Ok(Some(axes))
}

fn read_joint_40(spec: &mut ModelSpec, j: &Element) -> Result<JointSpec> {
    let name = j.name_attr().to_string();
    let path = format!("/jointset/{name}");
    let mut coordinates = Vec::new();
    if let Some(cs) = j.child("coordinates") {
        for c in cs.children_named("Coordinate") {
            coordinates.push(read_coordinate(c)?);
        }
    }
    if let Some(fr) = j.child("frames") {
        for f in &fr.children {
            if f.name == "PhysicalOffsetFrame" {
                spec.frames.push(read_frame(f, &path)?);
            } else {
                unsupported(spec, f, "joint frame");
            }
        }
    }
    let socket = |s: &str| -> Result<String> {
        j.child_text(s)
            .filter(|t| !t.is_empty())
            .map(str::to_string)
            .ok_or_else(|| j.error(format!("joint has no <{s}>")))
    };
    Ok(JointSpec {
        parent_frame: socket("socket_parent_frame")?,
        child_frame: socket("socket_child_frame")?,
        kind: j.name.to_string(),
        path,
        coordinates,
        spatial_transform: read_spatial_transform(j)?,
        name,
        loc: j.loc(),
    })
}

fn read_constraints(spec: &mut ModelSpec, set: &Element) -> Result<()> {
    for c in objects(set) {
        if c.name != "CoordinateCouplerConstraint" {
            unsupported(spec, c, "constraint");
            continue;
        }
        let enforced = match c.child("isEnforced") {
            Some(e) if !e.text().is_empty() => e.bool()?,
            _ => !c.child_bool_or("isDisabled", false)?,
        };
        let function =
            Function::find_property(c, "coupled_coordinates_function")?.ok_or_else(|| {
                c.error("CoordinateCouplerConstraint has no coupled_coordinates_function")
            })?;
        let independent = c
            .child("independent_coordinate_names")
            .map(|e| e.words())
            .unwrap_or_default();
        let dependent = c
            .child_text("dependent_coordinate_name")
            .filter(|s| !s.is_empty())
            .ok_or_else(|| c.error("CoordinateCouplerConstraint has no dependent_coordinate_name"))?
            .to_string();
        spec.couplers.push(CouplerSpec {
            name: c.name_attr().to_string(),
            enforced,
            function,
            independent,
            dependent,
            scale_factor: c.child_f64_or("scale_factor", 1.0)?,
            loc: c.loc(),
        });
    }
    Ok(())
}

/// Round to 6 significant digits, as OpenSim's 3.x → 4.0 upgrade does when it
/// re-serialises joint offsets and inertias with default stream precision.
fn sig6(x: f64) -> f64 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    format!("{x:.5e}").parse().unwrap_or(x)
}

fn sig6v(v: Vector3<f64>) -> Vector3<f64> {
    v.map(sig6)
}

/// 3.x layout: joints nested in bodies; converted as OpenSim's
/// `updateFromXMLNode` does (opensim-semantics.md §2.8).
fn read_3x(spec: &mut ModelSpec, model: &Element) -> Result<()> {
    let body_set = model
        .child("BodySet")
        .ok_or_else(|| model.error("3.x model has no <BodySet>"))?;
    // Ground is the body named "ground" in 3.x files.
    for b in objects(body_set) {
        if b.name != "Body" {
            unsupported(spec, b, "body type");
            continue;
        }
        let name = b.name_attr();
        if name == "ground" {
            spec.ground_name = "ground".into();
            collect_wraps(spec, "ground", b);
            continue;
        }
        let mut body = read_body(b, &mut spec.warnings)?;
        if spec.version < 30500 {
            body.inertia = body.inertia.map(sig6);
        }
        spec.bodies.push(body);
        collect_wraps(spec, name, b);
    }
    for b in objects(body_set) {
        let child = b.name_attr();
        if child == "ground" || b.name != "Body" {
            continue;
        }
        let Some(jw) = b.child("Joint") else { continue };
        for j in &jw.children {
            read_joint_3x(spec, j, child)?;
        }
    }
    for child in &model.children {
        match child.name.as_str() {
            "ConstraintSet" => read_constraints(spec, child)?,
            "ForceSet" => {
                for f in objects(child) {
                    spec.forces.push(f.clone());
                }
                if let Some(groups) = child.child("groups") {
                    spec.force_groups
                        .extend(groups.children.iter().map(|g| g.name_attr().to_string()));
                }
            }
            "BodySet" | "gravity" => {}
            "components" | "ComponentSet" => {
                for c in components(child) {
                    unsupported(spec, c, "component");
                }
            }
            name if IGNORED.contains(&name) => {}
            _ if is_empty_set(child) => {}
            _ => unsupported(spec, child, "model element"),
        }
    }
    Ok(())
}

fn read_joint_3x(spec: &mut ModelSpec, j: &Element, child_body: &str) -> Result<()> {
    let name = j.name_attr().to_string();
    let path = format!("/jointset/{name}");
    let mut parent_body = j
        .child_text("parent_body")
        .filter(|s| !s.is_empty())
        .ok_or_else(|| j.error("joint has no <parent_body>"))?
        .to_string();
    let mut child_body = child_body.to_string();
    let v3 = |n: &str| j.child_vec3_or(n, [0.0; 3]);
    let mut loc_parent = v3("location_in_parent")?;
    let mut ori_parent = v3("orientation_in_parent")?;
    let mut loc_child = if j.child("location_in_child").is_some() {
        v3("location_in_child")?
    } else {
        v3("location")?
    };
    let mut ori_child = if j.child("orientation_in_child").is_some() {
        v3("orientation_in_child")?
    } else {
        v3("orientation")?
    };
    if spec.version < 30514 && j.child_bool_or("reverse", false)? {
        std::mem::swap(&mut parent_body, &mut child_body);
        std::mem::swap(&mut loc_parent, &mut loc_child);
        std::mem::swap(&mut ori_parent, &mut ori_child);
    }
    let parent_path = if parent_body == "ground" {
        "/ground".to_string()
    } else {
        format!("/bodyset/{parent_body}")
    };
    let pf = format!("{parent_body}_offset");
    let cf = format!("{child_body}_offset");
    spec.frames.push(FrameSpec {
        path: format!("{path}/{pf}"),
        name: pf.clone(),
        parent: parent_path,
        translation: sig6v(loc_parent),
        orientation: sig6v(ori_parent),
        loc: j.loc(),
    });
    spec.frames.push(FrameSpec {
        path: format!("{path}/{cf}"),
        name: cf.clone(),
        parent: format!("/bodyset/{child_body}"),
        translation: sig6v(loc_child),
        orientation: sig6v(ori_child),
        loc: j.loc(),
    });
    let mut coordinates = Vec::new();
    if let Some(cs) = j.child("CoordinateSet") {
        for c in objects(cs) {
            coordinates.push(read_coordinate(c)?);
        }
    } else if let Some(cs) = j.child("coordinates") {
        for c in cs.children_named("Coordinate") {
            coordinates.push(read_coordinate(c)?);
        }
    }
    spec.joints.push(JointSpec {
        name,
        kind: j.name.to_string(),
        parent_frame: pf,
        child_frame: cf,
        path,
        coordinates,
        spatial_transform: read_spatial_transform(j)?,
        loc: j.loc(),
    });
    Ok(())
}

#[allow(dead_code)]
fn located(loc: &Location, msg: impl Into<String>) -> Error {
    Error::input(loc.clone(), msg)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Moving the force elements out of an owned document gives the spec
    /// (forces, their order, groups, warnings) that copying them gives, for
    /// every shared model and for two force sets in one document.
    #[test]
    fn owned_document_gives_the_copied_spec() {
        let two_sets = r#"<OpenSimDocument Version="40000"><Model name="m"><ForceSet name="a"><objects><CoordinateActuator name="x"><coordinate>q</coordinate></CoordinateActuator><Wrong name="y"><bad/></Wrong></objects><groups><ForceGroup name="g"/></groups></ForceSet><ForceSet name="b"><objects><CoordinateActuator name="z"/></objects></ForceSet><ForceSet name="c"/></Model></OpenSimDocument>"#;
        let mut docs = vec![(Path::new("two.osim").to_path_buf(), two_sets.to_string())];
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/models");
        match std::fs::read_dir(&dir) {
            Ok(entries) => {
                for model in entries.flatten() {
                    for f in std::fs::read_dir(model.path())
                        .into_iter()
                        .flatten()
                        .flatten()
                    {
                        let p = f.path();
                        if p.extension().is_some_and(|e| e == "osim") {
                            let text = std::fs::read_to_string(&p).unwrap();
                            docs.push((p, text));
                        }
                    }
                }
            }
            Err(_) => println!(
                "SKIP the shared models in owned_document_gives_the_copied_spec: {} absent",
                dir.display()
            ),
        }
        for (path, text) in &docs {
            let root = xml::parse_str(text, path).unwrap();
            let copied = ModelSpec::from_document(&root, path);
            let mut owned = root.clone();
            let moved = ModelSpec::from_owned_document(&mut owned, path);
            assert_eq!(
                format!("{moved:?}"),
                format!("{copied:?}"),
                "{}",
                path.display()
            );
        }
        let root = xml::parse_str(two_sets, Path::new("two.osim")).unwrap();
        let spec = ModelSpec::from_document(&root, Path::new("two.osim")).unwrap();
        let names: Vec<&str> = spec.forces.iter().map(|f| f.name_attr()).collect();
        assert_eq!(names, ["x", "y", "z"]);
        assert!(docs.len() > 1 || !dir.exists());
    }

    /// An empty set (Rajagopal2015's `<ComponentSet name="MiscComponents">`
    /// in a 3.x document) holds nothing to ignore and is not reported; a
    /// set with members still is.
    #[test]
    fn empty_sets_are_not_reported() {
        let doc = |extra: &str| {
            format!(
                r#"<OpenSimDocument Version="30000"><Model name="m3"><BodySet><objects>
<Body name="ground"><mass>0</mass></Body>
<Body name="upper"><mass>2.3</mass><mass_center>0 -0.4 0</mass_center><inertia_xx>0.11</inertia_xx><inertia_yy>0.02</inertia_yy><inertia_zz>0.11</inertia_zz>
<Joint><PinJoint name="shoulder"><parent_body>ground</parent_body><location_in_parent>0 1.5 0</location_in_parent><orientation_in_parent>0 0 0</orientation_in_parent><location>0 0 0</location><orientation>0 0 0</orientation>
<CoordinateSet><objects><Coordinate name="q1"><range>-3 3</range></Coordinate></objects></CoordinateSet></PinJoint></Joint></Body>
</objects></BodySet>{extra}</Model></OpenSimDocument>"#
            )
        };
        let read = |text: &str| {
            let root = xml::parse_str(text, Path::new("m3.osim")).unwrap();
            ModelSpec::from_document(&root, Path::new("m3.osim")).unwrap()
        };
        let spec = read(&doc(
            r#"<ComponentSet name="MiscComponents"><objects /><groups /></ComponentSet><WidgetSet name="w"><objects/></WidgetSet>"#,
        ));
        assert!(spec.unsupported.is_empty(), "{:?}", spec.unsupported);
        let spec = read(&doc(
            r#"<ComponentSet name="MiscComponents"><objects><Widget name="w"/></objects></ComponentSet>"#,
        ));
        assert_eq!(spec.unsupported.len(), 1, "{:?}", spec.unsupported);
        assert!(spec.unsupported[0].0.contains("<Widget name=\"w\">"));
    }
}
