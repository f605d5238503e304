//! The four Millard2012 muscle curves, semantics §4.5
//! (`OpenSim/Actuators/{ActiveForceLength,ForceVelocity,FiberForceLength,TendonForceLength}Curve.cpp`,
//! constructions of `OpenSim/Common/SmoothSegmentedFunctionFactory.cpp`).
//!
//! Each curve keeps its properties and the smooth segmented function built
//! from them; `value(x)` and `derivative(x, order)` evaluate it.

use super::bezier::{corner_control_points, scale_curviness, SmoothSegmentedFunction};
use crate::error::Result;
use crate::xml::Element;

fn prop(el: Option<&Element>, name: &str, default: f64) -> Result<f64> {
    match el {
        Some(e) => e.child_f64_or(name, default),
        None => Ok(default),
    }
}

/// Optional property: `Some` only when the element is present with text.
fn opt_prop(el: Option<&Element>, name: &str) -> Result<Option<f64>> {
    match el.and_then(|e| e.child(name)) {
        Some(c) if !c.text().is_empty() => Ok(Some(c.f64()?)),
        _ => Ok(None),
    }
}

fn located<T>(r: std::result::Result<T, String>, el: Option<&Element>, what: &str) -> Result<T> {
    r.map_err(|m| match el {
        Some(e) => e.error(format!("{what}: {m}")),
        None => crate::error::Error::msg(format!("{what}: {m}")),
    })
}

macro_rules! curve_eval {
    () => {
        /// Curve value at x.
        pub fn value(&self, x: f64) -> f64 {
            self.curve.value(x)
        }
        /// d^order/dx^order at x (order 0 = value; orders 0–3 supported,
        /// higher orders give NaN).
        pub fn derivative(&self, x: f64, order: usize) -> f64 {
            self.curve.derivative(x, order)
        }
        /// The underlying smooth segmented function.
        pub fn function(&self) -> &SmoothSegmentedFunction {
            &self.curve
        }
    };
}

// ---------------------------------------------------------------------------

/// `ActiveForceLengthCurve`: five corners through (l̃_min, y_min), the
/// shallow ascending limb, the plateau at (1, 1) and the descending limb to
/// (l̃_max, y_min); constant `minimum_value` outside.
#[derive(Debug, Clone, PartialEq)]
pub struct ActiveForceLengthCurve {
    pub min_norm_active_fiber_length: f64,
    pub transition_norm_fiber_length: f64,
    pub max_norm_active_fiber_length: f64,
    pub shallow_ascending_slope: f64,
    pub minimum_value: f64,
    curve: SmoothSegmentedFunction,
}

impl Default for ActiveForceLengthCurve {
    fn default() -> Self {
        Self::new(0.47 - 0.0259, 0.73, 1.8123, 0.8616, 0.1).expect("default curve is valid")
    }
}

impl ActiveForceLengthCurve {
    pub fn new(
        min_norm_active_fiber_length: f64,
        transition_norm_fiber_length: f64,
        max_norm_active_fiber_length: f64,
        shallow_ascending_slope: f64,
        minimum_value: f64,
    ) -> std::result::Result<Self, String> {
        let curve = fiber_active_force_length_curve(
            min_norm_active_fiber_length,
            transition_norm_fiber_length,
            1.0,
            max_norm_active_fiber_length,
            minimum_value,
            shallow_ascending_slope,
            1.0,
        )?;
        Ok(ActiveForceLengthCurve {
            min_norm_active_fiber_length,
            transition_norm_fiber_length,
            max_norm_active_fiber_length,
            shallow_ascending_slope,
            minimum_value,
            curve,
        })
    }

    /// Read an `<ActiveForceLengthCurve>` element (None: all defaults).
    pub fn from_xml(el: Option<&Element>) -> Result<Self> {
        let r = Self::new(
            prop(el, "min_norm_active_fiber_length", 0.47 - 0.0259)?,
            prop(el, "transition_norm_fiber_length", 0.73)?,
            prop(el, "max_norm_active_fiber_length", 1.8123)?,
            prop(el, "shallow_ascending_slope", 0.8616)?,
            prop(el, "minimum_value", 0.1)?,
        );
        located(r, el, "ActiveForceLengthCurve")
    }

    /// The same curve with another floor (`setMinValue`).
    pub fn with_minimum_value(&self, minimum_value: f64) -> std::result::Result<Self, String> {
        Self::new(
            self.min_norm_active_fiber_length,
            self.transition_norm_fiber_length,
            self.max_norm_active_fiber_length,
            self.shallow_ascending_slope,
            minimum_value,
        )
    }

    curve_eval!();
}

/// `createFiberActiveForceLengthCurve(x0, x1, x2, x3, ylow, dydx, curviness)`.
pub fn fiber_active_force_length_curve(
    x0: f64,
    x1: f64,
    x2: f64,
    x3: f64,
    ylow: f64,
    dydx: f64,
    curviness: f64,
) -> std::result::Result<SmoothSegmentedFunction, String> {
    let root_eps = f64::EPSILON.sqrt();
    if !(x0 >= 0.0 && x1 > x0 + root_eps && x2 > x1 + root_eps && x3 > x2 + root_eps) {
        return Err(format!(
            "need 0 <= min_norm_active_fiber_length ({x0}) < transition_norm_fiber_length ({x1}) \
             < 1 < max_norm_active_fiber_length ({x3})"
        ));
    }
    if !(ylow >= 0.0) {
        return Err(format!("minimum_value must be >= 0 (is {ylow})"));
    }
    let upper = (1.0 - ylow) / (x2 - x1);
    if !(dydx >= 0.0 && dydx < upper) {
        return Err(format!(
            "shallow_ascending_slope must be >= 0 and < {upper} (is {dydx})"
        ));
    }
    if !(0.0..=1.0).contains(&curviness) {
        return Err(format!(
            "curviness must be between 0 and 1 (is {curviness})"
        ));
    }
    let c = scale_curviness(curviness);
    let x_delta = 0.05 * x2;
    let xs = x2 - x_delta;
    // Ascending limb.
    let y0 = 0.0;
    let dydx0 = 0.0;
    let y1 = 1.0 - dydx * (xs - x1);
    let dydx01 = 1.25 * (y1 - y0) / (x1 - x0);
    let x01 = x0 + 0.5 * (x1 - x0);
    let y01 = y0 + 0.5 * (y1 - y0);
    // Shallow ascending plateau.
    let x1s = x1 + 0.5 * (xs - x1);
    let y1s = y1 + 0.5 * (1.0 - y1);
    let dydx1s = dydx;
    // Plateau.
    let y2 = 1.0;
    let dydx2 = 0.0;
    // Descending limb.
    let y3 = 0.0;
    let dydx3 = 0.0;
    let x23 = (x2 + x_delta) + 0.5 * (x3 - (x2 + x_delta));
    let y23 = y2 + 0.5 * (y3 - y2);
    let dydx23 = (y3 - y2) / ((x3 - x_delta) - (x2 + x_delta));
    let segs = vec![
        corner_control_points(x0, ylow, dydx0, x01, y01, dydx01, c)?,
        corner_control_points(x01, y01, dydx01, x1s, y1s, dydx1s, c)?,
        corner_control_points(x1s, y1s, dydx1s, x2, y2, dydx2, c)?,
        corner_control_points(x2, y2, dydx2, x23, y23, dydx23, c)?,
        corner_control_points(x23, y23, dydx23, x3, ylow, dydx3, c)?,
    ];
    Ok(SmoothSegmentedFunction::new(
        segs, x0, x3, ylow, ylow, 0.0, 0.0,
    ))
}

// ---------------------------------------------------------------------------

/// `ForceVelocityCurve`: four corners through (−1, 0), (−0.9, ·), (0, 1),
/// (0.9, ·), (1, f_max,E) over normalised fiber velocity (lengthening
/// positive); linear with the end slopes beyond ±1.
#[derive(Debug, Clone, PartialEq)]
pub struct ForceVelocityCurve {
    pub concentric_slope_at_vmax: f64,
    pub concentric_slope_near_vmax: f64,
    pub isometric_slope: f64,
    pub eccentric_slope_at_vmax: f64,
    pub eccentric_slope_near_vmax: f64,
    pub max_eccentric_velocity_force_multiplier: f64,
    pub concentric_curviness: f64,
    pub eccentric_curviness: f64,
    curve: SmoothSegmentedFunction,
}

impl Default for ForceVelocityCurve {
    fn default() -> Self {
        Self::new(0.0, 0.25, 5.0, 0.0, 0.15, 1.4, 0.6, 0.9).expect("default curve is valid")
    }
}

impl ForceVelocityCurve {
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        concentric_slope_at_vmax: f64,
        concentric_slope_near_vmax: f64,
        isometric_slope: f64,
        eccentric_slope_at_vmax: f64,
        eccentric_slope_near_vmax: f64,
        max_eccentric_velocity_force_multiplier: f64,
        concentric_curviness: f64,
        eccentric_curviness: f64,
    ) -> std::result::Result<Self, String> {
        let curve = fiber_force_velocity_curve(
            max_eccentric_velocity_force_multiplier,
            concentric_slope_at_vmax,
            concentric_slope_near_vmax,
            isometric_slope,
            eccentric_slope_at_vmax,
            eccentric_slope_near_vmax,
            concentric_curviness,
            eccentric_curviness,
        )?;
        Ok(ForceVelocityCurve {
            concentric_slope_at_vmax,
            concentric_slope_near_vmax,
            isometric_slope,
            eccentric_slope_at_vmax,
            eccentric_slope_near_vmax,
            max_eccentric_velocity_force_multiplier,
            concentric_curviness,
            eccentric_curviness,
            curve,
        })
    }

    /// Read a `<ForceVelocityCurve>` element (None: all defaults).
    pub fn from_xml(el: Option<&Element>) -> Result<Self> {
        let r = Self::new(
            prop(el, "concentric_slope_at_vmax", 0.0)?,
            prop(el, "concentric_slope_near_vmax", 0.25)?,
            prop(el, "isometric_slope", 5.0)?,
            prop(el, "eccentric_slope_at_vmax", 0.0)?,
            prop(el, "eccentric_slope_near_vmax", 0.15)?,
            prop(el, "max_eccentric_velocity_force_multiplier", 1.4)?,
            prop(el, "concentric_curviness", 0.6)?,
            prop(el, "eccentric_curviness", 0.9)?,
        );
        located(r, el, "ForceVelocityCurve")
    }

    /// The same curve with other end slopes (`setCurveShape` keeping the
    /// near-vmax slopes, isometric slope, force multiplier and curviness).
    pub fn with_slopes_at_vmax(
        &self,
        concentric_slope_at_vmax: f64,
        eccentric_slope_at_vmax: f64,
    ) -> std::result::Result<Self, String> {
        Self::new(
            concentric_slope_at_vmax,
            self.concentric_slope_near_vmax,
            self.isometric_slope,
            eccentric_slope_at_vmax,
            self.eccentric_slope_near_vmax,
            self.max_eccentric_velocity_force_multiplier,
            self.concentric_curviness,
            self.eccentric_curviness,
        )
    }

    curve_eval!();
}

/// `createFiberForceVelocityCurve(fmaxE, dydxC, dydxNearC, dydxIso, dydxE,
/// dydxNearE, concCurviness, eccCurviness)`.
#[allow(clippy::too_many_arguments)]
pub fn fiber_force_velocity_curve(
    fmax_e: f64,
    dydx_c: f64,
    dydx_near_c: f64,
    dydx_iso: f64,
    dydx_e: f64,
    dydx_near_e: f64,
    conc_curviness: f64,
    ecc_curviness: f64,
) -> std::result::Result<SmoothSegmentedFunction, String> {
    if !(fmax_e > 1.0) {
        return Err(format!(
            "max_eccentric_velocity_force_multiplier must be greater than 1 (is {fmax_e})"
        ));
    }
    if !(dydx_c >= 0.0 && dydx_c < 1.0) {
        return Err(format!(
            "concentric_slope_at_vmax must be in [0, 1) (is {dydx_c})"
        ));
    }
    if !(dydx_near_c > dydx_c && dydx_near_c <= 1.0) {
        return Err(format!(
            "concentric_slope_near_vmax must be > concentric_slope_at_vmax and <= 1 (is {dydx_near_c})"
        ));
    }
    if !(dydx_iso > 1.0) {
        return Err(format!(
            "isometric_slope must be greater than 1 (is {dydx_iso})"
        ));
    }
    if !(dydx_e >= 0.0 && dydx_e < fmax_e - 1.0) {
        return Err(format!(
            "eccentric_slope_at_vmax must be in [0, {}) (is {dydx_e})",
            fmax_e - 1.0
        ));
    }
    if !(dydx_near_e >= dydx_e && dydx_near_e < fmax_e - 1.0) {
        return Err(format!(
            "eccentric_slope_near_vmax must be >= eccentric_slope_at_vmax and < {} (is {dydx_near_e})",
            fmax_e - 1.0
        ));
    }
    for (name, v) in [
        ("concentric_curviness", conc_curviness),
        ("eccentric_curviness", ecc_curviness),
    ] {
        if !(0.0..=1.0).contains(&v) {
            return Err(format!("{name} must be between 0 and 1 (is {v})"));
        }
    }
    let c_c = scale_curviness(conc_curviness);
    let c_e = scale_curviness(ecc_curviness);
    let (x_c, y_c) = (-1.0, 0.0);
    let x_near_c = -0.9;
    let y_near_c = y_c + 0.5 * dydx_near_c * (x_near_c - x_c) + 0.5 * dydx_c * (x_near_c - x_c);
    let (x_iso, y_iso) = (0.0, 1.0);
    let (x_e, y_e) = (1.0, fmax_e);
    let x_near_e = 0.9;
    let y_near_e = y_e + 0.5 * dydx_near_e * (x_near_e - x_e) + 0.5 * dydx_e * (x_near_e - x_e);
    let segs = vec![
        corner_control_points(x_c, y_c, dydx_c, x_near_c, y_near_c, dydx_near_c, c_c)?,
        corner_control_points(x_near_c, y_near_c, dydx_near_c, x_iso, y_iso, dydx_iso, c_c)?,
        corner_control_points(x_iso, y_iso, dydx_iso, x_near_e, y_near_e, dydx_near_e, c_e)?,
        corner_control_points(x_near_e, y_near_e, dydx_near_e, x_e, y_e, dydx_e, c_e)?,
    ];
    Ok(SmoothSegmentedFunction::new(
        segs, x_c, x_e, y_c, y_e, dydx_c, dydx_e,
    ))
}

// ---------------------------------------------------------------------------

/// `FiberForceLengthCurve`: passive fiber force over normalised fiber
/// length, zero below 1 + `strain_at_zero_force`, 1 at 1 +
/// `strain_at_one_norm_force`, linear above. The three optional properties
/// are either all given or all omitted (then 0.2, 2/(e1−e0) and 0.75).
#[derive(Debug, Clone, PartialEq)]
pub struct FiberForceLengthCurve {
    pub strain_at_zero_force: f64,
    pub strain_at_one_norm_force: f64,
    pub stiffness_at_low_force: Option<f64>,
    pub stiffness_at_one_norm_force: Option<f64>,
    pub curviness: Option<f64>,
    /// Values actually used (given or computed).
    pub stiffness_at_low_force_in_use: f64,
    pub stiffness_at_one_norm_force_in_use: f64,
    pub curviness_in_use: f64,
    curve: SmoothSegmentedFunction,
}

impl Default for FiberForceLengthCurve {
    fn default() -> Self {
        Self::new(0.0, 0.7, None, None, None).expect("default curve is valid")
    }
}

impl FiberForceLengthCurve {
    pub fn new(
        strain_at_zero_force: f64,
        strain_at_one_norm_force: f64,
        stiffness_at_low_force: Option<f64>,
        stiffness_at_one_norm_force: Option<f64>,
        curviness: Option<f64>,
    ) -> std::result::Result<Self, String> {
        let (k_low, k_iso, c) = match (
            stiffness_at_low_force,
            stiffness_at_one_norm_force,
            curviness,
        ) {
            (Some(kl), Some(ki), Some(c)) => (kl, ki, c),
            (None, None, None) => (
                0.2,
                2.0 / (strain_at_one_norm_force - strain_at_zero_force),
                0.75,
            ),
            _ => {
                return Err("optional properties stiffness_at_low_force, \
                            stiffness_at_one_norm_force and curviness must either all be set \
                            or all be empty"
                    .into())
            }
        };
        let curve = fiber_force_length_curve(
            strain_at_zero_force,
            strain_at_one_norm_force,
            k_low,
            k_iso,
            c,
        )?;
        Ok(FiberForceLengthCurve {
            strain_at_zero_force,
            strain_at_one_norm_force,
            stiffness_at_low_force,
            stiffness_at_one_norm_force,
            curviness,
            stiffness_at_low_force_in_use: k_low,
            stiffness_at_one_norm_force_in_use: k_iso,
            curviness_in_use: c,
            curve,
        })
    }

    /// Read a `<FiberForceLengthCurve>` element (None: all defaults).
    pub fn from_xml(el: Option<&Element>) -> Result<Self> {
        let r = Self::new(
            prop(el, "strain_at_zero_force", 0.0)?,
            prop(el, "strain_at_one_norm_force", 0.7)?,
            opt_prop(el, "stiffness_at_low_force")?,
            opt_prop(el, "stiffness_at_one_norm_force")?,
            opt_prop(el, "curviness")?,
        );
        located(r, el, "FiberForceLengthCurve")
    }

    curve_eval!();
}

/// `createFiberForceLengthCurve(eZero, eIso, kLow, kIso, curviness)`.
pub fn fiber_force_length_curve(
    e_zero: f64,
    e_iso: f64,
    k_low: f64,
    k_iso: f64,
    curviness: f64,
) -> std::result::Result<SmoothSegmentedFunction, String> {
    if !(e_iso > e_zero) {
        return Err(format!(
            "strain_at_one_norm_force ({e_iso}) must be greater than strain_at_zero_force ({e_zero})"
        ));
    }
    if !(k_iso > 1.0 / (e_iso - e_zero)) {
        return Err(format!(
            "stiffness_at_one_norm_force must be greater than {} (is {k_iso})",
            1.0 / (e_iso - e_zero)
        ));
    }
    if !(k_low > 0.0 && k_low < 1.0 / (e_iso - e_zero)) {
        return Err(format!(
            "stiffness_at_low_force must be in (0, {}) (is {k_low})",
            1.0 / (e_iso - e_zero)
        ));
    }
    if !(0.0..=1.0).contains(&curviness) {
        return Err(format!(
            "curviness must be between 0 and 1 (is {curviness})"
        ));
    }
    let c = scale_curviness(curviness);
    let x_zero = 1.0 + e_zero;
    let y_zero = 0.0;
    let x_iso = 1.0 + e_iso;
    let y_iso = 1.0;
    let delta_x = (0.1 * (1.0 / k_iso)).min(0.1 * (x_iso - x_zero));
    let x_low = x_zero + delta_x;
    let x_foot = x_zero + 0.5 * (x_low - x_zero);
    let y_foot = 0.0;
    let y_low = y_foot + k_low * (x_low - x_foot);
    let segs = vec![
        corner_control_points(x_zero, y_zero, 0.0, x_low, y_low, k_low, c)?,
        corner_control_points(x_low, y_low, k_low, x_iso, y_iso, k_iso, c)?,
    ];
    Ok(SmoothSegmentedFunction::new(
        segs, x_zero, x_iso, y_zero, y_iso, 0.0, k_iso,
    ))
}

// ---------------------------------------------------------------------------

/// `TendonForceLengthCurve`: tendon force over normalised tendon length,
/// zero below 1, a toe region up to `norm_force_at_toe_end`, then linear
/// with `stiffness_at_one_norm_force`. The three optional properties are
/// either all given or all omitted (then 1.375/e_iso, 2/3 and 0.5).
#[derive(Debug, Clone, PartialEq)]
pub struct TendonForceLengthCurve {
    pub strain_at_one_norm_force: f64,
    pub stiffness_at_one_norm_force: Option<f64>,
    pub norm_force_at_toe_end: Option<f64>,
    pub curviness: Option<f64>,
    pub stiffness_at_one_norm_force_in_use: f64,
    pub norm_force_at_toe_end_in_use: f64,
    pub curviness_in_use: f64,
    curve: SmoothSegmentedFunction,
}

impl Default for TendonForceLengthCurve {
    fn default() -> Self {
        Self::new(0.049, None, None, None).expect("default curve is valid")
    }
}

impl TendonForceLengthCurve {
    pub fn new(
        strain_at_one_norm_force: f64,
        stiffness_at_one_norm_force: Option<f64>,
        norm_force_at_toe_end: Option<f64>,
        curviness: Option<f64>,
    ) -> std::result::Result<Self, String> {
        let (k_iso, f_toe, c) = match (
            stiffness_at_one_norm_force,
            norm_force_at_toe_end,
            curviness,
        ) {
            (Some(k), Some(f), Some(c)) => (k, f, c),
            (None, None, None) => (1.375 / strain_at_one_norm_force, 2.0 / 3.0, 0.5),
            _ => {
                return Err("optional properties stiffness_at_one_norm_force, \
                            norm_force_at_toe_end and curviness must either all be set or all \
                            be empty"
                    .into())
            }
        };
        let curve = tendon_force_length_curve(strain_at_one_norm_force, k_iso, f_toe, c)?;
        Ok(TendonForceLengthCurve {
            strain_at_one_norm_force,
            stiffness_at_one_norm_force,
            norm_force_at_toe_end,
            curviness,
            stiffness_at_one_norm_force_in_use: k_iso,
            norm_force_at_toe_end_in_use: f_toe,
            curviness_in_use: c,
            curve,
        })
    }

    /// Read a `<TendonForceLengthCurve>` element (None: all defaults).
    pub fn from_xml(el: Option<&Element>) -> Result<Self> {
        let r = Self::new(
            prop(el, "strain_at_one_norm_force", 0.049)?,
            opt_prop(el, "stiffness_at_one_norm_force")?,
            opt_prop(el, "norm_force_at_toe_end")?,
            opt_prop(el, "curviness")?,
        );
        located(r, el, "TendonForceLengthCurve")
    }

    curve_eval!();
}

/// `createTendonForceLengthCurve(eIso, kIso, fToe, curviness)`.
pub fn tendon_force_length_curve(
    e_iso: f64,
    k_iso: f64,
    f_toe: f64,
    curviness: f64,
) -> std::result::Result<SmoothSegmentedFunction, String> {
    if !(e_iso > 0.0) {
        return Err(format!(
            "strain_at_one_norm_force must be greater than 0 (is {e_iso})"
        ));
    }
    if !(f_toe > 0.0 && f_toe < 1.0) {
        return Err(format!(
            "norm_force_at_toe_end must be in (0, 1) (is {f_toe})"
        ));
    }
    if !(k_iso > 1.0 / e_iso) {
        return Err(format!(
            "stiffness_at_one_norm_force must be greater than {} (is {k_iso})",
            1.0 / e_iso
        ));
    }
    if !(0.0..=1.0).contains(&curviness) {
        return Err(format!(
            "curviness must be between 0 and 1 (is {curviness})"
        ));
    }
    let c = scale_curviness(curviness);
    let (x0, y0, dydx0) = (1.0, 0.0, 0.0);
    let x_iso = 1.0 + e_iso;
    let y_iso = 1.0;
    let dydx_iso = k_iso;
    let y_toe = f_toe;
    let x_toe = (y_toe - 1.0) / k_iso + x_iso;
    let x_foot = 1.0 + (x_toe - 1.0) / 10.0;
    let y_foot = 0.0;
    let y_toe_mid = y_toe * 0.5;
    let x_toe_mid = (y_toe_mid - y_iso) / k_iso + x_iso;
    let dydx_toe_mid = (y_toe_mid - y_foot) / (x_toe_mid - x_foot);
    let x_toe_ctrl = x_foot + 0.5 * (x_toe_mid - x_foot);
    let y_toe_ctrl = y_foot + dydx_toe_mid * (x_toe_ctrl - x_foot);
    let segs = vec![
        corner_control_points(x0, y0, dydx0, x_toe_ctrl, y_toe_ctrl, dydx_toe_mid, c)?,
        corner_control_points(
            x_toe_ctrl,
            y_toe_ctrl,
            dydx_toe_mid,
            x_toe,
            y_toe,
            dydx_iso,
            c,
        )?,
    ];
    Ok(SmoothSegmentedFunction::new(
        segs, x0, x_toe, y0, y_toe, dydx0, dydx_iso,
    ))
}
