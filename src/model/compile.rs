//! ModelSpec → Model: resolve sockets and frames, order bodies and
//! coordinates as Simbody's multibody tree does, derive coordinate motion
//! types, and check everything a later stage would otherwise trip over.

use std::collections::HashMap;

use nalgebra::{Matrix3, Vector3};

use super::joint::{JointKind, TransformAxis};
use super::{
    body_fixed_xyz, Body, Coordinate, Coupler, Frame, Joint, Model, MotionType, Transform,
};
use crate::error::{Error, Location, Result};
use crate::functions::Function;
use crate::parse::osim::{JointSpec, ModelSpec};

/// Join a component path with a (possibly relative) socket path.
fn resolve_path(owner: &str, rel: &str) -> String {
    let mut parts: Vec<&str> = if rel.starts_with('/') {
        Vec::new()
    } else {
        owner.split('/').filter(|s| !s.is_empty()).collect()
    };
    for seg in rel.split('/').filter(|s| !s.is_empty()) {
        match seg {
            "." => {}
            ".." => {
                parts.pop();
            }
            s => parts.push(s),
        }
    }
    format!("/{}", parts.join("/"))
}

struct FrameResolver<'a> {
    spec: &'a ModelSpec,
    body_index: HashMap<String, usize>,
    frame_specs: HashMap<String, usize>,
}

impl<'a> FrameResolver<'a> {
    /// Resolve an absolute frame path to (body index, transform of the frame in that body).
    fn resolve(&self, path: &str, depth: usize, loc: &Location) -> Result<(usize, Transform)> {
        if depth > 64 {
            return Err(Error::input(
                loc.clone(),
                format!("frame '{path}' is part of a cycle of offset frames"),
            ));
        }
        let ground_path = format!("/{}", self.spec.ground_name);
        if path == ground_path || path == "/ground" {
            return Ok((0, Transform::identity()));
        }
        if let Some(name) = path.strip_prefix("/bodyset/") {
            if let Some(&b) = self.body_index.get(name) {
                return Ok((b, Transform::identity()));
            }
        }
        if let Some(&fi) = self.frame_specs.get(path) {
            let f = &self.spec.frames[fi];
            let parent_path = resolve_path(&f.path, &f.parent);
            // Socket paths of an offset frame are relative to the frame itself;
            // OpenSim also accepts them relative to its owner. Try both.
            let owner = f.path.rsplit_once('/').map(|(o, _)| o).unwrap_or("");
            let (b, x_parent) = match self.resolve(&parent_path, depth + 1, &f.loc) {
                Ok(r) => r,
                Err(e) => {
                    let alt = resolve_path(owner, &f.parent);
                    self.resolve(&alt, depth + 1, &f.loc).map_err(|_| e)?
                }
            };
            let local = Transform {
                rotation: body_fixed_xyz(&f.orientation),
                translation: f.translation,
            };
            return Ok((b, x_parent.compose(&local)));
        }
        Err(Error::input(
            loc.clone(),
            format!("socket names a frame '{path}' that does not exist in the model"),
        ))
    }

    fn resolve_socket(
        &self,
        owner: &str,
        socket: &str,
        loc: &Location,
    ) -> Result<(usize, Transform, String)> {
        let path = resolve_path(owner, socket);
        let name = path.rsplit('/').next().unwrap_or("").to_string();
        let first = self.resolve(&path, 0, loc);
        match first {
            Ok((b, x)) => Ok((b, x, name)),
            Err(e) => {
                // A bare body name is accepted where OpenSim would resolve it
                // through the BodySet (e.g. "../femur_r" from a joint).
                if let Some(&b) = self.body_index.get(&name) {
                    if path.ends_with(&format!("/{name}"))
                        && !self.frame_specs.contains_key(&path)
                        && socket.trim_start_matches("../") == name
                    {
                        return Ok((b, Transform::identity(), name));
                    }
                }
                Err(e)
            }
        }
    }
}

/// Compile a model document into the immutable [`Model`].
pub fn compile(spec: &ModelSpec) -> Result<Model> {
    let mut warnings = spec.warnings.clone();
    // Bodies in file order first; index 0 = ground.
    let mut body_index: HashMap<String, usize> = HashMap::new();
    body_index.insert(spec.ground_name.clone(), 0);
    for (i, b) in spec.bodies.iter().enumerate() {
        if body_index.insert(b.name.clone(), i + 1).is_some() {
            return Err(Error::input(
                b.loc.clone(),
                format!("two bodies are named '{}'", b.name),
            ));
        }
    }
    let mut frame_specs = HashMap::new();
    for (i, f) in spec.frames.iter().enumerate() {
        if frame_specs.insert(f.path.clone(), i).is_some() {
            return Err(Error::input(
                f.loc.clone(),
                format!("two frames have the path '{}'", f.path),
            ));
        }
    }
    let resolver = FrameResolver {
        spec,
        body_index: body_index.clone(),
        frame_specs,
    };

    // Resolve every joint's frames (file-order body indices for now).
    struct Resolved<'s> {
        spec: &'s JointSpec,
        parent: usize,
        child: usize,
        x_pf: Transform,
        x_bm: Transform,
        pname: String,
        cname: String,
    }
    let mut resolved: Vec<Resolved> = Vec::new();
    let mut inboard: HashMap<usize, usize> = HashMap::new();
    for (ji, j) in spec.joints.iter().enumerate() {
        let (parent, x_pf, pname) = resolver.resolve_socket(&j.path, &j.parent_frame, &j.loc)?;
        let (child, x_bm, cname) = resolver.resolve_socket(&j.path, &j.child_frame, &j.loc)?;
        if child == 0 {
            return Err(Error::input(
                j.loc.clone(),
                format!(
                    "joint '{}' has ground as its child frame; reversed joints are not supported",
                    j.name
                ),
            ));
        }
        if parent == child {
            return Err(Error::input(
                j.loc.clone(),
                format!(
                    "joint '{}' connects body '{}' to itself",
                    j.name,
                    spec.bodies[child - 1].name
                ),
            ));
        }
        if let Some(prev) = inboard.insert(child, ji) {
            return Err(Error::input(
                j.loc.clone(),
                format!(
                    "body '{}' is the child of two joints ('{}' and '{}'): closed kinematic loops are not supported",
                    spec.bodies[child - 1].name, spec.joints[prev].name, j.name
                ),
            ));
        }
        resolved.push(Resolved {
            spec: j,
            parent,
            child,
            x_pf,
            x_bm,
            pname,
            cname,
        });
    }
    for (i, b) in spec.bodies.iter().enumerate() {
        if !inboard.contains_key(&(i + 1)) {
            return Err(Error::input(
                b.loc.clone(),
                format!(
                    "body '{}' is not connected to the model by any joint",
                    b.name
                ),
            ));
        }
    }

    // Tree order: by level from ground, then by joint order in the file.
    let mut level: HashMap<usize, usize> = HashMap::new();
    level.insert(0, 0);
    let mut order: Vec<usize> = Vec::new(); // joint indices (into `resolved`) in tree order
    let mut current = 0;
    loop {
        let mut added = false;
        for (ji, r) in resolved.iter().enumerate() {
            if level.get(&r.parent) == Some(&current) && !level.contains_key(&r.child) {
                level.insert(r.child, current + 1);
                order.push(ji);
                added = true;
            }
        }
        if !added {
            break;
        }
        current += 1;
    }
    if order.len() != resolved.len() {
        let r = resolved
            .iter()
            .find(|r| !level.contains_key(&r.child))
            .map(|r| r.spec)
            .unwrap_or(&spec.joints[0]);
        return Err(Error::input(
            r.loc.clone(),
            format!(
                "joint '{}' is not connected to ground through other joints (kinematic loop?)",
                r.name
            ),
        ));
    }
    // new body index for each file-order body index
    let mut new_index = vec![0usize; spec.bodies.len() + 1];
    for (k, &ji) in order.iter().enumerate() {
        new_index[resolved[ji].child] = k + 1;
    }

    // Bodies in tree order.
    let mut bodies = vec![Body {
        name: spec.ground_name.clone(),
        mass: 0.0,
        mass_center: Vector3::zeros(),
        inertia: Matrix3::zeros(),
        parent: None,
    }];
    for &ji in &order {
        let r = &resolved[ji];
        let bs = &spec.bodies[r.child - 1];
        let inertia = checked_inertia(bs, &mut warnings);
        bodies.push(Body {
            name: bs.name.clone(),
            mass: bs.mass,
            mass_center: bs.mass_center,
            inertia,
            parent: Some(new_index[r.parent]),
        });
    }

    // Joints and coordinates in tree order.
    let mut joints: Vec<Joint> = vec![Joint {
        name: String::new(),
        kind: JointKind::Weld,
        parent_body: 0,
        child_body: 0,
        x_pf: Transform::identity(),
        x_bm: Transform::identity(),
        q_start: 0,
        nq: 0,
        parent_frame_name: String::new(),
        child_frame_name: String::new(),
    }];
    let mut coordinates: Vec<Coordinate> = Vec::new();
    let mut coord_by_name: HashMap<String, usize> = HashMap::new();
    for &ji in &order {
        let r = &resolved[ji];
        let body = new_index[r.child];
        let (kind, coord_order, motion) = joint_kind(r.spec)?;
        let q_start = coordinates.len();
        for (k, &ci) in coord_order.iter().enumerate() {
            let cs = &r.spec.coordinates[ci];
            if coord_by_name
                .insert(cs.name.clone(), coordinates.len())
                .is_some()
            {
                return Err(Error::input(
                    cs.loc.clone(),
                    format!("two coordinates are named '{}'", cs.name),
                ));
            }
            if cs.range[0] > cs.range[1] {
                return Err(Error::input(
                    cs.loc.clone(),
                    format!(
                        "coordinate '{}' has range [{}, {}] with min > max",
                        cs.name, cs.range[0], cs.range[1]
                    ),
                ));
            }
            coordinates.push(Coordinate {
                name: cs.name.clone(),
                body,
                motion_type: motion[k],
                default_value: cs.default_value,
                default_speed: cs.default_speed,
                range: cs.range,
                clamped: cs.clamped,
                locked: cs.locked,
                prescribed: if cs.prescribed {
                    cs.prescribed_function.clone()
                } else {
                    None
                },
                dependent: cs.free_to_satisfy_constraints,
            });
        }
        joints.push(Joint {
            name: r.spec.name.clone(),
            kind,
            parent_body: new_index[r.parent],
            child_body: body,
            x_pf: r.x_pf,
            x_bm: r.x_bm,
            q_start,
            nq: coord_order.len(),
            parent_frame_name: r.pname.clone(),
            child_frame_name: r.cname.clone(),
        });
    }
    let mut coordinate_set_order = Vec::new();
    let mut joint_set_order = Vec::new();
    for j in &spec.joints {
        joint_set_order.push(joints.iter().position(|x| x.name == j.name).unwrap_or(0));
        for c in &j.coordinates {
            if let Some(&i) = coord_by_name.get(&c.name) {
                coordinate_set_order.push(i);
            }
        }
    }

    // Frames: ground, bodies, offset frames.
    let mut frames = vec![Frame {
        path: format!("/{}", spec.ground_name),
        name: spec.ground_name.clone(),
        body: 0,
        transform: Transform::identity(),
    }];
    for (b, body) in bodies.iter().enumerate().skip(1) {
        frames.push(Frame {
            path: format!("/bodyset/{}", body.name),
            name: body.name.clone(),
            body: b,
            transform: Transform::identity(),
        });
    }
    for f in &spec.frames {
        let (b, x) = resolver.resolve(&f.path, 0, &f.loc)?;
        frames.push(Frame {
            path: f.path.clone(),
            name: f.name.clone(),
            body: new_index[b],
            transform: x,
        });
    }

    // Coupler constraints.
    let mut couplers = Vec::new();
    for c in spec.couplers.iter().filter(|c| c.enforced) {
        let find = |n: &str| {
            coord_by_name.get(n).copied().ok_or_else(|| {
                Error::input(
                    c.loc.clone(),
                    format!(
                        "constraint '{}' names coordinate '{n}', which does not exist",
                        c.name
                    ),
                )
            })
        };
        let dependent = find(&c.dependent)?;
        let independent = c
            .independent
            .iter()
            .map(|n| find(n))
            .collect::<Result<Vec<_>>>()?;
        if independent.len() != 1 && !matches!(c.function, Function::Constant(_)) {
            return Err(Error::input(c.loc.clone(), format!("constraint '{}': couplers with {} independent coordinates are not supported (only one)", c.name, independent.len())));
        }
        coordinates[dependent].dependent = true;
        couplers.push(Coupler {
            name: c.name.clone(),
            function: c.function.clone(),
            independent,
            dependent,
            scale: c.scale_factor,
        });
    }

    Ok(Model {
        name: spec.name.clone(),
        file: spec.file.clone(),
        gravity: spec.gravity,
        bodies,
        joints,
        coordinates,
        coordinate_set_order,
        joint_set_order,
        frames,
        couplers,
        warnings,
    })
}

/// Inertia about the mass center as a matrix, with OpenSim's repairs (§2.2).
fn checked_inertia(b: &crate::parse::osim::BodySpec, warnings: &mut Vec<String>) -> Matrix3<f64> {
    let [xx, yy, zz, xy, xz, yz] = b.inertia;
    let m = Matrix3::new(xx, xy, xz, xy, yy, yz, xz, yz, zz);
    if b.mass == 0.0 {
        if m.iter().any(|v| *v != 0.0) {
            warnings.push(format!(
                "body '{}' is massless but has inertia; using zero inertia as OpenSim does",
                b.name
            ));
        }
        return Matrix3::zeros();
    }
    // A physically impossible matrix is used as given, as OpenSim 4.6
    // release builds do; parse::osim warns about it, naming file and line.
    m
}

/// Joint type, the order of its coordinates (indices into the spec's list),
/// and their motion types.
fn joint_kind(j: &JointSpec) -> Result<(JointKind, Vec<usize>, Vec<MotionType>)> {
    use MotionType::*;
    let fixed = |kind: JointKind,
                 types: &[MotionType]|
     -> Result<(JointKind, Vec<usize>, Vec<MotionType>)> {
        if j.coordinates.len() != types.len() {
            return Err(Error::input(
                j.loc.clone(),
                format!(
                    "{} '{}' needs {} coordinates, found {}",
                    j.kind,
                    j.name,
                    types.len(),
                    j.coordinates.len()
                ),
            ));
        }
        Ok((kind, (0..types.len()).collect(), types.to_vec()))
    };
    match j.kind.as_str() {
        "WeldJoint" => fixed(JointKind::Weld, &[]),
        "PinJoint" => fixed(JointKind::Pin, &[Rotational]),
        "SliderJoint" => fixed(JointKind::Slider, &[Translational]),
        "UniversalJoint" => fixed(JointKind::Universal, &[Rotational, Rotational]),
        "GimbalJoint" => fixed(JointKind::Gimbal, &[Rotational, Rotational, Rotational]),
        "BallJoint" => fixed(JointKind::Ball, &[Rotational, Rotational, Rotational]),
        "FreeJoint" => fixed(JointKind::Free, &[Rotational, Rotational, Rotational, Translational, Translational, Translational]),
        "PlanarJoint" => fixed(JointKind::Planar, &[Rotational, Translational, Translational]),
        "CustomJoint" => custom_joint(j),
        other => Err(Error::input(j.loc.clone(), format!("unknown or unsupported joint type '{other}'; supported: WeldJoint, PinJoint, SliderJoint, UniversalJoint, GimbalJoint, BallJoint, FreeJoint, PlanarJoint, CustomJoint"))),
    }
}

fn custom_joint(j: &JointSpec) -> Result<(JointKind, Vec<usize>, Vec<MotionType>)> {
    let axes = j.spatial_transform.as_ref().ok_or_else(|| {
        Error::input(
            j.loc.clone(),
            format!("CustomJoint '{}' has no SpatialTransform", j.name),
        )
    })?;
    // Unique coordinates in order of first appearance across the six axes.
    let mut order: Vec<usize> = Vec::new();
    for a in axes {
        for name in &a.coordinates {
            let ci = j.coordinates.iter().position(|c| &c.name == name).ok_or_else(|| {
                Error::input(a.loc.clone(), format!("transform axis names coordinate '{name}', which joint '{}' does not define", j.name))
            })?;
            if !order.contains(&ci) {
                order.push(ci);
            }
        }
    }
    if order.len() != j.coordinates.len() {
        let unused: Vec<&str> = j
            .coordinates
            .iter()
            .enumerate()
            .filter(|(i, _)| !order.contains(i))
            .map(|(_, c)| c.name.as_str())
            .collect();
        return Err(Error::input(
            j.loc.clone(),
            format!(
                "CustomJoint '{}': coordinates {:?} drive no transform axis",
                j.name, unused
            ),
        ));
    }
    // Pairwise non-collinear rotation axes and translation axes.
    for (lo, hi) in [(0, 3), (3, 6)] {
        for a in lo..hi {
            for b in a + 1..hi {
                if axes[a].axis.cross(&axes[b].axis).norm() < 1e-5 {
                    return Err(Error::input(
                        axes[b].loc.clone(),
                        format!(
                            "CustomJoint '{}': transform axes {} and {} are collinear",
                            j.name,
                            a + 1,
                            b + 1
                        ),
                    ));
                }
            }
        }
    }
    let mut motion = vec![None::<MotionType>; order.len()];
    let mut built: Vec<TransformAxis> = Vec::with_capacity(6);
    for (i, a) in axes.iter().enumerate() {
        let function = a.function.clone().unwrap_or(Function::Constant(0.0));
        let coordinate = match a.coordinates.len() {
            0 => None,
            1 => {
                let ci = j
                    .coordinates
                    .iter()
                    .position(|c| c.name == a.coordinates[0])
                    .unwrap_or(0);
                order.iter().position(|&o| o == ci)
            }
            _ => {
                if !matches!(function, Function::Constant(_)) {
                    return Err(Error::input(a.loc.clone(), format!("CustomJoint '{}': axes driven by several coordinates are supported only with a Constant function", j.name)));
                }
                None
            }
        };
        // Motion type (§2.6): slope ±1 LinearFunction → pure; anything else → Coupled unless already pure.
        for name in &a.coordinates {
            let ci = j
                .coordinates
                .iter()
                .position(|c| &c.name == name)
                .unwrap_or(0);
            let k = order.iter().position(|&o| o == ci).unwrap_or(0);
            let pure = matches!(function, Function::Linear { slope, .. } if slope.abs() == 1.0);
            let t = if pure {
                Some(if i < 3 {
                    MotionType::Rotational
                } else {
                    MotionType::Translational
                })
            } else {
                match motion[k] {
                    Some(MotionType::Rotational) | Some(MotionType::Translational) => motion[k],
                    _ => Some(MotionType::Coupled),
                }
            };
            motion[k] = t;
        }
        built.push(TransformAxis {
            axis: a.axis,
            coordinate,
            function,
        });
    }
    let arr: [TransformAxis; 6] = built
        .try_into()
        .map_err(|_| Error::internal("six axes expected"))?;
    Ok((
        JointKind::Custom(Box::new(arr)),
        order,
        motion
            .into_iter()
            .map(|m| m.unwrap_or(MotionType::Coupled))
            .collect(),
    ))
}

#[cfg(test)]
mod tests {
    use super::resolve_path;

    #[test]
    fn socket_paths() {
        assert_eq!(
            resolve_path("/jointset/hip_r", "pelvis_offset"),
            "/jointset/hip_r/pelvis_offset"
        );
        assert_eq!(
            resolve_path("/jointset/hip_r", "/bodyset/pelvis"),
            "/bodyset/pelvis"
        );
        assert_eq!(
            resolve_path("/jointset/hip_r/pelvis_offset", "../../../bodyset/pelvis"),
            "/bodyset/pelvis"
        );
    }
}
