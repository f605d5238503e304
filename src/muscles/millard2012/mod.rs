//! Millard2012EquilibriumMuscle, as far as static optimization needs it:
//! its properties, its four curves and the rigid-tendon forces, semantics
//! §4.4–4.5 (`OpenSim/Actuators/Millard2012EquilibriumMuscle.cpp`).

pub mod bezier;
pub mod curves;

pub use bezier::SmoothSegmentedFunction;
pub use curves::{
    ActiveForceLengthCurve, FiberForceLengthCurve, ForceVelocityCurve, TendonForceLengthCurve,
};

use super::pennation::{significant_real, FixedWidthPennation};
use super::MuscleParams;
use crate::error::Result;
use crate::xml::Element;

/// Below this `fiber_damping` the undamped (classic Hill) model is used.
pub const MIN_NONZERO_DAMPING_COEFFICIENT: f64 = 0.001;

/// Millard2012EquilibriumMuscle-specific properties and curves. The curves
/// are stored as `extendFinalizeFromProperties` leaves them: for the damped
/// model (or a rigid tendon) the active force–length floor is set to 0 and
/// the force–velocity end slopes to 0; for the undamped model with an
/// elastic tendon the floor is raised to at least 0.1 and the end slopes to
/// at least half the near-vmax slopes.
#[derive(Debug, Clone, PartialEq)]
pub struct Millard2012 {
    pub fiber_damping: f64,
    pub default_activation: f64,
    pub default_fiber_length: f64,
    pub activation_time_constant: f64,
    pub deactivation_time_constant: f64,
    pub minimum_activation: f64,
    pub maximum_pennation_angle: f64,
    pub active_force_length: ActiveForceLengthCurve,
    pub force_velocity: ForceVelocityCurve,
    pub fiber_force_length: FiberForceLengthCurve,
    pub tendon_force_length: TendonForceLengthCurve,
    pub pennation: FixedWidthPennation,
    /// max(SignificantReal, l̃_min,active·l_o, pennation l_min) [m].
    pub minimum_fiber_length: f64,
}

impl Millard2012 {
    /// Read the Millard-specific properties of `el` (common properties are
    /// already in `params`) and finalize as OpenSim does.
    pub(crate) fn from_xml(el: &Element, params: &MuscleParams) -> Result<Millard2012> {
        let (max_pen_default, min_act_default) = crate::muscles::submodel_defaults(el)?;
        let fiber_damping = el.child_f64_or("fiber_damping", 0.1)?;
        let maximum_pennation_angle =
            el.child_f64_or("maximum_pennation_angle", max_pen_default)?;
        let mut minimum_activation = el.child_f64_or("minimum_activation", min_act_default)?;
        let mut fal = ActiveForceLengthCurve::from_xml(el.child("ActiveForceLengthCurve"))?;
        let mut fv = ForceVelocityCurve::from_xml(el.child("ForceVelocityCurve"))?;
        let fpe = FiberForceLengthCurve::from_xml(el.child("FiberForceLengthCurve"))?;
        let fse = TendonForceLengthCurve::from_xml(el.child("TendonForceLengthCurve"))?;
        let fv_el = el.child("ForceVelocityCurve").unwrap_or(el);
        let fal_el = el.child("ActiveForceLengthCurve").unwrap_or(el);

        let use_fiber_damping = fiber_damping >= MIN_NONZERO_DAMPING_COEFFICIENT;
        let fiber_damping = if use_fiber_damping {
            fiber_damping
        } else {
            0.0
        };
        let sqrt_eps = f64::EPSILON.sqrt();
        if fv.concentric_slope_near_vmax < sqrt_eps {
            return Err(fv_el.error("concentric_slope_near_vmax cannot be less than 1.49e-8"));
        }
        if fv.eccentric_slope_near_vmax < sqrt_eps {
            return Err(fv_el.error("eccentric_slope_near_vmax cannot be less than 1.49e-8"));
        }
        let mut con_at = fv.concentric_slope_at_vmax;
        let mut ecc_at = fv.eccentric_slope_at_vmax;
        if !params.ignore_tendon_compliance && !use_fiber_damping {
            // Classic Hill model with an elastic tendon.
            if minimum_activation < 0.01 {
                return Err(el.error(
                    "Millard2012EquilibriumMuscle: minimum_activation cannot be less than 0.01 \
                     for the undamped model with an elastic tendon",
                ));
            }
            if params.min_control < minimum_activation {
                return Err(el.error(
                    "Millard2012EquilibriumMuscle: min_control cannot be less than minimum_activation",
                ));
            }
            if fal.minimum_value < 0.1 {
                fal = fal.with_minimum_value(0.1).map_err(|m| fal_el.error(m))?;
            }
            con_at = con_at.max(fv.concentric_slope_near_vmax * 0.5);
            ecc_at = ecc_at.max(fv.eccentric_slope_near_vmax * 0.5);
        } else {
            if minimum_activation > 0.0
                && (minimum_activation.clamp(0.0, 1.0) - minimum_activation).abs() > f64::EPSILON
            {
                minimum_activation = minimum_activation.clamp(0.0, 1.0);
            }
            if fal.minimum_value > 0.0 {
                fal = fal.with_minimum_value(0.0).map_err(|m| fal_el.error(m))?;
            }
            con_at = con_at.min(0.0);
            ecc_at = ecc_at.min(0.0);
            if minimum_activation < 0.0 {
                return Err(el.error(
                    "Millard2012EquilibriumMuscle: minimum_activation cannot be less than zero",
                ));
            }
            if params.min_control < minimum_activation {
                return Err(el.error(
                    "Millard2012EquilibriumMuscle: min_control cannot be less than minimum_activation",
                ));
            }
        }
        if con_at != fv.concentric_slope_at_vmax || ecc_at != fv.eccentric_slope_at_vmax {
            fv = fv
                .with_slopes_at_vmax(con_at, ecc_at)
                .map_err(|m| fv_el.error(m))?;
        }

        let pennation = FixedWidthPennation::new(
            params.optimal_fiber_length,
            params.pennation_angle_at_optimal,
            maximum_pennation_angle,
        )
        .map_err(|m| el.error(m))?;
        let minimum_fiber_length = significant_real().max(
            (fal.min_norm_active_fiber_length * params.optimal_fiber_length)
                .max(pennation.minimum_fiber_length),
        );
        let activation_time_constant = el.child_f64_or("activation_time_constant", 0.010)?;
        let deactivation_time_constant = el.child_f64_or("deactivation_time_constant", 0.040)?;
        if !(activation_time_constant > 0.0 && deactivation_time_constant > 0.0) {
            return Err(el.error(
                "Millard2012EquilibriumMuscle: activation and deactivation time constants must be positive",
            ));
        }
        Ok(Millard2012 {
            fiber_damping,
            default_activation: el.child_f64_or("default_activation", 0.05)?,
            // Constructed from the default optimal fiber length (0.1 m)
            // before the XML is read, hence this default.
            default_fiber_length: el.child_f64_or("default_fiber_length", 0.1)?,
            activation_time_constant,
            deactivation_time_constant,
            minimum_activation,
            maximum_pennation_angle,
            active_force_length: fal,
            force_velocity: fv,
            fiber_force_length: fpe,
            tendon_force_length: fse,
            pennation,
            minimum_fiber_length,
        })
    }

    /// `calcInextensibleTendonActiveFiberForce(s, 1.0)` (§4.4), including
    /// OpenSim's pennation bug: the angle applied to the force is the
    /// pennation model evaluated at the *normalised* fiber length.
    pub fn max_active_fiber_force_rigid_tendon(
        &self,
        p: &MuscleParams,
        length: f64,
        lengthening_speed: f64,
    ) -> f64 {
        let pen = &self.pennation;
        let lce = pen.fiber_length(length, p.tendon_slack_length);
        let phi = pen.pennation_angle(lce);
        let dlce = pen.fiber_velocity(phi.cos(), lengthening_speed, 0.0);
        if dlce.is_nan() {
            return 0.0;
        }
        self.active_fiber_force_along_tendon(p, 1.0, lce, dlce)
    }

    /// `calcActiveFiberForceAlongTendon(a, l^M, v^M)` with the pennation bug.
    pub fn active_fiber_force_along_tendon(
        &self,
        p: &MuscleParams,
        activation: f64,
        fiber_length: f64,
        fiber_velocity: f64,
    ) -> f64 {
        if fiber_length <= self.minimum_fiber_length {
            return 0.0;
        }
        let a = activation.clamp(self.minimum_activation.min(1.0), 1.0);
        let lce_n = fiber_length / p.optimal_fiber_length;
        let dlce_n = fiber_velocity / (p.optimal_fiber_length * p.max_contraction_velocity);
        let fal = self.active_force_length.value(lce_n);
        let fv = self.force_velocity.value(dlce_n);
        // OpenSim BUG reproduced: calcPennationAngle(lceN), not (lce).
        let phi_bug = self.pennation.pennation_angle(lce_n);
        p.max_isometric_force * (a * fal * fv) * phi_bug.cos()
    }

    /// The rigid-tendon fiber length clamped at this muscle's minimum fiber
    /// length (as `calcMuscleLengthInfo` clamps the state).
    pub fn rigid_tendon_fiber_length(&self, p: &MuscleParams, length: f64) -> f64 {
        self.pennation
            .fiber_length(length, p.tendon_slack_length)
            .max(self.minimum_fiber_length)
    }

    /// Passive elastic fiber force along the tendon, rigid tendon:
    /// F₀ f_PE(l̃) cos φ(l^M) with the correct pennation angle.
    pub fn passive_fiber_force_rigid_tendon(&self, p: &MuscleParams, length: f64) -> f64 {
        let lce = self.rigid_tendon_fiber_length(p, length);
        let phi = self.pennation.pennation_angle(lce);
        p.max_isometric_force
            * self.fiber_force_length.value(lce / p.optimal_fiber_length)
            * phi.cos()
    }
}
