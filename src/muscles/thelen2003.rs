//! Thelen2003Muscle curves and the rigid-tendon force used by static
//! optimization, semantics §4.3–4.4 (`OpenSim/Actuators/Thelen2003Muscle.cpp`).

use super::pennation::{significant_real, FixedWidthPennation};
use super::MuscleParams;
use crate::error::Result;
use crate::xml::Element;

/// Thelen2003Muscle-specific properties (defaults as in `constructProperties`).
#[derive(Debug, Clone, PartialEq)]
pub struct Thelen2003 {
    /// ε₀ᵀ, tendon strain at F₀ (`FmaxTendonStrain`, default 0.04).
    pub fmax_tendon_strain: f64,
    /// ε₀ᴹ, passive fiber strain at F₀ (`FmaxMuscleStrain`, default 0.6).
    pub fmax_muscle_strain: f64,
    /// γ, active force–length shape (`KshapeActive`, default 0.45).
    pub kshape_active: f64,
    /// k_PE, passive force–length shape (`KshapePassive`, default 5).
    pub kshape_passive: f64,
    /// A_f, force–velocity shape (`Af`, default 0.25).
    pub af: f64,
    /// F_len, maximum eccentric force multiplier (`Flen`, default 1.4).
    pub flen: f64,
    /// `fv_linear_extrap_threshold`, default 0.95.
    pub fv_linear_extrap_threshold: f64,
    /// `maximum_pennation_angle`, default acos(0.1).
    pub maximum_pennation_angle: f64,
    pub activation_time_constant: f64,
    pub deactivation_time_constant: f64,
    /// `minimum_activation`, default 0.01 (must be ≥ 0.01).
    pub minimum_activation: f64,
    /// Pennation model built from l_o, φ_o and φ_max.
    pub pennation: FixedWidthPennation,
}

impl Thelen2003 {
    /// Read the Thelen-specific properties of `el` (common properties are
    /// already in `params`) and apply OpenSim's validation
    /// (`Thelen2003Muscle::extendFinalizeFromProperties`).
    pub(crate) fn from_xml(el: &Element, params: &MuscleParams) -> Result<Thelen2003> {
        let (max_pen_default, min_act_default) = crate::muscles::submodel_defaults(el)?;
        let maximum_pennation_angle =
            el.child_f64_or("maximum_pennation_angle", max_pen_default)?;
        let t = Thelen2003 {
            fmax_tendon_strain: el.child_f64_or("FmaxTendonStrain", 0.04)?,
            fmax_muscle_strain: el.child_f64_or("FmaxMuscleStrain", 0.6)?,
            kshape_active: el.child_f64_or("KshapeActive", 0.45)?,
            kshape_passive: el.child_f64_or("KshapePassive", 5.0)?,
            af: el.child_f64_or("Af", 0.25)?,
            flen: el.child_f64_or("Flen", 1.4)?,
            fv_linear_extrap_threshold: el.child_f64_or("fv_linear_extrap_threshold", 0.95)?,
            maximum_pennation_angle,
            activation_time_constant: el.child_f64_or("activation_time_constant", 0.015)?,
            deactivation_time_constant: el.child_f64_or("deactivation_time_constant", 0.050)?,
            minimum_activation: el.child_f64_or("minimum_activation", min_act_default)?,
            pennation: FixedWidthPennation::new(
                params.optimal_fiber_length,
                params.pennation_angle_at_optimal,
                maximum_pennation_angle,
            )
            .map_err(|m| el.error(m))?,
        };
        let checks: [(bool, &str); 9] = [
            (
                t.fmax_tendon_strain > 0.0,
                "FmaxTendonStrain must be greater than zero",
            ),
            (
                t.fmax_muscle_strain > 0.0,
                "FmaxMuscleStrain must be greater than zero",
            ),
            (
                t.kshape_active > 0.0,
                "KshapeActive must be greater than zero",
            ),
            (
                t.kshape_passive > 0.0,
                "KshapePassive must be greater than zero",
            ),
            (t.af > 0.0, "Af must be greater than zero"),
            (t.flen > 1.0, "Flen must be greater than 1.0"),
            (
                t.fv_linear_extrap_threshold > 1.0 / t.flen,
                "fv_linear_extrap_threshold must be greater than 1.0/Flen",
            ),
            (
                t.minimum_activation >= 0.01,
                "minimum_activation cannot be less than 0.01",
            ),
            (
                params.min_control >= t.minimum_activation,
                "min_control cannot be less than minimum_activation",
            ),
        ];
        for (ok, msg) in checks {
            if !ok {
                return Err(el.error(format!("Thelen2003Muscle: {msg}")));
            }
        }
        if !(t.activation_time_constant > 0.0 && t.deactivation_time_constant > 0.0) {
            return Err(el.error(
                "Thelen2003Muscle: activation and deactivation time constants must be positive",
            ));
        }
        Ok(t)
    }

    /// Active force–length multiplier f_L(l̃) (`calcfal`).
    pub fn fal(&self, norm_fiber_length: f64) -> f64 {
        active_force_length(norm_fiber_length, self.kshape_active)
    }

    /// Passive force–length multiplier f_PE(l̃) (`calcfpe`).
    pub fn fpe(&self, norm_fiber_length: f64) -> f64 {
        passive_force_length(
            norm_fiber_length,
            self.fmax_muscle_strain,
            self.kshape_passive,
        )
    }

    /// Tendon force–length multiplier f_T(l_T/l_s) (`calcfse`).
    pub fn fse(&self, norm_tendon_length: f64) -> f64 {
        tendon_force_length(norm_tendon_length, self.fmax_tendon_strain)
    }

    /// Normalised fiber velocity for a given active fiber force a·f_L·f_V
    /// (`calcdlceN`, Thelen 2003 Eqs. 6–7 with linear extrapolation).
    pub fn norm_fiber_velocity(&self, act: f64, fal: f64, act_fal_fv: f64) -> f64 {
        self.dlce_n_and_slope(act, fal, act_fal_fv).0
    }

    /// (ṽ, ∂ṽ/∂F_m) as `calcdlceN` and `calcDdlceDaFalFv` compute them.
    fn dlce_n_and_slope(&self, act: f64, fal: f64, fm: f64) -> (f64, f64) {
        let af = self.af;
        let flen = self.flen;
        let afl = act * fal;
        let k = 0.25 + 0.75 * act;
        let fm_asy_c = 0.0;
        let fm_asy_e = afl * flen;
        let thr = self.fv_linear_extrap_threshold;
        let conc = |f: f64| (afl + f / af, 1.0 / af);
        let ecc = |f: f64| {
            (
                (2.0 + 2.0 / af) * (afl * flen - f) / (flen - 1.0),
                -(2.0 + 2.0 / af) / (flen - 1.0),
            )
        };
        if fm > fm_asy_c && fm < fm_asy_e * thr {
            let (b, db) = if fm <= afl { conc(fm) } else { ecc(fm) };
            let v = k * (fm - afl) / b;
            let dv = k / b - (k * (fm - afl) / (b * b)) * db;
            (v, dv)
        } else {
            let (fm0, (b, db)) = if fm <= fm_asy_c {
                (fm_asy_c, conc(fm_asy_c))
            } else {
                let f0 = thr * fm_asy_e;
                (f0, ecc(f0))
            };
            let v0 = k * (fm0 - afl) / b;
            let dv = k / b - (k * (fm0 - afl) / (b * b)) * db;
            (v0 + dv * (fm - fm0), dv)
        }
    }

    /// Force–velocity multiplier by Newton inversion of the Thelen curve
    /// (`calcfvInv`: start at f_V = 1, stop when |ṽ(F_m) − ṽ| < `tolerance`,
    /// at most `max_iterations`). Like OpenSim, the step computed in the
    /// converging iteration is still applied. `None` where OpenSim throws
    /// (no convergence).
    pub fn fv_inv(
        &self,
        act: f64,
        fal: f64,
        norm_fiber_velocity: f64,
        tolerance: f64,
        max_iterations: usize,
    ) -> Option<f64> {
        let sig = significant_real();
        let mut ferr: f64 = 1.0;
        let mut iter = 0;
        let mut fm = act * fal; // f_V = 1
        while ferr.abs() >= tolerance && iter < max_iterations {
            (fm, ferr) = self.fv_inv_step(act, fal, norm_fiber_velocity, fm, sig);
            iter += 1;
        }
        if ferr.abs() < tolerance {
            Some((fm / (act * fal)).max(0.0))
        } else {
            None
        }
    }

    /// One Newton step of [`fv_inv`](Self::fv_inv) from `fm`: the new f
    /// and the velocity error before it.
    #[inline(always)]
    fn fv_inv_step(
        &self,
        act: f64,
        fal: f64,
        norm_fiber_velocity: f64,
        fm: f64,
        sig: f64,
    ) -> (f64, f64) {
        let (v, dv) = self.dlce_n_and_slope(act, fal, fm);
        let ferr = v - norm_fiber_velocity;
        let fm = if dv.abs() > sig { fm - ferr / dv } else { fm };
        (fm, ferr)
    }

    /// Closed-form f_V at full activation (§4.3), using this muscle's
    /// A_f, F_len and extrapolation threshold.
    pub fn fv_full_activation(&self, norm_fiber_velocity: f64) -> f64 {
        force_velocity(
            norm_fiber_velocity,
            self.af,
            self.flen,
            self.fv_linear_extrap_threshold,
        )
    }

    /// `calcInextensibleTendonActiveFiberForce(s, 1.0)` (§4.4): rigid tendon
    /// at slack length, full activation.
    pub fn max_active_fiber_force_rigid_tendon(
        &self,
        p: &MuscleParams,
        length: f64,
        lengthening_speed: f64,
    ) -> f64 {
        let pen = &self.pennation;
        let lce = pen.fiber_length(length, p.tendon_slack_length);
        if !(lce > pen.minimum_fiber_length) {
            return 0.0;
        }
        let cos_phi = pen.cos_pennation(lce);
        let vce = pen.fiber_velocity(cos_phi, lengthening_speed, 0.0);
        self.active_force_along_tendon_at(p, 1.0, lce, vce, cos_phi)
    }

    /// ([`max_active_fiber_force_rigid_tendon`], [`passive_fiber_force_rigid_tendon`])
    /// bit for bit, with the fiber length and pennation computed once.
    ///
    /// [`max_active_fiber_force_rigid_tendon`]: Self::max_active_fiber_force_rigid_tendon
    /// [`passive_fiber_force_rigid_tendon`]: Self::passive_fiber_force_rigid_tendon
    pub fn rigid_tendon_forces(
        &self,
        p: &MuscleParams,
        length: f64,
        lengthening_speed: f64,
    ) -> (f64, f64) {
        match self.rigid_tendon_forces_begin(p, length, lengthening_speed) {
            RigidTendonForces::Known(active, passive) => (active, passive),
            RigidTendonForces::NeedsFv(pending) => {
                let fv = self.fv_inv(1.0, pending.fal, pending.norm_fiber_velocity, 1e-6, 100);
                pending.finish(self, fv)
            }
        }
    }

    /// [`rigid_tendon_forces`](Self::rigid_tendon_forces) up to the
    /// force–velocity inversion: the forces, or what they still need from
    /// `fv_inv(1, f_L, ṽ, 1e-6, 100)` ([`FvPending::finish`] completes them
    /// bit for bit). `muscles::set::MuscleFrame::evaluate` inverts several
    /// muscles' curves in lockstep ([`fv_inv_lockstep`]).
    pub fn rigid_tendon_forces_begin(
        &self,
        p: &MuscleParams,
        length: f64,
        lengthening_speed: f64,
    ) -> RigidTendonForces {
        let pen = &self.pennation;
        let lce = pen.fiber_length(length, p.tendon_slack_length);
        if !(lce > pen.minimum_fiber_length) {
            return RigidTendonForces::Known(0.0, self.passive_fiber_force_rigid_tendon(p, length));
        }
        // lce > l_min: the passive force's clamped fiber length is lce.
        let cos_phi = pen.cos_pennation(lce);
        let vce = pen.fiber_velocity(cos_phi, lengthening_speed, 0.0);
        let passive = p.max_isometric_force * self.fpe(lce / p.optimal_fiber_length) * cos_phi;
        match self.active_pending(p, 1.0, lce, vce, cos_phi) {
            None => RigidTendonForces::Known(0.0, passive),
            Some((_, pending)) => RigidTendonForces::NeedsFv(FvPending { passive, ..pending }),
        }
    }

    /// `calcActiveFiberForceAlongTendon(a, l^M, v^M)`.
    pub fn active_fiber_force_along_tendon(
        &self,
        p: &MuscleParams,
        activation: f64,
        fiber_length: f64,
        fiber_velocity: f64,
    ) -> f64 {
        let pen = &self.pennation;
        if !(fiber_length > pen.minimum_fiber_length) {
            return 0.0;
        }
        let cos_phi = pen.cos_pennation(fiber_length);
        self.active_force_along_tendon_at(p, activation, fiber_length, fiber_velocity, cos_phi)
    }

    /// [`active_fiber_force_along_tendon`](Self::active_fiber_force_along_tendon)
    /// for a fiber longer than l_min whose cos(pennation) is `cos_phi`.
    fn active_force_along_tendon_at(
        &self,
        p: &MuscleParams,
        activation: f64,
        fiber_length: f64,
        fiber_velocity: f64,
        cos_phi: f64,
    ) -> f64 {
        match self.active_pending(p, activation, fiber_length, fiber_velocity, cos_phi) {
            None => 0.0,
            Some((a, pending)) => {
                let fv = self.fv_inv(a, pending.fal, pending.norm_fiber_velocity, 1e-6, 100);
                pending.finish(self, fv).0
            }
        }
    }

    /// The active force along the tendon up to its force–velocity
    /// multiplier: the clamped activation and the rest (no passive force),
    /// or None when there is no active force (f_L underflowed: OpenSim
    /// would divide 0/0).
    fn active_pending(
        &self,
        p: &MuscleParams,
        activation: f64,
        fiber_length: f64,
        fiber_velocity: f64,
        cos_phi: f64,
    ) -> Option<(f64, FvPending)> {
        let pen = &self.pennation;
        let a = activation.clamp(self.minimum_activation.min(1.0), 1.0);
        let lce_n = pen.clamp_fiber_length(fiber_length) / p.optimal_fiber_length;
        let v_n = fiber_velocity / (p.optimal_fiber_length * p.max_contraction_velocity);
        let fal = self.fal(lce_n);
        (a * fal > 0.0).then(|| {
            (
                a,
                FvPending {
                    fal,
                    norm_fiber_velocity: v_n,
                    scale: p.max_isometric_force * a * fal,
                    cos_phi,
                    passive: 0.0,
                },
            )
        })
    }

    /// Passive fiber force along the tendon with a rigid tendon: fiber length
    /// from the path with the tendon at slack length, clamped at l_min, then
    /// F₀ f_PE(l̃) cos φ (as `calcMuscleLengthInfo` does for a fiber-length state).
    pub fn passive_fiber_force_rigid_tendon(&self, p: &MuscleParams, length: f64) -> f64 {
        let pen = &self.pennation;
        let lce = pen.clamp_fiber_length(pen.fiber_length(length, p.tendon_slack_length));
        p.max_isometric_force * self.fpe(lce / p.optimal_fiber_length) * pen.cos_pennation(lce)
    }
}

/// [`Thelen2003::rigid_tendon_forces_begin`]'s answer.
#[derive(Debug, Clone, Copy)]
pub enum RigidTendonForces {
    /// (maximum active force, passive force): no active force (fiber at
    /// its minimum length, or f_L underflowed).
    Known(f64, f64),
    /// The forces but for the force–velocity multiplier.
    NeedsFv(FvPending),
}

/// A rigid-tendon strength waiting for its f_V.
#[derive(Debug, Clone, Copy)]
pub struct FvPending {
    /// f_L and ṽ, the arguments of the inversion.
    pub fal: f64,
    pub norm_fiber_velocity: f64,
    /// F₀ · a · f_L (in that order), cos φ and the passive force.
    scale: f64,
    cos_phi: f64,
    passive: f64,
}

impl FvPending {
    /// (maximum active force, passive force) with `fv`, the result of
    /// `fv_inv(a, f_L, ṽ, 1e-6, 100)` (None, where OpenSim throws: the
    /// closed form at full activation, the exact inverse there and the best
    /// available answer otherwise).
    pub fn finish(&self, muscle: &Thelen2003, fv: Option<f64>) -> (f64, f64) {
        let fv = fv.unwrap_or_else(|| muscle.fv_full_activation(self.norm_fiber_velocity));
        (self.scale * fv * self.cos_phi, self.passive)
    }
}

/// `muscles[l].fv_inv(1, pending[l].fal, pending[l].norm_fiber_velocity,
/// 1e-6, 100)` for every lane, bit for bit, with the lanes' Newton steps
/// interleaved: each lane runs the same operations as alone and stops on
/// its own test, but the independent chains of divisions overlap (about
/// a sixth of static optimization's frame on gait2392 was these chains).
pub fn fv_inv_lockstep<const L: usize>(
    muscles: [&Thelen2003; L],
    pending: &[FvPending; L],
) -> [Option<f64>; L] {
    const TOLERANCE: f64 = 1e-6;
    const MAX_ITERATIONS: usize = 100;
    let act = 1.0;
    let sig = significant_real();
    let mut ferr = [1.0f64; L];
    let mut fm: [f64; L] = std::array::from_fn(|l| act * pending[l].fal);
    let mut iter = 0;
    while iter < MAX_ITERATIONS {
        let mut any = false;
        for l in 0..L {
            if ferr[l].abs() >= TOLERANCE {
                let p = &pending[l];
                (fm[l], ferr[l]) =
                    muscles[l].fv_inv_step(act, p.fal, p.norm_fiber_velocity, fm[l], sig);
                any = true;
            }
        }
        if !any {
            break;
        }
        iter += 1;
    }
    std::array::from_fn(|l| {
        (ferr[l].abs() < TOLERANCE).then(|| (fm[l] / (act * pending[l].fal)).max(0.0))
    })
}

/// Active force–length f_L(l̃) = exp(−(l̃−1)²/γ).
pub fn active_force_length(norm_fiber_length: f64, kshape_active: f64) -> f64 {
    let x = (norm_fiber_length - 1.0) * (norm_fiber_length - 1.0);
    (-x / kshape_active).exp()
}

/// Passive force–length f_PE(l̃) = (exp(k_PE (l̃−1)/ε₀ᴹ) − 1)/(exp(k_PE) − 1)
/// for l̃ > 1, else 0.
pub fn passive_force_length(
    norm_fiber_length: f64,
    fmax_muscle_strain: f64,
    kshape_passive: f64,
) -> f64 {
    if norm_fiber_length > 1.0 {
        ((kshape_passive * (norm_fiber_length - 1.0) / fmax_muscle_strain).exp() - 1.0)
            / (kshape_passive.exp() - 1.0)
    } else {
        0.0
    }
}

/// Tendon force–strain f_T(l_T/l_s) with the exponential toe
/// (k_toe = 3, F_toe = 0.33) and the linear part above ε_toe.
pub fn tendon_force_length(norm_tendon_length: f64, fmax_tendon_strain: f64) -> f64 {
    let x = norm_tendon_length - 1.0;
    let e0 = fmax_tendon_strain;
    let k_toe: f64 = 3.0;
    let f_toe = 33.0 / 100.0;
    let e3 = 3.0f64.exp();
    let e_toe = (99.0 * e0 * e3) / (166.0 * e3 - 67.0);
    let k_lin = (67.0 / 100.0) * 1.0 / (e0 - e_toe);
    if x > e_toe {
        k_lin * (x - e_toe) + f_toe
    } else if x > 0.0 {
        (f_toe / (k_toe.exp() - 1.0)) * ((k_toe * x / e_toe).exp() - 1.0)
    } else {
        0.0
    }
}

/// Closed-form force–velocity multiplier at full activation (§4.3), for
/// normalised fiber velocity ṽ = v^M/(l_o v_max) (lengthening positive):
/// concentric (1+ṽ)/(1−ṽ/A_f) clipped at 0, eccentric
/// (1+ṽcF_len)/(1+ṽc) with c = (2+2/A_f)/(F_len−1), and linear beyond the
/// extrapolation threshold (`threshold`·F_len).
pub fn force_velocity(norm_fiber_velocity: f64, af: f64, flen: f64, threshold: f64) -> f64 {
    let v = norm_fiber_velocity;
    if v <= 0.0 {
        ((1.0 + v) / (1.0 - v / af)).max(0.0)
    } else {
        let c = (2.0 + 2.0 / af) / (flen - 1.0);
        let fv0 = threshold * flen;
        let v_thr = (fv0 - 1.0) / (c * (flen - fv0));
        if v < v_thr {
            (1.0 + v * c * flen) / (1.0 + v * c)
        } else {
            let s = (flen - 1.0) / (c * (flen - fv0) * (flen - fv0));
            fv0 + (v - v_thr) / s
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn default_thelen() -> Thelen2003 {
        Thelen2003 {
            fmax_tendon_strain: 0.04,
            fmax_muscle_strain: 0.6,
            kshape_active: 0.45,
            kshape_passive: 5.0,
            af: 0.25,
            flen: 1.4,
            fv_linear_extrap_threshold: 0.95,
            maximum_pennation_angle: 0.1f64.acos(),
            activation_time_constant: 0.015,
            deactivation_time_constant: 0.05,
            minimum_activation: 0.01,
            pennation: FixedWidthPennation::new(0.1, 0.0, 0.1f64.acos()).unwrap(),
        }
    }

    #[test]
    fn tendon_curve_reaches_one_at_fmax_strain_and_is_continuous() {
        // Closed-form facts: f_T(1+ε₀ᵀ) = 1, f_T(1+ε_toe) = 0.33 from both sides.
        for e0 in [0.033, 0.04] {
            assert_relative_eq!(tendon_force_length(1.0 + e0, e0), 1.0, max_relative = 1e-12);
            let e3 = 3.0f64.exp();
            let etoe = 99.0 * e0 * e3 / (166.0 * e3 - 67.0);
            let lo = tendon_force_length(1.0 + etoe * (1.0 - 1e-12), e0);
            let hi = tendon_force_length(1.0 + etoe * (1.0 + 1e-12), e0);
            assert_relative_eq!(lo, 0.33, max_relative = 1e-9);
            assert_relative_eq!(hi, 0.33, max_relative = 1e-9);
        }
        assert_eq!(tendon_force_length(0.99, 0.04), 0.0);
    }

    #[test]
    fn passive_curve_is_one_at_fmax_muscle_strain() {
        assert_relative_eq!(
            passive_force_length(1.6, 0.6, 5.0),
            1.0,
            max_relative = 1e-14
        );
        assert_eq!(passive_force_length(0.9, 0.6, 5.0), 0.0);
    }

    #[test]
    fn closed_form_fv_matches_newton_inverse_at_full_activation() {
        let t = default_thelen();
        for i in -150..=250 {
            let v = i as f64 * 0.01;
            let fal = 0.8;
            let newton = t.fv_inv(1.0, fal, v, 1e-12, 100).unwrap();
            let closed = t.fv_full_activation(v);
            assert!(
                (newton - closed).abs() < 1e-9,
                "v={v}: newton {newton} closed {closed}"
            );
        }
    }

    /// The lockstep inversion equals each lane's own `fv_inv` bit for bit:
    /// lanes of different muscles (A_f, F_len, threshold) that converge
    /// after different numbers of steps, in the linear extrapolations on
    /// both sides, with a NaN speed (no convergence: None) beside them.
    #[test]
    fn lockstep_inversion_is_each_lanes_inversion_bit_for_bit() {
        let mut muscles = Vec::new();
        for (af, flen, thr) in [(0.25, 1.4, 0.95), (0.3, 1.8, 0.9), (0.1, 1.2, 0.99)] {
            let mut t = default_thelen();
            (t.af, t.flen, t.fv_linear_extrap_threshold) = (af, flen, thr);
            muscles.push(t);
        }
        let mut state = 0x9E3779B97F4A7C15u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut steps_seen, mut none_seen) = (std::collections::BTreeSet::new(), 0);
        for case in 0..20_000 {
            let ts: [&Thelen2003; 4] = std::array::from_fn(|_| &muscles[(next() * 3.0) as usize]);
            let pending: [FvPending; 4] = std::array::from_fn(|l| {
                let v = if case % 97 == 0 && l == 2 {
                    f64::NAN
                } else {
                    -2.0 + 5.0 * next()
                };
                FvPending {
                    fal: 1e-3 + 1.2 * next(),
                    norm_fiber_velocity: v,
                    scale: 0.0,
                    cos_phi: 1.0,
                    passive: 0.0,
                }
            });
            let got = fv_inv_lockstep(ts, &pending);
            for l in 0..4 {
                let (t, p) = (ts[l], &pending[l]);
                let want = t.fv_inv(1.0, p.fal, p.norm_fiber_velocity, 1e-6, 100);
                assert_eq!(
                    got[l].map(f64::to_bits),
                    want.map(f64::to_bits),
                    "case {case} lane {l}"
                );
                none_seen += usize::from(want.is_none());
                // Steps this lane took alone.
                let (mut fm, mut ferr, mut k) = (p.fal, 1.0f64, 0);
                while ferr.abs() >= 1e-6 && k < 100 {
                    (fm, ferr) =
                        t.fv_inv_step(1.0, p.fal, p.norm_fiber_velocity, fm, significant_real());
                    k += 1;
                }
                steps_seen.insert(k);
            }
        }
        assert!(none_seen > 0, "no lane without convergence");
        assert!(
            steps_seen.len() >= 4,
            "iteration counts seen: {steps_seen:?}"
        );
    }

    #[test]
    fn fv_is_zero_at_vmax_and_continuous_at_threshold() {
        assert_eq!(force_velocity(-1.0, 0.25, 1.4, 0.95), 0.0);
        assert_eq!(force_velocity(-1.5, 0.25, 1.4, 0.95), 0.0);
        assert_eq!(force_velocity(0.0, 0.25, 1.4, 0.95), 1.0);
        let c = (2.0 + 2.0 / 0.25) / 0.4;
        let vthr = (0.95 * 1.4 - 1.0) / (0.05 * c * 1.4);
        let below = force_velocity(vthr * (1.0 - 1e-12), 0.25, 1.4, 0.95);
        let above = force_velocity(vthr * (1.0 + 1e-12), 0.25, 1.4, 0.95);
        assert_relative_eq!(below, 0.95 * 1.4, max_relative = 1e-9);
        assert_relative_eq!(above, 0.95 * 1.4, max_relative = 1e-9);
    }
}
