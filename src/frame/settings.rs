//! The StaticOptimization element's settings as the plan holds them: read
//! once in the parse stage (`parse::analyses`), re-exported here; a run
//! compiles them into its numeric options (`frame::options::SoOptions`).

pub use crate::parse::analyses::{
    ConstraintMatrix, EqualActivation, KneeSelection, StaticOptimizationSetup,
    CONTACT_WEIGHT_RANGE, DEFAULT_ACTIVATION_EXPONENT, DEFAULT_CONTACT_WEIGHT,
    DEFAULT_CONVERGENCE_CRITERION, DEFAULT_MAX_ITERATIONS, DEFAULT_TOLERANCE,
};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::Result;

    fn parse(body: &str) -> Result<StaticOptimizationSetup> {
        let el = crate::xml::parse_str(
            &format!("<StaticOptimization name=\"SO\">{body}</StaticOptimization>"),
            std::path::Path::new("setup.xml"),
        )
        .unwrap();
        let common = crate::parse::setup::AnalysisCommon {
            name: "SO".into(),
            on: true,
            step_interval: 1,
            in_degrees: false,
        };
        StaticOptimizationSetup::from_xml(&el, common)
    }

    /// `<knee_contact>`: off unless given; `all`/`true`, joint names, and
    /// the word `axial`; an empty element is an error naming the choices.
    #[test]
    fn knee_contact_property() {
        let s = parse("").unwrap();
        assert_eq!(s.knee_contact, KneeSelection::Off);
        let s = parse("<knee_contact>all</knee_contact>").unwrap();
        assert_eq!(s.knee_contact, KneeSelection::All);
        assert!(s.knee_contact_frontal);
        let s = parse("<knee_contact>walker_knee_l</knee_contact>").unwrap();
        assert_eq!(
            s.knee_contact,
            KneeSelection::Joints(vec!["walker_knee_l".into()])
        );
        let s = parse("<knee_contact>axial</knee_contact>").unwrap();
        assert_eq!(s.knee_contact, KneeSelection::All);
        assert!(!s.knee_contact_frontal);
        assert_eq!(
            parse("<knee_contact>false</knee_contact>")
                .unwrap()
                .knee_contact,
            KneeSelection::Off
        );
        let e = parse("<knee_contact></knee_contact>")
            .unwrap_err()
            .to_string();
        assert!(e.contains("knee_contact is empty"), "{e}");
    }

    /// `<knee_contact_medial_share>`: 0.65 unless given; a share outside
    /// (0, 1) is an error naming the element's line.
    #[test]
    fn knee_contact_medial_share_property() {
        let s = parse("<knee_contact>all</knee_contact>").unwrap();
        assert_eq!(
            s.knee_contact_medial_share,
            crate::parse::analyses::DEFAULT_KNEE_MEDIAL_SHARE
        );
        assert_eq!(s.knee_contact_medial_share, 0.65);
        let s = parse("<knee_contact_medial_share>0.5</knee_contact_medial_share>").unwrap();
        assert_eq!(s.knee_contact_medial_share, 0.5);
        for bad in ["0", "1", "-0.2", "1.5"] {
            let e = parse(&format!(
                "<knee_contact_medial_share>{bad}</knee_contact_medial_share>"
            ))
            .unwrap_err()
            .to_string();
            assert!(
                e.contains("knee_contact_medial_share") && e.contains("setup.xml"),
                "{e}"
            );
        }
    }
}
