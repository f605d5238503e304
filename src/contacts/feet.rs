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
//! **Floor.** Unless given, its height is found from the motion over the
//! analysed frames: each point's lowest height over the trial, and the floor
//! at the median of those minima (a point that sinks at push-off, or one
//! that never lands, does not move it).
//!
//! **Moving floor.** On a treadmill the stance foot moves back with the belt.
//! Whether the floor is a belt, and its velocity, is decided by the test of
//! [`super::floor`] (or given); a belt becomes the contacts'
//! `plane_velocity`, so stance is static friction, not slip.

use nalgebra::Vector3;

use crate::dynamics::{kinematics, Data};
use crate::error::{Error, Location, Result};
use crate::model::Model;
use crate::motion::states::States;

use super::floor::{self, FloorDecision, FloorMotion, PointTrack};

/// One foot contact point: its name, body and location in the body.
#[derive(Debug, Clone)]
pub struct FootPoint {
    pub name: String,
    pub side: char,
    pub body: usize,
    pub body_name: String,
    pub local: Vector3<f64>,
    /// Height of the floor under this point (m, ground y): the level at
    /// which the point dwells in stance, found from the motion (see
    /// [`build`]); the common floor when the point never dwells.
    pub contact_level: f64,
    /// Where the point dwells on the floor (ground x and z, m): with the
    /// level, a point of the floor plane under this point.
    pub dwell_xz: (f64, f64),
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
    /// `speed_weight`: full strength below, none above (m/s), for a gait
    /// no faster than [`Self::speed_weight_gait_speed`]; see
    /// [`Self::for_gait_speed`].
    pub speed_weight: (f64, f64),
    /// The gait speed (m/s) `speed_weight` holds for as given.
    pub speed_weight_gait_speed: f64,
    /// Force per unit multiplier (N).
    pub optimal_force: f64,
}

impl FootContactParameters {
    /// The parameters for a gait of speed `v` (m/s, the body's horizontal
    /// speed over the floor): the slip-speed gate `speed_weight` is the
    /// walking one up to [`Self::speed_weight_gait_speed`] and scales with
    /// the speed above it. A landing foot sheds its forward speed over the
    /// last centimetres of its swing, and how fast it still slides when the
    /// floor takes its load scales with the speed it swings at, which
    /// scales with the gait's: in the raw IK of the development trials the
    /// heel slid at 0.2-0.3 v relative to the floor when the plates first
    /// saw load, walking at 1.2 m/s and running at 4.7 m/s alike. A gate
    /// fixed in m/s is either too loose for walking (the landing heel
    /// loads early) or shuts the landing foot out in fast running (the
    /// pelvis then carries the impact). A speed that is not finite leaves
    /// the walking gate.
    pub fn for_gait_speed(self, v: f64) -> FootContactParameters {
        let k = if v.is_finite() {
            (v / self.speed_weight_gait_speed).max(1.0)
        } else {
            1.0
        };
        FootContactParameters {
            speed_weight: (k * self.speed_weight.0, k * self.speed_weight.1),
            ..self
        }
    }
}

impl Default for FootContactParameters {
    fn default() -> Self {
        FootContactParameters {
            contact_tolerance: 0.005,
            transition_zone: 0.03,
            static_friction: 0.35,
            kinetic_friction: 0.25,
            v_trans: 0.8,
            // Walking: none from 0.8 m/s, where AnyBody's foot contacts
            // switch off (FootPlateConditionalContact, LimitVelHigh).
            speed_weight: (0.12, 0.8),
            speed_weight_gait_speed: 1.3,
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
    /// Slope of the floor found from the motion: dh/dx and dh/dz (ground);
    /// (0, 0) when the floor height is given.
    pub floor_slope: (f64, f64),
    /// What the check of the points against the motion found.
    pub warnings: Vec<String>,
    pub floor_height: f64,
    pub belt_velocity: Vector3<f64>,
    /// Treadmill or ground, and why ([`super::floor`]).
    pub decision: FloorDecision,
    /// The body's horizontal speed over the floor (m/s): the pelvis's mean
    /// velocity less the belt's.
    pub gait_speed: f64,
    /// As used: `speed_weight` scaled to `gait_speed`
    /// ([`FootContactParameters::for_gait_speed`]).
    pub parameters: FootContactParameters,
    /// Per foot (right, left): the times [t0, t1) over which its contacts
    /// carry nothing (`off_intervals`): the swing before a foot strike that
    /// takes over from the other foot ([`super::events`]); empty unless set.
    pub off_intervals: [Vec<(f64, f64)>; 2],
    /// The factor on a contact's weight within its off intervals
    /// (`off_weight`): 0 unless set.
    pub off_weight: f64,
    /// Per foot: the times [t0, t1) over which its contacts are on the
    /// floor whatever their slip (`held_intervals`): the trailing foot's
    /// double support ([`super::events::apply_transition`]); empty unless
    /// set.
    pub held_intervals: [Vec<(f64, f64)>; 2],
    /// Per point (in the order of `points`): further times [t0, t1) over
    /// which it carries nothing, at `off_weight` (its `off_intervals` are
    /// its foot's and these): a landing foot's points but its heel's over
    /// double support ([`super::events::heel_rocker_intervals`]); empty
    /// unless set.
    pub heel_rocker_intervals: Vec<Vec<(f64, f64)>>,
    /// Per foot: knots of its contacts' summed force target along
    /// `target_axes` (`force_target`, group `foot_r` / `foot_l`; the trailing
    /// foot's smooth transition, [`super::events::trailing_targets`]);
    /// empty unless set.
    pub force_target: [Vec<super::events::TargetKnot>; 2],
    /// What a newton off the target costs (`force_target_optimal_force`, N,
    /// per axis).
    pub target_optimal_force: Vec<f64>,
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
                contact_level: 0.0,
                dwell_xz: (0.0, 0.0),
            });
        }
        // The hallux, in the toes frame (at the MTP joint), on the sole.
        out.push(FootPoint {
            name: format!("foot_hallux_{side}"),
            side,
            body: t,
            body_name: toes.clone(),
            local: Vector3::new(0.25 * l, -mtp.y, -lat * 0.05 * l),
            contact_level: 0.0,
            dwell_xz: (0.0, 0.0),
        });
    }
    Ok(out)
}

/// Build the contact set over the motion `states`, from its frames within
/// `range` (the analysed time range, s; the rest, such as the reflected
/// padding a low-pass filter adds before and after the trial, is no
/// evidence): floor height (unless `floor` is given) and how the floor
/// moves (decided from the motion unless `motion` gives it, see
/// [`super::floor`]).
pub fn build(
    model: &Model,
    states: &States,
    range: (f64, f64),
    floor: Option<f64>,
    motion: FloorMotion,
    parameters: FootContactParameters,
) -> Result<FootContactSet> {
    let points = foot_points(model)?;
    let mut data = Data::new(model);
    // The analysed frames: from the state at or closest before the initial
    // time (as OpenSim picks the first state) to the final time.
    let eps = 1e-9;
    let first = states
        .time
        .iter()
        .rposition(|&t| t <= range.0 + eps)
        .unwrap_or(0);
    let frames: Vec<usize> = (first..states.time.len())
        .filter(|&i| states.time[i] <= range.1 + eps)
        .collect();
    if frames.is_empty() {
        return Err(Error::msg(format!(
            "predict-grf: the motion has no frame between {} and {} s",
            range.0, range.1
        )));
    }
    let n = frames.len();
    let time: Vec<f64> = frames.iter().map(|&i| states.time[i]).collect();
    let mut velocities = vec![Vec::with_capacity(n); points.len()];
    let mut positions = vec![Vec::with_capacity(n); points.len()];
    let root = (0..model.nq())
        .find(|&c| model.is_root_coordinate(c))
        .map(|c| model.coordinates[c].body);
    let (mut pelvis, mut pelvis_x) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for &i in &frames {
        data.q.copy_from_slice(&states.q[i]);
        data.u.copy_from_slice(&states.u[i]);
        data.udot.iter_mut().for_each(|x| *x = 0.0);
        kinematics::full(model, &mut data);
        for (k, p) in points.iter().enumerate() {
            let g = data.station_position(p.body, &p.local);
            let v = data.station_velocity(p.body, &p.local);
            velocities[k].push(v);
            positions[k].push(g);
        }
        // The walking direction and progression: the root body (pelvis),
        // or the calcanei's midpoint for a model without one.
        match root {
            Some(b) => {
                pelvis.push(data.station_position(b, &Vector3::zeros()));
                pelvis_x.push(data.station_position(b, &Vector3::x()));
            }
            None => {
                let m = 0.5
                    * (positions[0][positions[0].len() - 1] + positions[6][positions[6].len() - 1]);
                pelvis.push(m);
                pelvis_x.push(m + Vector3::x());
            }
        }
    }
    let floor_height = match floor {
        Some(f) => f,
        None => {
            let mut lowest: Vec<f64> = positions
                .iter()
                .map(|p| p.iter().map(|g| g.y).fold(f64::INFINITY, f64::min))
                .collect();
            median(&mut lowest)
        }
    };
    let tracks: Vec<PointTrack> = points
        .iter()
        .enumerate()
        .map(|(k, p)| PointTrack {
            side: p.side,
            positions: &positions[k],
            velocities: &velocities[k],
        })
        .collect();
    let all: Vec<usize> = (0..n).collect();
    let ev = floor::evidence(&time, &all, &pelvis, &pelvis_x, &tracks);
    let decision = floor::decide(ev, motion);
    let belt_velocity = decision.belt_velocity;
    let over_floor = decision.evidence.pelvis_velocity - belt_velocity;
    let gait_speed = over_floor.x.hypot(over_floor.z);
    let parameters = parameters.for_gait_speed(gait_speed);
    let mut points = points;
    let mut dwell_samples = Vec::with_capacity(points.len());
    for (k, p) in points.iter_mut().enumerate() {
        let samples = dwell_samples_of(&positions[k], &velocities[k], floor_height, &belt_velocity);
        match (floor, samples.len() >= DWELL_MIN_FRAMES) {
            (None, true) => {
                let mut h: Vec<f64> = samples.iter().map(|g| g.y).collect();
                let mut x: Vec<f64> = samples.iter().map(|g| g.x).collect();
                let mut z: Vec<f64> = samples.iter().map(|g| g.z).collect();
                p.contact_level =
                    median(&mut h).clamp(floor_height - DWELL_BAND, floor_height + DWELL_BAND);
                p.dwell_xz = (median(&mut x), median(&mut z));
            }
            _ => {
                p.contact_level = floor.unwrap_or(floor_height);
                let mut x: Vec<f64> = positions[k].iter().map(|g| g.x).collect();
                let mut z: Vec<f64> = positions[k].iter().map(|g| g.z).collect();
                p.dwell_xz = (median(&mut x), median(&mut z));
            }
        }
        dwell_samples.push(samples);
    }
    // A point that never dwells (a foot that only lands at the end of a
    // short trial) rests, when it lands, as its mirror image on the other
    // foot does (the model's feet are mirror images on one floor): it takes
    // that point's contact level when that one dwells, else the median
    // level of the points that dwell, else the common floor.
    if floor.is_none() {
        let dwells: Vec<bool> = dwell_samples
            .iter()
            .map(|s| s.len() >= DWELL_MIN_FRAMES)
            .collect();
        let mut levels: Vec<f64> = points
            .iter()
            .zip(&dwells)
            .filter(|(_, &d)| d)
            .map(|(p, _)| p.contact_level)
            .collect();
        let fallback = if levels.is_empty() {
            floor_height
        } else {
            median(&mut levels)
        };
        let names: Vec<String> = points.iter().map(|p| p.name.clone()).collect();
        for k in 0..points.len() {
            if dwells[k] {
                continue;
            }
            let other = if points[k].side == 'r' { 'l' } else { 'r' };
            let stem = &names[k][..names[k].len() - 1];
            let mirror =
                (0..points.len()).find(|&j| dwells[j] && names[j] == format!("{stem}{other}"));
            points[k].contact_level = match mirror {
                Some(j) => points[j].contact_level,
                None => fallback,
            };
        }
    }
    let mut warnings = Vec::new();
    if decision.source == floor::DecisionSource::Fallback {
        warnings.push(format!("floor: {}", decision.reason));
    }
    for side in ['r', 'l'] {
        // Deepest sink of each point of this foot below its contact level.
        let sinks: Vec<(usize, f64, usize)> = points
            .iter()
            .enumerate()
            .filter(|(_, p)| p.side == side)
            .map(|(k, p)| {
                positions[k]
                    .iter()
                    .enumerate()
                    .fold((k, 0.0f64, 0usize), |acc, (i, g)| {
                        let s = p.contact_level - g.y;
                        if s > acc.1 {
                            (k, s, i)
                        } else {
                            acc
                        }
                    })
            })
            .collect();
        let sunk: Vec<&(usize, f64, usize)> = sinks.iter().filter(|s| s.1 > SINK_WARNING).collect();
        if sunk.len() * 2 > sinks.len() {
            let worst = sunk
                .iter()
                .max_by(|a, b| a.1.total_cmp(&b.1))
                .expect("not empty");
            warnings.push(format!(
                "foot {side}: {} of its {} contact points sink more than {:.0} cm below their contact levels (up to {:.1} cm, at t = {:.3} s): the motion's vertical position drifts there, or the floor is not flat; the predicted forces there are uncertain",
                sunk.len(), sinks.len(), 100.0 * SINK_WARNING, 100.0 * worst.1, time[worst.2]
            ));
        } else {
            for &&(k, s, i) in &sunk {
                warnings.push(format!(
                    "foot contact point {} on {} sinks {:.1} cm below its contact level at t = {:.3} s: the foot is rigid there (a toe rolling over) or the markers err; the force there is uncertain",
                    points[k].name, points[k].body_name, 100.0 * s, time[i]
                ));
            }
        }
    }
    let floor_slope = match floor {
        Some(_) => (0.0, 0.0),
        None => slope_of(&dwell_samples),
    };
    Ok(FootContactSet {
        points,
        warnings,
        floor_slope,
        floor_height,
        belt_velocity,
        decision,
        gait_speed,
        parameters,
        off_intervals: [Vec::new(), Vec::new()],
        off_weight: 0.0,
        held_intervals: [Vec::new(), Vec::new()],
        heel_rocker_intervals: Vec::new(),
        force_target: [Vec::new(), Vec::new()],
        target_optimal_force: Vec::new(),
    })
}

/// A point dwells where it rests on the floor: low (within
/// [`DWELL_BAND`] of the common floor), hardly moving vertically (below
/// [`DWELL_VERTICAL_SPEED`]) and moving with the floor horizontally (within
/// [`DWELL_SLIP_SPEED`] of the belt). Its ground positions there.
fn dwell_samples_of(
    positions: &[Vector3<f64>],
    velocities: &[Vector3<f64>],
    floor: f64,
    belt: &Vector3<f64>,
) -> Vec<Vector3<f64>> {
    positions
        .iter()
        .zip(velocities)
        .filter(|(g, v)| {
            let slip = Vector3::new(v.x - belt.x, 0.0, v.z - belt.z).norm();
            g.y < floor + DWELL_BAND && v.y.abs() < DWELL_VERTICAL_SPEED && slip < DWELL_SLIP_SPEED
        })
        .map(|(g, _)| *g)
        .collect()
}

/// The floor's slope (dh/dx, dh/dz) from the dwell samples: height against
/// position, pooled over the points with one level per point (each point's
/// samples taken about their own means), by least squares. A direction in
/// which the samples spread less than [`SLOPE_MIN_SPREAD`] (RMS) gets slope 0.
fn slope_of(samples: &[Vec<Vector3<f64>>]) -> (f64, f64) {
    let (mut sxx, mut sxz, mut szz, mut sxh, mut szh, mut n) = (0.0, 0.0, 0.0, 0.0, 0.0, 0usize);
    for s in samples.iter().filter(|s| s.len() >= DWELL_MIN_FRAMES) {
        let m = s.iter().sum::<Vector3<f64>>() / s.len() as f64;
        for g in s {
            let d = g - m;
            sxx += d.x * d.x;
            sxz += d.x * d.z;
            szz += d.z * d.z;
            sxh += d.x * d.y;
            szh += d.z * d.y;
            n += 1;
        }
    }
    if n == 0 {
        return (0.0, 0.0);
    }
    let spread = SLOPE_MIN_SPREAD * SLOPE_MIN_SPREAD * n as f64;
    match (sxx > spread, szz > spread) {
        (true, true) => {
            let det = sxx * szz - sxz * sxz;
            if det.abs() < 1e-12 {
                (0.0, 0.0)
            } else {
                ((szz * sxh - sxz * szh) / det, (sxx * szh - sxz * sxh) / det)
            }
        }
        (true, false) => (sxh / sxx, 0.0),
        (false, true) => (0.0, szh / szz),
        (false, false) => (0.0, 0.0),
    }
}

/// A point more than this below its contact level (m) draws a warning.
pub const SINK_WARNING: f64 = 0.02;

/// Least RMS spread of the dwell positions (m) for a slope along an axis.
pub const SLOPE_MIN_SPREAD: f64 = 0.05;

/// Height band above the common floor within which a point may dwell (m).
pub const DWELL_BAND: f64 = 0.03;
/// Largest vertical speed of a dwelling point (m/s).
pub const DWELL_VERTICAL_SPEED: f64 = 0.05;
/// Largest horizontal speed over the floor of a dwelling point (m/s).
pub const DWELL_SLIP_SPEED: f64 = 0.15;
/// Fewest frames a point must dwell for its own contact level.
pub const DWELL_MIN_FRAMES: usize = 5;

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
    /// Height of the floor plane under point `p` at ground (x, z): its
    /// contact level through its dwell position, with the floor's slope.
    pub fn floor_height_under(&self, p: &FootPoint, x: f64, z: f64) -> f64 {
        p.contact_level
            + self.floor_slope.0 * (x - p.dwell_xz.0)
            + self.floor_slope.1 * (z - p.dwell_xz.1)
    }

    /// Slope angles of the floor (degrees): about z (rise along +x) and
    /// about x (rise along +z).
    pub fn floor_tilt_degrees(&self) -> (f64, f64) {
        (
            self.floor_slope.0.atan().to_degrees(),
            self.floor_slope.1.atan().to_degrees(),
        )
    }

    /// Unit normal of the floor (ground frame), from its slope.
    pub fn floor_normal(&self) -> Vector3<f64> {
        Vector3::new(-self.floor_slope.0, 1.0, -self.floor_slope.1).normalize()
    }

    /// [`FootContactSet::force_set_xml`] parsed, as if read from `path`
    /// (where it is written): the contacts a prediction's plan adds.
    pub fn force_set_document(&self, path: &std::path::Path) -> Result<crate::xml::Element> {
        crate::forces::force_set_document(&self.force_set_xml(), path)
    }

    /// The set as an OpenSim ForceSet document of PointOnPlaneContacts (a
    /// force-set file a setup can name).
    pub fn force_set_xml(&self) -> String {
        let p = &self.parameters;
        // The belt moves in the floor's plane.
        let normal = self.floor_normal();
        let v = self.belt_velocity - normal * self.belt_velocity.dot(&normal);
        let mut s = String::from(
            "<?xml version=\"1.0\" encoding=\"UTF-8\" ?>\n<!-- Foot contacts generated by statopt predict-grf from the model's feet and the motion (docs/grf_prediction.md). -->\n<OpenSimDocument Version=\"40000\">\n\t<ForceSet name=\"foot_contacts\">\n\t\t<objects>\n",
        );
        for (i, pt) in self.points.iter().enumerate() {
            s.push_str(&format!(
                "\t\t\t<PointOnPlaneContact name=\"{}\">\n\t\t\t\t<point_body>{}</point_body>\n\t\t\t\t<point_location>{} {} {}</point_location>\n\t\t\t\t<plane_body>ground</plane_body>\n\t\t\t\t<plane_origin>{} {} {}</plane_origin>\n\t\t\t\t<plane_normal>{} 1 {}</plane_normal>\n\t\t\t\t<plane_velocity>{} {} {}</plane_velocity>\n\t\t\t\t<static_friction>{}</static_friction>\n\t\t\t\t<kinetic_friction>{}</kinetic_friction>\n\t\t\t\t<contact_tolerance>{}</contact_tolerance>\n\t\t\t\t<contact_transition_zone>{}</contact_transition_zone>\n\t\t\t\t<v_trans>{}</v_trans>\n\t\t\t\t<speed_weight>{} {}</speed_weight>\n\t\t\t\t<optimal_force>{}</optimal_force>\n{}\t\t\t</PointOnPlaneContact>\n",
                pt.name,
                pt.body_name,
                pt.local.x,
                pt.local.y,
                pt.local.z,
                pt.dwell_xz.0,
                pt.contact_level,
                pt.dwell_xz.1,
                -self.floor_slope.0,
                -self.floor_slope.1,
                v.x,
                v.y,
                v.z,
                p.static_friction,
                p.kinetic_friction,
                p.contact_tolerance,
                p.transition_zone,
                p.v_trans,
                p.speed_weight.0,
                p.speed_weight.1,
                p.optimal_force,
                off_intervals_xml(
                    &super::events::merged(
                        self.off_intervals[if pt.side == 'r' { 0 } else { 1 }]
                            .iter()
                            .chain(self.heel_rocker_intervals.get(i).into_iter().flatten())
                            .copied()
                            .collect()
                    ),
                    self.off_weight,
                ) + &held_intervals_xml(&self.held_intervals[if pt.side == 'r' { 0 } else { 1 }])
                    + &self.force_target_xml(pt.side)
            ));
        }
        s.push_str("\t\t</objects>\n\t</ForceSet>\n</OpenSimDocument>\n");
        s
    }
}

impl FootContactSet {
    /// The `force_target_*` lines of a contact of foot `side` (empty when
    /// the foot has no target).
    fn force_target_xml(&self, side: char) -> String {
        let knots = &self.force_target[if side == 'r' { 0 } else { 1 }];
        if knots.is_empty() {
            return String::new();
        }
        let k: Vec<String> = knots
            .iter()
            .map(|(t, on, rows)| {
                let v: Vec<String> = rows
                    .iter()
                    .map(|(a, f)| format!("{} {} {} {f}", a.x, a.y, a.z))
                    .collect();
                format!("{t} {} {}", u8::from(*on), v.join(" "))
            })
            .collect();
        let m = knots[0].2.len();
        format!(
            "\t\t\t\t<force_target_group>foot_{side}</force_target_group>\n\t\t\t\t<force_target_rows>{m}</force_target_rows>\n\t\t\t\t<force_target>{}</force_target>\n\t\t\t\t<force_target_optimal_force>{}</force_target_optimal_force>\n",
            k.join(" "),
            self.target_optimal_force
                .iter()
                .map(|x| x.to_string())
                .collect::<Vec<_>>()
                .join(" ")
        )
    }
}

/// The `<off_intervals>` line of a contact (empty when there are none).
fn off_intervals_xml(intervals: &[(f64, f64)], weight: f64) -> String {
    if intervals.is_empty() {
        return String::new();
    }
    format!(
        "\t\t\t\t<off_intervals>{}</off_intervals>\n\t\t\t\t<off_weight>{weight}</off_weight>\n",
        intervals_text(intervals)
    )
}

/// The `<held_intervals>` line of a contact (empty when there are none).
fn held_intervals_xml(intervals: &[(f64, f64)]) -> String {
    if intervals.is_empty() {
        return String::new();
    }
    format!(
        "\t\t\t\t<held_intervals>{}</held_intervals>\n",
        intervals_text(intervals)
    )
}

/// Intervals as the property's text: `t0 t1 t0 t1 ...`.
fn intervals_text(intervals: &[(f64, f64)]) -> String {
    intervals
        .iter()
        .flat_map(|&(a, b)| [format!("{a}"), format!("{b}")])
        .collect::<Vec<_>>()
        .join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The slip-speed gate: the walking one (0.12 / 0.8 m/s) up to
    /// 1.3 m/s, scaled with the gait's speed above it (a runner's foot
    /// lands sliding faster), never below the walking one, and the walking
    /// one for a speed that is not finite.
    #[test]
    fn the_slip_speed_gate_scales_with_a_faster_gait() {
        let p = FootContactParameters::default();
        assert_eq!(p.speed_weight, (0.12, 0.8));
        for v in [0.0, 0.9, 1.3, f64::NAN] {
            assert_eq!(p.for_gait_speed(v).speed_weight, (0.12, 0.8), "v = {v}");
        }
        let run = p.for_gait_speed(3.9).speed_weight;
        assert!(
            (run.0 - 0.36).abs() < 1e-12 && (run.1 - 2.4).abs() < 1e-12,
            "{run:?}"
        );
        // Nothing else changes.
        let q = p.for_gait_speed(5.0);
        assert_eq!(q.static_friction, p.static_friction);
        assert_eq!(q.contact_tolerance, p.contact_tolerance);
        assert_eq!(q.v_trans, p.v_trans);
    }

    /// Two points dwelling on a floor that rises 3 % along x and falls 1 %
    /// along z, at levels 1 cm apart and over different stretches: the slope
    /// comes back exactly, whatever each point's own level.
    #[test]
    fn slope_of_a_tilted_floor_comes_back() {
        let (gx, gz) = (0.03, -0.01);
        let sample = |x: f64, z: f64, level: f64| Vector3::new(x, level + gx * x + gz * z, z);
        let a: Vec<_> = (0..40)
            .map(|i| {
                sample(
                    0.4 - 0.02 * i as f64,
                    0.1 + 0.003 * (i % 7) as f64 * 30.0,
                    0.0,
                )
            })
            .collect();
        let b: Vec<_> = (0..30)
            .map(|i| {
                sample(
                    1.2 - 0.03 * i as f64,
                    -0.2 + 0.01 * (i % 5) as f64 * 20.0,
                    0.01,
                )
            })
            .collect();
        let (sx, sz) = slope_of(&[a, b]);
        assert!(
            (sx - gx).abs() < 1e-12 && (sz - gz).abs() < 1e-12,
            "{sx} {sz}"
        );
    }

    /// Samples that do not spread along an axis give no slope along it
    /// (a point dwelling in place tells nothing of the floor's tilt).
    #[test]
    fn no_spread_no_slope() {
        let a: Vec<_> = (0..20)
            .map(|i| Vector3::new(0.5 + 0.001 * i as f64, 0.01 * i as f64, 0.0))
            .collect();
        assert_eq!(slope_of(&[a]), (0.0, 0.0));
    }

    /// A dwelling point: low, still vertically and moving with the belt;
    /// a point sweeping past in swing or dropping onto the floor is not.
    #[test]
    fn dwell_samples_follow_the_belt() {
        let belt = Vector3::new(-1.0, 0.0, 0.0);
        let p = [
            Vector3::new(0.3, 0.011, 0.0),
            Vector3::new(0.3, 0.011, 0.0),
            Vector3::new(0.3, 0.011, 0.0),
            Vector3::new(0.3, 0.1, 0.0),
        ];
        let v = [
            Vector3::new(-1.05, 0.01, 0.0), // with the belt: dwells
            Vector3::new(0.0, 0.0, 0.0),    // still in the lab: slips on the belt
            Vector3::new(-1.0, -0.3, 0.0),  // dropping
            Vector3::new(-1.0, 0.0, 0.0),   // high
        ];
        let d = dwell_samples_of(&p, &v, 0.0, &belt);
        assert_eq!(d.len(), 1);
    }
}
