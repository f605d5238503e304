//! OpenSim's JointReaction analysis (opensim-semantics.md §7;
//! `OpenSim/Analyses/JointReaction.cpp`, Simbody's
//! `calcMobilizerReactionForces`).
//!
//! Per frame:
//! 1. every actuator gets its force from `forces_file` (linear interpolation
//!    in time, §7.2): a muscle's tension is applied along its path as point
//!    forces on the bodies, a CoordinateActuator as a generalized force,
//!    Point/TorqueActuators as body forces; external loads and passive forces
//!    are evaluated at the state;
//! 2. accelerations come from **forward dynamics** with those forces and the
//!    model's constraints (locked/prescribed coordinates, couplers): the
//!    reduced system `Cᵀ M C y = −Cᵀ τ(d)`, u̇ = d + C y, C the coupling
//!    vectors of the independent coordinates, d the constrained accelerations
//!    at y = 0;
//! 3. the reaction of each joint is Simbody's "free-body" reaction: what the
//!    child's subtree needs (Σ M a + gyroscopic − applied *body* forces),
//!    i.e. the RNEA's transmitted spatial force, referred to the child joint
//!    frame origin M_o. Applied *mobility* forces (CoordinateActuators,
//!    limit forces, moving-path-point terms, constraint mobility forces) are
//!    therefore included in the reaction, as Simbody documents. The parent
//!    case is −F shifted to the parent joint frame origin F_o.
//!
//! Output: `<name>_<analysis>_ReactionLoads.sto`, storage `Joint Reaction
//! Loads`, nine columns per joint `<joint>_on_<body>_in_<frame>_{fx,fy,fz,
//! mx,my,mz,px,py,pz}` (§1.5): force and moment (about M_o or F_o) and the
//! point's location, all in the frame E.
//!
//! Differences from OpenSim, by design: a `forces_file` missing any actuator
//! (or no `forces_file` at all while the model has actuators) is an error
//! naming the actuators, where OpenSim silently computes meaningless forces
//! from default muscle states; actuators are read by column name, where
//! OpenSim reads only the first n_act columns (a warning says when that
//! would differ); actuators with `appliesForce=false` need no column.
//!
//! This module is the analysis's driver ([`run`]): it streams the states and
//! writes the table. Its parts are the `reactions` stage: the setup element
//! ([`crate::reactions::setup`]), the forces file
//! ([`crate::reactions::forces_file`]), the run compiled once and a frame
//! ([`crate::reactions::problem`]), a frame's reactions
//! ([`crate::reactions::joint`]).

use crate::error::Result;
use crate::frame::driver::{for_each_frame, is_frame};
use crate::frame::workspace::Workspace;
use crate::parse::setup::AnalyzeSetup;
use crate::storage::StoWriter;
use crate::storage::TableFile;
use crate::tools::inputs::{open_motion_stream, results_dir};
use crate::tools::{RunOptions, RunSummary};
use crate::writers::names::{OutputKind, RunKey, Sweep};

// The JointReaction analysis's parts are the `reactions` stage (the table's
// description, `writers::tables`); these paths stay for users.
pub use crate::reactions::forces_file::{values_at_time, values_at_time_in, ForcesFile};
pub use crate::reactions::joint::{
    apply_forces, column_labels, forward_dynamics, reactions, reactions_at_accelerations,
    static_optimization_reactions, ReactionSpec,
};
pub use crate::reactions::problem::{JointReactionProblem, WithForces};
pub use crate::reactions::setup::{resolve_reactions, JointReactionSetup};
pub use crate::writers::tables::JOINT_REACTION_DESCRIPTION as DESCRIPTION;

pub fn run(
    setup: &AnalyzeSetup,
    jr: &JointReactionSetup,
    motion: &TableFile,
    model: Option<&crate::forces::analysis_model::AnalysisModel>,
    opts: &RunOptions,
) -> Result<RunSummary> {
    let (problem, mut warnings) = match model {
        Some(am) => JointReactionProblem::build_from(setup, jr, am.clone())?,
        None => JointReactionProblem::build(setup, jr)?,
    };
    // States streamed block by block (motion::stream): flat memory.
    let mut stream = open_motion_stream(setup, motion, &problem.model, &[])?;
    warnings.extend(stream.motion_warnings(&[]));
    warnings.extend(crate::tools::inputs::missing_columns_warning(
        setup,
        &stream.missing,
    ));
    let (i0, i1, step) = (stream.first_row, stream.last_row, jr.common.step_interval);
    let nframes = if i1 < i0 {
        0
    } else {
        (i0..=i1).filter(|&i| is_frame(i, i0, i1, step)).count()
    };
    let dir = results_dir(setup, opts)?;
    let path = dir.join(
        RunKey::analysis(&setup.name, &jr.common.name, Sweep::Single)
            .file(OutputKind::ReactionLoads),
    );
    let precision = opts.precision.unwrap_or(setup.output_precision);
    let mut w = StoWriter::create_for_setup(
        &setup.setup_file,
        &path,
        "Joint Reaction Loads",
        DESCRIPTION,
        &column_labels(&problem.specs),
        precision,
        false,
    )?;
    let mut progress = crate::tools::progress::bar(
        nframes as u64,
        opts,
        &format!("{}_{}", setup.name, jr.common.name),
    );
    let start = std::time::Instant::now();
    let mut last = None;
    let completed = for_each_frame(
        &mut crate::frame::driver::PreparingLoads::new(
            WithForces {
                inner: &mut stream,
                forces: &problem.forces,
            },
            problem.loads.as_ref(),
        ),
        i0,
        i1,
        step,
        || Workspace::new(&problem.model, &problem.muscles),
        |ws, block, i| {
            Ok((
                block.time[i],
                problem.frame(block.time[i], &block.q[i], &block.u[i], ws)?,
            ))
        },
        |(t, row)| {
            w.write_row(t, &row)?;
            last = Some(t);
            progress.inc(1);
            Ok(())
        },
    )?;
    progress.finish_and_clear();
    w.finish()?;
    Ok(RunSummary {
        stopped: (!completed).then(|| (crate::tools::interrupt::requested().unwrap_or(130), last)),
        frames: nframes,
        results_dirs: path.parent().map(|d| d.to_path_buf()).into_iter().collect(),
        files: vec![path],
        warnings,
        loop_seconds: start.elapsed().as_secs_f64(),
        ..Default::default()
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dynamics::{kinematics, rnea, BodyForce, Data};
    use crate::forces::actuators::{Actuator, ActuatorKind};
    use crate::model::{compile, Model};
    use crate::parse::osim::ModelSpec;
    use crate::paths::coupling;
    use nalgebra::Vector3;
    use std::path::Path;

    const G: f64 = 9.80665;
    const M: f64 = 2.5;
    /// Height of the pin above the ground origin (parent offset), m.
    const H: f64 = 1.3;
    /// Mass centre of the link in its body frame.
    const C: [f64; 3] = [0.4, -0.2, 0.0];
    const I: f64 = 0.08;

    fn model_from(text: &str) -> Model {
        let root = crate::xml::parse_str(text, Path::new("test.osim")).unwrap();
        compile(&ModelSpec::from_document(&root, Path::new("test.osim")).unwrap()).unwrap()
    }

    /// A link on a pin about z at (0, H, 0); gravity `gravity`; optional
    /// extra XML inside the Model (constraints) and coordinate properties.
    fn pendulum(gravity: &str, two_links: bool, coord2: &str, extra: &str) -> Model {
        let link = |name: &str| {
            format!(
                r#"<Body name="{name}"><mass>{M}</mass><mass_center>{} {} {}</mass_center><inertia>{I} {I} {I} 0 0 0</inertia></Body>"#,
                C[0], C[1], C[2]
            )
        };
        let pin = |name: &str, parent: &str, child: &str, loc: [f64; 3], coord: &str| {
            format!(
                r#"<PinJoint name="{name}">
  <socket_parent_frame>{parent}_offset</socket_parent_frame>
  <socket_child_frame>{child}_offset</socket_child_frame>
  <coordinates><Coordinate name="{coord}">{}</Coordinate></coordinates>
  <frames>
    <PhysicalOffsetFrame name="{parent}_offset"><socket_parent>{ppath}</socket_parent><translation>{} {} {}</translation><orientation>0 0 0</orientation></PhysicalOffsetFrame>
    <PhysicalOffsetFrame name="{child}_offset"><socket_parent>/bodyset/{child}</socket_parent><translation>0 0 0</translation><orientation>0 0 0</orientation></PhysicalOffsetFrame>
  </frames>
</PinJoint>"#,
                if coord == "q2" { coord2 } else { "" },
                loc[0],
                loc[1],
                loc[2],
                ppath = if parent == "ground" {
                    "/ground".to_string()
                } else {
                    format!("/bodyset/{parent}")
                }
            )
        };
        let (bodies, joints) = if two_links {
            (
                link("link") + &link("link2"),
                pin("pin", "ground", "link", [0.0, H, 0.0], "q")
                    + &pin("pin2", "link", "link2", [0.8, -0.1, 0.0], "q2"),
            )
        } else {
            (
                link("link"),
                pin("pin", "ground", "link", [0.0, H, 0.0], "q"),
            )
        };
        model_from(&format!(
            r#"<?xml version="1.0"?>
<OpenSimDocument Version="40000"><Model name="p">
<gravity>{gravity}</gravity>
<BodySet name="bodyset"><objects>{bodies}</objects></BodySet>
<JointSet name="jointset"><objects>{joints}</objects></JointSet>
{extra}
</Model></OpenSimDocument>"#
        ))
    }

    fn spec(model: &Model, on_child: bool, frame: &str) -> ReactionSpec {
        let jr = JointReactionSetup::from_text(
            &format!(
                "<JointReaction name=\"JR\"><joint_names>pin</joint_names><apply_on_bodies>{}</apply_on_bodies><express_in_frame>{frame}</express_in_frame></JointReaction>",
                if on_child { "child" } else { "parent" }
            ),
            Path::new("setup.xml"),
            Path::new("."),
        )
        .unwrap();
        let (mut specs, w) = resolve_reactions(model, &jr).unwrap();
        assert!(w.is_empty());
        specs.remove(0)
    }

    fn run_frame(
        model: &Model,
        q: f64,
        u: f64,
        tau: f64,
        specs: &[ReactionSpec],
    ) -> (Data, Vec<f64>) {
        let mut data = Data::new(model);
        data.q[0] = q;
        data.u[0] = u;
        kinematics::full(model, &mut data);
        data.clear_applied();
        data.applied_gen[0] = tau;
        let mut out = vec![0.0; 9 * specs.len()];
        reactions(model, &mut data, 0.0, specs, &mut out).unwrap();
        (data, out)
    }

    fn assert_close(got: &[f64], want: &[f64], tol: f64, what: &str) {
        for (k, (g, w)) in got.iter().zip(want).enumerate() {
            assert!((g - w).abs() <= tol, "{what}[{k}]: got {g}, want {w}");
        }
    }

    #[test]
    fn hanging_pendulum_at_rest_carries_its_weight() {
        // Mass centre straight below the pin: q such that C rotated is −y.
        let model = pendulum(&format!("0 -{G} 0"), false, "", "");
        let q0 = -(C[0].atan2(-C[1])); // rotate C = (0.4, −0.2) onto −y
        let specs = [
            spec(&model, true, "ground"),
            spec(&model, false, "ground"),
            spec(&model, true, "child"),
        ];
        let (data, out) = run_frame(&model, q0, 0.0, 0.0, &specs);
        assert!(
            data.udot[0].abs() < 1e-12,
            "at rest: udot = {}",
            data.udot[0]
        );
        let w = M * G;
        // On the link at the pin: the weight held up, no moment; point M_o = (0, H, 0).
        assert_close(
            &out[0..9],
            &[0.0, w, 0.0, 0.0, 0.0, 0.0, 0.0, H, 0.0],
            1e-9,
            "child",
        );
        // On ground at F_o (the same point): the weight pulling down.
        assert_close(
            &out[9..18],
            &[0.0, -w, 0.0, 0.0, 0.0, 0.0, 0.0, H, 0.0],
            1e-9,
            "parent",
        );
        // In the link's frame (rotated by q0), at its origin, which is M_o.
        let (s, c) = q0.sin_cos();
        let f_link = [s * w, c * w, 0.0]; // R(q0)ᵀ (0, w, 0)
        assert_close(
            &out[18..27],
            &[f_link[0], f_link[1], 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            1e-9,
            "in child",
        );
        assert_eq!(
            column_labels(&specs[..1])[0],
            "pin_on_link_in_ground_fx".to_string()
        );
        assert_eq!(specs[1].label_root, "pin_on_ground_in_ground");
        assert_eq!(specs[2].label_root, "pin_on_link_in_link");
    }

    #[test]
    fn spinning_pendulum_needs_the_centripetal_force_and_includes_mobility_torques() {
        // Gravity along the pin axis: no gravity torque, so with no applied
        // torque the link spins at constant ω and the pin supplies
        // m·a_c − m·g with a_c = −ω² c (c: mass centre relative to the pin),
        // and the moment about the pin that balances gravity's: m G (c × ẑ).
        let model = pendulum(&format!("0 0 -{G}"), false, "", "");
        let specs = [spec(&model, true, "ground"), spec(&model, false, "ground")];
        let (q, w) = (0.7, 3.0);
        for tau in [0.0, 1.7] {
            let (data, out) = run_frame(&model, q, w, tau, &specs);
            let (s, co) = q.sin_cos();
            let c = Vector3::new(co * C[0] - s * C[1], s * C[0] + co * C[1], 0.0);
            let i_zz = I + M * (C[0] * C[0] + C[1] * C[1]);
            let alpha = tau / i_zz;
            assert!(
                (data.udot[0] - alpha).abs() < 1e-12,
                "udot {} vs {alpha}",
                data.udot[0]
            );
            let a_c = -w * w * c + Vector3::z().cross(&c) * alpha;
            let f = M * a_c + Vector3::new(0.0, 0.0, M * G);
            // Moment about the pin: balances gravity's, plus the applied
            // torque delivered across the mobilizer (Simbody includes
            // mobility forces in the reaction).
            let m = M * G * c.cross(&Vector3::z()) + Vector3::new(0.0, 0.0, tau);
            let want = [f[0], f[1], f[2], m[0], m[1], m[2], 0.0, H, 0.0];
            assert_close(&out[0..9], &want, 1e-9, &format!("child, tau {tau}"));
            let want_p = [-f[0], -f[1], -f[2], -m[0], -m[1], -m[2], 0.0, H, 0.0];
            assert_close(&out[9..18], &want_p, 1e-9, &format!("parent, tau {tau}"));
        }
    }

    /// Reduced equations of motion `Cᵀ τ = 0` at the forward-dynamics accelerations.
    fn reduced_residual(model: &Model, data: &mut Data) -> f64 {
        kinematics::full(model, data);
        rnea::inverse_dynamics_after_kinematics(model, data, true);
        (0..model.nq())
            .filter(|&k| !model.coordinates[k].is_constrained())
            .map(|k| coupling::project(model, &data.q, k, &data.tau).abs())
            .fold(0.0, f64::max)
    }

    #[test]
    fn forward_dynamics_honours_locks_and_couplers() {
        // Locked second joint: it stays still, the first obeys the reduced EOM.
        let locked = pendulum(&format!("0 -{G} 0"), true, "<locked>true</locked>", "");
        let mut data = Data::new(&locked);
        data.q.copy_from_slice(&[0.4, 0.0]);
        data.u.copy_from_slice(&[1.2, 0.0]);
        kinematics::full(&locked, &mut data);
        data.clear_applied();
        forward_dynamics(&locked, &mut data, 0.0).unwrap();
        assert_eq!(data.udot[1], 0.0);
        assert!(data.udot[0].abs() > 1.0);
        assert!(reduced_residual(&locked, &mut data) < 1e-10);
        // A locked link moves as one rigid body: same as a single body whose
        // mass properties are the union (checked through energy balance is
        // overkill; the reduced EOM residual above already pins u̇₁).

        // Coupler q2 = 0.5 q1²: u̇2 = q1 u̇1 + u1² (s = 0.5, f = q²).
        let coupler = r#"<ConstraintSet name="constraintset"><objects>
<CoordinateCouplerConstraint name="c"><independent_coordinate_names>q</independent_coordinate_names>
<dependent_coordinate_name>q2</dependent_coordinate_name>
<coupled_coordinates_function><PolynomialFunction name="f"><coefficients>1 0 0</coefficients></PolynomialFunction></coupled_coordinates_function>
<scale_factor>0.5</scale_factor></CoordinateCouplerConstraint></objects></ConstraintSet>"#;
        let coupled = pendulum(&format!("0 -{G} 0"), true, "", coupler);
        assert_eq!(coupled.couplers.len(), 1);
        let mut data = Data::new(&coupled);
        let (q1, u1) = (0.6, -0.9);
        data.q.copy_from_slice(&[q1, 0.5 * q1 * q1]);
        data.u.copy_from_slice(&[u1, q1 * u1]);
        kinematics::full(&coupled, &mut data);
        data.clear_applied();
        data.applied_gen[0] = 2.0;
        forward_dynamics(&coupled, &mut data, 0.0).unwrap();
        let want = q1 * data.udot[0] + u1 * u1;
        assert!(
            (data.udot[1] - want).abs() < 1e-12,
            "{} vs {want}",
            data.udot[1]
        );
        assert!(reduced_residual(&coupled, &mut data) < 1e-10);
    }

    #[test]
    fn body_level_actuators_match_their_generalized_forces() {
        let model = pendulum(&format!("0 -{G} 0"), true, "", "");
        let mut data = Data::new(&model);
        data.q.copy_from_slice(&[0.3, -0.8]);
        kinematics::positions(&model, &mut data);
        let acts = [
            ActuatorKind::Point {
                body: 2,
                point: Vector3::new(0.1, 0.2, 0.3),
                point_is_global: false,
                direction: Vector3::new(0.0, 0.6, 0.8),
                force_is_global: false,
            },
            ActuatorKind::Torque {
                body_a: 2,
                body_b: 1,
                axis: Vector3::new(0.0, 0.0, 1.0),
                torque_is_global: true,
            },
            ActuatorKind::Coordinate { coordinate: 1 },
        ];
        for kind in acts {
            let a = Actuator {
                name: "a".into(),
                type_name: "X".into(),
                kind,
                optimal_force: 1.0,
                min_control: -1.0,
                max_control: 1.0,
                applies_force: true,
            };
            let mut want = vec![0.0; 2];
            a.add_unit_generalized_force(&model, &data, &mut want);
            let mut applied = vec![BodyForce::default(); model.nbodies()];
            let mut gen = vec![0.0; 2];
            a.apply(&data, 3.0, &mut applied, &mut gen);
            for (b, bf) in applied.iter().enumerate().skip(1) {
                let x = Vector3::zeros();
                // A spatial force (F, moment about the origin) = F at the
                // origin plus a torque.
                crate::dynamics::jacobian::add_point_force(
                    &model, &data, b, &x, &bf.force, &mut gen,
                );
                crate::dynamics::jacobian::add_body_torque(&model, &data, b, &bf.moment, &mut gen);
            }
            for k in 0..2 {
                assert!(
                    (gen[k] - 3.0 * want[k]).abs() < 1e-12,
                    "{:?}: {gen:?} vs 3×{want:?}",
                    a.kind
                );
            }
        }
    }

    #[test]
    fn reaction_list_follows_opensim_rules() {
        let model = pendulum(&format!("0 -{G} 0"), true, "", "");
        let parse = |body: &str| {
            let jr = JointReactionSetup::from_text(
                &format!("<JointReaction name=\"JR\">{body}</JointReaction>"),
                Path::new("setup.xml"),
                Path::new("."),
            )
            .unwrap();
            resolve_reactions(&model, &jr)
        };
        // Defaults: all joints, on child, in ground.
        let (s, _) = parse("").unwrap();
        let roots: Vec<&str> = s.iter().map(|s| s.label_root.as_str()).collect();
        assert_eq!(roots, ["pin_on_link_in_ground", "pin2_on_link2_in_ground"]);
        // Order of joint_names, per-joint lists, keywords case-insensitive,
        // frames by body name and by joint-relative path, unknown joints skipped.
        let (s, w) = parse(
            "<joint_names>pin2 nope pin</joint_names><apply_on_bodies>PARENT child child</apply_on_bodies><express_in_frame>Child link pin2/link2_offset</express_in_frame>",
        )
        .unwrap();
        let roots: Vec<&str> = s.iter().map(|s| s.label_root.as_str()).collect();
        assert_eq!(
            roots,
            ["pin2_on_link_in_link2", "pin_on_link_in_link2_offset"]
        );
        assert_eq!(w.len(), 1);
        assert!(parse("<apply_on_bodies>child parent child</apply_on_bodies>").is_err());
        assert!(parse("<apply_on_bodies>middle</apply_on_bodies>").is_err());
        assert!(parse("<express_in_frame>nowhere</express_in_frame>").is_err());
    }
}
