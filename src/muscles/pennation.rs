//! Fixed-width (constant parallelogram height) pennation model, semantics §4.2
//! (`OpenSim/Actuators/MuscleFixedWidthPennationModel.cpp`).
//!
//! The fiber is the diagonal of a parallelogram of constant height
//! h = l_o sin φ_o; the pennation angle follows from sin φ = h / l^M and is
//! capped at `maximum_pennation_angle`.

/// `SimTK::Eps`.
pub const EPS: f64 = f64::EPSILON;

/// `SimTK::SignificantReal` = Eps^(7/8) ≈ 2.0e-14.
pub fn significant_real() -> f64 {
    f64::EPSILON.powf(0.875)
}

/// The pennation model of one muscle, with its derived constants
/// (`extendFinalizeFromProperties`).
#[derive(Debug, Clone, PartialEq)]
pub struct FixedWidthPennation {
    pub optimal_fiber_length: f64,
    pub pennation_angle_at_optimal: f64,
    pub maximum_pennation_angle: f64,
    /// h = l_o sin φ_o.
    pub parallelogram_height: f64,
    /// sin φ_max.
    pub maximum_sin_pennation: f64,
    /// l_min = h / sin φ_max (or 0.01 l_o when φ_max is ~0).
    pub minimum_fiber_length: f64,
    /// l_min cos φ_max.
    pub minimum_fiber_length_along_tendon: f64,
}

impl FixedWidthPennation {
    /// Build the model; returns a message when a property is out of the range
    /// OpenSim accepts (l_o > 0, 0 ≤ φ_o < π/2, 0 ≤ φ_max ≤ π/2).
    pub fn new(
        optimal_fiber_length: f64,
        pennation_angle_at_optimal: f64,
        maximum_pennation_angle: f64,
    ) -> Result<Self, String> {
        let sig = significant_real();
        if !(optimal_fiber_length > 0.0) {
            return Err(format!(
                "optimal_fiber_length must be greater than zero (is {optimal_fiber_length})"
            ));
        }
        if !(pennation_angle_at_optimal >= 0.0
            && pennation_angle_at_optimal <= std::f64::consts::FRAC_PI_2 - sig)
        {
            return Err(format!(
                "pennation_angle_at_optimal must be in [0, pi/2) (is {pennation_angle_at_optimal})"
            ));
        }
        if !(maximum_pennation_angle >= 0.0
            && maximum_pennation_angle <= std::f64::consts::FRAC_PI_2)
        {
            return Err(format!(
                "maximum_pennation_angle must be in [0, pi/2] (is {maximum_pennation_angle})"
            ));
        }
        let h = optimal_fiber_length * pennation_angle_at_optimal.sin();
        let max_sin = maximum_pennation_angle.sin();
        let lmin = if maximum_pennation_angle > sig {
            h / max_sin
        } else {
            optimal_fiber_length * 0.01
        };
        Ok(FixedWidthPennation {
            optimal_fiber_length,
            pennation_angle_at_optimal,
            maximum_pennation_angle,
            parallelogram_height: h,
            maximum_sin_pennation: max_sin,
            minimum_fiber_length: lmin,
            minimum_fiber_length_along_tendon: lmin * maximum_pennation_angle.cos(),
        })
    }

    /// Fiber length from path length and tendon length (`calcFiberLength`):
    /// √(h² + (L − l_T)²), or l_min when the fiber would be shorter along the
    /// tendon than l_min cos φ_max.
    pub fn fiber_length(&self, muscle_length: f64, tendon_length: f64) -> f64 {
        let along = muscle_length - tendon_length;
        if along >= self.minimum_fiber_length_along_tendon {
            let h = self.parallelogram_height;
            (h * h + along * along).sqrt()
        } else {
            self.minimum_fiber_length
        }
    }

    /// Pennation angle for a fiber length (`calcPennationAngle`). Note the
    /// comparisons are against l_min in metres, whatever the argument is.
    pub fn pennation_angle(&self, fiber_length: f64) -> f64 {
        if self.pennation_angle_at_optimal > EPS {
            if fiber_length > self.minimum_fiber_length {
                let sin_phi = self.parallelogram_height / fiber_length;
                if sin_phi < self.maximum_sin_pennation {
                    sin_phi.asin()
                } else {
                    self.maximum_pennation_angle
                }
            } else {
                self.maximum_pennation_angle
            }
        } else {
            0.0
        }
    }

    /// cos of [`pennation_angle`](Self::pennation_angle), bit for bit: 1
    /// without evaluating cos(0) for a muscle that is not pennated.
    pub fn cos_pennation(&self, fiber_length: f64) -> f64 {
        if self.pennation_angle_at_optimal > EPS {
            self.pennation_angle(fiber_length).cos()
        } else {
            1.0
        }
    }

    /// Fiber velocity from musculotendon and tendon velocities
    /// (`calcFiberVelocity`): (v^MT − v^T) cos φ.
    pub fn fiber_velocity(
        &self,
        cos_pennation: f64,
        muscle_velocity: f64,
        tendon_velocity: f64,
    ) -> f64 {
        (muscle_velocity - tendon_velocity) * cos_pennation
    }

    /// Tendon length L − l^M cos φ (`calcTendonLength`).
    pub fn tendon_length(&self, cos_pennation: f64, fiber_length: f64, muscle_length: f64) -> f64 {
        muscle_length - fiber_length * cos_pennation
    }

    /// max(l_min, l) (`clampFiberLength`).
    pub fn clamp_fiber_length(&self, fiber_length: f64) -> f64 {
        self.minimum_fiber_length.max(fiber_length)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn unpennated_muscle_has_zero_angle_and_zero_min_length() {
        let p = FixedWidthPennation::new(0.1, 0.0, 0.1f64.acos()).unwrap();
        assert_eq!(p.minimum_fiber_length, 0.0);
        assert_eq!(p.pennation_angle(0.12), 0.0);
        assert_eq!(p.fiber_length(0.5, 0.38), 0.5 - 0.38);
    }

    #[test]
    fn pennated_geometry_is_a_constant_height_parallelogram() {
        let (lo, phio) = (0.05, 0.436);
        let p = FixedWidthPennation::new(lo, phio, 0.1f64.acos()).unwrap();
        // At l^M = l_o the angle is φ_o (closed form).
        assert_relative_eq!(p.pennation_angle(lo), phio, max_relative = 1e-14);
        // Fiber along tendon reproduces the path length minus tendon.
        let lm = p.fiber_length(0.30, 0.25);
        let phi = p.pennation_angle(lm);
        assert_relative_eq!(lm * phi.cos(), 0.05, max_relative = 1e-14);
        assert_relative_eq!(lm * phi.sin(), lo * phio.sin(), max_relative = 1e-14);
        // Below l_min the angle saturates at φ_max and the length is l_min.
        let lmin = lo * phio.sin() / 0.1f64.acos().sin();
        assert_relative_eq!(p.minimum_fiber_length, lmin, max_relative = 1e-15);
        assert_eq!(p.fiber_length(0.25, 0.25), lmin);
        assert_eq!(p.pennation_angle(lmin * 0.5), 0.1f64.acos());
    }

    #[test]
    fn invalid_properties_are_rejected() {
        assert!(FixedWidthPennation::new(0.0, 0.0, 1.0).is_err());
        assert!(FixedWidthPennation::new(0.1, 1.6, 1.0).is_err());
        assert!(FixedWidthPennation::new(0.1, 0.1, 1.7).is_err());
    }
}
