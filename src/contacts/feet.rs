//! Foot contacts for ground-reaction prediction, built from a model's own
//! feet and the motion (issue 14).
//!
//! **Points.** For each side s of an OpenSim gait2392/Rajagopal-family model
//! (bodies `calcn_s` and `toes_s`, the toes on a joint whose frame in the
//! calcaneus is the metatarsophalangeal (MTP) joint), the foot's own
//! geometry sets the points: L = the heel→MTP distance along the
//! calcaneus x axis (so the set scales with the model), the sole at the
//! calcaneus frame's y = 0 (the heel's underside in these models), and the
//! foot's half width 0.2 L. On the calcaneus: heel medial and lateral
//! (x = 0.1 L, z = ±0.12 L), midfoot lateral (0.55 L, ±0.2 L), the first
//! and fifth metatarsal heads (0.95 L medially, 0.85 L laterally, ±0.2 L);
//! on the toes: the hallux (0.25 L from the MTP joint, medially 0.05 L).
//! Lateral is +z on the right foot and −z on the left, as in these models.
//!
//! **Floor.** Unless given, its height is found from the motion: each point's
//! lowest height over the trial, and the floor at the median of those minima
//! (a point that sinks at push-off, or one that never lands, does not move
//! it). The floor is level (normal +y).
//!
//! **Moving floor.** On a treadmill the stance foot moves back with the belt.
//! The belt velocity is the median horizontal velocity of the points while
//! they are within 1 cm of the floor; above 0.2 m/s it becomes the contacts'
//! `plane_velocity`, so stance is static friction, not slip.

use nalgebra::Vector3;

use crate::dynamics::{kinematics, Data};
use crate::error::{Error, Location, Result};
use crate::model::Model;
use crate::motion::states::States;

/// One foot contact point: its name, body and location in the body.
#[derive(Debug, Clone)]
pub struct FootPoint {
    pub name: String,
    pub side: char,
    pub body: usize,
    pub body_name: String,
    pub local: Vector3<f64>,
}

/// Contact parameters of the generated set (documented in
/// docs/grf_prediction.md).
#[derive(Debug, Clone, Copy)]
pub struct FootContactParameters {
    /// Full strength up to this height above the floor (m): d_tol.
    pub contact_tolerance: f64,
    /// Strength falls to zero over this further height (m): d_trans.
    pub transition_zone: f64,
    pub static_friction: f64,
    pub kinetic_friction: f64,
    pub v_trans: f64,
    /// `speed_weight`: full strength below, none above (m/s).
    pub speed_weight: (f64, f64),
    /// Force per unit multiplier (N).
    pub optimal_force: f64,
}

impl Default for FootContactParameters {
    fn default() -> Self {
        FootContactParameters {
            contact_tolerance: 0.01,
            transition_zone: 0.04,
            static_friction: 0.8,
            kinetic_friction: 0.5,
            v_trans: 0.3,
            speed_weight: (0.3, 1.0),
            optimal_force: 100.0,
        }
    }
}

/// A belt speed below this (m/s) is treated as a fixed floor.
pub const BELT_THRESHOLD: f64 = 0.2;

/// The generated contact set: points, floor height and belt velocity.
#[derive(Debug, Clone)]
pub struct FootContactSet {
    pub points: Vec<FootPoint>,
    pub floor_height: f64,
    pub belt_velocity: Vector3<f64>,
    pub parameters: FootContactParameters,
}

/// The foot points of `model` (see the module doc). A model without
/// `calcn_r/l` and `toes_r/l` bodies gets an error naming what to provide.
pub fn foot_points(model: &Model) -> Result<Vec<FootPoint>> {
    let mut out = Vec::new();
    for side in ['r', 'l'] {
        let (calcn, toes) = (format!("calcn_{side}"), format!("toes_{side}"));
        let (Some(c), Some(t)) = (model.body_index(&calcn), model.body_index(&toes)) else {
            return Err(Error::input(
                Location::file(&model.file),
                format!(
                    "ground-reaction prediction builds foot contacts on bodies {calcn} and {toes} (the OpenSim gait2392/Rajagopal family); this model has no such bodies: give your own PointOnPlaneContact set in <force_set_files>"
                ),
            ));
        };
        let j = &model.joints[t];
        if j.parent_body != c {
            return Err(Error::input(
                Location::file(&model.file),
                format!("{toes} is not jointed to {calcn}: give your own foot contacts in <force_set_files>"),
            ));
        }
        // MTP joint in the calcaneus frame.
        let mtp = j.x_pf.apply(&Vector3::zeros());
        let l = mtp.x;
        if !(l > 0.05 && l < 0.5) {
            return Err(Error::input(
                Location::file(&model.file),
                format!("the {toes} joint lies {l:.3} m along {calcn}'s x axis; expected a heel-to-MTP length between 0.05 and 0.5 m: give your own foot contacts in <force_set_files>"),
            ));
        }
        let lat = if side == 'r' { 1.0 } else { -1.0 };
        let on_calcn = [
            ("heel_med", 0.1, -0.12),
            ("heel_lat", 0.1, 0.12),
            ("midfoot_lat", 0.55, 0.2),
            ("meta1", 0.95, -0.2),
            ("meta5", 0.85, 0.2),
        ];
        for (name, x, z) in on_calcn {
            out.push(FootPoint {
                name: format!("foot_{name}_{side}"),
                side,
                body: c,
                body_name: calcn.clone(),
                local: Vector3::new(x * l, 0.0, lat * z * l),
            });
        }
        // The hallux, in the toes frame (at the MTP joint), on the sole.
        out.push(FootPoint {
            name: format!("foot_hallux_{side}"),
            side,
            body: t,
            body_name: toes.clone(),
            local: Vector3::new(0.25 * l, -mtp.y, -lat * 0.05 * l),
        });
    }
    Ok(out)
}

/// Build the contact set over the motion `states`: floor height (unless
/// `floor` is given) and belt velocity from the points' motion.
pub fn build(
    model: &Model,
    states: &States,
    floor: Option<f64>,
    parameters: FootContactParameters,
) -> Result<FootContactSet> {
    let points = foot_points(model)?;
    let mut data = Data::new(model);
    let n = states.time.len();
    let mut lowest = vec![f64::INFINITY; points.len()];
    let mut heights = vec![Vec::with_capacity(n); points.len()];
    let mut velocities = vec![Vec::with_capacity(n); points.len()];
    for i in 0..n {
        data.q.copy_from_slice(&states.q[i]);
        data.u.copy_from_slice(&states.u[i]);
        data.udot.iter_mut().for_each(|x| *x = 0.0);
        kinematics::full(model, &mut data);
        for (k, p) in points.iter().enumerate() {
            let g = data.station_position(p.body, &p.local);
            let v = data.station_velocity(p.body, &p.local);
            lowest[k] = lowest[k].min(g.y);
            heights[k].push(g.y);
            velocities[k].push(v);
        }
    }
    let floor_height = match floor {
        Some(f) => f,
        None => median(&mut lowest.clone()),
    };
    let mut stance_vx = Vec::new();
    let mut stance_vz = Vec::new();
    for k in 0..points.len() {
        for i in 0..n {
            if heights[k][i] < floor_height + 0.01 {
                stance_vx.push(velocities[k][i].x);
                stance_vz.push(velocities[k][i].z);
            }
        }
    }
    let belt = if stance_vx.is_empty() {
        Vector3::zeros()
    } else {
        Vector3::new(median(&mut stance_vx), 0.0, median(&mut stance_vz))
    };
    let belt_velocity = if belt.norm() > BELT_THRESHOLD {
        belt
    } else {
        Vector3::zeros()
    };
    Ok(FootContactSet {
        points,
        floor_height,
        belt_velocity,
        parameters,
    })
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len();
    if n == 0 {
        return f64::NAN;
    }
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

impl FootContactSet {
    /// The set as an OpenSim ForceSet document of PointOnPlaneContacts (a
    /// force-set file a setup can name).
    pub fn force_set_xml(&self) -> String {
        let p = &self.parameters;
        let v = self.belt_velocity;
        let mut s = String::from(
            "<?xml version=\"1.0\" encoding=\"UTF-8\" ?>\n<!-- Foot contacts generated by statopt predict-grf from the model's feet and the motion (docs/grf_prediction.md). -->\n<OpenSimDocument Version=\"40000\">\n\t<ForceSet name=\"foot_contacts\">\n\t\t<objects>\n",
        );
        for pt in &self.points {
            s.push_str(&format!(
                "\t\t\t<PointOnPlaneContact name=\"{}\">\n\t\t\t\t<point_body>{}</point_body>\n\t\t\t\t<point_location>{} {} {}</point_location>\n\t\t\t\t<plane_body>ground</plane_body>\n\t\t\t\t<plane_origin>0 {} 0</plane_origin>\n\t\t\t\t<plane_normal>0 1 0</plane_normal>\n\t\t\t\t<plane_velocity>{} 0 {}</plane_velocity>\n\t\t\t\t<static_friction>{}</static_friction>\n\t\t\t\t<kinetic_friction>{}</kinetic_friction>\n\t\t\t\t<contact_tolerance>{}</contact_tolerance>\n\t\t\t\t<contact_transition_zone>{}</contact_transition_zone>\n\t\t\t\t<v_trans>{}</v_trans>\n\t\t\t\t<speed_weight>{} {}</speed_weight>\n\t\t\t\t<optimal_force>{}</optimal_force>\n\t\t\t</PointOnPlaneContact>\n",
                pt.name,
                pt.body_name,
                pt.local.x,
                pt.local.y,
                pt.local.z,
                self.floor_height,
                v.x,
                v.z,
                p.static_friction,
                p.kinetic_friction,
                p.contact_tolerance,
                p.transition_zone,
                p.v_trans,
                p.speed_weight.0,
                p.speed_weight.1,
                p.optimal_force
            ));
        }
        s.push_str("\t\t</objects>\n\t</ForceSet>\n</OpenSimDocument>\n");
        s
    }
}
