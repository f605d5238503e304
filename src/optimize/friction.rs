//! Static-friction constraints of a point-on-plane contact (Krüger & Wartzack
//! 2017, §2.1 eq. 2 and §2.2.4 eq. 15–16).
//!
//! Coulomb's static regime demands ‖(λs1, λs2)‖ ≤ μ_s λn (eq. 2). The paper
//! replaces this cone by the four-sided pyramid of eq. 16,
//! |λs1| ≤ μ_s λn and |λs2| ≤ μ_s λn, whose faces are *tangent* to the cone:
//! the pyramid **circumscribes** the cone (it contains it and allows up to
//! √2 μ_s λn of shear along the diagonals). We offer:
//!
//! * [`FrictionModel::Pyramid4`] — exactly eq. 16 (circumscribed, 4 faces
//!   with normals at 0°, 90°, 180°, 270° in the (e1, e2) plane);
//! * [`FrictionModel::Pyramid8`] — the **circumscribed** eight-sided pyramid,
//!   faces tangent to the cone with normals every 45°:
//!   c·λs1 + s·λs2 ≤ μ_s λn for (c, s) = (cos kπ/4, sin kπ/4). It keeps the
//!   convention of eq. 16 (an outer approximation, never stricter than
//!   Coulomb) and lies between the cone and `Pyramid4`: the shear it admits
//!   in direction φ is μ_s λn / cos δ, δ = angle from φ to the nearest face
//!   normal (≤ 22.5°, so at most 8.2 % above the cone instead of 41 %);
//! * [`FrictionModel::Cone`] — the exact second-order cone of eq. 2.
//!
//! With μ_s = 0 every model reduces to λs1 = λs2 = 0, which the solver
//! poses as equalities (a cone with an empty interior would hamper the
//! interior-point method).
use std::f64::consts::FRAC_1_SQRT_2;

/// A contact in the static friction regime (Krüger & Wartzack 2017, eq. 2
/// and 16): indices of its normal multiplier λn and its two shear
/// multipliers λs1, λs2 among the problem variables, and the static friction
/// coefficient μ_s. The friction constraint couples them as
/// ‖(λs1, λs2)‖ ≤ μ_s λn (approximated according to
/// [`super::FrameProblem::friction`]). The unilateral bound λn ≥ 0 (eq. 10) is not
/// implied by this struct: set it through [`super::FrameProblem::lower`]. (Any of the
/// friction models does force λn ≥ 0 when μ_s > 0.)
///
/// Contacts in the kinetic regime are not listed here: their shear force is
/// a fixed multiple of the normal force (eq. 3) and belongs in the columns
/// of `A` that the physics layer builds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StaticContact {
    pub normal: usize,
    pub shear: [usize; 2],
    pub mu: f64,
}

pub use crate::parse::analyses::FrictionModel;

const PYRAMID4: [(f64, f64); 4] = [(1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0)];
const PYRAMID8: [(f64, f64); 8] = [
    (1.0, 0.0),
    (-1.0, 0.0),
    (0.0, 1.0),
    (0.0, -1.0),
    (FRAC_1_SQRT_2, FRAC_1_SQRT_2),
    (FRAC_1_SQRT_2, -FRAC_1_SQRT_2),
    (-FRAC_1_SQRT_2, FRAC_1_SQRT_2),
    (-FRAC_1_SQRT_2, -FRAC_1_SQRT_2),
];

impl FrictionModel {
    /// Unit face normals (c1, c2) of a pyramid: each face is the linear
    /// inequality c1·λs1 + c2·λs2 ≤ μ_s λn. Empty for the cone.
    pub fn facets(self) -> &'static [(f64, f64)] {
        match self {
            FrictionModel::Pyramid4 => &PYRAMID4,
            FrictionModel::Pyramid8 => &PYRAMID8,
            FrictionModel::Cone => &[],
        }
    }

    /// Largest shear magnitude the model admits in the in-plane direction at
    /// angle `phi` (radians, from e1 towards e2), per unit μ_s λn: 1 for the
    /// cone, 1 / cos δ for a circumscribed pyramid (δ = angle from `phi` to
    /// the nearest face normal).
    pub fn shear_limit_factor(self, phi: f64) -> f64 {
        match self {
            FrictionModel::Cone => 1.0,
            _ => {
                let (d1, d2) = (phi.cos(), phi.sin());
                // The ray r·(d1, d2) leaves the polygon at the face with the
                // largest projection c·d.
                let best = self
                    .facets()
                    .iter()
                    .map(|(c1, c2)| c1 * d1 + c2 * d2)
                    .fold(f64::NEG_INFINITY, f64::max);
                1.0 / best
            }
        }
    }

    /// Violation of the contact's friction constraint at `x` (≤ 0 when it
    /// holds): max over faces of c·s − μ n for a pyramid, ‖s‖ − μ n for the
    /// cone.
    pub fn violation(self, contact: &StaticContact, x: &[f64]) -> f64 {
        let n = x[contact.normal];
        let (s1, s2) = (x[contact.shear[0]], x[contact.shear[1]]);
        let limit = contact.mu * n;
        match self {
            FrictionModel::Cone => s1.hypot(s2) - limit,
            _ => self
                .facets()
                .iter()
                .map(|(c1, c2)| c1 * s1 + c2 * s2 - limit)
                .fold(f64::NEG_INFINITY, f64::max),
        }
    }
}
