//! Shared wrap-object types: the wrap object itself, its quadrant, the
//! `PathWrap` pairing and the result of one `wrap_line` call
//! (opensim-semantics §5.4; `WrapObject.cpp`, `PathWrap.cpp`, `WrapResult.h`).

use nalgebra::{Matrix3, Vector3};

use crate::error::Result;
use crate::xml::Element;

/// Shape and dimensions of a wrap object, in the wrap object's own frame.
#[derive(Debug, Clone, PartialEq)]
pub enum WrapShape {
    /// Axis along local z, centred at the origin (`WrapCylinder`).
    Cylinder { radius: f64, length: f64 },
    /// Centred at the origin (`WrapSphere`).
    Sphere { radius: f64 },
    /// Semi-axes along local x, y, z (`WrapEllipsoid`).
    Ellipsoid { dimensions: Vector3<f64> },
    /// `inner_radius` is the tube radius, `outer_radius` the radius of the
    /// tube's centre circle in the local z = 0 plane (`WrapTorus`).
    Torus {
        inner_radius: f64,
        outer_radius: f64,
    },
}

/// Side of the object to which wrapping is constrained (`quadrant` property).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Quadrant {
    /// `"all"` or unassigned: unconstrained.
    All,
    /// `axis` 0..=2 (x, y, z) and `sign` ±1.
    Axis { axis: usize, sign: i32 },
}

impl Quadrant {
    /// OpenSim's `_wrapSign`: 0 when unconstrained.
    pub fn wrap_sign(&self) -> i32 {
        match self {
            Quadrant::All => 0,
            Quadrant::Axis { sign, .. } => *sign,
        }
    }

    /// OpenSim's `_wrapAxis` (0 when unconstrained, as in OpenSim).
    pub fn wrap_axis(&self) -> usize {
        match self {
            Quadrant::All => 0,
            Quadrant::Axis { axis, .. } => *axis,
        }
    }

    /// Parse the `quadrant` property exactly as
    /// `WrapObject::extendFinalizeFromProperties` does. Only the listed
    /// spellings are accepted; anything else is an error in OpenSim too.
    pub fn parse(s: &str) -> Option<Quadrant> {
        let q = |axis, sign| Some(Quadrant::Axis { axis, sign });
        match s {
            "-x" | "-X" => q(0, -1),
            "x" | "+x" | "X" | "+X" => q(0, 1),
            "-y" | "-Y" => q(1, -1),
            "y" | "+y" | "Y" | "+Y" => q(1, 1),
            "-z" | "-Z" => q(2, -1),
            "z" | "+z" | "Z" | "+Z" => q(2, 1),
            "all" | "ALL" | "All" | "Unassigned" => Some(Quadrant::All),
            _ => None,
        }
    }
}

/// A wrap object as read from a `<WrapCylinder>`, `<WrapSphere>`,
/// `<WrapEllipsoid>` or `<WrapTorus>` element.
#[derive(Debug, Clone, PartialEq)]
pub struct WrapObject {
    pub name: String,
    pub shape: WrapShape,
    pub active: bool,
    /// Orientation of the wrap frame in its body frame, from
    /// `xyz_body_rotation` (body-fixed X-Y-Z Euler angles).
    pub rotation: Matrix3<f64>,
    /// Origin of the wrap frame in its body frame.
    pub translation: Vector3<f64>,
    pub quadrant: Quadrant,
}

/// Rotation matrix for body-fixed X-Y-Z Euler angles (Simbody
/// `setRotationToBodyFixedXYZ`): R = Rx(a)·Ry(b)·Rz(c).
pub fn body_fixed_xyz(angles: &Vector3<f64>) -> Matrix3<f64> {
    let (s1, c1) = angles[0].sin_cos();
    let (s2, c2) = angles[1].sin_cos();
    let (s3, c3) = angles[2].sin_cos();
    let rx = Matrix3::new(1.0, 0.0, 0.0, 0.0, c1, -s1, 0.0, s1, c1);
    let ry = Matrix3::new(c2, 0.0, s2, 0.0, 1.0, 0.0, -s2, 0.0, c2);
    let rz = Matrix3::new(c3, -s3, 0.0, s3, c3, 0.0, 0.0, 0.0, 1.0);
    rx * ry * rz
}

impl WrapObject {
    /// Read a wrap object element. Defaults follow OpenSim's
    /// `constructProperties` (cylinder radius 1, length 1; sphere radius
    /// 0.05; ellipsoid dimensions 0.05³; torus inner 0.01, outer 0.05) and
    /// the same validity checks as `extendFinalizeFromProperties`.
    pub fn from_xml(el: &Element) -> Result<WrapObject> {
        let shape = match el.name.as_str() {
            "WrapCylinder" => {
                let radius = el.child_f64_or("radius", 1.0)?;
                let length = el.child_f64_or("length", 1.0)?;
                if radius < 0.0 {
                    return Err(el.error("WrapCylinder radius cannot be less than zero"));
                }
                if length < 0.0 {
                    return Err(el.error("WrapCylinder length cannot be less than zero"));
                }
                WrapShape::Cylinder { radius, length }
            }
            "WrapSphere" => {
                let radius = el.child_f64_or("radius", 0.05)?;
                if radius < 0.0 {
                    return Err(el.error("WrapSphere radius cannot be less than zero"));
                }
                WrapShape::Sphere { radius }
            }
            "WrapEllipsoid" => {
                let dimensions = el.child_vec3_or("dimensions", [0.05, 0.05, 0.05])?;
                if dimensions.iter().any(|d| !(*d > 0.0)) {
                    return Err(
                        el.error("WrapEllipsoid dimensions (radii) must all be greater than zero")
                    );
                }
                WrapShape::Ellipsoid { dimensions }
            }
            "WrapTorus" => {
                let inner_radius = el.child_f64_or("inner_radius", 0.01)?;
                let outer_radius = el.child_f64_or("outer_radius", 0.05)?;
                if !(inner_radius > 0.0) {
                    return Err(el.error("WrapTorus inner_radius must be greater than zero"));
                }
                if !(outer_radius > 0.0) {
                    return Err(el.error("WrapTorus outer_radius must be greater than zero"));
                }
                WrapShape::Torus {
                    inner_radius,
                    outer_radius,
                }
            }
            other => {
                return Err(el.error(format!(
                    "unknown wrap object type <{other}> (expected WrapCylinder, WrapSphere, \
                     WrapEllipsoid or WrapTorus)"
                )))
            }
        };
        let active = el.child_bool_or("active", true)?;
        let angles = el.child_vec3_or("xyz_body_rotation", [0.0; 3])?;
        let translation = el.child_vec3_or("translation", [0.0; 3])?;
        let quadrant = match el.child("quadrant") {
            Some(q) if !q.text().is_empty() => Quadrant::parse(q.text()).ok_or_else(|| {
                q.error(format!(
                    "quadrant '{}' was specified incorrectly (expected all, x, +x, -x, y, +y, \
                     -y, z, +z or -z)",
                    q.text()
                ))
            })?,
            _ => Quadrant::All,
        };
        Ok(WrapObject {
            name: el.name_attr().to_string(),
            shape,
            active,
            rotation: body_fixed_xyz(&angles),
            translation,
            quadrant,
        })
    }

    /// Express a point given in the wrap object's body frame in the wrap
    /// object's own frame (`_pose.shiftBaseStationToFrame`).
    pub fn body_to_wrap(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.rotation.transpose() * (p - self.translation)
    }

    /// Express a point given in the wrap frame in the body frame
    /// (`_pose.shiftFrameStationToBase`).
    pub fn wrap_to_body(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.rotation * p + self.translation
    }
}

/// `PathWrap` method; used only by `WrapEllipsoid`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WrapMethod {
    Hybrid,
    Midpoint,
    Axial,
}

/// Outcome of one `wrap_line` call (OpenSim `WrapObject::WrapAction`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WrapAction {
    /// The segment does not wrap.
    NoWrap,
    /// An endpoint is inside the object; no wrap.
    InsideRadius,
    /// A valid wrap, to be compared with other segments by added length.
    Wrapped,
    /// The segment must wrap (it intersects the object); first one wins.
    MandatoryWrap,
}

/// Result of wrapping one straight segment P1→P2 over a wrap object.
/// All points are in the wrap object's frame.
#[derive(Debug, Clone, PartialEq)]
pub struct WrapResult {
    pub action: WrapAction,
    /// Tangent point nearest P1 (equals P1 when there is no wrap).
    pub r1: Vector3<f64>,
    /// Tangent point nearest P2 (equals P2 when there is no wrap).
    pub r2: Vector3<f64>,
    /// Length along the surface from R1 to R2, exactly as OpenSim stores it
    /// (this is what `GeometryPath` adds to the path length).
    pub wrap_path_length: f64,
    /// Surface points from R1 to R2 as OpenSim keeps them (`wrap_pts`).
    /// OpenSim inserts the wrap only when this list is non-empty.
    pub wrap_points: Vec<Vector3<f64>>,
    /// Ellipsoid wrapping-plane point (normalized coordinates), as in OpenSim.
    pub c1: Vector3<f64>,
    /// Ellipsoid point on the muscle line used to find `c1` (normalized).
    pub sv: Vector3<f64>,
}

impl WrapResult {
    /// A result that does not wrap: R1 = P1, R2 = P2, zero surface length.
    pub fn no_wrap(action: WrapAction, p1: Vector3<f64>, p2: Vector3<f64>) -> WrapResult {
        WrapResult {
            action,
            r1: p1,
            r2: p2,
            wrap_path_length: 0.0,
            wrap_points: Vec::new(),
            c1: Vector3::zeros(),
            sv: Vector3::zeros(),
        }
    }

    /// True when `GeometryPath::applyWrapObjects` would insert this wrap
    /// (a `wrapped`/`mandatoryWrap` code with a non-empty point list).
    pub fn wraps(&self) -> bool {
        matches!(self.action, WrapAction::Wrapped | WrapAction::MandatoryWrap)
            && !self.wrap_points.is_empty()
    }

    /// |P1R1| + surface length + |R2P2|: the wrapped length of the segment.
    pub fn total_length(&self, p1: &Vector3<f64>, p2: &Vector3<f64>) -> f64 {
        if self.wraps() {
            (self.r1 - p1).norm() + self.wrap_path_length + (p2 - self.r2).norm()
        } else {
            (p2 - p1).norm()
        }
    }
}

/// One `<PathWrap>` of a `GeometryPath`'s `PathWrapSet`.
#[derive(Debug, Clone, PartialEq)]
pub struct PathWrap {
    pub name: String,
    pub wrap_object: String,
    pub method: WrapMethod,
    /// 1-based [start, end] indices into the PathPointSet; values < 1 mean
    /// the first / last point. Default (-1, -1).
    pub range: (i32, i32),
}

impl PathWrap {
    /// Read a `<PathWrap>` element (`PathWrap::extendConnectToModel`
    /// spellings of `method`: hybrid/Hybrid/HYBRID, midpoint…, axial…).
    pub fn from_xml(el: &Element) -> Result<PathWrap> {
        if el.name != "PathWrap" {
            return Err(el.error(format!("expected <PathWrap>, found <{}>", el.name)));
        }
        let wrap_object = el.req("wrap_object")?.text().to_string();
        if wrap_object.is_empty() {
            return Err(el.error("PathWrap has an empty <wrap_object>"));
        }
        let method = match el.child("method") {
            None => WrapMethod::Hybrid,
            Some(m) => match m.text() {
                "hybrid" | "Hybrid" | "HYBRID" | "Unassigned" | "" => WrapMethod::Hybrid,
                "midpoint" | "Midpoint" | "MIDPOINT" => WrapMethod::Midpoint,
                "axial" | "Axial" | "AXIAL" => WrapMethod::Axial,
                other => {
                    return Err(m.error(format!(
                        "wrapping method '{other}' is not hybrid, midpoint or axial"
                    )))
                }
            },
        };
        let range = match el.child("range") {
            None => (-1, -1),
            Some(r) if r.text().is_empty() => (-1, -1),
            Some(r) => {
                let mut v = Vec::new();
                for w in r.words() {
                    let i = w.parse::<i32>().map_err(|_| {
                        r.error(format!("expected two integers in <range>, found '{w}'"))
                    })?;
                    v.push(i);
                }
                if v.len() != 2 {
                    return Err(r.error(format!(
                        "expected two integers in <range>, found {}",
                        v.len()
                    )));
                }
                (v[0], v[1])
            }
        };
        Ok(PathWrap {
            name: el.name_attr().to_string(),
            wrap_object,
            method,
            range,
        })
    }
}
