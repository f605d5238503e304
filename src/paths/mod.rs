//! Muscle paths (OpenSim's GeometryPath, opensim-semantics.md §5): path
//! points fixed on bodies, conditional points, moving points, and wrapping
//! over wrap objects; compiled once against a [`Model`], evaluated per frame.
//!
//! - [`geometry`]: current path, length, lengthening speed, and the
//!   generalized force of a unit tension (→ moment arms);
//! - [`coupling`]: the coupling vectors that map a coordinate's speed to all
//!   speeds under coupler and lock constraints (OpenSim's MomentArmSolver).

pub mod coupling;
pub mod geometry;

use nalgebra::{Matrix3, Vector3};

use crate::error::Result;
use crate::functions::Function;
use crate::model::{Model, Transform};
use crate::wrapping::{PathWrap, WrapObject};
use crate::xml::Element;

#[derive(Debug, Clone)]
pub enum PointKind {
    Fixed,
    /// Active iff `range[0] - 1e-5 <= q[coordinate] <= range[1] + 1e-5`.
    Conditional {
        coordinate: usize,
        range: [f64; 2],
    },
    /// Location (x, y, z) = functions of the clamped coordinate, in the
    /// parent frame.
    Moving {
        coordinate: usize,
        functions: Box<[Function; 3]>,
        clamp: [f64; 2],
    },
}

#[derive(Debug, Clone)]
pub struct PathPoint {
    pub name: String,
    pub body: usize,
    /// The parent frame in its body (identity when the frame is the body).
    pub frame: Transform,
    /// Location in the parent frame (ignored for moving points).
    pub location: Vector3<f64>,
    /// `frame` applied to `location`: the location in the body (ignored
    /// for moving points).
    pub body_location: Vector3<f64>,
    pub kind: PointKind,
}

/// A wrap object bound to its body.
#[derive(Debug, Clone)]
pub struct BodyWrapObject {
    pub body: usize,
    pub object: WrapObject,
    /// Wrap frame in the body: rotation and translation of the wrap object.
    pub rotation: Matrix3<f64>,
    pub translation: Vector3<f64>,
}

#[derive(Debug, Clone)]
pub struct PathWrapRef {
    /// Index into the model's wrap objects.
    pub object: usize,
    pub wrap: PathWrap,
}

#[derive(Debug, Clone)]
pub struct GeometryPath {
    pub points: Vec<PathPoint>,
    pub wraps: Vec<PathWrapRef>,
}

/// Resolve a socket path to a frame of the model: (body, frame-in-body).
pub fn resolve_frame(model: &Model, socket: &str, el: &Element) -> Result<(usize, Transform)> {
    let s = socket.trim();
    let name = s.rsplit('/').next().unwrap_or(s);
    let f = model
        .frames
        .iter()
        .find(|f| f.path == s)
        .or_else(|| {
            model.frames.iter().find(|f| {
                f.path == format!("/bodyset/{name}")
                    && (s == name || s.ends_with(&format!("bodyset/{name}")))
            })
        })
        .or_else(|| {
            if s == name {
                model.frames.iter().find(|f| f.name == name)
            } else {
                None
            }
        })
        .ok_or_else(|| {
            el.error(format!(
                "socket names a frame '{s}' that does not exist in the model"
            ))
        })?;
    Ok((f.body, f.transform))
}

fn resolve_coordinate(model: &Model, socket: &str, el: &Element) -> Result<usize> {
    let name = socket.trim().rsplit('/').next().unwrap_or("");
    model.coordinate_index(name).ok_or_else(|| {
        el.error(format!(
            "socket names a coordinate '{}' that does not exist in the model",
            socket.trim()
        ))
    })
}

/// Wrap objects of a model document, bound to body indices.
pub fn compile_wrap_objects(
    model: &Model,
    wraps: &[(String, Element)],
) -> Result<Vec<BodyWrapObject>> {
    wraps
        .iter()
        .map(|(body, el)| {
            let b = model
                .body_index(body)
                .ok_or_else(|| el.error(format!("wrap object on unknown body '{body}'")))?;
            let object = WrapObject::from_xml(el)?;
            Ok(BodyWrapObject {
                body: b,
                rotation: object.rotation,
                translation: object.translation,
                object,
            })
        })
        .collect()
}

impl GeometryPath {
    /// Compile a `<GeometryPath>` element (4.0 or 3.x spelling).
    pub fn from_xml(
        el: &Element,
        model: &Model,
        wrap_objects: &[BodyWrapObject],
    ) -> Result<GeometryPath> {
        let set = el
            .child("PathPointSet")
            .ok_or_else(|| el.error("GeometryPath has no PathPointSet"))?;
        let objs = set
            .child("objects")
            .ok_or_else(|| set.error("PathPointSet has no <objects>"))?;
        let mut points = Vec::new();
        for p in &objs.children {
            points.push(read_point(p, model)?);
        }
        if points.len() < 2 {
            return Err(el.error(format!(
                "a path needs at least two points, found {}",
                points.len()
            )));
        }
        let mut wraps = Vec::new();
        if let Some(ws) = el.child("PathWrapSet").and_then(|s| s.child("objects")) {
            for w in ws.children_named("PathWrap") {
                let wrap = PathWrap::from_xml(w)?;
                let object = wrap_objects
                    .iter()
                    .position(|o| o.object.name == wrap.wrap_object)
                    .ok_or_else(|| {
                        w.error(format!(
                            "wrap object '{}' does not exist in the model",
                            wrap.wrap_object
                        ))
                    })?;
                wraps.push(PathWrapRef { object, wrap });
            }
        }
        Ok(GeometryPath { points, wraps })
    }
}

fn read_point(p: &Element, model: &Model) -> Result<PathPoint> {
    let socket = p
        .child_text("socket_parent_frame")
        .filter(|s| !s.is_empty())
        .map(str::to_string)
        .or_else(|| {
            p.child_text("body")
                .filter(|s| !s.is_empty())
                .map(|b| format!("/bodyset/{b}"))
        })
        .ok_or_else(|| p.error("path point has no socket_parent_frame (or 3.x <body>)"))?;
    let (body, frame) = resolve_frame(model, &socket, p)?;
    let location = p.child_vec3_or("location", [0.0; 3])?;
    let coord_socket = |n4: &str, n3: &str| -> Option<String> {
        p.child_text(n4)
            .filter(|s| !s.is_empty())
            .or_else(|| p.child_text(n3).filter(|s| !s.is_empty()))
            .map(str::to_string)
    };
    let kind = match p.name.as_str() {
        "PathPoint" => PointKind::Fixed,
        "ConditionalPathPoint" => {
            let c = coord_socket("socket_coordinate", "coordinate")
                .ok_or_else(|| p.error("ConditionalPathPoint has no coordinate"))?;
            let range = p.req("range")?.numbers_n(2)?;
            PointKind::Conditional {
                coordinate: resolve_coordinate(model, &c, p)?,
                range: [range[0], range[1]],
            }
        }
        "MovingPathPoint" => {
            let sx = coord_socket("socket_x_coordinate", "x_coordinate");
            let sy = coord_socket("socket_y_coordinate", "y_coordinate");
            let sz = coord_socket("socket_z_coordinate", "z_coordinate");
            let named: Vec<&String> = [&sx, &sy, &sz].into_iter().flatten().collect();
            let first = named
                .first()
                .ok_or_else(|| p.error("MovingPathPoint names no coordinate"))?;
            let cname = |s: &str| s.trim().rsplit('/').next().unwrap_or("").to_string();
            if named.iter().any(|s| cname(s) != cname(first)) || named.len() != 3 {
                return Err(p.error(
                    "MovingPathPoint: x, y and z locations must depend on the same coordinate",
                ));
            }
            let coordinate = resolve_coordinate(model, first, p)?;
            let f = |n: &str| -> Result<Function> {
                Ok(Function::find_property(p, n)?.unwrap_or(Function::Constant(0.0)))
            };
            let c = &model.coordinates[coordinate];
            PointKind::Moving {
                coordinate,
                functions: Box::new([f("x_location")?, f("y_location")?, f("z_location")?]),
                clamp: c.range,
            }
        }
        other => return Err(p.error(format!("unsupported path point type '{other}'"))),
    };
    Ok(PathPoint {
        name: p.name_attr().to_string(),
        body,
        frame,
        location,
        body_location: frame.apply(&location),
        kind,
    })
}
