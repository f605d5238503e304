//! statopt's knee contact method (docs/knee_contact.md): the tibiofemoral
//! contact of a knee as two unknown contact forces of the same optimisation,
//! one per compartment, as the seed paper treats a contact (Krüger &
//! Wartzack 2017: a multiplier of the objective's `(1/w0) l'l` term).
//!
//! The knee's reaction on the tibia R(x) is affine in the problem's
//! variables x wherever the equations of motion hold (the accelerations are
//! then the targets, and the RNEA reaction at fixed accelerations is linear
//! in the applied forces): R(x) = R0 + Σ_v G_v x_v, with R0 from inertia,
//! gravity, external loads and passive forces, and G_v = −(the spatial force
//! variable v applies to the bodies distal to the knee per unit). Two rows per
//! knee tie the compartments' compressive forces to it, in the tibia's body
//! frame at the joint centre M_o:
//!
//! - axial: `l_med + l_lat = −F_y(x)` (compression along the tibial long axis),
//! - frontal: `z_med l_med + z_lat l_lat = M_x(x)` (the adduction moment,
//!   balanced by the two compartments' loads at ±[`CONDYLE_SPACING`]/2 from
//!   the joint centre, Lerner et al. 2015),
//!
//! with `l ≥ 0` (cartilage only pushes). Each `l` is a compartment's load in
//! units of its capacity C (newtons: [`Knee::capacity`]) and costs `l²` in
//! the objective, as a muscle's activation does: a muscle costs
//! `(F/F_max)²`, a compartment `(L/C)²`. C is the largest load a
//! compartment habitually carries, as F_max is the largest force a muscle
//! produces: the knee's habitual peak (twice the StaticOptimization's
//! `<knee_contact_capacity>` in body weights, default
//! 2 × [`DEFAULT_KNEE_CAPACITY_BW`] = 3.46 BW) times the compartment's
//! habitual share of it (`<knee_contact_medial_share>` medially, default
//! [`DEFAULT_KNEE_MEDIAL_SHARE`], the rest laterally: instrumented knees carry
//! most of the load medially in walking). C does not depend on the run's contact weight w0, which
//! weighs the contacts with the environment (docs/knee_contact.md). Shear
//! and the other moments stay with the joint (ligaments,
//! menisci), as in OpenSim's reaction. The reaction the JointReaction
//! reports afterwards is the same R(x) (tested), so the method changes the
//! muscle forces, never how the reaction is computed.

use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

use crate::contacts::Regime;
use crate::dynamics::{BodyForce, Data};
use crate::error::{Error, Result};
use crate::frame::problem::{Control, SoProblem};
use crate::model::Model;
use crate::muscles::set::MuscleFrame;
use crate::paths::geometry;

/// Distance between the medial and lateral compartments' load centres (m),
/// each compartment loaded at its plateau's centre: the proximal tibia is
/// 73.5 ± 5.6 mm wide (Kwak et al. 2007, CT of 100 cadavers), its medial and
/// lateral plateaus 33 ± 2 and 34.8 ± 2.4 mm (CT of 26 male knees, J Bone Joint
/// Surg Br 92-B Supp IV, 2010), so the
/// centres lie 73.5 − (33 + 34.8)/2 ≈ 40 mm apart.
pub const CONDYLE_SPACING: f64 = 0.040;

pub use crate::parse::analyses::{DEFAULT_KNEE_CAPACITY_BW, DEFAULT_KNEE_MEDIAL_SHARE};

/// Which knees a StaticOptimization solves with the knee contact method
/// (read with the setup, `parse::analyses`).
pub use crate::parse::analyses::KneeSelection;

/// One knee of the method.
#[derive(Debug, Clone)]
pub struct Knee {
    /// The knee joint's name.
    pub name: String,
    /// The tibia (the joint's child body; `model.joints[tibia]` is the knee).
    pub tibia: usize,
    pub femur: usize,
    /// Bodies distal to the knee (the tibia's subtree), per body index.
    pub distal: Vec<bool>,
    /// z of the medial and lateral load centres in the tibia frame, relative
    /// to the joint centre (OpenSim's z points to the subject's right on
    /// both sides: medial is −z on the right knee, +z on the left).
    pub z: [f64; 2],
    /// Whether the frontal-plane row holds (the method). Without it (an
    /// ingredient study, docs/knee_contact.md) the knee has one axial contact
    /// at its centre: the lateral multiplier is held at zero.
    pub frontal: bool,
    /// Newtons per unit multiplier, per compartment (medial, lateral): its
    /// load capacity, the knee's capacity (twice the setup's capacity in
    /// body weights × the model's weight) times the compartment's share
    /// (`<knee_contact_medial_share>` medially, the rest laterally). The one
    /// axial contact, carrying the whole knee, has the knee's capacity in
    /// both entries (the lateral multiplier is held at zero).
    pub capacity: [f64; 2],
}

/// The knees `sel` names, or an error naming what is wrong. `frontal`: two
/// compartments (the method) or one axial contact per knee; `capacity_bw`:
/// a compartment's capacity in body weights at an even split, so the
/// knee's is twice that; `medial_share`: the medial compartment's share of
/// the knee's capacity (the axial contact carries the whole knee's).
pub fn select(
    model: &Model,
    sel: &KneeSelection,
    frontal: bool,
    capacity_bw: f64,
    medial_share: f64,
) -> Result<Vec<Knee>> {
    let bw = model.total_mass() * model.gravity.norm();
    let knee_capacity = 2.0 * capacity_bw * bw;
    let capacity = if frontal {
        [
            medial_share * knee_capacity,
            (1.0 - medial_share) * knee_capacity,
        ]
    } else {
        [knee_capacity; 2]
    };
    let tibias: Vec<usize> = match sel {
        KneeSelection::Off => return Ok(Vec::new()),
        KneeSelection::All => {
            let v: Vec<usize> = (1..model.nbodies())
                .filter(|&b| model.bodies[b].name.starts_with("tibia"))
                .collect();
            if v.is_empty() {
                return Err(Error::msg(
                    "knee_contact: the model has no knee (no body named tibia_*): name the knee joints instead",
                ));
            }
            v
        }
        KneeSelection::Joints(names) => names
            .iter()
            .map(|n| {
                (1..model.nbodies())
                    .find(|&b| model.joints[b].name == *n)
                    .ok_or_else(|| {
                        Error::msg(format!("knee_contact: the model has no joint '{n}'"))
                    })
            })
            .collect::<Result<_>>()?,
    };
    tibias
        .into_iter()
        .map(|tibia| {
            let name = model.joints[tibia].name.clone();
            let body = &model.bodies[tibia].name;
            let side = if body.ends_with("_l") || name.ends_with("_l") {
                1.0
            } else if body.ends_with("_r") || name.ends_with("_r") {
                -1.0
            } else {
                return Err(Error::msg(format!(
                    "knee_contact: cannot tell the side of knee '{name}' (child body '{body}'): the method needs the side (a name ending in _l or _r) to place the medial compartment"
                )));
            };
            let femur = model.joints[tibia].parent_body;
            if femur == 0 {
                return Err(Error::msg(format!(
                    "knee_contact: joint '{name}' joins {body} to ground, not to a femur"
                )));
            }
            let mut distal = vec![false; model.nbodies()];
            distal[tibia] = true;
            for b in tibia + 1..model.nbodies() {
                distal[b] = distal[model.joints[b].parent_body];
            }
            let h = 0.5 * CONDYLE_SPACING;
            Ok(Knee {
                name,
                tibia,
                femur,
                distal,
                z: [side * h, -side * h],
                frontal,
                capacity,
            })
        })
        .collect()
}

pub use crate::parse::analyses::EqualActivation;

/// The gastrocnemius heads' names (medial, lateral) in the models statopt
/// meets: Rajagopal et al. 2016 and gait2392/gait10dof18musc.
const GASTROCNEMIUS_HEADS: [(&str, &str); 2] = [("gasmed", "gaslat"), ("med_gas", "lat_gas")];

/// Pairs of controls (indices into `labels`, the controls' names) held at
/// one activation under the knee contact method, one equation each:
/// per knee of `knees`, the two heads of its gastrocnemius (`<name>_l` or
/// `_r` on the knee's side; a model without them gets none), or the named
/// groups; none without knees. A named muscle that is not a control is an
/// error naming it.
pub fn equal_activation_pairs(
    labels: &[String],
    knees: &[Knee],
    sel: &EqualActivation,
) -> Result<Vec<[usize; 2]>> {
    if knees.is_empty() {
        return Ok(Vec::new());
    }
    let find = |n: &str| labels.iter().position(|l| l == n);
    let mut pairs = Vec::new();
    match sel {
        EqualActivation::Off => {}
        EqualActivation::Gastrocnemius => {
            for k in knees {
                let side = if k.z[0] > 0.0 { "_l" } else { "_r" };
                for (m, l) in GASTROCNEMIUS_HEADS {
                    if let (Some(i), Some(j)) =
                        (find(&format!("{m}{side}")), find(&format!("{l}{side}")))
                    {
                        pairs.push([i, j]);
                        break;
                    }
                }
            }
        }
        EqualActivation::Groups(groups) => {
            for g in groups {
                let idx: Vec<usize> = g
                    .iter()
                    .map(|n| {
                        find(n).ok_or_else(|| {
                            Error::msg(format!(
                                "knee_contact_equal_activation: '{n}' is not a muscle or actuator of the model's force set"
                            ))
                        })
                    })
                    .collect::<Result<_>>()?;
                pairs.extend(idx.windows(2).map(|w| [w[0], w[1]]));
            }
        }
    }
    Ok(pairs)
}

/// Per-thread buffers of the knee rows.
#[derive(Debug, Clone, Default)]
pub struct KneeScratch {
    applied: Vec<BodyForce>,
    gen: Vec<f64>,
    /// Per knee, per variable: the reaction's change per unit variable
    /// (force, moment about the ground origin, ground frame).
    unit: Vec<BodyForce>,
    /// Per knee: the reaction at x = 0.
    r0: Vec<BodyForce>,
}

fn distal_sum(knee: &Knee, applied: &[BodyForce]) -> BodyForce {
    let mut s = BodyForce::default();
    for (f, &d) in applied.iter().zip(&knee.distal) {
        if d {
            s.add(f);
        }
    }
    s
}

/// The reaction on the tibia at the joint centre M_o, in the tibia frame:
/// (force, moment about M_o).
pub(crate) fn in_tibia(data: &Data, tibia: usize, f: &BodyForce) -> (Vector3<f64>, Vector3<f64>) {
    let r: Matrix3<f64> = data.rotation[tibia].transpose();
    let p = data.p_gm[tibia];
    (r * f.force, r * (f.moment - p.cross(&f.force)))
}

impl SoProblem {
    /// Fill the knee rows (`row0..`) and the knee variables' columns
    /// (`col0..`) of the frame's A and b. `data` holds the frame's
    /// kinematics, the external loads in `data.applied`, and the RNEA at the
    /// target accelerations in `data.joint_force`; `scale` the variables'
    /// force scales. The columns of controls and contacts are written on the
    /// knee rows only.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn knee_rows(
        &self,
        data: &Data,
        mf: &MuscleFrame,
        states: &[crate::contacts::ContactState],
        scale: &[f64],
        a: &mut DMatrix<f64>,
        b: &mut DVector<f64>,
        row0: usize,
        col0: usize,
        s: &mut KneeScratch,
    ) {
        let model = &self.model;
        let nb = model.nbodies();
        let nv = self.controls.len();
        let nc = self.contacts.len();
        let nvar = nv + 3 * nc;
        s.applied.clear();
        s.applied.resize(nb, BodyForce::default());
        s.gen.clear();
        s.gen.resize(model.nq(), 0.0);
        // Passive forces as body forces (the equations took them as
        // generalized forces, the RNEA's joint forces lack them).
        for p in &self.passive {
            p.apply(data, &mut s.applied, &mut s.gen);
        }
        if self.options.passive_fiber_forces {
            for m in 0..self.muscles.len() {
                geometry::add_tension_forces(
                    mf.path_state(m),
                    mf.passive_force[m],
                    &mut s.applied,
                    &mut s.gen,
                );
            }
        }
        let nk = self.knees.len();
        s.unit.clear();
        s.unit.resize(nk * nvar, BodyForce::default());
        s.r0.clear();
        for k in &self.knees {
            let mut r = data.joint_force[k.tibia];
            let p = distal_sum(k, &s.applied);
            r.force -= p.force;
            r.moment -= p.moment;
            s.r0.push(r);
        }
        // Per control: its force per unit variable on the distal bodies.
        for (v, ctl) in self.controls.iter().enumerate() {
            s.applied.iter_mut().for_each(|f| *f = BodyForce::default());
            match ctl {
                Control::Muscle(m) => geometry::add_tension_forces(
                    mf.path_state(*m),
                    scale[v],
                    &mut s.applied,
                    &mut s.gen,
                ),
                Control::Actuator(act) => act.apply(data, scale[v], &mut s.applied, &mut s.gen),
            }
            for (ki, k) in self.knees.iter().enumerate() {
                let f = distal_sum(k, &s.applied);
                s.unit[ki * nvar + v] = BodyForce {
                    force: -f.force,
                    moment: -f.moment,
                };
            }
        }
        for (ci, (c, st)) in self.contacts.iter().zip(states).enumerate() {
            let kinetic = st.regime == Regime::Kinetic;
            for j in 0..3 {
                let mut l = [0.0; 3];
                l[j] = 1.0;
                let (f_point, p, f_plane) = c.forces(st, l, kinetic);
                let on_point = BodyForce::at_point(f_point, p);
                let on_plane = BodyForce::at_point(f_plane, st.projection_ground);
                for (ki, k) in self.knees.iter().enumerate() {
                    let mut f = BodyForce::default();
                    if k.distal[c.point_body] {
                        f.add(&on_point);
                    }
                    if k.distal[c.plane_body] {
                        f.add(&on_plane);
                    }
                    s.unit[ki * nvar + nv + 3 * ci + j] = BodyForce {
                        force: -f.force,
                        moment: -f.moment,
                    };
                }
            }
        }
        for (ki, k) in self.knees.iter().enumerate() {
            let (ra, rb) = (row0 + 2 * ki, row0 + 2 * ki + 1);
            let (f0, m0) = in_tibia(data, k.tibia, &s.r0[ki]);
            // l_med + l_lat + Σ G_y x = −F0_y ;  z·l − Σ G_mx x = M0_x.
            b[ra] = -f0.y;
            b[rb] = if k.frontal { m0.x } else { 0.0 };
            for v in 0..nvar {
                let u = &s.unit[ki * nvar + v];
                // M_o shifts each part of the affine map alike.
                let (gf, gm) = in_tibia(data, k.tibia, u);
                a[(ra, v)] = gf.y;
                a[(rb, v)] = if k.frontal { -gm.x } else { 0.0 };
            }
            for kj in 0..nk {
                for j in 0..2 {
                    let col = col0 + 2 * kj + j;
                    let same = kj == ki;
                    a[(ra, col)] = if same { k.capacity[j] } else { 0.0 };
                    a[(rb, col)] = match (same, k.frontal) {
                        (false, _) => 0.0,
                        (true, true) => k.z[j] * k.capacity[j],
                        // Without the frontal row: l_lat = 0.
                        (true, false) => (j as f64) * k.capacity[j],
                    };
                }
            }
        }
    }
}

/// Medial and lateral compressive loads of a knee from its reaction on the
/// tibia (tibia frame, moment about the joint centre): the two rows solved
/// for (l_med, l_lat). At a solution of the method both are ≥ 0.
pub fn compartments(knee: &Knee, fy: f64, mx: f64) -> (f64, f64) {
    let n = -fy;
    let [zm, zl] = knee.z;
    let med = (mx - zl * n) / (zm - zl);
    (med, n - med)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn knee(side: f64) -> Knee {
        let h = 0.5 * CONDYLE_SPACING;
        Knee {
            name: "k".into(),
            tibia: 1,
            femur: 0,
            distal: vec![false, true],
            z: [side * h, -side * h],
            frontal: true,
            capacity: [1653.0, 890.0],
        }
    }

    /// The two rows solved for the compartments: they carry the compression
    /// and balance the frontal moment, and a moment towards the medial side
    /// (+z on a left knee, −z on a right one) loads the medial compartment.
    #[test]
    fn compartments_balance_compression_and_frontal_moment() {
        for (side, mx) in [(1.0, 10.0), (-1.0, -10.0), (1.0, -4.0), (-1.0, 7.5)] {
            let k = knee(side);
            let fy = -1000.0;
            let (med, lat) = compartments(&k, fy, mx);
            assert!((med + lat - 1000.0).abs() < 1e-9);
            assert!((k.z[0] * med + k.z[1] * lat - mx).abs() < 1e-9);
            // |mx| / spacing moves from one side to the other.
            let shift = mx.abs() / CONDYLE_SPACING;
            let expected_med = 500.0 + if side * mx > 0.0 { shift } else { -shift };
            assert!((med - expected_med).abs() < 1e-9, "{side} {mx}: {med}");
        }
    }

    /// The gastrocnemius heads of each knee's side are tied by default;
    /// `none` ties nothing; named groups tie each to the next; an unknown
    /// name is an error naming it; without knees nothing is tied.
    #[test]
    fn equal_activation_pairs_by_side_and_name() {
        let labels: Vec<String> = [
            "soleus_r", "gasmed_r", "gaslat_r", "gasmed_l", "gaslat_l", "vasmed_r", "vaslat_r",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        let right = knee(-1.0);
        let left = knee(1.0);
        let p = equal_activation_pairs(
            &labels,
            std::slice::from_ref(&right),
            &EqualActivation::Gastrocnemius,
        )
        .unwrap();
        assert_eq!(p, vec![[1, 2]]);
        let p = equal_activation_pairs(
            &labels,
            &[left, right.clone()],
            &EqualActivation::Gastrocnemius,
        )
        .unwrap();
        assert_eq!(p, vec![[3, 4], [1, 2]]);
        assert!(equal_activation_pairs(
            &labels,
            std::slice::from_ref(&right),
            &EqualActivation::Off
        )
        .unwrap()
        .is_empty());
        assert!(
            equal_activation_pairs(&labels, &[], &EqualActivation::Gastrocnemius)
                .unwrap()
                .is_empty()
        );
        let g =
            EqualActivation::from_text("vasmed_r vaslat_r; gasmed_r gaslat_r soleus_r").unwrap();
        let p = equal_activation_pairs(&labels, std::slice::from_ref(&right), &g).unwrap();
        assert_eq!(p, vec![[5, 6], [1, 2], [2, 0]]);
        let g = EqualActivation::from_text("vasmed_r vasint_r").unwrap();
        let e = equal_activation_pairs(&labels, &[right], &g)
            .unwrap_err()
            .to_string();
        assert!(e.contains("vasint_r"), "{e}");
        assert!(EqualActivation::from_text("vasmed_r").is_err());
        assert!(EqualActivation::from_text(" ; ").is_err());
        assert_eq!(
            EqualActivation::from_text("None").unwrap(),
            EqualActivation::Off
        );
    }
}
