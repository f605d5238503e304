//! Tests for the wrapping module: closed-form geometry, degenerate input,
//! XML reading, endpoint gradients by finite differences, and numbers from
//! real OpenSim 4.6.

use std::f64::consts::PI;
use std::path::Path;

use approx::assert_abs_diff_eq;
use nalgebra::Vector3;

use super::*;

type V = Vector3<f64>;

fn v(x: f64, y: f64, z: f64) -> V {
    V::new(x, y, z)
}

fn obj(shape: WrapShape, quadrant: Quadrant) -> WrapObject {
    WrapObject {
        name: "w".into(),
        shape,
        active: true,
        rotation: nalgebra::Matrix3::identity(),
        translation: V::zeros(),
        quadrant,
    }
}

fn cyl(r: f64, l: f64, q: Quadrant) -> WrapObject {
    obj(
        WrapShape::Cylinder {
            radius: r,
            length: l,
        },
        q,
    )
}

fn finite(res: &WrapResult) -> bool {
    res.r1.iter().chain(res.r2.iter()).all(|x| x.is_finite())
        && res.wrap_path_length.is_finite()
        && res
            .wrap_points
            .iter()
            .all(|p| p.iter().all(|x| x.is_finite()))
}

fn is_tangent_cyl(r: f64, p: &V, t: &V) -> bool {
    // radial direction at t is perpendicular to (p - t) projected on xy.
    let radial = v(t.x, t.y, 0.0);
    let d = v(p.x - t.x, p.y - t.y, 0.0);
    ((radial.norm() - r).abs() < 1e-9) && (radial.dot(&d).abs() < 1e-9 * d.norm().max(1.0))
}

// ---------------------------------------------------------------- cylinder

#[test]
fn cylinder_line_missing_cylinder_does_not_wrap() {
    let o = cyl(0.05, 1.0, Quadrant::All);
    let res = wrap_line(
        &o,
        WrapMethod::Hybrid,
        v(-0.2, 0.1, 0.0),
        v(0.2, 0.1, 0.0),
        true,
    );
    assert_eq!(res.action, WrapAction::NoWrap);
    assert!(!res.wraps());
}

#[test]
fn cylinder_planar_wrap_matches_closed_form() {
    // P1, P2 in the z = 0 plane, symmetric about the y axis; the line y = -0.01
    // crosses the cylinder. Tangent lengths sqrt(d² − r²), arc r·θ with
    // θ = π − 2·acos(r/d) around the side nearer the line (y < 0).
    let r = 0.05;
    let (x, y) = (0.2, -0.01);
    let o = cyl(r, 1.0, Quadrant::All);
    let p1 = v(-x, y, 0.0);
    let p2 = v(x, y, 0.0);
    let res = wrap_line(&o, WrapMethod::Hybrid, p1, p2, true);
    assert_eq!(res.action, WrapAction::MandatoryWrap);
    let d = (x * x + y * y).sqrt();
    let tangent = (d * d - r * r).sqrt();
    // Angle of P1 and P2 from +x axis, and tangent offsets.
    let phi1 = y.atan2(-x);
    let phi2 = y.atan2(x);
    let beta = (r / d).acos();
    // Tangent points on the y<0 side: phi1 + beta and phi2 - beta.
    let t1 = phi1 + beta;
    let t2 = phi2 - beta;
    let mut theta = (t1 - t2).abs();
    if theta > PI {
        theta = 2.0 * PI - theta;
    }
    let expected = 2.0 * tangent + r * theta;
    assert_abs_diff_eq!(res.total_length(&p1, &p2), expected, epsilon = 1e-12);
    assert_abs_diff_eq!(res.wrap_path_length, r * theta, epsilon = 1e-12);
    assert!(res.r1.y < 0.0 && res.r2.y < 0.0);
    assert!(is_tangent_cyl(r, &p1, &res.r1) && is_tangent_cyl(r, &p2, &res.r2));
}

#[test]
fn cylinder_helix_length_is_pythagorean() {
    let r = 0.04;
    let o = cyl(r, 1.0, Quadrant::All);
    let p1 = v(-0.15, 0.01, -0.1);
    let p2 = v(0.12, -0.02, 0.15);
    let res = wrap_line(&o, WrapMethod::Hybrid, p1, p2, true);
    assert_eq!(res.action, WrapAction::MandatoryWrap);
    let a1 = res.r1.y.atan2(res.r1.x);
    let a2 = res.r2.y.atan2(res.r2.x);
    let mut th = (a2 - a1).abs();
    if th > PI {
        th = 2.0 * PI - th;
    }
    let dz = res.r2.z - res.r1.z;
    assert_abs_diff_eq!(
        res.wrap_path_length,
        ((r * th).powi(2) + dz * dz).sqrt(),
        epsilon = 1e-12
    );
    // Tangent points on the surface, in the planes perpendicular to the axis
    // they are tangent (xy-projection).
    assert!(is_tangent_cyl(r, &p1, &res.r1) && is_tangent_cyl(r, &p2, &res.r2));
    // Note: OpenSim's axial sliding (plane through P1, P2 and an apex point)
    // is not the exact geodesic, so the three pieces do not unfold into one
    // straight line exactly; the OpenSim reference cases pin that behaviour.
}

#[test]
fn cylinder_inside_radius() {
    let o = cyl(0.05, 1.0, Quadrant::All);
    let res = wrap_line(
        &o,
        WrapMethod::Hybrid,
        v(0.01, 0.0, 0.0),
        v(0.2, 0.0, 0.0),
        true,
    );
    assert_eq!(res.action, WrapAction::InsideRadius);
    assert!(!res.wraps());
}

#[test]
fn cylinder_beyond_ends_does_not_wrap() {
    // Crosses the axis line but far beyond the cylinder's length.
    let o = cyl(0.05, 0.1, Quadrant::All);
    let res = wrap_line(
        &o,
        WrapMethod::Hybrid,
        v(-0.2, 0.0, 0.5),
        v(0.2, 0.01, 0.5),
        true,
    );
    assert_eq!(res.action, WrapAction::NoWrap);
}

#[test]
fn cylinder_quadrant_rules() {
    let q = Quadrant::Axis { axis: 1, sign: 1 };
    let o = cyl(0.05, 1.0, q);
    // Both points on the active (+y) side, line clear of the cylinder: no wrap.
    let res = wrap_line(
        &o,
        WrapMethod::Hybrid,
        v(-0.2, 0.08, 0.0),
        v(0.2, 0.08, 0.0),
        true,
    );
    assert_eq!(res.action, WrapAction::NoWrap);
    // Line through the cylinder with a point on the active side: mandatory,
    // wrapping over the +y side even though the line passes at y = -0.01.
    let p1 = v(-0.2, 0.0, 0.0);
    let p2 = v(0.2, -0.02, 0.0);
    let res = wrap_line(&o, WrapMethod::Hybrid, p1, p2, true);
    assert_eq!(res.action, WrapAction::MandatoryWrap);
    assert!(
        res.r1.y > 0.0 && res.r2.y > 0.0,
        "{:?} {:?}",
        res.r1,
        res.r2
    );
    // Points on opposite sides, line clear below: 'wrapped' over the top.
    // (closest point of the line to the axis at (-0.108, -0.139): off side)
    let res = wrap_line(
        &o,
        WrapMethod::Hybrid,
        v(-0.3, 0.01, 0.0),
        v(0.1, -0.3, 0.0),
        true,
    );
    assert_eq!(res.action, WrapAction::Wrapped);
    // Both points off the active side: wraps around the far (+y) side.
    let p1 = v(-0.2, -0.02, 0.0);
    let p2 = v(0.2, -0.02, 0.0);
    let res = wrap_line(&o, WrapMethod::Hybrid, p1, p2, true);
    assert_eq!(res.action, WrapAction::Wrapped);
    let r = 0.05;
    let d = (0.2f64 * 0.2 + 0.02 * 0.02).sqrt();
    let beta = (r / d).acos();
    let phi = (0.02f64 / 0.2).atan(); // P2 is at angle -phi, P1 at π + phi
                                      // over the top: from angle (π+phi) − ... going through +y.
    let t1 = (PI + phi) - beta; // tangent point angle nearer +y for P1 (mod 2π)
    let t2 = -phi + beta;
    let theta = t1 - t2;
    let expected = 2.0 * (d * d - r * r).sqrt() + r * theta;
    assert_abs_diff_eq!(res.total_length(&p1, &p2), expected, epsilon = 1e-12);
    assert!(res.r1.y > 0.0 && res.r2.y > 0.0);
}

// ------------------------------------------------------------------ sphere

#[test]
fn sphere_great_circle_arc() {
    let r = 0.05;
    let o = obj(WrapShape::Sphere { radius: r }, Quadrant::All);
    let p1 = v(-0.15, 0.02, -0.01);
    let p2 = v(0.13, -0.01, 0.03);
    let res = wrap_line(&o, WrapMethod::Hybrid, p1, p2, true);
    assert_eq!(res.action, WrapAction::Wrapped);
    assert_abs_diff_eq!(res.r1.norm(), r, epsilon = 1e-12);
    assert_abs_diff_eq!(res.r2.norm(), r, epsilon = 1e-12);
    // tangency: (P − R) ⟂ R
    assert_abs_diff_eq!((p1 - res.r1).dot(&res.r1), 0.0, epsilon = 1e-12);
    assert_abs_diff_eq!((p2 - res.r2).dot(&res.r2), 0.0, epsilon = 1e-12);
    // coplanar with the centre, P1, P2
    let n = p1.cross(&p2).normalize();
    assert_abs_diff_eq!(res.r1.dot(&n), 0.0, epsilon = 1e-12);
    assert_abs_diff_eq!(res.r2.dot(&n), 0.0, epsilon = 1e-12);
    // Closed form: angle(P1,P2) − acos(r/|P1|) − acos(r/|P2|).
    let ang = (p1.dot(&p2) / (p1.norm() * p2.norm())).acos();
    let theta = ang - (r / p1.norm()).acos() - (r / p2.norm()).acos();
    assert_abs_diff_eq!(res.wrap_path_length, r * theta, epsilon = 1e-12);
}

#[test]
fn sphere_no_wrap_and_inside() {
    let o = obj(WrapShape::Sphere { radius: 0.05 }, Quadrant::All);
    let res = wrap_line(
        &o,
        WrapMethod::Hybrid,
        v(-0.2, 0.06, 0.0),
        v(0.2, 0.06, 0.0),
        true,
    );
    assert_eq!(res.action, WrapAction::NoWrap);
    let res = wrap_line(
        &o,
        WrapMethod::Hybrid,
        v(0.0, 0.01, 0.0),
        v(0.2, 0.06, 0.0),
        true,
    );
    assert_eq!(res.action, WrapAction::InsideRadius);
}

// --------------------------------------------------------------- ellipsoid

#[test]
fn ellipsoid_that_is_a_sphere_gives_the_sphere_answer() {
    let r = 0.05;
    let s = obj(WrapShape::Sphere { radius: r }, Quadrant::All);
    let e = obj(
        WrapShape::Ellipsoid {
            dimensions: V::repeat(r),
        },
        Quadrant::All,
    );
    for (p1, p2) in [
        (v(-0.15, 0.02, -0.01), v(0.15, 0.03, 0.02)),
        (v(-0.1, -0.08, 0.03), v(0.12, 0.05, -0.02)),
    ] {
        let rs = wrap_line(&s, WrapMethod::Hybrid, p1, p2, true);
        let ls = rs.total_length(&p1, &p2);
        for m in [WrapMethod::Hybrid, WrapMethod::Midpoint, WrapMethod::Axial] {
            let re = wrap_line(&e, m, p1, p2, true);
            assert_eq!(re.action, WrapAction::MandatoryWrap);
            // Tangent search converges to ssq < 1e-8 (normalized units) and the
            // arc is a ~1 mm polyline, so agreement is ~1e-6 m, as in OpenSim
            // (0.30570149 vs 0.30570118 for the same case there).
            assert_abs_diff_eq!(re.total_length(&p1, &p2), ls, epsilon = 2e-6);
            assert_abs_diff_eq!(re.r1, rs.r1, epsilon = 1e-4);
            assert_abs_diff_eq!(re.r2, rs.r2, epsilon = 1e-4);
        }
    }
}

#[test]
fn ellipsoid_no_wrap_inside_and_collinear() {
    let e = obj(
        WrapShape::Ellipsoid {
            dimensions: v(0.06, 0.03, 0.04),
        },
        Quadrant::All,
    );
    let res = wrap_line(
        &e,
        WrapMethod::Hybrid,
        v(-0.2, 0.05, 0.0),
        v(0.2, 0.05, 0.0),
        true,
    );
    assert_eq!(res.action, WrapAction::NoWrap);
    let res = wrap_line(
        &e,
        WrapMethod::Hybrid,
        v(0.01, 0.0, 0.0),
        v(0.2, 0.05, 0.0),
        true,
    );
    assert_eq!(res.action, WrapAction::InsideRadius);
    // P1, P2 on the same ray from the centre.
    let res = wrap_line(
        &e,
        WrapMethod::Hybrid,
        v(0.1, 0.1, 0.0),
        v(0.2, 0.2, 0.0),
        true,
    );
    assert_eq!(res.action, WrapAction::NoWrap);
}

// ------------------------------------------------------------------- torus

#[test]
fn torus_line_through_hole_clear_of_tube_does_not_wrap() {
    let t = obj(
        WrapShape::Torus {
            inner_radius: 0.02,
            outer_radius: 0.08,
        },
        Quadrant::All,
    );
    let p1 = v(0.0, 0.0, 0.1);
    let p2 = v(0.01, 0.0, -0.1);
    let res = wrap_line(&t, WrapMethod::Hybrid, p1, p2, true);
    assert!(!res.wraps());
    assert_abs_diff_eq!(
        res.total_length(&p1, &p2),
        (p2 - p1).norm(),
        epsilon = 1e-15
    );
}

#[test]
fn torus_wraps_inside_of_tube() {
    let (ri, ro) = (0.02, 0.08);
    let t = obj(
        WrapShape::Torus {
            inner_radius: ri,
            outer_radius: ro,
        },
        Quadrant::All,
    );
    // Straight line in the y = 0 plane through the tube at x = 0.065:
    // it wraps around the inner side of the tube cross-section (a circle of
    // radius ri centred at (ro, 0, 0)) — a planar 2-D wrap with closed form.
    let p1 = v(0.065, 0.0, 0.1);
    let p2 = v(0.065, 0.0, -0.1);
    let res = wrap_line(&t, WrapMethod::Hybrid, p1, p2, true);
    assert!(res.wraps());
    let c = v(ro, 0.0, 0.0);
    let d = (p1 - c).norm();
    let tangent = (d * d - ri * ri).sqrt();
    // angle at the centre between c→p1 and c→p2, minus the two tangent angles
    let ang = ((p1 - c).dot(&(p2 - c)) / (d * d)).acos();
    let theta = 2.0 * PI - ang - 2.0 * (ri / d).acos();
    let theta = if theta > PI { 2.0 * PI - theta } else { theta };
    let _ = theta;
    // the wrap goes around the side facing the torus centre (x < ro)
    assert!(res.r1.x < ro && res.r2.x < ro);
    assert_abs_diff_eq!((res.r1 - c).norm(), ri, epsilon = 1e-9);
    assert_abs_diff_eq!((res.r2 - c).norm(), ri, epsilon = 1e-9);
    let phi1 = (p1.z - c.z).atan2(p1.x - c.x);
    let phi2 = (p2.z - c.z).atan2(p2.x - c.x);
    let b = (ri / d).acos();
    // tangent points towards −x: angles phi1 + b and phi2 − b (measured in xz)
    let mut th = ((phi1 + b) - (phi2 - b)).abs();
    if th > PI {
        th = 2.0 * PI - th;
    }
    let expected = 2.0 * tangent + ri * th;
    assert_abs_diff_eq!(res.total_length(&p1, &p2), expected, epsilon = 1e-9);
}

// ---------------------------------------------------------- degenerate cases

#[test]
fn degenerate_input_gives_no_nan() {
    let shapes = [
        cyl(0.05, 0.5, Quadrant::All),
        cyl(0.05, 0.5, Quadrant::Axis { axis: 0, sign: -1 }),
        obj(WrapShape::Sphere { radius: 0.05 }, Quadrant::All),
        obj(
            WrapShape::Sphere { radius: 0.05 },
            Quadrant::Axis { axis: 2, sign: 1 },
        ),
        obj(
            WrapShape::Ellipsoid {
                dimensions: v(0.05, 0.03, 0.04),
            },
            Quadrant::All,
        ),
        obj(
            WrapShape::Ellipsoid {
                dimensions: v(0.05, 0.03, 0.04),
            },
            Quadrant::Axis { axis: 1, sign: -1 },
        ),
        obj(
            WrapShape::Torus {
                inner_radius: 0.02,
                outer_radius: 0.08,
            },
            Quadrant::All,
        ),
    ];
    let pairs = [
        // coincident points
        (v(0.1, 0.02, 0.01), v(0.1, 0.02, 0.01)),
        // point on the cylinder / sphere surface
        (v(0.05, 0.0, 0.0), v(-0.2, 0.01, 0.0)),
        // collinear with the centre, on opposite sides
        (v(-0.2, 0.0, 0.0), v(0.2, 0.0, 0.0)),
        // through the centre, oblique
        (v(-0.2, -0.1, -0.05), v(0.2, 0.1, 0.05)),
        // parallel to the cylinder axis
        (v(0.1, 0.0, -0.2), v(0.1, 0.0, 0.2)),
        // at the origin
        (v(0.0, 0.0, 0.0), v(0.2, 0.0, 0.0)),
    ];
    for o in &shapes {
        for (p1, p2) in &pairs {
            for m in [WrapMethod::Hybrid, WrapMethod::Midpoint, WrapMethod::Axial] {
                for single in [true, false] {
                    let res = wrap_line(o, m, *p1, *p2, single);
                    if res.wraps() || res.action == WrapAction::NoWrap {
                        assert!(finite(&res), "{:?} {:?} {:?} -> {:?}", o.shape, p1, p2, res);
                        let l = res.total_length(p1, p2);
                        assert!(l.is_finite());
                        let (g1, g2) = endpoint_gradients(&res, *p1, *p2);
                        assert!(g1.iter().chain(g2.iter()).all(|x| x.is_finite()));
                    }
                }
            }
        }
    }
}

// ------------------------------------------------------ endpoint gradients

#[test]
fn endpoint_gradients_match_finite_differences() {
    // Cases where OpenSim's tangent points are exact (sphere; cylinder with
    // P1, P2 in one plane perpendicular to the axis), so the envelope
    // theorem applies. For helical cylinder wraps OpenSim's axial sliding is
    // approximate and its own length's derivative differs from the
    // force-based moment arm by ~1e-3 (e.g. 0.7024 vs 0.7044 for
    // P1 = (-0.15, 0.01, -0.1), P2 = (0.12, -0.02, 0.15), r = 0.04); OpenSim's
    // moment arm is the unit-vector one, which `matches_opensim_4_6_reference`
    // checks against computeMomentArm.
    let cases: Vec<(WrapObject, V, V)> = vec![
        (
            cyl(0.04, 1.0, Quadrant::All),
            v(-0.15, 0.01, 0.02),
            v(0.12, -0.02, 0.02),
        ),
        (
            cyl(0.05, 1.0, Quadrant::Axis { axis: 1, sign: 1 }),
            v(-0.2, -0.02, 0.03),
            v(0.2, -0.03, 0.03),
        ),
        (
            obj(WrapShape::Sphere { radius: 0.05 }, Quadrant::All),
            v(-0.15, 0.02, -0.01),
            v(0.13, -0.01, 0.03),
        ),
        (
            obj(
                WrapShape::Sphere { radius: 0.05 },
                Quadrant::Axis { axis: 2, sign: 1 },
            ),
            v(-0.15, 0.0, 0.02),
            v(0.15, 0.01, -0.03),
        ),
    ];
    let h = 1e-6;
    for (o, p1, p2) in cases {
        let len = |a: V, b: V| wrap_line(&o, WrapMethod::Hybrid, a, b, true).total_length(&a, &b);
        let res = wrap_line(&o, WrapMethod::Hybrid, p1, p2, true);
        assert!(res.wraps());
        let (g1, g2) = endpoint_gradients(&res, p1, p2);
        for k in 0..3 {
            let mut e = V::zeros();
            e[k] = h;
            let d1 = (len(p1 + e, p2) - len(p1 - e, p2)) / (2.0 * h);
            let d2 = (len(p1, p2 + e) - len(p1, p2 - e)) / (2.0 * h);
            assert_abs_diff_eq!(g1[k], d1, epsilon = 1e-6);
            assert_abs_diff_eq!(g2[k], d2, epsilon = 1e-6);
        }
    }
}

// ---------------------------------------------------------------- XML

fn parse(src: &str) -> crate::xml::Element {
    crate::xml::parse_str(src, Path::new("t.osim")).unwrap()
}

#[test]
fn wrap_object_from_xml() {
    let el = parse(
        "<WrapCylinder name=\"TRIlongglen\">\n<active>true</active>\n\
         <xyz_body_rotation>1.37532 -0.294612 2.43596</xyz_body_rotation>\n\
         <translation>-0.043905 -0.0039 0.1478</translation>\n<quadrant>x</quadrant>\n\
         <radius>0.003</radius>\n<length>0.03</length>\n</WrapCylinder>",
    );
    let o = WrapObject::from_xml(&el).unwrap();
    assert_eq!(o.name, "TRIlongglen");
    assert_eq!(o.quadrant, Quadrant::Axis { axis: 0, sign: 1 });
    assert_eq!(
        o.shape,
        WrapShape::Cylinder {
            radius: 0.003,
            length: 0.03
        }
    );
    // Body-fixed XYZ: R = Rx·Ry·Rz; check against an independent composition.
    let (a, b, c) = (1.37532f64, -0.294612f64, 2.43596f64);
    let r = nalgebra::Rotation3::from_axis_angle(&Vector3::x_axis(), a)
        * nalgebra::Rotation3::from_axis_angle(&Vector3::y_axis(), b)
        * nalgebra::Rotation3::from_axis_angle(&Vector3::z_axis(), c);
    assert_abs_diff_eq!(o.rotation, *r.matrix(), epsilon = 1e-15);
    let p = v(0.1, -0.2, 0.3);
    assert_abs_diff_eq!(o.wrap_to_body(&o.body_to_wrap(&p)), p, epsilon = 1e-15);

    let el =
        parse("<WrapEllipsoid name=\"e\"><dimensions>0.035 0.02 0.02</dimensions></WrapEllipsoid>");
    let o = WrapObject::from_xml(&el).unwrap();
    assert_eq!(o.quadrant, Quadrant::All);
    assert!(o.active);
    let el = parse("<WrapSphere name=\"s\"/>");
    assert_eq!(
        WrapObject::from_xml(&el).unwrap().shape,
        WrapShape::Sphere { radius: 0.05 }
    );
    let el = parse("<WrapTorus name=\"t\"><quadrant>-Y</quadrant></WrapTorus>");
    let o = WrapObject::from_xml(&el).unwrap();
    assert_eq!(o.quadrant, Quadrant::Axis { axis: 1, sign: -1 });
    assert_eq!(
        o.shape,
        WrapShape::Torus {
            inner_radius: 0.01,
            outer_radius: 0.05
        }
    );
}

#[test]
fn wrap_object_xml_errors_name_line() {
    let el = parse("<A>\n<WrapCone name=\"c\"/></A>");
    let e = WrapObject::from_xml(&el.children[0])
        .unwrap_err()
        .to_string();
    assert!(e.contains("line 2") && e.contains("WrapCone"), "{e}");
    let el = parse("<WrapSphere name=\"s\">\n<quadrant>up</quadrant></WrapSphere>");
    let e = WrapObject::from_xml(&el).unwrap_err().to_string();
    assert!(e.contains("line 2") && e.contains("quadrant"), "{e}");
    let el =
        parse("<WrapEllipsoid name=\"e\">\n<dimensions>0.1 0 0.1</dimensions></WrapEllipsoid>");
    assert!(WrapObject::from_xml(&el).is_err());
    let el = parse("<WrapCylinder name=\"c\">\n<radius>-1</radius></WrapCylinder>");
    assert!(WrapObject::from_xml(&el).is_err());
}

#[test]
fn path_wrap_from_xml() {
    let el = parse(
        "<PathWrap name=\"pw\"><wrap_object>BIClonghh</wrap_object>\
         <method>hybrid</method><range>2 3</range></PathWrap>",
    );
    let pw = PathWrap::from_xml(&el).unwrap();
    assert_eq!(pw.wrap_object, "BIClonghh");
    assert_eq!(pw.method, WrapMethod::Hybrid);
    assert_eq!(pw.range, (2, 3));
    let el = parse(
        "<PathWrap name=\"pw\"><wrap_object>x</wrap_object><method>Axial</method></PathWrap>",
    );
    let pw = PathWrap::from_xml(&el).unwrap();
    assert_eq!((pw.method, pw.range), (WrapMethod::Axial, (-1, -1)));
    let el = parse(
        "<PathWrap name=\"pw\">\n<wrap_object>x</wrap_object>\n<method>spiral</method></PathWrap>",
    );
    let e = PathWrap::from_xml(&el).unwrap_err().to_string();
    assert!(e.contains("line 3"), "{e}");
    let el = parse("<PathWrap name=\"pw\"><wrap_object>x</wrap_object><range>1</range></PathWrap>");
    assert!(PathWrap::from_xml(&el).is_err());
}

#[test]
fn arm26_wrap_objects_parse() {
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/validation/arm26/inputs/arm26.osim");
    if !path.exists() {
        eprintln!("SKIP: {} absent", path.display());
        return;
    }
    let root = crate::xml::parse_file(&path).unwrap();
    let mut objs = Vec::new();
    let mut wraps = Vec::new();
    fn walk(e: &crate::xml::Element, objs: &mut Vec<WrapObject>, wraps: &mut Vec<PathWrap>) {
        if e.name.starts_with("Wrap") && e.name != "WrapObjectSet" {
            objs.push(WrapObject::from_xml(e).unwrap());
        }
        if e.name == "PathWrap" {
            wraps.push(PathWrap::from_xml(e).unwrap());
        }
        for c in &e.children {
            walk(c, objs, wraps);
        }
    }
    walk(&root, &mut objs, &mut wraps);
    let names: Vec<_> = objs.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(names, ["TRIlongglen", "TRIlonghh", "BIClonghh", "TRI"]);
    assert_eq!(objs[1].quadrant, Quadrant::Axis { axis: 2, sign: 1 });
    assert_eq!(objs[2].quadrant, Quadrant::Axis { axis: 1, sign: -1 });
    assert_eq!(objs[3].quadrant, Quadrant::All);
    assert!(wraps.iter().all(|w| w.method == WrapMethod::Hybrid));
    assert!(wraps
        .iter()
        .any(|w| w.range == (2, 3) && w.wrap_object == "BIClonghh"));
}

// ------------------------------------------------- OpenSim 4.6 reference

/// One pose of a reference model built by
/// tests/reference_scripts/wrap_reference.py (run with `--rust` to print
/// these lines): wrap object on ground with pose (rot, trans), P1 on
/// ground, P2 at the origin of a FreeJoint body. `length` is
/// `GeometryPath.getLength`, `moment_arms` are `computeMomentArm` about the
/// three translational coordinates, `wrap_pts` the two PathWrapPoints in
/// ground (empty when OpenSim did not wrap).
struct RefCase {
    name: &'static str,
    shape: &'static str,
    params: &'static [f64],
    quadrant: &'static str,
    method: &'static str,
    rot: [f64; 3],
    trans: [f64; 3],
    multi: bool,
    p1: [f64; 3],
    p2: [f64; 3],
    length: f64,
    moment_arms: [f64; 3],
    wrap_pts: &'static [[f64; 3]],
}

#[rustfmt::skip]
const REFERENCE: &[RefCase] = &[
    RefCase { name: "cyl_all", shape: "cyl", params: &[0.05, 0.5], quadrant: "all", method: "hybrid", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: false, p1: [-0.15, 0.02, -0.05], p2: [0.15, 0.03, 0.06], length: 0.3236518281669899, moment_arms: [-0.9318647458888866, 0.12712574099382418, -0.3398045634570139], wrap_pts: &[[-0.01013849045542109, 0.04896132158434182, 0.00157121416638617], [0.00675844083666605, 0.049541129150003076, 0.0077669525592263255]] },
    RefCase { name: "cyl_all", shape: "cyl", params: &[0.05, 0.5], quadrant: "all", method: "hybrid", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: false, p1: [-0.15, 0.02, -0.05], p2: [0.2, -0.01, 0.1], length: 0.3919064392541407, moment_arms: [-0.8809423487098295, 0.2747450041650934, -0.38529957297657613], wrap_pts: &[[-0.01013849045542109, 0.04896132158434182, 0.008347182017597987], [0.014886623370282456, 0.04773246740564916, 0.019036580461662567]] },
    RefCase { name: "cyl_all", shape: "cyl", params: &[0.05, 0.5], quadrant: "all", method: "hybrid", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: false, p1: [-0.15, 0.02, -0.05], p2: [0.12, 0.04, -0.2], length: 0.31189761097319796, moment_arms: [-0.8748182286646987, 0.0742106847289934, 0.4787335804683155], wrap_pts: &[[-0.01013849045542109, 0.04896132158434182, -0.12867451382218498], [0.004226312451722192, 0.04982106264483344, -0.1366442648907693]] },
    RefCase { name: "cyl_all_multi", shape: "cyl", params: &[0.05, 0.5], quadrant: "all", method: "hybrid", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: true, p1: [-0.15, 0.02, -0.05], p2: [0.15, 0.03, 0.06], length: 0.32365176503399934, moment_arms: [-0.9318763639942371, 0.1271273259451362, -0.33977210778243544], wrap_pts: &[[-0.01013849045542109, 0.04896132158434182, 0.0016049269229159208], [0.00675844083666605, 0.049541129150003076, 0.007772592631967012]] },
    RefCase { name: "cyl_all_multi", shape: "cyl", params: &[0.05, 0.5], quadrant: "all", method: "hybrid", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: true, p1: [-0.15, 0.02, -0.05], p2: [0.2, -0.01, 0.1], length: 0.39190317539621633, moment_arms: [-0.8820342592828626, 0.2750855451498414, -0.382548700561048], wrap_pts: &[[-0.01013849045542109, 0.04896132158434182, 0.009181776674627749], [0.014886623370282456, 0.04773246740564916, 0.0197141370180538]] },
    RefCase { name: "cyl_all_multi", shape: "cyl", params: &[0.05, 0.5], quadrant: "all", method: "hybrid", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: true, p1: [-0.15, 0.02, -0.05], p2: [0.12, 0.04, -0.2], length: 0.31189691232695915, moment_arms: [-0.8737310676857121, 0.07411846104409787, 0.480729107807339], wrap_pts: &[[-0.01013849045542109, 0.04896132158434182, -0.12840434631907455], [0.004226312451722192, 0.04982106264483344, -0.1363010157461071]] },
    RefCase { name: "cyl_py", shape: "cyl", params: &[0.05, 0.5], quadrant: "+y", method: "hybrid", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: false, p1: [-0.15, 0.06, -0.05], p2: [0.15, 0.07, 0.06], length: 0.3196873472629156, moment_arms: [-0.9384168706347817, -0.03128056235449275, -0.34408618589941997], wrap_pts: &[] },
    RefCase { name: "cyl_py", shape: "cyl", params: &[0.05, 0.5], quadrant: "+y", method: "hybrid", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: false, p1: [-0.15, 0.06, -0.05], p2: [0.15, -0.02, 0.06], length: 0.335187477509274, moment_arms: [-0.8427855838710422, 0.42735248397179365, -0.3272343412025766], wrap_pts: &[[0.0032899902249853077, 0.04989164222912994, 0.003440449370680554], [0.02261260124763568, 0.04459450935726759, 0.010538390420999022]] },
    RefCase { name: "cyl_py", shape: "cyl", params: &[0.05, 0.5], quadrant: "+y", method: "hybrid", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: false, p1: [-0.15, 0.06, -0.05], p2: [0.12, -0.1, 0.0], length: 0.3589919978863261, moment_arms: [-0.5177561741212207, 0.8440436913215248, -0.13970966788197062], wrap_pts: &[[0.0032899902249853077, 0.04989164222912994, -0.04999999999999994], [0.04262018153063267, 0.026144217836759208, -0.020879922402608386]] },
    RefCase { name: "cyl_mx_far", shape: "cyl", params: &[0.05, 0.5], quadrant: "-x", method: "hybrid", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: false, p1: [0.12, -0.1, -0.05], p2: [0.1, 0.12, 0.06], length: 0.42285561686720596, moment_arms: [-0.8323428405599432, -0.5105785981419553, -0.21567311118449792], wrap_pts: &[[-0.01803001759620644, -0.04663602111544773, -0.01731405066152014], [-0.026144217836759208, 0.04262018153063267, 0.02731405066151993]] },
    RefCase { name: "cyl_mx_far", shape: "cyl", params: &[0.05, 0.5], quadrant: "-x", method: "hybrid", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: false, p1: [0.12, -0.1, -0.05], p2: [0.15, 0.03, 0.02], length: 0.4475736429405568, moment_arms: [-0.9890896314916546, 0.13493240608941104, -0.05911807390827905], wrap_pts: &[[-0.01803001759620644, -0.04663602111544773, -0.04068428110776168], [0.00675844083666605, 0.049541129150003076, 0.011438424980166673]] },
    RefCase { name: "cyl_rot", shape: "cyl", params: &[0.03, 0.2], quadrant: "all", method: "hybrid", rot: [0.3, -0.5, 1.1], trans: [0.01, -0.02, 0.03], multi: false, p1: [-0.1, 0.05, 0.0], p2: [0.1, 0.0, 0.05], length: 0.21213203435596428, moment_arms: [-0.9428090415820634, 0.23570226039551584, -0.23570226039551584], wrap_pts: &[] },
    RefCase { name: "cyl_rot", shape: "cyl", params: &[0.03, 0.2], quadrant: "all", method: "hybrid", rot: [0.3, -0.5, 1.1], trans: [0.01, -0.02, 0.03], multi: false, p1: [-0.1, 0.05, 0.0], p2: [0.08, -0.03, 0.1], length: 0.22090722034374521, moment_arms: [-0.8148217143826667, 0.3621429841700741, -0.4526787302125927], wrap_pts: &[] },
    RefCase { name: "sph_all", shape: "sph", params: &[0.05], quadrant: "all", method: "hybrid", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: false, p1: [-0.15, 0.02, -0.01], p2: [0.15, 0.03, 0.02], length: 0.30570148856769597, moment_arms: [-0.9895726295000454, 0.12758533745517692, -0.06684304459563556], wrap_pts: &[[-0.01083338619172644, 0.048048939488634757, 0.008598671853165813], [0.005576629429704105, 0.04862046697869428, 0.010244578809177902]] },
    RefCase { name: "sph_all", shape: "sph", params: &[0.05], quadrant: "all", method: "hybrid", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: false, p1: [-0.15, 0.02, -0.01], p2: [0.1, -0.06, 0.05], length: 0.2708500889276318, moment_arms: [-0.9663352643092741, 0.2137252155007191, -0.14323997071870923], wrap_pts: &[[-0.022978192664441566, -0.03187897330246747, 0.030914943361687902], [-0.01269308880959992, -0.03507557099399723, 0.033295492426403145]] },
    RefCase { name: "sph_pz", shape: "sph", params: &[0.05], quadrant: "+z", method: "hybrid", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: false, p1: [-0.15, 0.0, 0.02], p2: [0.15, 0.01, 0.01], length: 0.3082176316540318, moment_arms: [-0.9669999869222267, 0.040849017172968544, 0.25148038310853593], wrap_pts: &[[-0.010463808112787909, 0.015042088246350727, 0.04652143915409057], [0.012563479056353993, 0.01580573617388433, 0.045742077980805804]] },
    RefCase { name: "sph_pz", shape: "sph", params: &[0.05], quadrant: "+z", method: "hybrid", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: false, p1: [-0.15, 0.0, 0.02], p2: [0.15, 0.01, -0.03], length: 0.32579028923676173, moment_arms: [-0.8650678874847814, -0.29233281973095143, 0.4076752047289225], wrap_pts: &[[-0.011984753146369043, -0.03351638431604973, 0.035114351402232284], [0.024639753314278173, -0.03236305025997099, 0.02907774981806726]] },
    RefCase { name: "ell_sphere_mid", shape: "ell", params: &[0.05, 0.05, 0.05], quadrant: "all", method: "midpoint", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: false, p1: [-0.15, 0.02, -0.01], p2: [0.15, 0.03, 0.02], length: 0.30570117587282997, moment_arms: [-0.9895733412170602, 0.12758008970535953, -0.06684252436343241], wrap_pts: &[[-0.01083263790472856, 0.04804825368439494, 0.008598351168044301], [0.0055760672815084004, 0.04861976017782027, 0.010244623779450629]] },
    RefCase { name: "ell_sphere_mid", shape: "ell", params: &[0.05, 0.05, 0.05], quadrant: "all", method: "midpoint", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: false, p1: [-0.15, 0.02, -0.01], p2: [0.1, -0.06, 0.05], length: 0.2708498918665095, moment_arms: [-0.9663348909250967, 0.2137262381661915, -0.14324096376424536], wrap_pts: &[[-0.022977243626527116, -0.031878446326093, 0.03091460336616781], [-0.012693165081425421, -0.035075425231891375, 0.03329535885799056]] },
    RefCase { name: "ell_hybrid", shape: "ell", params: &[0.06, 0.03, 0.04], quadrant: "all", method: "hybrid", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: false, p1: [-0.15, 0.01, -0.01], p2: [0.15, 0.02, 0.015], length: 0.30273716608497764, moment_arms: [-0.9948222744376454, 0.06707840094985304, -0.07634874202448427], wrap_pts: &[[-0.01663133749989082, 0.028783457962500945, 0.0020511082591660257], [0.0072900490290271295, 0.029622578380822936, 0.004047566071870718]] },
    RefCase { name: "ell_hybrid", shape: "ell", params: &[0.06, 0.03, 0.04], quadrant: "all", method: "hybrid", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: false, p1: [-0.15, 0.01, -0.01], p2: [0.1, -0.05, 0.04], length: 0.2620714420907437, moment_arms: [-0.9637027404601775, 0.19941379915915688, -0.17751384378254925], wrap_pts: &[[-0.032312138178144455, -0.022431770618881793, 0.015537292571162507], [-0.026612165807202093, -0.023800828882849286, 0.016678065467223148]] },
    RefCase { name: "ell_hybrid", shape: "ell", params: &[0.06, 0.03, 0.04], quadrant: "all", method: "hybrid", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: false, p1: [-0.15, 0.01, -0.01], p2: [0.02, 0.12, 0.01], length: 0.20346989949375802, moment_arms: [-0.8355044182110838, -0.5406205059012895, -0.09829463743659811], wrap_pts: &[] },
    RefCase { name: "ell_axial", shape: "ell", params: &[0.06, 0.03, 0.04], quadrant: "all", method: "axial", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: false, p1: [-0.15, 0.01, -0.01], p2: [0.15, 0.02, 0.015], length: 0.30273716608497764, moment_arms: [-0.9948222744376454, 0.06707840094985304, -0.07634874202448427], wrap_pts: &[[-0.01663133749989082, 0.028783457962500945, 0.0020511082591660257], [0.0072900490290271295, 0.029622578380822936, 0.004047566071870718]] },
    RefCase { name: "ell_axial", shape: "ell", params: &[0.06, 0.03, 0.04], quadrant: "all", method: "axial", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: false, p1: [-0.15, 0.01, -0.01], p2: [0.1, -0.05, 0.04], length: 0.2620710877046586, moment_arms: [-0.9635851715874331, 0.19890432539470262, -0.17871957485428297], wrap_pts: &[[-0.0323057507555652, -0.022495989890177467, 0.015377964945612332], [-0.02660031013645645, -0.02386702283829498, 0.016518989424947943]] },
    RefCase { name: "ell_midpoint", shape: "ell", params: &[0.06, 0.03, 0.04], quadrant: "all", method: "midpoint", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: false, p1: [-0.15, 0.01, -0.01], p2: [0.15, 0.02, 0.015], length: 0.30273713939174407, moment_arms: [-0.9947959780615808, 0.06710155933884171, -0.0766703512891296], wrap_pts: &[[-0.016623842750940542, 0.028786305957914673, 0.002005375670559425], [0.007298535141447776, 0.02962558255473066, 0.004001793652706842]] },
    RefCase { name: "ell_midpoint", shape: "ell", params: &[0.06, 0.03, 0.04], quadrant: "all", method: "midpoint", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: false, p1: [-0.15, 0.01, -0.01], p2: [0.1, -0.05, 0.04], length: 0.2620710537198726, moment_arms: [-0.9635372621942362, 0.19871617657393603, -0.1791865662684349], wrap_pts: &[[-0.03230253409171971, -0.02252108242384178, 0.015314844489932374], [-0.026595535381011774, -0.023891429268696127, 0.016457351282731368]] },
    RefCase { name: "ell_py_hybrid", shape: "ell", params: &[0.06, 0.03, 0.04], quadrant: "+y", method: "hybrid", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: false, p1: [-0.15, -0.01, -0.01], p2: [0.15, -0.02, 0.015], length: 0.31541552355483315, moment_arms: [-0.9318905405826751, 0.35579939438461855, -0.07061735854638204], wrap_pts: &[[-0.030966948172112783, 0.02568908894180254, 0.0007790576212917564], [0.03527544595708646, 0.023802276202945016, 0.006306334151802177]] },
    RefCase { name: "ell_py_hybrid", shape: "ell", params: &[0.06, 0.03, 0.04], quadrant: "+y", method: "hybrid", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: false, p1: [-0.15, -0.01, -0.01], p2: [0.1, 0.05, 0.04], length: 0.2620714420907437, moment_arms: [-0.9637027404601775, -0.19941379915915688, -0.17751384378254925], wrap_pts: &[[-0.032312138178144455, 0.022431770618881793, 0.015537292571162507], [-0.026612165807202093, 0.023800828882849286, 0.016678065467223148]] },
    RefCase { name: "sph_mz_far", shape: "sph", params: &[0.05], quadrant: "-z", method: "hybrid", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: false, p1: [-0.15, 0.0, 0.03], p2: [0.15, 0.01, 0.02], length: 0.33800647526131855, moment_arms: [-0.8869096355486433, -0.12444912584237794, -0.444863702102161], wrap_pts: &[[-0.025105896321344773, -0.00944346550753186, -0.042196148273390355], [0.023013865389188815, -0.007818403152923281, -0.04369478884245416]] },
    RefCase { name: "sph_mz_far", shape: "sph", params: &[0.05], quadrant: "-z", method: "hybrid", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: false, p1: [-0.15, 0.0, 0.03], p2: [0.12, -0.02, 0.01], length: 0.3098818373878665, moment_arms: [-0.8341901286595446, 0.3492122182371401, -0.4268227452712291], wrap_pts: &[[-0.023972604023577343, 0.024308357405452168, -0.03652968678455322], [0.027108518596495934, 0.01888662687531138, -0.03752896940732851]] },
    RefCase { name: "ell_mz_axial", shape: "ell", params: &[0.06, 0.03, 0.04], quadrant: "-z", method: "axial", rot: [0.2, 0.1, -0.3], trans: [0.01, 0.0, 0.0], multi: false, p1: [-0.15, 0.01, 0.02], p2: [0.15, 0.02, 0.015], length: 0.31015177374779834, moment_arms: [-0.9756613525013729, 0.06912500907188128, -0.20810251886030573], wrap_pts: &[[-0.022838220630394618, 0.02925469224941954, -0.015262401846885166], [0.005129246146924677, 0.030264004153357116, -0.01590003381677855]] },
    RefCase { name: "ell_mz_axial", shape: "ell", params: &[0.06, 0.03, 0.04], quadrant: "-z", method: "axial", rot: [0.2, 0.1, -0.3], trans: [0.01, 0.0, 0.0], multi: false, p1: [-0.15, 0.01, 0.02], p2: [0.1, -0.05, 0.04], length: 0.25787593916455254, moment_arms: [-0.9694584179118516, 0.2326700202988444, -0.07755667343294813], wrap_pts: &[] },
    RefCase { name: "ell_px_midpoint", shape: "ell", params: &[0.03, 0.05, 0.04], quadrant: "+x", method: "midpoint", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: false, p1: [-0.02, -0.15, 0.01], p2: [-0.01, 0.15, 0.02], length: 0.31207814794805233, moment_arms: [0.247021641740622, -0.9690099511523562, -0.0001519193074507923], wrap_pts: &[[0.022631080213976747, -0.02310572165748108, 0.018649514452499086], [0.023921397400516926, 0.016934041056172106, 0.019979138203581933]] },
    RefCase { name: "ell_px_midpoint", shape: "ell", params: &[0.03, 0.05, 0.04], quadrant: "+x", method: "midpoint", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: false, p1: [-0.02, -0.15, 0.01], p2: [-0.03, 0.1, -0.03], length: 0.2781527445405122, moment_arms: [0.5702236081363556, -0.8121323452203186, 0.12363693044920232], wrap_pts: &[[0.02416238242316999, -0.026689088933524747, -0.01030638781812623], [0.018347556512665963, 0.03114172423581228, -0.01951719396276562]] },
    RefCase { name: "arm26_TRI", shape: "cyl", params: &[0.016, 0.05], quadrant: "all", method: "hybrid", rot: [-0.14015, -0.00628319, 0.154985], trans: [0.0028, -0.2919, -0.0069], multi: false, p1: [-0.02, -0.25, -0.01], p2: [-0.025, -0.33, -0.005], length: 0.08031189202104506, moment_arms: [0.062257280636469035, 0.9961164901835046, -0.06225728063646903], wrap_pts: &[] },
    RefCase { name: "arm26_TRI", shape: "cyl", params: &[0.016, 0.05], quadrant: "all", method: "hybrid", rot: [-0.14015, -0.00628319, 0.154985], trans: [0.0028, -0.2919, -0.0069], multi: false, p1: [-0.02, -0.25, -0.01], p2: [0.01, -0.32, 0.0], length: 0.08049460653740428, moment_arms: [-0.7277339531765836, 0.6785922672632687, -0.09957825166409806], wrap_pts: &[[-0.013023989890467758, -0.29396898069256694, -0.0037903328017890765], [-0.008191470519507216, -0.3030369447917048, -0.0024891992762250004]] },
    RefCase { name: "arm26_TRI", shape: "cyl", params: &[0.016, 0.05], quadrant: "all", method: "hybrid", rot: [-0.14015, -0.00628319, 0.154985], trans: [0.0028, -0.2919, -0.0069], multi: false, p1: [-0.02, -0.25, -0.01], p2: [-0.03, -0.31, -0.02], length: 0.06164414002968976, moment_arms: [0.16222142113076254, 0.9733285267845753, 0.16222142113076257], wrap_pts: &[] },
    RefCase { name: "arm26_TRI_multi", shape: "cyl", params: &[0.016, 0.05], quadrant: "all", method: "hybrid", rot: [-0.14015, -0.00628319, 0.154985], trans: [0.0028, -0.2919, -0.0069], multi: true, p1: [-0.02, -0.25, -0.01], p2: [-0.025, -0.33, -0.005], length: 0.08031189202104506, moment_arms: [0.062257280636469035, 0.9961164901835046, -0.06225728063646903], wrap_pts: &[] },
    RefCase { name: "arm26_TRI_multi", shape: "cyl", params: &[0.016, 0.05], quadrant: "all", method: "hybrid", rot: [-0.14015, -0.00628319, 0.154985], trans: [0.0028, -0.2919, -0.0069], multi: true, p1: [-0.02, -0.25, -0.01], p2: [0.01, -0.32, 0.0], length: 0.08049460653740428, moment_arms: [-0.7277339531765836, 0.6785922672632687, -0.09957825166409806], wrap_pts: &[[-0.013023989890467758, -0.29396898069256694, -0.0037903328017890765], [-0.008191470519507216, -0.3030369447917048, -0.0024891992762250004]] },
    RefCase { name: "arm26_TRI_multi", shape: "cyl", params: &[0.016, 0.05], quadrant: "all", method: "hybrid", rot: [-0.14015, -0.00628319, 0.154985], trans: [0.0028, -0.2919, -0.0069], multi: true, p1: [-0.02, -0.25, -0.01], p2: [-0.03, -0.31, -0.02], length: 0.06164414002968976, moment_arms: [0.16222142113076254, 0.9733285267845753, 0.16222142113076257], wrap_pts: &[] },
    RefCase { name: "arm26_TRIlongglen_multi", shape: "cyl", params: &[0.003, 0.03], quadrant: "x", method: "hybrid", rot: [1.37532, -0.294612, 2.43596], trans: [-0.043905, -0.0039, 0.1478], multi: true, p1: [-0.05, -0.01, 0.14], p2: [-0.04, 0.01, 0.16], length: 0.030011346859677476, moment_arms: [-0.3542916290522527, -0.6597412428492122, -0.6627359459598352], wrap_pts: &[[-0.04644204455126074, -0.002011192700806175, 0.14793528646153367], [-0.04635571810257078, -0.001835248186377164, 0.1481110291534998]] },
    RefCase { name: "arm26_TRIlongglen_multi", shape: "cyl", params: &[0.003, 0.03], quadrant: "x", method: "hybrid", rot: [1.37532, -0.294612, 2.43596], trans: [-0.043905, -0.0039, 0.1478], multi: true, p1: [-0.05, -0.01, 0.14], p2: [-0.035, -0.02, 0.15], length: 0.028356043797976842, moment_arms: [-0.8134986839813464, 0.5517685301821336, 0.18376991119676123], wrap_pts: &[[-0.04918763432181381, -0.010887013426595218, 0.14969274122336623], [-0.04585070641290323, -0.01264033434008266, 0.15245118202793193]] },
    RefCase { name: "arm26_TRIlongglen_multi", shape: "cyl", params: &[0.003, 0.03], quadrant: "x", method: "hybrid", rot: [1.37532, -0.294612, 2.43596], trans: [-0.043905, -0.0039, 0.1478], multi: true, p1: [-0.05, -0.01, 0.14], p2: [-0.05, 0.005, 0.155], length: 0.021213203435596416, moment_arms: [0.0, -0.7071067811865478, -0.7071067811865471], wrap_pts: &[] },
    RefCase { name: "arm26_TRIlonghh", shape: "ell", params: &[0.035, 0.02, 0.02], quadrant: "z", method: "hybrid", rot: [3.00162, -0.853466, 2.57419], trans: [-0.0078, -0.0041, -0.0014], multi: false, p1: [-0.05, 0.02, -0.01], p2: [-0.03, -0.06, 0.0], length: 0.08306623862918075, moment_arms: [-0.24077170617153845, 0.9630868246861536, -0.1203858530857692], wrap_pts: &[] },
    RefCase { name: "arm26_TRIlonghh", shape: "ell", params: &[0.035, 0.02, 0.02], quadrant: "z", method: "hybrid", rot: [3.00162, -0.853466, 2.57419], trans: [-0.0078, -0.0041, -0.0014], multi: false, p1: [-0.05, 0.02, -0.01], p2: [-0.02, -0.05, -0.02], length: 0.07681145747868609, moment_arms: [-0.3905667329424716, 0.911322376865767, 0.13018891098082386], wrap_pts: &[] },
    RefCase { name: "arm26_TRIlonghh", shape: "ell", params: &[0.035, 0.02, 0.02], quadrant: "z", method: "hybrid", rot: [3.00162, -0.853466, 2.57419], trans: [-0.0078, -0.0041, -0.0014], multi: false, p1: [-0.05, 0.02, -0.01], p2: [0.0, -0.06, 0.01], length: 0.09650074205355047, moment_arms: [-0.5439733737443158, 0.8093997320477663, -0.22128046099516105], wrap_pts: &[[-0.02760516499819087, -0.018841713024480435, -0.0012245962188853936], [-0.026889789205167006, -0.019989607528634074, -0.0009383753664730478]] },
    RefCase { name: "arm26_BIClonghh", shape: "ell", params: &[0.025, 0.02, 0.02], quadrant: "-y", method: "hybrid", rot: [-2.00434, -1.00164, 0.975465], trans: [0.0033, 0.0073, 0.0003], multi: false, p1: [-0.01, 0.04, 0.02], p2: [0.02, -0.04, 0.01], length: 0.08792363822528892, moment_arms: [-0.31579826653366977, 0.9027865461710939, 0.29197244203314227], wrap_pts: &[[0.00241193758061765, 0.009700511102886805, 0.024476612464895284], [0.00498575773308551, 0.0029218819606111404, 0.023881472587123465]] },
    RefCase { name: "arm26_BIClonghh", shape: "ell", params: &[0.025, 0.02, 0.02], quadrant: "-y", method: "hybrid", rot: [-2.00434, -1.00164, 0.975465], trans: [0.0033, 0.0073, 0.0003], multi: false, p1: [-0.01, 0.04, 0.02], p2: [0.03, -0.03, -0.01], length: 0.09007181145107103, moment_arms: [-0.22867315079109943, 0.8354248019812418, 0.49977393923840624], wrap_pts: &[[0.013709606260000753, 0.016750389214529034, 0.015975860482805027], [0.020071925947751992, 0.006270805166503292, 0.011698186520705077]] },
    RefCase { name: "arm26_BIClonghh", shape: "ell", params: &[0.025, 0.02, 0.02], quadrant: "-y", method: "hybrid", rot: [-2.00434, -1.00164, 0.975465], trans: [0.0033, 0.0073, 0.0003], multi: false, p1: [-0.01, 0.04, 0.02], p2: [0.0, -0.05, 0.02], length: 0.09076430544742575, moment_arms: [-0.12745228755331686, 0.99055210764312, 0.050620514035314944], wrap_pts: &[[-0.0072973045242314795, 0.007118214068208927, 0.022767787845970878], [-0.007060690745777581, 0.004875296739734676, 0.022804310553046256]] },
    RefCase { name: "torus_all", shape: "tor", params: &[0.02, 0.08], quadrant: "all", method: "hybrid", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: false, p1: [0.0, 0.0, 0.1], p2: [0.01, 0.0, -0.1], length: 0.2002498439450079, moment_arms: [-0.049937616943892225, 0.0, 0.9987523388778445], wrap_pts: &[] },
    RefCase { name: "torus_all", shape: "tor", params: &[0.02, 0.08], quadrant: "all", method: "hybrid", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: false, p1: [0.0, 0.0, 0.1], p2: [0.065, 0.0, -0.1], length: 0.2102974084481309, moment_arms: [-0.30908607233755814, 0.0, 0.9510340687309482], wrap_pts: &[] },
    RefCase { name: "torus_all", shape: "tor", params: &[0.02, 0.08], quadrant: "all", method: "hybrid", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: false, p1: [0.0, 0.0, 0.1], p2: [0.07, -0.01, -0.12], length: 0.23108440016582688, moment_arms: [-0.3029196256855408, 0.04327423224079154, 0.9520331092974139], wrap_pts: &[] },
    RefCase { name: "torus_through_tube", shape: "tor", params: &[0.02, 0.08], quadrant: "all", method: "hybrid", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: false, p1: [0.065, 0.0, 0.1], p2: [0.065, 0.01, -0.1], length: 0.2005198458135125, moment_arms: [-0.05193274474005561, -0.05387901598482819, 0.9971960898741385], wrap_pts: &[[0.05985038406093294, 0.0045532092783044376, 0.0009649684249879127], [0.05985044637412002, 0.004657457765571966, -0.0011199048687290593]] },
    RefCase { name: "torus_through_tube", shape: "tor", params: &[0.02, 0.08], quadrant: "all", method: "hybrid", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: false, p1: [0.065, 0.0, 0.1], p2: [0.07, -0.01, -0.12], length: 0.22079062404065916, moment_arms: [-0.08469333877625906, 0.049623725104136644, 0.9951706005875167], wrap_pts: &[[0.059891713259412525, -0.003980976341780371, 0.0009726384425485912], [0.05993725876761716, -0.004104014413353085, -0.0017599544370030418]] },
    RefCase { name: "torus_through_tube", shape: "tor", params: &[0.02, 0.08], quadrant: "all", method: "hybrid", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: false, p1: [0.065, 0.0, 0.1], p2: [0.05, 0.0, -0.1], length: 0.20056171120131583, moment_arms: [0.07478994824163421, 0.0, 0.9971993098884563], wrap_pts: &[] },
    RefCase { name: "torus_multi", shape: "tor", params: &[0.02, 0.08], quadrant: "all", method: "hybrid", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: true, p1: [0.065, 0.0, 0.1], p2: [0.065, 0.01, -0.1], length: 0.2005198458135125, moment_arms: [-0.05193274474005561, -0.05387901598482819, 0.9971960898741385], wrap_pts: &[[0.05985038406093294, 0.0045532092783044376, 0.0009649684249879127], [0.05985044637412002, 0.004657457765571966, -0.0011199048687290593]] },
    RefCase { name: "torus_multi", shape: "tor", params: &[0.02, 0.08], quadrant: "all", method: "hybrid", rot: [0.0, 0.0, 0.0], trans: [0.0, 0.0, 0.0], multi: true, p1: [0.065, 0.0, 0.1], p2: [0.07, -0.01, -0.12], length: 0.22079062404065916, moment_arms: [-0.08469333877625906, 0.049623725104136644, 0.9951706005875167], wrap_pts: &[[0.059891713259412525, -0.003980976341780371, 0.0009726384425485912], [0.05993725876761716, -0.004104014413353085, -0.0017599544370030418]] },
];

#[test]
fn matches_opensim_4_6_reference() {
    let mut worst_len: f64 = 0.0;
    let mut worst_ma: f64 = 0.0;
    for c in REFERENCE {
        let shape = match c.shape {
            "cyl" => WrapShape::Cylinder {
                radius: c.params[0],
                length: c.params[1],
            },
            "sph" => WrapShape::Sphere {
                radius: c.params[0],
            },
            "ell" => WrapShape::Ellipsoid {
                dimensions: V::new(c.params[0], c.params[1], c.params[2]),
            },
            _ => WrapShape::Torus {
                inner_radius: c.params[0],
                outer_radius: c.params[1],
            },
        };
        let o = WrapObject {
            name: c.name.into(),
            shape,
            active: true,
            rotation: body_fixed_xyz(&V::from(c.rot)),
            translation: V::from(c.trans),
            quadrant: Quadrant::parse(c.quadrant).unwrap(),
        };
        let method = match c.method {
            "hybrid" => WrapMethod::Hybrid,
            "midpoint" => WrapMethod::Midpoint,
            _ => WrapMethod::Axial,
        };
        let (g1, g2) = (V::from(c.p1), V::from(c.p2));
        let (p1, p2) = (o.body_to_wrap(&g1), o.body_to_wrap(&g2));
        let res = wrap_line(&o, method, p1, p2, !c.multi);
        let len = res.total_length(&p1, &p2);
        let tag = format!("{} P2={:?}", c.name, c.p2);
        assert_eq!(res.wraps(), !c.wrap_pts.is_empty(), "{tag}: wraps? {res:?}");
        assert!(
            (len - c.length).abs() < 1e-9,
            "{tag}: length {len} vs OpenSim {}",
            c.length
        );
        worst_len = worst_len.max((len - c.length).abs());
        if res.wraps() {
            let r1 = o.wrap_to_body(&res.r1);
            let r2 = o.wrap_to_body(&res.r2);
            assert!(
                (r1 - V::from(c.wrap_pts[0])).norm() < 1e-9,
                "{tag}: r1 {r1:?}"
            );
            assert!(
                (r2 - V::from(c.wrap_pts[1])).norm() < 1e-9,
                "{tag}: r2 {r2:?}"
            );
        }
        // Moment arm about translation q_k of P2 = −dL/dq_k = −(R·∇₂L)_k.
        let (_, grad2) = endpoint_gradients(&res, p1, p2);
        let grad_ground = o.rotation * grad2;
        for k in 0..3 {
            let ma = -grad_ground[k];
            assert!(
                (ma - c.moment_arms[k]).abs() < 1e-9,
                "{tag}: moment arm {k}: {ma} vs OpenSim {}",
                c.moment_arms[k]
            );
            worst_ma = worst_ma.max((ma - c.moment_arms[k]).abs());
        }
    }
    eprintln!("worst length diff {worst_len:e} m, worst moment-arm diff {worst_ma:e}");
}
