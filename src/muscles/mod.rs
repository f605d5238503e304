//! Muscle force models: Thelen2003Muscle and Millard2012EquilibriumMuscle,
//! semantics §4 (4.1–4.5). Path geometry is not handled here: callers pass
//! the musculotendon length L and lengthening speed dL/dt.

// `!(x > 0.0)` is used on purpose throughout: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::manual_range_contains)]

pub mod millard2012;
pub mod pennation;
pub mod set;
pub mod thelen2003;

pub use millard2012::Millard2012;
pub use pennation::FixedWidthPennation;
pub use thelen2003::Thelen2003;

use crate::error::Result;
use crate::xml::Element;

/// Latest OpenSim document version (`XMLDocument::LatestVersion`, 4.6).
pub const LATEST_DOCUMENT_VERSION: i64 = 40600;

/// The muscle model and its model-specific properties.
#[derive(Debug, Clone, PartialEq)]
#[allow(clippy::large_enum_variant)] // few muscles per model; keeps the plain API
pub enum MuscleModel {
    Thelen2003(Thelen2003),
    Millard2012(Millard2012),
}

/// Properties common to all muscles (§4.1), with OpenSim's defaults.
#[derive(Debug, Clone, PartialEq)]
pub struct MuscleParams {
    /// F₀ [N], default 1000.
    pub max_isometric_force: f64,
    /// l_o [m], default 0.1.
    pub optimal_fiber_length: f64,
    /// l_s [m], default 0.2.
    pub tendon_slack_length: f64,
    /// φ_o [rad], default 0 (3.x spelling `pennation_angle` accepted).
    pub pennation_angle_at_optimal: f64,
    /// v_max [l_o/s], default 10.
    pub max_contraction_velocity: f64,
    /// Default 0.01 for both models (they set `min_control` to the default
    /// `minimum_activation` at construction); for documents older than
    /// 30513 a `min_control` of 0 is dropped (OpenSim's upgrade rule).
    pub min_control: f64,
    /// Default 1.
    pub max_control: f64,
    /// `appliesForce` (or `!isDisabled`), default true.
    pub applies_force: bool,
    /// PathActuator `optimal_force`, default 1 (unused by muscles in SO).
    pub optimal_force: f64,
    pub ignore_tendon_compliance: bool,
    pub ignore_activation_dynamics: bool,
}

/// A muscle: name, common properties and model.
#[derive(Debug, Clone, PartialEq)]
pub struct Muscle {
    pub name: String,
    pub params: MuscleParams,
    pub model: MuscleModel,
}

impl Muscle {
    /// Read a `<Thelen2003Muscle>` or `<Millard2012EquilibriumMuscle>`
    /// element, with OpenSim's defaults for absent properties. The document
    /// version (for the 3.x upgrade rules) is read from the head of the
    /// element's file; when that is unavailable the latest version is
    /// assumed. `<GeometryPath>` is ignored.
    pub fn from_xml(el: &Element) -> Result<Muscle> {
        let version = document_version(&el.file).unwrap_or(LATEST_DOCUMENT_VERSION);
        Self::from_xml_with_version(el, version)
    }

    /// As [`Muscle::from_xml`], with the document version given.
    pub fn from_xml_with_version(el: &Element, version: i64) -> Result<Muscle> {
        let params = read_common_params(el, version)?;
        let model = match el.name.as_str() {
            "Thelen2003Muscle" => MuscleModel::Thelen2003(Thelen2003::from_xml(el, &params)?),
            "Millard2012EquilibriumMuscle" => {
                MuscleModel::Millard2012(Millard2012::from_xml(el, &params)?)
            }
            other => {
                return Err(el.error(format!(
                    "unsupported muscle type <{other}> (supported: Thelen2003Muscle, \
                     Millard2012EquilibriumMuscle)"
                )))
            }
        };
        Ok(Muscle {
            name: el.name_attr().to_string(),
            params,
            model,
        })
    }

    /// OpenSim's `calcInextensibleTendonActiveFiberForce(s, 1.0)` (§4.4): the
    /// rigid-tendon active fiber force along the tendon at full activation,
    /// at path length `length` [m] and lengthening speed
    /// `lengthening_speed` [m/s]. Static optimization multiplies this by
    /// activation. For Millard2012 this reproduces OpenSim's pennation bug.
    pub fn max_active_fiber_force_rigid_tendon(&self, length: f64, lengthening_speed: f64) -> f64 {
        match &self.model {
            MuscleModel::Thelen2003(t) => {
                t.max_active_fiber_force_rigid_tendon(&self.params, length, lengthening_speed)
            }
            MuscleModel::Millard2012(m) => {
                m.max_active_fiber_force_rigid_tendon(&self.params, length, lengthening_speed)
            }
        }
    }

    /// `(max_active_fiber_force_rigid_tendon(length, lengthening_speed),
    /// passive_fiber_force_rigid_tendon(length))`, bit for bit, sharing
    /// the fiber length and pennation they both need.
    pub fn rigid_tendon_forces(&self, length: f64, lengthening_speed: f64) -> (f64, f64) {
        match &self.model {
            MuscleModel::Thelen2003(t) => {
                t.rigid_tendon_forces(&self.params, length, lengthening_speed)
            }
            MuscleModel::Millard2012(m) => (
                m.max_active_fiber_force_rigid_tendon(&self.params, length, lengthening_speed),
                m.passive_fiber_force_rigid_tendon(&self.params, length),
            ),
        }
    }

    /// Passive elastic fiber force along the tendon with a rigid tendon:
    /// fiber length from the path length with the tendon at slack length,
    /// clamped at the model's minimum fiber length, then
    /// F₀ × passive force–length multiplier × cos(pennation). Fiber damping
    /// is not included. Static optimization does not use this force.
    pub fn passive_fiber_force_rigid_tendon(&self, length: f64) -> f64 {
        match &self.model {
            MuscleModel::Thelen2003(t) => t.passive_fiber_force_rigid_tendon(&self.params, length),
            MuscleModel::Millard2012(m) => m.passive_fiber_force_rigid_tendon(&self.params, length),
        }
    }
}

/// `Version` attribute of the `<OpenSimDocument>` root of an XML file, read
/// from the file's first 64 KiB; None if the file cannot be read or has none.
/// Defaults for `maximum_pennation_angle` and `minimum_activation` from the
/// muscle's optional sub-model elements (older files keep them in
/// `MuscleFixedWidthPennationModel` / `MuscleFirstOrderActivationDynamicModel`);
/// acos(0.1) and 0.01 when absent.
pub(crate) fn submodel_defaults(el: &Element) -> Result<(f64, f64)> {
    let max_pen = match el.child("MuscleFixedWidthPennationModel") {
        Some(p) => p.child_f64_or("maximum_pennation_angle", 0.1f64.acos())?,
        None => 0.1f64.acos(),
    };
    let min_act = match el.child("MuscleFirstOrderActivationDynamicModel") {
        Some(a) => a.child_f64_or("minimum_activation", 0.01)?,
        None => 0.01,
    };
    Ok((max_pen, min_act))
}

pub fn document_version(file: &std::path::Path) -> Option<i64> {
    use std::io::Read;
    let mut buf = Vec::new();
    std::fs::File::open(file)
        .ok()?
        .take(65536)
        .read_to_end(&mut buf)
        .ok()?;
    let text = String::from_utf8_lossy(&buf);
    let start = text.find("<OpenSimDocument")?;
    let rest = &text[start..];
    let tag = &rest[..rest.find('>')?];
    let v = tag.find("Version")?;
    let after = tag[v + "Version".len()..]
        .trim_start()
        .strip_prefix('=')?
        .trim_start();
    let quote = after.chars().next()?;
    if quote != '"' && quote != '\'' {
        return None;
    }
    let body = &after[1..];
    body[..body.find(quote)?].trim().parse().ok()
}

fn read_common_params(el: &Element, version: i64) -> Result<MuscleParams> {
    let applies_force = match el.child("appliesForce") {
        Some(c) if !c.text().is_empty() => c.bool()?,
        _ => match el.child("isDisabled") {
            Some(c) if !c.text().is_empty() => !c.bool()?,
            _ => true,
        },
    };
    let pennation_angle_at_optimal = match el.child("pennation_angle_at_optimal") {
        Some(c) if !c.text().is_empty() => c.f64()?,
        _ => el.child_f64_or("pennation_angle", 0.0)?,
    };
    let mut min_control = el.child_f64_or_inf("min_control", 0.01)?;
    let mut max_control = el.child_f64_or_inf("max_control", 1.0)?;
    if version < 30513 {
        // Muscle::updateFromXMLNode: 0 and 1 were unupdated defaults.
        if el.child("min_control").is_some() && min_control.abs() <= pennation::significant_real() {
            min_control = 0.01;
        }
        if el.child("max_control").is_some()
            && (max_control - 1.0).abs() <= pennation::significant_real()
        {
            max_control = 1.0;
        }
    }
    let p = MuscleParams {
        max_isometric_force: el.child_f64_or("max_isometric_force", 1000.0)?,
        optimal_fiber_length: el.child_f64_or("optimal_fiber_length", 0.1)?,
        tendon_slack_length: el.child_f64_or("tendon_slack_length", 0.2)?,
        pennation_angle_at_optimal,
        max_contraction_velocity: el.child_f64_or("max_contraction_velocity", 10.0)?,
        min_control,
        max_control,
        applies_force,
        optimal_force: el.child_f64_or("optimal_force", 1.0)?,
        ignore_tendon_compliance: el.child_bool_or("ignore_tendon_compliance", false)?,
        ignore_activation_dynamics: el.child_bool_or("ignore_activation_dynamics", false)?,
    };
    // OpenSim itself checks only l_o (pennation model); negative or
    // non-finite sizes and a zero v_max (a division) are rejected here.
    for (name, v, strict) in [
        ("max_isometric_force", p.max_isometric_force, false),
        ("tendon_slack_length", p.tendon_slack_length, false),
        ("max_contraction_velocity", p.max_contraction_velocity, true),
    ] {
        let ok = v.is_finite() && if strict { v > 0.0 } else { v >= 0.0 };
        if !ok {
            let what = if strict { "positive" } else { "non-negative" };
            return Err(el.error(format!("<{name}> must be {what} and finite (is {v})")));
        }
    }
    Ok(p)
}

#[cfg(test)]
mod tests;
