//! Muscle-path wrapping over cylinders, spheres, ellipsoids and tori,
//! reproducing OpenSim 4.6 (opensim-semantics §5.4; `OpenSim/Simulation/Wrap/`).
//!
//! Everything here works in the wrap object's own frame: the path code
//! converts the two segment endpoints with [`WrapObject::body_to_wrap`],
//! calls [`wrap_line`], and converts `r1`, `r2` back with
//! [`WrapObject::wrap_to_body`]. `GeometryPath::applyWrapObjects` (segment
//! selection, multi-object passes) is the caller's job; this module answers
//! for one segment and one object.
//!
//! OpenSim keeps the previous `WrapResult` per `PathWrap`, but because
//! `WrapResult`'s copy does not copy `factor` (it becomes NaN) the previous
//! tangent points are never usable; only the ellipsoid's `c1` survives, and
//! it is read only when a point-to-ellipsoid projection fails to converge.
//! So `wrap_line` is a pure function here.

pub mod cylinder;
pub mod ellipsoid;
pub mod math;
pub mod sphere;
pub mod torus;
pub mod types;

pub use types::{
    body_fixed_xyz, PathWrap, Quadrant, WrapAction, WrapMethod, WrapObject, WrapResult, WrapShape,
};

use nalgebra::Vector3;

/// Wrap the straight segment p1→p2 (wrap-object frame) over `obj`.
///
/// `method` is used only by ellipsoids. `single_wrap` must be true when the
/// path has exactly one `PathWrap` (OpenSim's `WrapResult::singleWrap`); it
/// switches off the cylinder's iterative tangency adjustment, which OpenSim
/// performs only for paths with several wrap objects.
///
/// The result is a wrap to insert into the path only if
/// [`WrapResult::wraps`]; its wrapped length is
/// [`WrapResult::total_length`]. `obj.active` is not consulted here.
pub fn wrap_line(
    obj: &WrapObject,
    method: WrapMethod,
    p1: Vector3<f64>,
    p2: Vector3<f64>,
    single_wrap: bool,
) -> WrapResult {
    let res = match &obj.shape {
        WrapShape::Cylinder { radius, length } => {
            cylinder::wrap_cylinder(*radius, *length, obj.quadrant, p1, p2, single_wrap)
        }
        WrapShape::Sphere { radius } => sphere::wrap_sphere(*radius, obj.quadrant, p1, p2),
        WrapShape::Ellipsoid { dimensions } => {
            ellipsoid::wrap_ellipsoid(*dimensions, obj.quadrant, method, p1, p2)
        }
        WrapShape::Torus {
            inner_radius,
            outer_radius,
        } => torus::wrap_torus(
            *inner_radius,
            *outer_radius,
            obj.quadrant,
            p1,
            p2,
            single_wrap,
        ),
    };
    // Safety net for degenerate input (e.g. coincident endpoints on a
    // torus) where OpenSim's arithmetic would produce NaN: report no wrap.
    let finite = res.r1.iter().chain(res.r2.iter()).all(|x| x.is_finite())
        && res.wrap_path_length.is_finite()
        && res
            .wrap_points
            .iter()
            .all(|p| p.iter().all(|x| x.is_finite()));
    if finite {
        res
    } else {
        WrapResult::no_wrap(WrapAction::NoWrap, p1, p2)
    }
}

/// Gradients of the wrapped segment length with respect to P1 and P2 (in
/// the wrap frame), as OpenSim's moment-arm computation uses them.
///
/// OpenSim computes moment arms from forces (§5.3): a unit tension pulls
/// P1 towards R1 and P2 towards R2, and the wrap points R1, R2 are fixed on
/// the wrap object's body. So the effective derivative of the length with
/// respect to the endpoints, expressed in the wrap frame, is the unit
/// vector (P1 − R1)/|P1 − R1| for P1 and (P2 − R2)/|P2 − R2| for P2, for
/// every shape. For an exact tangent wrap (cylinder, sphere) this equals
/// the true gradient of |P1R1| + arc + |R2P2| (envelope theorem).
/// Without a wrap it is the gradient of |P1P2|. Zero-length segments give
/// zero vectors (OpenSim uses the raw difference then; it is zero too).
pub fn endpoint_gradients(
    res: &WrapResult,
    p1: Vector3<f64>,
    p2: Vector3<f64>,
) -> (Vector3<f64>, Vector3<f64>) {
    if res.wraps() {
        (
            math::unit_or_zero(&(p1 - res.r1)),
            math::unit_or_zero(&(p2 - res.r2)),
        )
    } else {
        let u = math::unit_or_zero(&(p1 - p2));
        (u, -u)
    }
}

#[cfg(test)]
mod tests;
