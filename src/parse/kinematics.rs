//! OpenSim's BodyKinematics and PointKinematics analyses of an AnalyzeTool
//! setup (`OpenSim/Analyses/BodyKinematics.cpp`, `PointKinematics.cpp`),
//! read into their typed settings. Names are resolved against the model
//! by `dynamics::body_kinematics`, which reports a name it cannot find at
//! the element that holds it.

use nalgebra::Vector3;

use crate::error::Result;
use crate::parse::setup::AnalysisCommon;
use crate::xml::Element;

/// The name OpenSim's BodyKinematics gives the whole model's centre of mass
/// in `<bodies>` and in its columns.
pub const CENTER_OF_MASS: &str = "center_of_mass";

/// `<BodyKinematics>`: each listed body's mass centre and orientation, and
/// the whole model's centre of mass.
#[derive(Debug, Clone)]
pub struct BodyKinematicsSetup {
    pub common: AnalysisCommon,
    /// Body names, `all` (every body and the centre of mass) or
    /// `center_of_mass` (OpenSim's default: `all`).
    pub bodies: Vec<String>,
    /// `<express_results_in_body_local_frame>` (default false): velocities
    /// and accelerations in each body's frame (files `_vel_bodyLocal`,
    /// `_acc_bodyLocal`); positions and the centre of mass stay in ground.
    pub express_in_body_frame: bool,
    /// The element, for located errors.
    pub element: Element,
}

/// `<PointKinematics>`: one point fixed on a body (or on ground).
#[derive(Debug, Clone)]
pub struct PointKinematicsSetup {
    pub common: AnalysisCommon,
    /// `<body_name>` (default `ground`): a body, `ground`, or another
    /// physical frame of the model by name or path.
    pub body_name: String,
    /// `<relative_to_body_name>` (default `none`): positions measured in,
    /// and velocities and accelerations expressed in, this frame.
    pub relative_to: Option<String>,
    /// `<point_name>` (default `NONAME`): the files' and columns' name.
    pub point_name: String,
    /// `<point>`: the point in the body's frame (default the origin).
    pub point: Vector3<f64>,
    /// The element, for located errors.
    pub element: Element,
}

/// A kinematics analysis of an AnalyzeTool setup.
#[derive(Debug, Clone)]
pub enum KinematicsSetup {
    Body(BodyKinematicsSetup),
    Point(PointKinematicsSetup),
}

impl KinematicsSetup {
    /// The properties every analysis has.
    pub fn common(&self) -> &AnalysisCommon {
        match self {
            KinematicsSetup::Body(b) => &b.common,
            KinematicsSetup::Point(p) => &p.common,
        }
    }

    pub fn common_mut(&mut self) -> &mut AnalysisCommon {
        match self {
            KinematicsSetup::Body(b) => &mut b.common,
            KinematicsSetup::Point(p) => &mut p.common,
        }
    }

    /// The analysis of element `el` if it is a BodyKinematics or
    /// PointKinematics, None for any other element.
    pub fn from_xml(el: &Element, common: AnalysisCommon) -> Result<Option<KinematicsSetup>> {
        Ok(Some(match el.name.as_str() {
            "BodyKinematics" => KinematicsSetup::Body(BodyKinematicsSetup::from_xml(el, common)?),
            "PointKinematics" => {
                KinematicsSetup::Point(PointKinematicsSetup::from_xml(el, common)?)
            }
            _ => return Ok(None),
        }))
    }
}

fn text_or<'a>(el: &'a Element, name: &str, default: &'a str) -> &'a str {
    match el.child_text(name) {
        Some(t) if !t.trim().is_empty() => t.trim(),
        _ => default,
    }
}

impl BodyKinematicsSetup {
    pub fn from_xml(el: &Element, common: AnalysisCommon) -> Result<Self> {
        let bodies = match el.child("bodies") {
            None => vec!["all".to_string()],
            Some(b) => {
                let w = b.words();
                if w.is_empty() {
                    // OpenSim records nothing then (its warning: "no bodies
                    // to record kinematics for") and writes tables of time
                    // alone: refused, as it is surely not what was meant.
                    return Err(b.error(
                        "<bodies> is empty: name the bodies to record, 'all' (every body and the centre of mass) or 'center_of_mass'",
                    ));
                }
                w
            }
        };
        Ok(BodyKinematicsSetup {
            common,
            bodies,
            express_in_body_frame: el
                .child_bool_or("express_results_in_body_local_frame", false)?,
            element: el.clone(),
        })
    }
}

impl PointKinematicsSetup {
    pub fn from_xml(el: &Element, common: AnalysisCommon) -> Result<Self> {
        let point = match el.child("point") {
            Some(p) if !p.text().trim().is_empty() => p.vec3()?,
            _ => Vector3::zeros(),
        };
        let relative = text_or(el, "relative_to_body_name", "none");
        let point_name = text_or(el, "point_name", "NONAME");
        if point_name.contains(char::is_whitespace) {
            return Err(el.req("point_name")?.error(format!(
                "point_name '{point_name}' holds a space; it names the files and columns, so give one word"
            )));
        }
        Ok(PointKinematicsSetup {
            common,
            body_name: text_or(el, "body_name", "ground").to_string(),
            relative_to: (!relative.eq_ignore_ascii_case("none")).then(|| relative.to_string()),
            point_name: point_name.to_string(),
            point,
            element: el.clone(),
        })
    }
}
