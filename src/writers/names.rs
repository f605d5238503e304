//! The names of a static-optimization run's output files, made in one
//! place: `<setup>_<analysis>_[w0_<tag>_]<kind>` (`leg_extension_cam1_SO_
//! w0_500_force.sto`, `..._JR_w0_mean_KneeLoads.sto`). A run of one
//! contact weight carries no `w0_` part; a sweep's runs carry their weight's
//! tag ([`w0_tag`]) and its statistics the tags `mean`, `min`, `max`. Read
//! back by [`split_table_stem`] and [`w0_tag_in`] (a study's figure
//! references; the Python package, through its binding).

/// Which run of a contact-weight sweep a file belongs to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Sweep<'a> {
    /// The run of a single weight: no `w0_` part.
    Single,
    /// The run of weight w0 in a sweep.
    Weight(f64),
    /// A statistic over the sweep's runs: `mean`, `min` or `max`.
    Stat(&'a str),
}

/// The tags of a sweep's statistics tables.
pub const SWEEP_STATS: [&str; 3] = ["mean", "min", "max"];

/// A contact weight as file names carry it: `500`, `0.001`, `1e6`.
pub fn w0_tag(w0: f64) -> String {
    let t = format!("{w0}");
    if t.len() <= 8 {
        t
    } else {
        format!("{w0:e}")
    }
}

/// The start every file of a run shares: `<setup>_<analysis>_` or
/// `<setup>_<analysis>_w0_<tag>_`.
pub fn prefix(setup: &str, analysis: &str, sweep: Sweep) -> String {
    match sweep {
        Sweep::Single => format!("{setup}_{analysis}_"),
        Sweep::Weight(w0) => format!("{setup}_{analysis}_w0_{}_", w0_tag(w0)),
        Sweep::Stat(s) => format!("{setup}_{analysis}_w0_{s}_"),
    }
}

/// The file name of table `kind` (with its extension, e.g.
/// `activation.sto`, `log.mcap`) of a run.
pub fn file_name(setup: &str, analysis: &str, sweep: Sweep, kind: &str) -> String {
    format!("{}{kind}", prefix(setup, analysis, sweep))
}

/// The file name of table `kind` that belongs to a setup rather than to
/// one of its analyses: `<setup>_[w0_<tag>_]<kind>` (the knee contact
/// method's `<setup>_KneeContact.sto`, `<setup>_w0_500_KneeContact.sto`).
pub fn setup_file_name(setup: &str, sweep: Sweep, kind: &str) -> String {
    match sweep {
        Sweep::Single => format!("{setup}_{kind}"),
        Sweep::Weight(w0) => format!("{setup}_w0_{}_{kind}", w0_tag(w0)),
        Sweep::Stat(t) => format!("{setup}_w0_{t}_{kind}"),
    }
}

/// The three files of OpenSim's BodyKinematics analysis `analysis` of
/// setup `setup`: `<setup>_<analysis>_pos_global.sto`, `_vel_global.sto`,
/// `_acc_global.sto` (`_bodyLocal` for the velocities and accelerations
/// when they are expressed in the bodies' frames).
pub fn body_kinematics_files(setup: &str, analysis: &str, body_frame: bool) -> [String; 3] {
    let frame = if body_frame { "bodyLocal" } else { "global" };
    [
        format!("{setup}_{analysis}_pos_global.sto"),
        format!("{setup}_{analysis}_vel_{frame}.sto"),
        format!("{setup}_{analysis}_acc_{frame}.sto"),
    ]
}

/// The three files of OpenSim's PointKinematics analysis `analysis` of
/// setup `setup`: `<setup>_<analysis>_<point>_pos.sto`, `_vel.sto`, `_acc.sto`.
pub fn point_kinematics_files(setup: &str, analysis: &str, point: &str) -> [String; 3] {
    ["pos", "vel", "acc"].map(|k| format!("{setup}_{analysis}_{point}_{k}.sto"))
}

/// A table's file stem (no extension) ending in `_<kind>` split into the
/// run's name without the w0 part and the w0 tag, if any:
/// `a_SO_w0_500_force` with kind `force` → (`a_SO`, Some(`500`)),
/// `a_SO_force` → (`a_SO`, None); None when the stem is not of `kind`.
pub fn split_table_stem(stem: &str, kind: &str) -> Option<(String, Option<String>)> {
    let run = stem.strip_suffix(kind)?.strip_suffix('_')?;
    match run.rfind("_w0_") {
        Some(k) if !run[k + 4..].is_empty() && !run[k + 4..].contains('_') => {
            Some((run[..k].to_string(), Some(run[k + 4..].to_string())))
        }
        _ => Some((run.to_string(), None)),
    }
}

/// The w0 tag a file name carries (`..._w0_500_force.sto` → `500`), if any.
pub fn w0_tag_in(file: &str) -> Option<&str> {
    let k = file.find("_w0_")?;
    file[k + 4..].split('_').next().filter(|t| !t.is_empty())
}

/// A file name with its w0 part taken out (`x_SO_w0_1_force.sto` →
/// `x_SO_force.sto`): the name the same run writes with a single weight.
pub fn without_w0(file: &str) -> String {
    match (file.find("_w0_"), w0_tag_in(file)) {
        (Some(k), Some(tag)) => format!("{}{}", &file[..k + 1], &file[k + 5 + tag.len()..]),
        _ => file.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        assert_eq!(w0_tag(500.0), "500");
        assert_eq!(w0_tag(0.001), "0.001");
        assert_eq!(w0_tag(1e6), "1000000");
        assert_eq!(w0_tag(1e9), "1e9");
        assert_eq!(
            file_name("cam1", "SO", Sweep::Weight(500.0), "force.sto"),
            "cam1_SO_w0_500_force.sto"
        );
        assert_eq!(
            file_name("cam1", "SO", Sweep::Single, "log.mcap"),
            "cam1_SO_log.mcap"
        );
        assert_eq!(
            file_name("cam1", "JR", Sweep::Stat("mean"), "KneeLoads.sto"),
            "cam1_JR_w0_mean_KneeLoads.sto"
        );
        for (sweep, tag) in [
            (Sweep::Single, None),
            (Sweep::Weight(0.5), Some("0.5")),
            (Sweep::Stat("max"), Some("max")),
        ] {
            let name = file_name("a_b", "SO", sweep, "MomentArm_knee_angle_r");
            assert_eq!(
                split_table_stem(&name, "MomentArm_knee_angle_r"),
                Some(("a_b_SO".to_string(), tag.map(String::from)))
            );
            assert_eq!(w0_tag_in(&name), tag);
        }
        assert_eq!(split_table_stem("a_SO_force", "activation"), None);
        assert_eq!(
            without_w0("../o/x_SO_w0_1_force.sto"),
            "../o/x_SO_force.sto"
        );
        assert_eq!(
            without_w0("x_JR_w0_mean_KneeLoads.sto"),
            "x_JR_KneeLoads.sto"
        );
        assert_eq!(without_w0("x_SO_force.sto"), "x_SO_force.sto");
    }
}
