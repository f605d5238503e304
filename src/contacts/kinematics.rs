//! Per-frame geometry of a point-on-plane contact and the generalized forces
//! of its multipliers (Krüger & Wartzack 2017, §2.1, eqs. 1, 3, 8; §2.2.4).
//!
//! # Force model and signs
//!
//! The paper's force components act on the PLANE body B, at the projection
//! p* of the point onto the plane (eq. 1, times F0 = `optimal_force`):
//!
//! F_B = w F0 (−λn n + λs1 e1 + λs2 e2)            (static regime)
//!
//! and the equal and opposite force −F_B acts on the POINT body A at p. So
//! λn ≥ 0 pushes the point away from the plane along +n.
//!
//! In the kinetic regime (eq. 3) the shear is fixed by the normal force:
//!
//! F_B = w F0 λn (−n + μk v̂),  F_A = −F_B = w F0 λn (n − μk v̂),
//!
//! with v̂ the unit slip velocity of the point relative to the plane. The
//! friction on the point body thus opposes its slip, and the friction on the
//! plane body drags it along with the point (the paper: "it must point into
//! the direction of v_rel", meaning the force on B). Physical check: a block
//! (point body) sliding along +x on the ground gets friction −μk λn F0 x̂.
//! This is also the plugin's `computeForceVectors`.
//!
//! # Smooth regime transition (statopt extension, `regime_blend`)
//!
//! The paper switches hard at v_trans. With `regime_blend` = h > 0 the
//! switch is blended by β = smoothstep((s − v_trans + h/2)/h) of the slip
//! speed s (β = 3x² − 2x³, x clamped to [0, 1]; C¹, β = 0 for
//! s ≤ v_trans − h/2, 1 for s ≥ v_trans + h/2), and
//!
//! F_B = w F0 (−λn n + β μk λn v̂ + λs1 e1 + λs2 e2),  ‖(λs1, λs2)‖ ≤ (1 − β) μs λn,
//!
//! which is linear in the multipliers with a (shrunken) second-order cone, so
//! the frame problem stays convex. β = 0 is the static regime, β = 1 the
//! kinetic one (the shear multipliers are then held at zero). With h = 0
//! (default) β is 1 above v_trans and 0 at or below it: the paper's switch.
//!
//! # Differences from the plugin's geometry (deliberate)
//!
//! - The distance is signed ((p − o)·n, positive on the normal side) and
//!   p* = p − d n. The plugin takes |d| and forms p − |d| n, which is not on
//!   the plane when the point is on the negative side, and it weakens a
//!   penetrating contact as if it were separated.
//! - The slip velocity is that of p relative to the material point of B that
//!   coincides with p (the time derivative of p's coordinates in B, expressed
//!   in ground), projected into the plane. The plugin subtracts the velocities
//!   of the two body origins, which is wrong whenever a body rotates.

use nalgebra::Vector3;

use super::Contact;
use crate::dynamics::jacobian::add_point_force;
use crate::dynamics::Data;
use crate::model::Model;

/// Coulomb regime of a contact at one frame (§2.2.4).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Regime {
    /// Slip speed ≤ v_trans: shear multipliers free within the friction cone.
    Static,
    /// Slip speed > v_trans: shear fixed by eq. 3.
    Kinetic,
}

/// Per-frame geometry of one contact; all vectors in ground.
#[derive(Debug, Clone, PartialEq)]
pub struct ContactState {
    /// Signed point-to-plane distance d, positive on the normal side.
    pub distance: f64,
    /// w(d) of eq. 8 ([`weight`]); 1 when d_tol < 0. Times the slip-speed
    /// factor ([`Contact::speed_factor`]) when `speed_weight` is given.
    pub weight: f64,
    /// p: the point (on body A).
    pub point_ground: Vector3<f64>,
    /// p* = p − d n: the orthogonal projection of p onto the plane, where
    /// the force on the plane body acts.
    pub projection_ground: Vector3<f64>,
    pub normal_ground: Vector3<f64>,
    pub e1_ground: Vector3<f64>,
    pub e2_ground: Vector3<f64>,
    /// In-plane velocity of p relative to the plane body.
    pub slip_velocity: Vector3<f64>,
    pub slip_speed: f64,
    /// Kinetic share β ∈ [0, 1] ([`Contact::kinetic_share`]): 0 static,
    /// 1 kinetic, between them the blended regime of `regime_blend`.
    pub beta: f64,
    /// `Kinetic` iff β = 1; `Static` otherwise (including blended frames,
    /// whose static shear limit is (1 − β) μs λn).
    pub regime: Regime,
}

/// The weighting function of eq. 8,
/// w(d) = ½ [1 + tanh(−π (2 (d − d_tol) − d_trans) / d_trans)],
/// which falls from ≈1 at d ≤ d_tol through ½ at d_tol + d_trans/2 to ≈0 at
/// d_tol + d_trans. As in the plugin, w = 0 exactly beyond d_tol + d_trans
/// (a step of (1 − tanh π)/2 ≈ 0.0019), so a separated contact is switched
/// off completely ("deactivated as soon as w(d) = 0", §2.2.1). With
/// d_tol < 0 the distance has no effect: w = 1.
pub fn weight(d: f64, d_tol: f64, d_trans: f64) -> f64 {
    if d_tol < 0.0 {
        return 1.0;
    }
    if d > d_tol + d_trans {
        return 0.0;
    }
    let arg = -std::f64::consts::PI * (2.0 * (d - d_tol) - d_trans) / d_trans;
    0.5 * (1.0 + arg.tanh())
}

impl Contact {
    /// Geometry at the current frame. Needs positions and velocities in
    /// `data` ([`crate::dynamics::kinematics::full`]).
    pub fn state(&self, _model: &Model, data: &Data) -> ContactState {
        let (a, b) = (self.point_body, self.plane_body);
        let r_b = data.rotation[b];
        let p = data.station_position(a, &self.point);
        let o = data.station_position(b, &self.origin);
        let n = r_b * self.normal;
        let d = (p - o).dot(&n);
        let p_star = p - n * d;
        // Velocity of p relative to the material point of B's surface at p
        // (a moving surface, `plane_velocity`, slides over B).
        let v_b = data.velocity[b]
            + data.omega[b].cross(&(p - data.position[b]))
            + r_b * self.surface_velocity;
        let v_rel = data.station_velocity(a, &self.point) - v_b;
        let slip = v_rel - n * v_rel.dot(&n);
        let slip_speed = slip.norm();
        let beta = self.kinetic_share(slip_speed);
        ContactState {
            distance: d,
            weight: weight(d, self.d_tol, self.d_trans) * self.speed_factor(slip_speed),
            point_ground: p,
            projection_ground: p_star,
            normal_ground: n,
            e1_ground: r_b * self.e1,
            e2_ground: r_b * self.e2,
            slip_velocity: slip,
            slip_speed,
            beta,
            regime: if beta >= 1.0 {
                Regime::Kinetic
            } else {
                Regime::Static
            },
        }
    }

    /// Which side of the plane the point body lies on, at the positions in
    /// `data` ([`crate::dynamics::kinematics::positions`]): the signed
    /// distances (m, positive on the normal's side) of the point p and of
    /// the point body's mass centre from the plane. A contact pushes its
    /// point body along +n (λn ≥ 0), away from the plane, so a body whose
    /// mass centre lies behind the plane would be pulled through it: the
    /// normal faces away from the body (`--check` says so). None when the
    /// point body has no mass (ground, a massless frame body).
    pub fn sides(&self, model: &Model, data: &Data) -> Option<(f64, f64)> {
        let (a, b) = (self.point_body, self.plane_body);
        let body = &model.bodies[a];
        if a == 0 || body.mass <= 0.0 {
            return None;
        }
        let n = data.rotation[b] * self.normal;
        let o = data.station_position(b, &self.origin);
        let p = data.station_position(a, &self.point);
        let com = data.station_position(a, &body.mass_center);
        Some(((p - o).dot(&n), (com - o).dot(&n)))
    }

    /// Whether the contact is off at time `t` (`off_intervals`).
    pub fn is_off_at(&self, t: f64) -> bool {
        self.off_intervals.iter().any(|&(a, b)| t >= a && t < b)
    }

    /// Whether the contact is held at time `t` (`held_intervals`).
    pub fn is_held_at(&self, t: f64) -> bool {
        self.held_intervals.iter().any(|&(a, b)| t >= a && t < b)
    }

    /// `st` as a held contact has it (`held_intervals`): on the floor
    /// whatever its slip, so its weight is w(d) alone (no slip-speed gate)
    /// and its regime static.
    pub fn hold(&self, st: &mut ContactState) {
        st.weight = weight(st.distance, self.d_tol, self.d_trans);
        st.beta = 0.0;
        st.regime = Regime::Static;
    }

    /// The factor of `time_weight` at time `t`: linear between its knots,
    /// the first (last) knot's value before (after) them; 1 without knots.
    pub fn time_factor(&self, t: f64) -> f64 {
        let k = &self.time_weight;
        match k.len() {
            0 => 1.0,
            _ if t <= k[0].0 => k[0].1,
            n if t >= k[n - 1].0 => k[n - 1].1,
            _ => {
                let i = k.partition_point(|p| p.0 <= t);
                let (a, b) = (k[i - 1], k[i]);
                a.1 + (b.1 - a.1) * (t - a.0) / (b.0 - a.0)
            }
        }
    }

    /// The slip-speed factor of the weight (`speed_weight`, statopt): 1 up
    /// to s_full, 0 from s_zero, the C¹ smoothstep 1 − (3x² − 2x³) between
    /// (x = (s − s_full)/(s_zero − s_full)); 1 when the property is absent.
    pub fn speed_factor(&self, s: f64) -> f64 {
        match self.speed_weight {
            None => 1.0,
            Some((full, zero)) => {
                let x = ((s - full) / (zero - full)).clamp(0.0, 1.0);
                1.0 - x * x * (3.0 - 2.0 * x)
            }
        }
    }

    /// The kinetic share β of slip speed `s` (module doc): the hard switch
    /// (0 at s ≤ v_trans, 1 above) when `regime_blend` is 0, else the C¹
    /// smoothstep across [v_trans − h/2, v_trans + h/2].
    pub fn kinetic_share(&self, s: f64) -> f64 {
        let h = self.regime_blend;
        if h <= 0.0 {
            return if s > self.v_trans { 1.0 } else { 0.0 };
        }
        let x = ((s - self.v_trans + 0.5 * h) / h).clamp(0.0, 1.0);
        x * x * (3.0 - 2.0 * x)
    }

    /// Static friction coefficient left to the free shear multipliers:
    /// (1 − β) μs (μs itself with the hard switch in the static regime).
    pub fn static_limit(&self, st: &ContactState) -> f64 {
        (1.0 - st.beta) * self.mu_s
    }

    /// Kinetic shear direction scaled by μk β in a blended frame
    /// (0 < β < 1): the in-plane force on the plane body per unit of the
    /// normal force component. Zero without slip and outside the blend, so
    /// the static-model columns and forces of a fully static or kinetic
    /// state are the paper's eq. 1.
    fn blended_shear(&self, st: &ContactState) -> Vector3<f64> {
        if st.beta > 0.0 && st.beta < 1.0 && st.slip_speed > 0.0 {
            st.slip_velocity * (st.beta * self.mu_k / st.slip_speed)
        } else {
            Vector3::zeros()
        }
    }

    /// Add to `gen` the generalized force of the pair: `f_plane` on body B
    /// at p*, and −`f_plane` on body A at p.
    fn add_pair(
        &self,
        model: &Model,
        data: &Data,
        st: &ContactState,
        f_plane: &Vector3<f64>,
        gen: &mut [f64],
    ) {
        add_point_force(
            model,
            data,
            self.plane_body,
            &st.projection_ground,
            f_plane,
            gen,
        );
        add_point_force(
            model,
            data,
            self.point_body,
            &st.point_ground,
            &(-f_plane),
            gen,
        );
    }

    /// Add to `out[i]` (each of length nq) the generalized force produced by
    /// multiplier i = (λn, λs1, λs2) at value 1 and the others 0, in the
    /// static-regime model (eq. 1 × F0): on the plane body at p*,
    /// −w F0 n, +w F0 e1, +w F0 e2; on the point body at p, the opposite.
    /// In a blended frame (0 < β < 1) the normal column also carries the
    /// kinetic shear w F0 β μk v̂ (module doc). Positions in `data` must be
    /// current.
    pub fn add_unit_generalized_forces(
        &self,
        model: &Model,
        data: &Data,
        st: &ContactState,
        out: &mut [Vec<f64>; 3],
    ) {
        let s = st.weight * self.optimal_force;
        if s == 0.0 {
            return;
        }
        let dirs = [
            self.blended_shear(st) - st.normal_ground,
            st.e1_ground,
            st.e2_ground,
        ];
        for (col, dir) in out.iter_mut().zip(dirs) {
            self.add_pair(model, data, st, &(dir * s), col);
        }
    }

    /// Kinetic regime: add to `gen` the generalized force of λn = 1 with the
    /// shear that eq. 3 attaches to it: w F0 (−n + μk v̂) on the plane body at
    /// p*, w F0 (n − μk v̂) on the point body at p (v̂ = slip direction; see
    /// the module doc for the signs). With zero slip the shear is omitted.
    pub fn add_kinetic_normal_column(
        &self,
        model: &Model,
        data: &Data,
        st: &ContactState,
        gen: &mut [f64],
    ) {
        let f = self.kinetic_plane_force(st, 1.0);
        if f != Vector3::zeros() {
            self.add_pair(model, data, st, &f, gen);
        }
    }

    /// Force on the plane body for normal multiplier `lambda_n` in the
    /// kinetic regime.
    fn kinetic_plane_force(&self, st: &ContactState, lambda_n: f64) -> Vector3<f64> {
        let s = st.weight * self.optimal_force * lambda_n;
        let shear = if st.slip_speed > 0.0 {
            st.slip_velocity * (self.mu_k / st.slip_speed)
        } else {
            Vector3::zeros()
        };
        (shear - st.normal_ground) * s
    }

    /// Contact forces for multipliers `lambda` = (λn, λs1, λs2), in ground:
    /// (force on the point body, its application point p, force on the plane
    /// body). The plane-body force acts at `st.projection_ground` (p*). With
    /// `kinetic`, λs1 and λs2 are ignored and the shear follows eq. 3;
    /// otherwise a blended frame adds β μk λn v̂ to the free shear.
    pub fn forces(
        &self,
        st: &ContactState,
        lambda: [f64; 3],
        kinetic: bool,
    ) -> (Vector3<f64>, Vector3<f64>, Vector3<f64>) {
        let f_plane = if kinetic {
            self.kinetic_plane_force(st, lambda[0])
        } else {
            ((self.blended_shear(st) - st.normal_ground) * lambda[0]
                + st.e1_ground * lambda[1]
                + st.e2_ground * lambda[2])
                * (st.weight * self.optimal_force)
        };
        (-f_plane, st.point_ground, f_plane)
    }
}
