//! Malformed input of every kind the tool reads gets exit status 2 and one
//! message naming the file, the element or column and the line or row —
//! never a panic, never a silent NaN. Companion of tests/bad_input.rs (which
//! covers missing files, sockets and the time range); docs/failure_modes.md
//! lists what is checked and what the user should do.
//!
//! Files covered: model `.osim` (4.0 and 3.x layouts), artifact model
//! (`artifact_files`), contacts force-set file, AnalyzeTool and
//! InverseDynamicsTool setups, study document, motion `.mot`, external loads
//! XML and its data file.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use proptest::prelude::*;

const PENDULUM: &str = include_str!("../models/double_pendulum.osim");
const MOTION: &str = include_str!("../motions/double_pendulum_swing.mot");

/// The double pendulum with two reserve actuators, one Thelen muscle whose
/// path has a fixed and a moving point (SimmSpline data), every property on
/// its own line so that a line number identifies the property.
fn rich_model() -> String {
    let forces = r#"<ForceSet name="forceset">
			<objects>
				<CoordinateActuator name="r1">
					<coordinate>q1</coordinate>
					<optimal_force>100</optimal_force>
					<min_control>-Inf</min_control>
					<max_control>Inf</max_control>
				</CoordinateActuator>
				<CoordinateActuator name="r2">
					<coordinate>q2</coordinate>
					<optimal_force>100</optimal_force>
				</CoordinateActuator>
				<Thelen2003Muscle name="flexor">
					<GeometryPath name="path">
						<PathPointSet>
							<objects>
								<PathPoint name="p1">
									<socket_parent_frame>/bodyset/upper</socket_parent_frame>
									<location>0.05 -0.2 0</location>
								</PathPoint>
								<MovingPathPoint name="p2">
									<socket_parent_frame>/bodyset/lower</socket_parent_frame>
									<socket_x_coordinate>/jointset/elbow/q2</socket_x_coordinate>
									<socket_y_coordinate>/jointset/elbow/q2</socket_y_coordinate>
									<socket_z_coordinate>/jointset/elbow/q2</socket_z_coordinate>
									<x_location>
										<SimmSpline>
											<x>-4 0 4</x>
											<y>0.05 0.05 0.05</y>
										</SimmSpline>
									</x_location>
									<y_location>
										<SimmSpline>
											<x>-4 0 4</x>
											<y>-0.1 -0.1 -0.1</y>
										</SimmSpline>
									</y_location>
									<z_location>
										<Constant>
											<value>0</value>
										</Constant>
									</z_location>
								</MovingPathPoint>
							</objects>
						</PathPointSet>
					</GeometryPath>
					<max_isometric_force>500</max_isometric_force>
					<optimal_fiber_length>0.3</optimal_fiber_length>
					<tendon_slack_length>0.5</tendon_slack_length>
					<pennation_angle_at_optimal>0</pennation_angle_at_optimal>
					<max_contraction_velocity>10</max_contraction_velocity>
				</Thelen2003Muscle>
			</objects>
			<groups />
		</ForceSet>"#;
    let start = PENDULUM.find("<ForceSet").unwrap();
    let end = PENDULUM.find("</ForceSet>").unwrap() + "</ForceSet>".len();
    format!("{}{}{}", &PENDULUM[..start], forces, &PENDULUM[end..])
}

/// A contact far below the pendulum (never active), in a force-set file.
const CONTACTS: &str = r#"<?xml version="1.0"?>
<OpenSimDocument Version="40000">
	<ForceSet name="contacts">
		<objects>
			<PointOnPlaneContact name="tip">
				<point_body>lower</point_body>
				<point_location>0 -0.7 0</point_location>
				<plane_body>ground</plane_body>
				<plane_origin>0 -50 0</plane_origin>
				<plane_normal>0 1 0</plane_normal>
				<static_friction>0.8</static_friction>
				<kinetic_friction>0.5</kinetic_friction>
				<contact_tolerance>0.005</contact_tolerance>
				<contact_transition_zone>0.01</contact_transition_zone>
				<v_trans>0.01</v_trans>
				<optimal_force>100</optimal_force>
			</PointOnPlaneContact>
		</objects>
	</ForceSet>
</OpenSimDocument>
"#;

/// A small artifact: one body welded to ground.
const ARTIFACT: &str = r#"<?xml version="1.0"?>
<OpenSimDocument Version="40000">
	<Model name="frame">
		<BodySet name="bodyset">
			<objects>
				<Body name="post">
					<mass>5</mass>
					<mass_center>0 0.5 0</mass_center>
					<inertia>0.4 0.01 0.4 0 0 0</inertia>
				</Body>
			</objects>
		</BodySet>
		<JointSet name="jointset">
			<objects>
				<WeldJoint name="post_weld">
					<socket_parent_frame>/ground</socket_parent_frame>
					<socket_child_frame>/bodyset/post</socket_child_frame>
				</WeldJoint>
			</objects>
		</JointSet>
	</Model>
</OpenSimDocument>
"#;

const ANALYZE: &str = r#"<?xml version="1.0"?>
<OpenSimDocument Version="40000">
	<AnalyzeTool name="run">
		<model_file>model.osim</model_file>
		<artifact_files>artifact.osim</artifact_files>
		<force_set_files>contacts.xml</force_set_files>
		<results_directory>out</results_directory>
		<initial_time>0</initial_time>
		<final_time>0.2</final_time>
		<AnalysisSet name="Analyses">
			<objects>
				<StaticOptimization name="SO">
					<activation_exponent>2</activation_exponent>
					<contact_weight>1</contact_weight>
					<optimizer_convergence_criterion>1e-4</optimizer_convergence_criterion>
				</StaticOptimization>
			</objects>
		</AnalysisSet>
		<coordinates_file>motion.mot</coordinates_file>
		<lowpass_cutoff_frequency_for_coordinates>-1</lowpass_cutoff_frequency_for_coordinates>
	</AnalyzeTool>
</OpenSimDocument>
"#;

const ID_SETUP: &str = r#"<?xml version="1.0"?>
<OpenSimDocument Version="40600">
	<InverseDynamicsTool name="id">
		<results_directory>out</results_directory>
		<model_file>model.osim</model_file>
		<time_range>0 0.2</time_range>
		<forces_to_exclude>Muscles</forces_to_exclude>
		<external_loads_file>loads.xml</external_loads_file>
		<coordinates_file>motion.mot</coordinates_file>
		<lowpass_cutoff_frequency_for_coordinates>6</lowpass_cutoff_frequency_for_coordinates>
		<output_gen_force_file>id.sto</output_gen_force_file>
	</InverseDynamicsTool>
</OpenSimDocument>
"#;

const LOADS: &str = r#"<?xml version="1.0"?>
<OpenSimDocument Version="40000">
	<ExternalLoads name="loads">
		<objects>
			<ExternalForce name="push">
				<applied_to_body>lower</applied_to_body>
				<force_expressed_in_body>ground</force_expressed_in_body>
				<point_expressed_in_body>lower</point_expressed_in_body>
				<force_identifier>f_</force_identifier>
				<point_identifier>p_</point_identifier>
			</ExternalForce>
		</objects>
		<datafile>loads.mot</datafile>
	</ExternalLoads>
</OpenSimDocument>
"#;

fn loads_data() -> String {
    let mut s = String::from(
        "loads\nversion=1\nnRows=11\nnColumns=7\ninDegrees=no\nendheader\ntime\tf_x\tf_y\tf_z\tp_x\tp_y\tp_z\n",
    );
    for k in 0..11 {
        s.push_str(&format!(
            "{:.2}\t1.0\t2.0\t0.0\t0.0\t-0.5\t0.0\n",
            k as f64 * 0.2
        ));
    }
    s
}

const STUDY: &str = r#"<?xml version="1.0"?>
<OpenSimDocument Version="40000">
	<StatoptStudy name="study">
		<setups>id_setup.xml</setups>
		<results_directory>figs</results_directory>
		<Figure name="f" title="t" y_label="y">
			<Series file="out/id.sto" column="q1_moment" scale="1" label="q1"/>
		</Figure>
	</StatoptStudy>
</OpenSimDocument>
"#;

/// One scenario's files, by name; `mutate` rewrites one of them.
#[derive(Clone)]
struct Files(Vec<(&'static str, String)>);

impl Files {
    fn analyze() -> Files {
        Files(vec![
            ("model.osim", rich_model()),
            ("artifact.osim", ARTIFACT.to_string()),
            ("contacts.xml", CONTACTS.to_string()),
            ("motion.mot", MOTION.to_string()),
            ("setup.xml", ANALYZE.to_string()),
        ])
    }
    fn inverse_dynamics() -> Files {
        Files(vec![
            ("model.osim", rich_model()),
            ("motion.mot", MOTION.to_string()),
            ("loads.xml", LOADS.to_string()),
            ("loads.mot", loads_data()),
            ("id_setup.xml", ID_SETUP.to_string()),
            ("study.xml", STUDY.to_string()),
        ])
    }
    fn get(&self, name: &str) -> &str {
        &self.0.iter().find(|(n, _)| *n == name).unwrap().1
    }
    /// Replace the only occurrence of `from` in file `name`; returns the
    /// 1-based line where the replacement starts.
    fn replace(&mut self, name: &str, from: &str, to: &str) -> usize {
        let f = self.0.iter_mut().find(|(n, _)| *n == name).unwrap();
        assert_eq!(
            f.1.matches(from).count(),
            1,
            "'{from}' must occur once in {name}"
        );
        let at = f.1.find(from).unwrap();
        let line = f.1[..at].matches('\n').count() + 1;
        f.1 = f.1.replacen(from, to, 1);
        line
    }
    fn write(&self, dir: &Path) {
        for (n, t) in &self.0 {
            std::fs::write(dir.join(n), t).unwrap();
        }
    }
}

/// Run the tool on `entry` in a fresh folder; (exit status, stderr).
fn run(test: &str, files: &Files, entry: &str) -> (i32, String) {
    let dir = common::out_dir(&format!("malformed_{test}"));
    files.write(&dir);
    let out = Command::new(env!("CARGO_BIN_EXE_statopt-tool"))
        .arg(dir.join(entry))
        .arg("--threads")
        .arg("1")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(
        !err.contains("panicked"),
        "{test}: the tool panicked:\n{err}"
    );
    (out.status.code().unwrap_or(-1), err)
}

/// Assert exit status 2 and a message holding every one of `needles`.
fn expect_input_error(test: &str, (code, err): (i32, String), needles: &[&str]) {
    assert_eq!(
        code, 2,
        "{test}: expected exit status 2, got {code}:\n{err}"
    );
    for n in needles {
        assert!(err.contains(n), "{test}: message lacks '{n}':\n{err}");
    }
}

#[test]
fn good_inputs_run() {
    let (code, err) = run("good_analyze", &Files::analyze(), "setup.xml");
    assert_eq!(code, 0, "{err}");
    let (code, err) = run("good_study", &Files::inverse_dynamics(), "study.xml");
    assert_eq!(code, 0, "{err}");
    assert!(!err.contains("unknown property"), "{err}");
}

/// NaN and Inf in every kind of numeric field: (file, text, replacement,
/// element named in the message). The reported line is the line of the text.
#[test]
fn nan_and_inf_in_every_numeric_field() {
    let analyze_cases: &[(&str, &str, &str, &str)] = &[
        ("model.osim", "<mass>2.3</mass>", "<mass>NaN</mass>", "<mass>"),
        ("model.osim", "<mass>1.7</mass>", "<mass>Inf</mass>", "<mass>"),
        ("model.osim", "0.11 0.02 0.11 0 0 0", "0.11 nan 0.11 0 0 0", "<inertia>"),
        ("model.osim", "<mass_center>0 -0.4 0", "<mass_center>0 -inf 0", "<mass_center>"),
        ("model.osim", "<translation>0 1.5 0", "<translation>0 NaN 0", "<translation>"),
        ("model.osim", "<orientation>0 0 0</orientation>\n\t\t\t\t\t\t</PhysicalOffsetFrame>\n\t\t\t\t\t\t<PhysicalOffsetFrame name=\"upper_offset\">\n\t\t\t\t\t\t\t<socket_parent>/bodyset/upper</socket_parent>\n\t\t\t\t\t\t\t<translation>0 0 0", "<orientation>0 Inf 0</orientation>\n\t\t\t\t\t\t</PhysicalOffsetFrame>\n\t\t\t\t\t\t<PhysicalOffsetFrame name=\"upper_offset\">\n\t\t\t\t\t\t\t<socket_parent>/bodyset/upper</socket_parent>\n\t\t\t\t\t\t\t<translation>0 0 0", "<orientation>"),
        ("model.osim", "<default_value>0</default_value>\n\t\t\t\t\t\t\t<range>-3.14159 3.14159</range>\n\t\t\t\t\t\t</Coordinate>\n\t\t\t\t\t</coordinates>\n\t\t\t\t\t<frames>\n\t\t\t\t\t\t<PhysicalOffsetFrame name=\"ground_offset\">", "<default_value>NaN</default_value>\n\t\t\t\t\t\t\t<range>-3.14159 3.14159</range>\n\t\t\t\t\t\t</Coordinate>\n\t\t\t\t\t</coordinates>\n\t\t\t\t\t<frames>\n\t\t\t\t\t\t<PhysicalOffsetFrame name=\"ground_offset\">", "<default_value>"),
        ("model.osim", "<gravity>0 -9.80665 0</gravity>", "<gravity>0 NaN 0</gravity>", "<gravity>"),
        ("model.osim", "<max_isometric_force>500<", "<max_isometric_force>NaN<", "<max_isometric_force>"),
        ("model.osim", "<optimal_fiber_length>0.3<", "<optimal_fiber_length>Inf<", "<optimal_fiber_length>"),
        ("model.osim", "<tendon_slack_length>0.5<", "<tendon_slack_length>-Inf<", "<tendon_slack_length>"),
        ("model.osim", "<pennation_angle_at_optimal>0<", "<pennation_angle_at_optimal>nan<", "<pennation_angle_at_optimal>"),
        ("model.osim", "<max_contraction_velocity>10<", "<max_contraction_velocity>inf<", "<max_contraction_velocity>"),
        ("model.osim", "<location>0.05 -0.2 0</location>", "<location>0.05 NaN 0</location>", "<location>"),
        ("model.osim", "<y>0.05 0.05 0.05</y>", "<y>0.05 NaN 0.05</y>", "<y>"),
        ("model.osim", "<x>-4 0 4</x>\n\t\t\t\t\t\t\t\t\t\t\t<y>-0.1", "<x>-4 Inf 4</x>\n\t\t\t\t\t\t\t\t\t\t\t<y>-0.1", "<x>"),
        ("model.osim", "<value>0</value>", "<value>NaN</value>", "<value>"),
        ("model.osim", "<optimal_force>100</optimal_force>\n\t\t\t\t\t<min_control>", "<optimal_force>Inf</optimal_force>\n\t\t\t\t\t<min_control>", "<optimal_force>"),
        ("model.osim", "<min_control>-Inf</min_control>", "<min_control>NaN</min_control>", "<min_control>"),
        ("artifact.osim", "<mass>5</mass>", "<mass>NaN</mass>", "<mass>"),
        ("artifact.osim", "<inertia>0.4 0.01 0.4 0 0 0", "<inertia>0.4 0.01 Inf 0 0 0", "<inertia>"),
        ("contacts.xml", "<point_location>0 -0.7 0", "<point_location>0 NaN 0", "<point_location>"),
        ("contacts.xml", "<plane_normal>0 1 0", "<plane_normal>0 Inf 0", "<plane_normal>"),
        ("contacts.xml", "<static_friction>0.8<", "<static_friction>NaN<", "<static_friction>"),
        ("contacts.xml", "<contact_tolerance>0.005<", "<contact_tolerance>Inf<", "<contact_tolerance>"),
        ("contacts.xml", "<v_trans>0.01<", "<v_trans>NaN<", "<v_trans>"),
        ("setup.xml", "<initial_time>0<", "<initial_time>NaN<", "<initial_time>"),
        ("setup.xml", "<final_time>0.2<", "<final_time>nan<", "<final_time>"),
        ("setup.xml", "<contact_weight>1<", "<contact_weight>NaN<", "<contact_weight>"),
        ("setup.xml", "<activation_exponent>2<", "<activation_exponent>Inf<", "<activation_exponent>"),
        ("setup.xml", "<optimizer_convergence_criterion>1e-4<", "<optimizer_convergence_criterion>NaN<", "<optimizer_convergence_criterion>"),
        ("setup.xml", "<lowpass_cutoff_frequency_for_coordinates>-1<", "<lowpass_cutoff_frequency_for_coordinates>NaN<", "<lowpass_cutoff_frequency_for_coordinates>"),
    ];
    let mut failures = Vec::new();
    for (k, (file, from, to, element)) in analyze_cases.iter().enumerate() {
        let mut f = Files::analyze();
        let line = f.replace(file, from, to);
        let (code, err) = run(&format!("nan_{k}"), &f, "setup.xml");
        let line_s = format!("line {line}");
        if code != 2 || !err.contains(file) || !err.contains(&line_s) || !err.contains(element) {
            failures.push(format!(
                "{file}: {to:?} → exit {code}, expected 2 naming {file}, {line_s}, {element}:\n{err}"
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

#[test]
fn nan_in_storage_cells_and_time_column() {
    // Motion: a data cell and the time column.
    let cases: &[(&str, &str, &str, &str)] = &[
        (
            "motion.mot",
            "0.0200\t1.88371559",
            "0.0200\tNaN",
            "column 'q1'",
        ),
        (
            "motion.mot",
            "0.0200\t1.88371559",
            "NaN\t1.88371559",
            "column 'time'",
        ),
        (
            "motion.mot",
            "0.0200\t1.88371559",
            "0.0200\tInf",
            "column 'q1'",
        ),
        ("loads.mot", "0.20\t1.0", "0.20\tNaN", "column 'f_x'"),
        ("loads.mot", "0.40\t1.0", "inf\t1.0", "column 'time'"),
    ];
    for (k, (file, from, to, column)) in cases.iter().enumerate() {
        let mut f = Files::inverse_dynamics();
        let line = f.replace(file, from, to);
        expect_input_error(
            &format!("storage_{k}"),
            run(&format!("storage_{k}"), &f, "id_setup.xml"),
            &[file, &format!("line {line}"), column],
        );
    }
}

#[test]
fn nan_in_setup_and_study_numbers() {
    let mut f = Files::inverse_dynamics();
    let line = f.replace("id_setup.xml", "<time_range>0 0.2<", "<time_range>0 NaN<");
    expect_input_error(
        "id_time_range",
        run("id_time_range", &f, "id_setup.xml"),
        &["id_setup.xml", &format!("line {line}"), "<time_range>"],
    );
    // -Inf Inf is OpenSim's own spelling of "the whole motion": accepted.
    let mut f = Files::inverse_dynamics();
    f.replace(
        "id_setup.xml",
        "<time_range>0 0.2<",
        "<time_range>-Inf Inf<",
    );
    let (code, err) = run("id_time_range_inf", &f, "id_setup.xml");
    assert_eq!(code, 0, "{err}");

    let mut f = Files::inverse_dynamics();
    let line = f.replace("study.xml", "scale=\"1\"", "scale=\"NaN\"");
    expect_input_error(
        "study_scale",
        run("study_scale", &f, "study.xml"),
        &["study.xml", &format!("line {line}"), "<Series", "scale"],
    );
}

/// A truncated file of every kind: the message names the file and a line.
#[test]
fn truncated_files_of_every_kind() {
    let cases: &[(&str, &str, fn() -> Files)] = &[
        ("model.osim", "setup.xml", Files::analyze),
        ("artifact.osim", "setup.xml", Files::analyze),
        ("contacts.xml", "setup.xml", Files::analyze),
        ("setup.xml", "setup.xml", Files::analyze),
        ("motion.mot", "setup.xml", Files::analyze),
        ("loads.xml", "id_setup.xml", Files::inverse_dynamics),
        ("loads.mot", "id_setup.xml", Files::inverse_dynamics),
        ("id_setup.xml", "id_setup.xml", Files::inverse_dynamics),
        ("study.xml", "study.xml", Files::inverse_dynamics),
    ];
    for (file, entry, make) in cases {
        let mut f = make();
        let text = f.get(file).to_string();
        let cut = text.len() * 2 / 3;
        let cut = (0..=cut).rev().find(|&i| text.is_char_boundary(i)).unwrap();
        f.0.iter_mut().find(|(n, _)| n == file).unwrap().1 = text[..cut].to_string();
        let test = format!("truncated_{}", file.replace('.', "_"));
        expect_input_error(&test, run(&test, &f, entry), &[file, "line"]);
    }
}

#[test]
fn unknown_element_types_are_named() {
    let cases: &[(&str, &str, &str, &str, fn() -> Files, &str)] = &[
        // joint type (3.x and 4.0 layouts are covered in tests/bad_input.rs and below)
        (
            "artifact.osim",
            "WeldJoint name",
            "HingeJoint name",
            "HingeJoint",
            Files::analyze,
            "setup.xml",
        ),
        // analysis type
        (
            "setup.xml",
            "<StaticOptimization name=\"SO\">",
            "<InducedAccelerations name=\"SO\">",
            "InducedAccelerations",
            Files::analyze,
            "setup.xml",
        ),
        // tool type
        (
            "id_setup.xml",
            "<InverseDynamicsTool name=\"id\">",
            "<ForwardTool name=\"id\">",
            "ForwardTool",
            Files::inverse_dynamics,
            "id_setup.xml",
        ),
    ];
    for (k, (file, from, to, named, make, entry)) in cases.iter().enumerate() {
        let mut f = make();
        let line = f.replace(file, from, to);
        if *file == "artifact.osim" {
            f.replace(file, "</WeldJoint>", "</HingeJoint>");
        }
        if *file == "setup.xml" {
            f.replace(file, "</StaticOptimization>", "</InducedAccelerations>");
        }
        if *file == "id_setup.xml" {
            f.replace(file, "</InverseDynamicsTool>", "</ForwardTool>");
        }
        expect_input_error(
            &format!("unknown_{k}"),
            run(&format!("unknown_{k}"), &f, entry),
            &[file, &format!("line {line}"), named],
        );
    }
}

/// An unknown force type needed by static optimization is refused by name.
#[test]
fn unknown_force_type_is_named() {
    let mut f = Files::analyze();
    let line = f.replace(
        "contacts.xml",
        "<PointOnPlaneContact name=\"tip\">",
        "<HuntCrossleyForce name=\"tip\">",
    );
    f.replace(
        "contacts.xml",
        "</PointOnPlaneContact>",
        "</HuntCrossleyForce>",
    );
    let (code, err) = run("unknown_force", &f, "setup.xml");
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("HuntCrossleyForce")
            && err.contains("contacts.xml")
            && err.contains(&format!("line {line}")),
        "{err}"
    );
}

/// Unknown properties of known elements: ignored as OpenSim 4.6 ignores them
/// (checked: a `<frobnicate>` in a Body loads in OpenSim 4.6 without a
/// message), but with a warning naming file, line and element.
#[test]
fn unknown_properties_warn_with_location() {
    let mut f = Files::analyze();
    let line = f.replace(
        "model.osim",
        "<mass_center>0 -0.4 0</mass_center>",
        "<mass_centre>0 -0.4 0</mass_centre>",
    );
    let sline = f.replace(
        "setup.xml",
        "<activation_exponent>2</activation_exponent>",
        "<activation_exponant>2</activation_exponant>",
    );
    // The setup's misspelling is refused unless the user reads on past it.
    let (code, err) = run_with("unknown_property", &f, "setup.xml", &["--allow-unknown"]);
    assert_eq!(code, 0, "{err}");
    assert!(
        err.contains("model.osim")
            && err.contains("<Body name=\"upper\">")
            && err.contains("unknown property <mass_centre>")
            && err.contains(&format!("(line {line})")),
        "{err}"
    );
    assert!(
        err.contains("setup.xml")
            && err.contains("unknown element <activation_exponant>")
            && err.contains("did you mean activation_exponent")
            && err.contains(&format!("line {sline}")),
        "{err}"
    );
}

#[test]
fn physically_impossible_bodies() {
    for (k, (from, to)) in [
        ("<mass>2.3</mass>", "<mass>-2.3</mass>"),
        ("0.11 0.02 0.11 0 0 0", "-0.11 0.02 0.11 0 0 0"),
    ]
    .iter()
    .enumerate()
    {
        let mut f = Files::analyze();
        let line = f.replace("model.osim", from, to);
        expect_input_error(
            &format!("impossible_{k}"),
            run(&format!("impossible_{k}"), &f, "setup.xml"),
            &["model.osim", &format!("line {line}"), "<"],
        );
    }
    // The triangle inequality violated: OpenSim 4.6 accepts it (its
    // leg6dof9musc model has such a body); statopt warns.
    let mut f = Files::analyze();
    f.replace("model.osim", "0.11 0.02 0.11 0 0 0", "0.11 0.02 0.5 0 0 0");
    let (code, err) = run("triangle", &f, "setup.xml");
    assert_eq!(code, 0, "{err}");
    assert!(
        err.contains("triangle inequality") && err.contains("model.osim"),
        "{err}"
    );
    // Said once, where it is (file and line), and what is done with it.
    let said: Vec<&str> = err.lines().filter(|l| l.contains("inertia")).collect();
    assert_eq!(said.len(), 1, "one warning about the inertia: {err}");
    assert!(said[0].contains("used as given"), "{err}");
    // It names the body even when the location is the <inertia> element.
    let body = Files::analyze().get("model.osim").to_string();
    let line = body
        .lines()
        .position(|l| l.contains("0.11 0.02 0.11 0 0 0"))
        .unwrap();
    let name = body
        .lines()
        .take(line)
        .filter_map(|l| l.split("<Body name=\"").nth(1))
        .last()
        .unwrap();
    let name = &name[..name.find('"').unwrap()];
    assert!(said[0].contains(&format!("body '{name}'")), "{err}");
}

/// Degrees in a file that says radians (and radians read as degrees the
/// other way round are undetectable: they are small): refused, naming the
/// file, column and row.
#[test]
fn motion_in_wrong_units() {
    let mut f = Files::analyze();
    f.replace("motion.mot", "inDegrees=yes", "inDegrees=no");
    expect_input_error(
        "units",
        run("units", &f, "setup.xml"),
        // q1 = 30 sin(pi t) degrees read as radians first leaves
        // [-pi - 2pi, pi + 2pi] where sin(pi t) > 0.31416: t = 0.12, row 7.
        &["motion.mot", "column 'q1'", "row 7 ", "inDegrees=no"],
    );
}

/// The 3.x layout: NaN in a 3.x joint offset and a truncated 3.x file.
#[test]
fn model_3x_layout() {
    let model3 = r#"<?xml version="1.0"?>
<OpenSimDocument Version="30000">
	<Model name="m3">
		<BodySet>
			<objects>
				<Body name="ground">
					<mass>0</mass>
				</Body>
				<Body name="upper">
					<mass>2.3</mass>
					<mass_center>0 -0.4 0</mass_center>
					<inertia_xx>0.11</inertia_xx>
					<inertia_yy>0.02</inertia_yy>
					<inertia_zz>0.11</inertia_zz>
					<Joint>
						<PinJoint name="shoulder">
							<parent_body>ground</parent_body>
							<location_in_parent>0 1.5 0</location_in_parent>
							<orientation_in_parent>0 0 0</orientation_in_parent>
							<location>0 0 0</location>
							<orientation>0 0 0</orientation>
							<CoordinateSet>
								<objects>
									<Coordinate name="q1">
										<range>-3.14159 3.14159</range>
									</Coordinate>
								</objects>
							</CoordinateSet>
						</PinJoint>
					</Joint>
				</Body>
			</objects>
		</BodySet>
	</Model>
</OpenSimDocument>
"#;
    let dir = common::out_dir("malformed_3x");
    let p = dir.join("m3.osim");
    std::fs::write(&p, model3).unwrap();
    statopt::tools::loading::load_model(&p).expect("the 3.x model loads");
    for (k, (from, to, el)) in [
        (
            "<location_in_parent>0 1.5 0",
            "<location_in_parent>0 NaN 0",
            "<location_in_parent>",
        ),
        ("<inertia_yy>0.02<", "<inertia_yy>Inf<", "<inertia_yy>"),
        (
            "<PinJoint name=\"shoulder\">",
            "<HingeJoint name=\"shoulder\">",
            "HingeJoint",
        ),
    ]
    .iter()
    .enumerate()
    {
        let mut text = model3.replacen(from, to, 1);
        if k == 2 {
            text = text.replacen("</PinJoint>", "</HingeJoint>", 1);
        }
        let line = model3[..model3.find(from).unwrap()].matches('\n').count() + 1;
        std::fs::write(&p, &text).unwrap();
        let e = statopt::tools::loading::load_model(&p).unwrap_err();
        let msg = e.to_string();
        assert_eq!(e.exit_code(), 2, "{msg}");
        assert!(
            msg.contains("m3.osim") && msg.contains(&format!("line {line}")) && msg.contains(el),
            "{msg}"
        );
    }
}

fn write_tmp(name: &str, text: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("malformed_prop");
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn xml_files() -> Vec<(&'static str, String)> {
    let mut v = Files::analyze().0;
    v.extend(Files::inverse_dynamics().0);
    v.retain(|(n, _)| !n.ends_with(".mot"));
    v
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, .. ProptestConfig::default() })]

    /// Any cut of any XML input before its root's closing tag is an input
    /// error naming the file and a line (the line of the unclosed element or
    /// of the broken token).
    #[test]
    fn truncated_xml_is_located(which in 0usize..9, frac in 0.0f64..1.0) {
        let files = xml_files();
        let (name, text) = &files[which % files.len()];
        let end = text.rfind("</").unwrap();
        let mut cut = (frac * end as f64) as usize;
        while !text.is_char_boundary(cut) { cut -= 1; }
        let p = write_tmp(&format!("cut_{name}"), &text[..cut]);
        let e = statopt::xml::parse_file(&p).unwrap_err();
        prop_assert_eq!(e.exit_code(), 2);
        let msg = e.to_string();
        prop_assert!(msg.contains(name) && (msg.contains("line") || msg.contains("no XML element")), "{}", msg);
    }

    /// Any cut of a legacy motion (nRows given) is an error naming the file.
    /// Cuts inside the last value are left out: "0.00000000" cut to "0.0000"
    /// is still a complete, valid file (a case proptest once found).
    #[test]
    fn truncated_motion_is_located(frac in 0.0f64..1.0) {
        let text = MOTION.trim_end();
        let last_value = text.rfind('\t').unwrap() + 1;
        let cut = (frac * last_value as f64) as usize;
        let p = write_tmp("cut.mot", &text[..cut]);
        let e = statopt::storage::read(&p).unwrap_err();
        prop_assert_eq!(e.exit_code(), 2);
        let msg = e.to_string();
        prop_assert!(msg.contains("cut.mot"), "{}", msg);
    }
}

/// statopt's own elements get the same check: a misspelled contact property
/// used to be ignored without a word, so the run used the default friction.
#[test]
fn misspelled_contact_property_warns_with_location() {
    for ty in ["PointOnPlaneContact", "ContactPointOnPlane"] {
        let mut f = Files::analyze();
        if ty != "PointOnPlaneContact" {
            f.replace(
                "contacts.xml",
                "<PointOnPlaneContact name=\"tip\">",
                &format!("<{ty} name=\"tip\">"),
            );
            f.replace(
                "contacts.xml",
                "</PointOnPlaneContact>",
                &format!("</{ty}>"),
            );
        }
        let line = f.replace(
            "contacts.xml",
            "<static_friction>0.8</static_friction>",
            "<static_fricton>0.05</static_fricton>",
        );
        let (code, err) = run(&format!("misspelled_contact_{ty}"), &f, "setup.xml");
        assert_eq!(code, 0, "{err}");
        assert!(
            err.contains("contacts.xml")
                && err.contains(&format!("<{ty} name=\"tip\">"))
                && err.contains("unknown property <static_fricton>")
                && err.contains(&format!("(line {line})")),
            "{ty}: {err}"
        );
    }
}

/// OpenSim's own `<defaults>` block (in the stock gait2392 setups) and
/// statopt's setup extensions are known: no "check its spelling" false alarm.
#[test]
fn defaults_block_and_statopt_setup_options_draw_no_warning() {
    let mut f = Files::analyze();
    f.replace(
        "setup.xml",
        "<model_file>model.osim</model_file>",
        "<defaults><StaticOptimization name=\"default\"><on>true</on></StaticOptimization></defaults>\n<model_file>model.osim</model_file><reduce_model>false</reduce_model><coordinate_spline>gcv5</coordinate_spline>",
    );
    f.replace(
        "setup.xml",
        "<activation_exponent>2</activation_exponent>",
        "<activation_exponent>2</activation_exponent><constraint_matrix>analytic</constraint_matrix><solver_tolerance>1e-8</solver_tolerance><solver>clarabel</solver>",
    );
    let (code, err) = run("defaults_block", &f, "setup.xml");
    assert_eq!(code, 0, "{err}");
    assert!(!err.contains("unknown property"), "{err}");
}

/// An unknown `<solver>` is an input error naming the file, the element and
/// the value.
#[test]
fn unknown_solver_is_refused() {
    let mut f = Files::analyze();
    f.replace(
        "setup.xml",
        "<activation_exponent>2</activation_exponent>",
        "<activation_exponent>2</activation_exponent><solver>ipopt</solver>",
    );
    expect_input_error(
        "unknown_solver",
        run("unknown_solver", &f, "setup.xml"),
        &["setup.xml", "solver", "'ipopt'", "clarabel"],
    );
}

/// A Body without `<mass>` is refused, as OpenSim 4.6 refuses it
/// ("unspecified or negative mass"); it used to run as massless.
#[test]
fn body_without_mass_is_refused() {
    for (k, to) in [(0, ""), (1, "<mas>2.3</mas>")] {
        let mut f = Files::analyze();
        f.replace("model.osim", "<mass>2.3</mass>", to);
        expect_input_error(
            &format!("no_mass_{k}"),
            run(&format!("no_mass_{k}"), &f, "setup.xml"),
            &["model.osim", "<Body name=\"upper\">", "mass"],
        );
    }
}

/// Where OpenSim clamps or ignores silently, statopt says so; where the
/// input would make the numbers meaningless, it refuses. Each case failed
/// silently before (exit 0, nothing said).
#[test]
fn silent_clamps_are_said_out_loud() {
    // (name, file, from, to, expected exit status, words the message holds)
    let cases: &[(&str, &str, &str, &str, i32, &[&str])] = &[
        (
            "nyquist",
            "setup.xml",
            "<lowpass_cutoff_frequency_for_coordinates>-1</lowpass_cutoff_frequency_for_coordinates>",
            "<lowpass_cutoff_frequency_for_coordinates>30</lowpass_cutoff_frequency_for_coordinates>",
            0,
            &["motion.mot", "30 Hz", "Nyquist", "25 Hz", "0.49 fs"],
        ),
        (
            "final_time_past_data",
            "setup.xml",
            "<final_time>0.2</final_time>",
            "<final_time>5</final_time>",
            0,
            &["setup.xml", "end time 5 is past the last time", "(2)"],
        ),
        (
            "unmatched_column",
            "motion.mot",
            "time\tq1\tq2",
            "time\tq1\tq2_typo",
            0,
            &["motion.mot", "1 column(s) match no coordinate", "q2_typo"],
        ),
        (
            "mu_k_above_mu_s",
            "contacts.xml",
            "<kinetic_friction>0.5</kinetic_friction>",
            "<kinetic_friction>0.9</kinetic_friction>",
            0,
            &["contacts.xml", "<PointOnPlaneContact name=\"tip\">", "kinetic_friction 0.9 exceeds static_friction 0.8"],
        ),
        (
            "empty_contact_weight",
            "setup.xml",
            "<contact_weight>1</contact_weight>",
            "<contact_weight/>",
            2,
            &["setup.xml", "<contact_weight>", "empty"],
        ),
        (
            "tiny_contact_weight",
            "setup.xml",
            "<contact_weight>1</contact_weight>",
            "<contact_weight>1e-300</contact_weight>",
            2,
            &["setup.xml", "<contact_weight>", "1e-300", "outside"],
        ),
        (
            "near_duplicate_rows",
            "motion.mot",
            "0.0200\t1.88371559\t0.08879722",
            "0.0000001\t0.00000001\t0.00000001",
            2,
            &["motion.mot", "near-duplicate", "1e-7"],
        ),
        (
            "non_uniform_time",
            "motion.mot",
            "0.0200\t1.88371559\t0.08879722",
            "0.0100\t0.94185779\t0.02219930",
            0,
            &["motion.mot", "not uniform", "0.01 s to 0.03"],
        ),
    ];
    for (name, file, from, to, code, needles) in cases {
        let mut f = Files::analyze();
        f.replace(file, from, to);
        let (got, err) = run(&format!("clamp_{name}"), &f, "setup.xml");
        assert_eq!(got, *code, "{name}: exit status {got}:\n{err}");
        for n in *needles {
            assert!(err.contains(n), "{name}: message lacks '{n}':\n{err}");
        }
    }
    // forces_to_exclude naming nothing (inverse dynamics).
    let mut f = Files::inverse_dynamics();
    f.replace(
        "id_setup.xml",
        "<forces_to_exclude>Muscles</forces_to_exclude>",
        "<forces_to_exclude>Muscles elbow_sprng</forces_to_exclude>",
    );
    let (code, err) = run("clamp_forces_to_exclude", &f, "id_setup.xml");
    assert_eq!(code, 0, "{err}");
    assert!(
        err.contains("forces_to_exclude: 'elbow_sprng' matches no force"),
        "{err}"
    );
    assert!(!err.contains("'Muscles' matches no force"), "{err}");
}

/// A file the setup names but that is not there: the error names the setup,
/// the element and its line (it named only the path before).
#[test]
fn missing_input_files_name_the_setup_element_and_line() {
    for (element, from, to) in [
        (
            "model_file",
            "<model_file>model.osim<",
            "<model_file>nomodel.osim<",
        ),
        (
            "coordinates_file",
            "<coordinates_file>motion.mot<",
            "<coordinates_file>nomotion.mot<",
        ),
        (
            "force_set_files",
            "<force_set_files>contacts.xml<",
            "<force_set_files>nocontacts.xml<",
        ),
        (
            "artifact_files",
            "<artifact_files>artifact.osim<",
            "<artifact_files>noartifact.osim<",
        ),
    ] {
        let mut f = Files::analyze();
        let line = f.replace("setup.xml", from, to);
        let missing = to
            .trim_start_matches(&format!("<{element}>"))
            .trim_end_matches('<');
        expect_input_error(
            &format!("missing_{element}"),
            run(&format!("missing_{element}"), &f, "setup.xml"),
            &[
                "setup.xml",
                &format!("line {line}"),
                &format!("<{element}>"),
                missing,
                "file not found",
            ],
        );
    }
}

/// A study of the analyze setup (static optimization with one contact).
fn analyze_study(series_file: &str) -> Files {
    let mut f = Files::analyze();
    f.0.push((
        "study.xml",
        format!(
            r#"<?xml version="1.0"?>
<OpenSimDocument Version="40000"><StatoptStudy name="study"><setups>setup.xml</setups><results_directory>figs</results_directory>
<Figure name="f" title="t" y_label="y"><Series file="{series_file}" column="q1_reserve q1_reserve" label="q1"/></Figure>
</StatoptStudy></OpenSimDocument>
"#
        ),
    ));
    f.replace(
        "setup.xml",
        "<contact_weight>1</contact_weight>",
        "<contact_weight>1 1000</contact_weight><reserve_actuators>1</reserve_actuators>",
    );
    f
}

/// A study's figure naming a w0 its setup does not run is refused before
/// anything is computed (it used to fail, or draw an old table, after the
/// whole computation).
#[test]
fn study_figures_are_checked_against_the_runs_before_computing() {
    let f = analyze_study("out/run_SO_w0_500_activation.sto");
    let (code, err) = run("study_w0", &f, "study.xml");
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("malformed_study_w0");
    assert_eq!(code, 2, "{err}");
    for n in ["study.xml", "<Series", "names w0 = 500", "w0 = 1, 1000"] {
        assert!(err.contains(n), "lacks '{n}': {err}");
    }
    assert!(
        !dir.join("out").exists(),
        "nothing may be computed before the check"
    );
}

/// A study's figure naming a table its setup does not write (a misspelt
/// kind, a w0 it runs) is refused before anything is computed: references
/// are looked up among the names of the setup's planned outputs
/// (`writers::names::Planned`). It used to pass the check (the name began
/// with the setup's and carried a w0 it runs) and fail after the runs.
#[test]
fn study_figures_name_tables_the_plan_writes() {
    let f = analyze_study("out/run_SO_w0_1000_activations.sto");
    let (code, err) = run("study_kind", &f, "study.xml");
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("malformed_study_kind");
    assert_eq!(code, 2, "{err}");
    for n in [
        "study.xml",
        "<Series",
        "run_SO_w0_1000_activations.sto",
        "writes no table",
        "run_SO_w0_1_activation.sto",
    ] {
        assert!(err.contains(n), "lacks '{n}': {err}");
    }
    assert!(
        !dir.join("out").exists(),
        "nothing may be computed before the check"
    );
    // The right name passes the check and is drawn.
    let f = analyze_study("out/run_SO_w0_1000_activation.sto");
    let (code, err) = run("study_kind_ok", &f, "study.xml");
    assert_eq!(code, 0, "{err}");
}

/// A table left over from an earlier run is not drawn: the study stops and
/// names it. Here the first run wrote ContactForces; the second run has no
/// contacts, so the old table would have been drawn as if it were current.
#[test]
fn study_never_draws_a_stale_table() {
    let mut f = analyze_study("out/run_SO_w0_1_ContactForces.sto");
    f.replace(
        "study.xml",
        "column=\"q1_reserve q1_reserve\"",
        "column=\"tip_distance\"",
    );
    let (code, err) = run("study_stale", &f, "study.xml");
    assert_eq!(code, 0, "first run: {err}");
    // Same folder, contacts dropped: ContactForces is no longer written.
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("malformed_study_stale");
    let setup = std::fs::read_to_string(dir.join("setup.xml")).unwrap();
    std::fs::write(
        dir.join("setup.xml"),
        setup.replace("<force_set_files>contacts.xml</force_set_files>", ""),
    )
    .unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_statopt-tool"))
        .arg(dir.join("study.xml"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("run_SO_w0_1_ContactForces.sto") && err.contains("stale"),
        "{err}"
    );
}

/// `-o DIR` on a study moves every output, the setups' tables too.
#[test]
fn study_results_dir_moves_every_output() {
    let f = analyze_study("out/run_SO_w0_1_activation.sto");
    let dir = common::out_dir("malformed_study_moved");
    f.write(&dir);
    let moved = dir.join("moved");
    let out = Command::new(env!("CARGO_BIN_EXE_statopt-tool"))
        .arg(dir.join("study.xml"))
        .arg("-o")
        .arg(&moved)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{err}");
    assert!(
        moved.join("out/run_SO_w0_1_activation.sto").is_file(),
        "{err}"
    );
    assert!(moved.join("f.png").is_file());
    assert!(
        !dir.join("out").exists(),
        "the setup's own folder stays empty"
    );
    assert!(!dir.join("figs").exists());
    // The summary counts every solve of the study (two w0, 11 frames each).
    assert!(err.contains("22 of 22 frame problems solved"), "{err}");
}

/// `--check` reports every problem at once and runs nothing.
#[test]
fn check_reports_every_problem_at_once_without_running() {
    let check = |test: &str, f: &Files, entry: &str| -> (i32, String, PathBuf) {
        let dir = common::out_dir(&format!("malformed_{test}"));
        f.write(&dir);
        let out = Command::new(env!("CARGO_BIN_EXE_statopt-tool"))
            .arg(dir.join(entry))
            .arg("--check")
            .output()
            .unwrap();
        (
            out.status.code().unwrap_or(-1),
            String::from_utf8_lossy(&out.stderr).to_string(),
            dir,
        )
    };
    // Two missing files.
    let mut f = Files::analyze();
    f.replace(
        "setup.xml",
        "<coordinates_file>motion.mot<",
        "<coordinates_file>nomotion.mot<",
    );
    f.replace(
        "setup.xml",
        "<force_set_files>contacts.xml<",
        "<force_set_files>nocontacts.xml<",
    );
    let (code, err, dir) = check("check_missing", &f, "setup.xml");
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("nomotion.mot")
            && err.contains("nocontacts.xml")
            && err.contains("2 problem(s)"),
        "{err}"
    );
    assert!(!dir.join("out").exists());
    // Problems in two stages: a contact property and the motion.
    let mut f = Files::analyze();
    f.replace(
        "contacts.xml",
        "<static_friction>0.8</static_friction>",
        "<static_friction>-0.8</static_friction>",
    );
    f.replace(
        "motion.mot",
        "0.0200\t1.88371559\t0.08879722",
        "0.0200\tNaN\t0.08879722",
    );
    let (code, err, dir) = check("check_stages", &f, "setup.xml");
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("static_friction") && err.contains("NaN") && err.contains("2 problem(s)"),
        "{err}"
    );
    assert!(!dir.join("out").exists());
    // A good setup: no problem, nothing written.
    let (code, err, dir) = check("check_good", &Files::analyze(), "setup.xml");
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("0 problem(s)"), "{err}");
    assert!(!dir.join("out").exists());
}

/// Errors about `<close_contacts>` entries carry the setup's line.
#[test]
fn close_contacts_errors_carry_a_line() {
    for (entry, needle) in [
        ("nocontact=q1", "no contact named 'nocontact'"),
        ("tip=q9", "q9"),
    ] {
        let mut f = Files::analyze();
        let line = f.replace(
            "setup.xml",
            "<coordinates_file>motion.mot</coordinates_file>",
            &format!("<close_contacts>{entry}</close_contacts><coordinates_file>motion.mot</coordinates_file>"),
        );
        expect_input_error(
            &format!("close_{entry}"),
            run(
                &format!("close_{}", entry.replace('=', "_")),
                &f,
                "setup.xml",
            ),
            &[
                "setup.xml",
                &format!("line {line}"),
                "<close_contacts>",
                needle,
            ],
        );
    }
}

/// Run the tool on `entry` with extra arguments; (exit status, stderr).
fn run_with(test: &str, files: &Files, entry: &str, args: &[&str]) -> (i32, String) {
    let dir = common::out_dir(&format!("malformed_{test}"));
    files.write(&dir);
    let out = Command::new(env!("CARGO_BIN_EXE_statopt-tool"))
        .arg(dir.join(entry))
        .args(args)
        .arg("--threads")
        .arg("1")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(
        !err.contains("panicked"),
        "{test}: the tool panicked:\n{err}"
    );
    (out.status.code().unwrap_or(-1), err)
}

/// A misspelled property of a setup document is refused (exit 2), not
/// ignored: `<contact_wieght>` used to leave w0 at its default 1000 where
/// the user meant 1, with a warning and exit 0. The message names the file,
/// the line, the element and the nearest known name; `--check` says the
/// same and exits 2; `--allow-unknown` reads on with a warning.
#[test]
fn unknown_setup_element_is_refused_with_the_nearest_name() {
    let mut f = Files::analyze();
    let line = f.replace(
        "setup.xml",
        "<contact_weight>1</contact_weight>",
        "<contact_wieght>1</contact_wieght>",
    );
    let needles = [
        "setup.xml".to_string(),
        format!("line {line}"),
        "<contact_wieght>".to_string(),
        "<StaticOptimization name=\"SO\">".to_string(),
        "did you mean contact_weight".to_string(),
    ];
    let needles: Vec<&str> = needles.iter().map(String::as_str).collect();
    let r = run("unknown_element", &f, "setup.xml");
    expect_input_error("unknown_element", r, &needles);
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("malformed_unknown_element");
    assert!(
        !dir.join("out").exists(),
        "a refused setup must write nothing"
    );
    let r = run_with("unknown_element_check", &f, "setup.xml", &["--check"]);
    expect_input_error("unknown_element_check", r, &needles);
    let (code, err) = run_with(
        "unknown_element_allowed",
        &f,
        "setup.xml",
        &["--allow-unknown"],
    );
    assert_eq!(code, 0, "{err}");
    assert!(
        err.contains("warning:") && err.contains("did you mean contact_weight"),
        "{err}"
    );
    // An unknown element of a setup's figure, and of a study document.
    let mut f = Files::inverse_dynamics();
    let line = f.replace("study.xml", "<Figure name=\"f\"", "<Figuer name=\"f\"");
    f.replace("study.xml", "</Figure>", "</Figuer>");
    let r = run("unknown_study_element", &f, "study.xml");
    expect_input_error(
        "unknown_study_element",
        r,
        &[
            "study.xml",
            &format!("line {line}"),
            "<Figuer>",
            "did you mean Figure",
        ],
    );
    let mut f = Files::inverse_dynamics();
    f.replace("study.xml", "scale=\"1\"", "scael=\"1\"");
    let r = run("unknown_study_attribute", &f, "study.xml");
    expect_input_error(
        "unknown_study_attribute",
        r,
        &["scael", "did you mean scale"],
    );
}

/// Properties OpenSim defines that statopt does not use are accepted and
/// listed once in the summary.
#[test]
fn unused_opensim_properties_are_listed_once() {
    let mut f = Files::analyze();
    f.replace(
        "setup.xml",
        "<initial_time>0</initial_time>",
        "<initial_time>0</initial_time><maximum_integrator_step_size>1</maximum_integrator_step_size>",
    );
    f.replace(
        "setup.xml",
        "<activation_exponent>2</activation_exponent>",
        "<activation_exponent>2</activation_exponent><start_time>0</start_time>",
    );
    let (code, err) = run("unused_properties", &f, "setup.xml");
    assert_eq!(code, 0, "{err}");
    let line = "accepted but not used by statopt (OpenSim 4.6 properties): AnalyzeTool <maximum_integrator_step_size>, StaticOptimization <start_time>";
    assert_eq!(err.matches(line).count(), 1, "{err}");
}

/// A results_directory that names a file is an error naming the setup, the
/// element and its line (it used to say only "./afile: cannot read or
/// write file: File exists"), found by `--check` too (which passed it).
#[test]
fn results_directory_that_is_a_file_is_named() {
    let mut f = Files::analyze();
    let line = f.replace(
        "setup.xml",
        "<results_directory>out</results_directory>",
        "<results_directory>afile</results_directory>",
    );
    f.0.push(("afile", "not a folder".to_string()));
    let needles = [
        "setup.xml".to_string(),
        format!("line {line}"),
        "<results_directory>".to_string(),
        "afile".to_string(),
        "is a file, not a folder".to_string(),
    ];
    let needles: Vec<&str> = needles.iter().map(String::as_str).collect();
    let r = run("results_dir_file", &f, "setup.xml");
    expect_input_error("results_dir_file", r, &needles);
    let r = run_with("results_dir_file_check", &f, "setup.xml", &["--check"]);
    expect_input_error("results_dir_file_check", r, &needles);
    // A folder below a file cannot be created either.
    let mut f = f.clone();
    f.replace(
        "setup.xml",
        "<results_directory>afile</results_directory>",
        "<results_directory>afile/out</results_directory>",
    );
    let r = run_with(
        "results_dir_below_file_check",
        &f,
        "setup.xml",
        &["--check"],
    );
    expect_input_error(
        "results_dir_below_file_check",
        r,
        &["<results_directory>", "cannot be created"],
    );
}

/// A coordinates file without a column for one of the model's coordinates:
/// the warning names the file and the coordinate in words (it printed a
/// Rust debug list, `["q2"]`, and no file).
#[test]
fn a_missing_column_is_named_with_its_file() {
    let mut f = Files::analyze();
    f.replace("motion.mot", "time\tq1\tq2", "time\tq1\tq2_renamed");
    let (code, err) = run("missing_column", &f, "setup.xml");
    assert_eq!(code, 0, "{err}");
    let line = err
        .lines()
        .find(|l| l.contains("no column for the coordinate q2"))
        .unwrap_or_else(|| panic!("{err}"));
    assert!(
        line.contains("motion.mot") && !line.contains("[\""),
        "{line}"
    );
}

/// `--check` checks a setup's own figure references before anything runs:
/// a table of a w0 the setup does not run, or a file that is neither the
/// setup's nor there, is a problem naming the element and its line.
#[test]
fn check_finds_a_setups_bad_figure_reference() {
    let mut f = Files::analyze();
    let line = f.replace(
        "setup.xml",
        "<coordinates_file>motion.mot</coordinates_file>",
        "<Figure name=\"fig\"><Series file=\"run_SO_w0_500_force.sto\" column=\"r1\"/></Figure>\n<coordinates_file>motion.mot</coordinates_file>",
    );
    let r = run_with("figure_ref_check", &f, "setup.xml", &["--check"]);
    expect_input_error(
        "figure_ref_check",
        r,
        &[
            "setup.xml",
            &format!("line {line}"),
            "<Series>",
            "names w0 = 500",
            "a single w0",
        ],
    );
}

/// A setup's `<Figure>`s and `<Metric>`s are read into typed values with
/// the setup: a metric op without its `where` column, or a `fill_between`
/// naming a series its panel lacks, is an error of reading the setup,
/// found by `--check` and by a run before any frame is computed (a run
/// wrote every table and failed only when it drew; `--check` passed).
#[test]
fn a_setups_bad_figure_or_metric_is_refused_before_the_run() {
    for (tag, element, needles) in [
        (
            "metric_where",
            "<Metric name=\"peak\" file=\"run_SO_force.sto\" columns=\"r1\" op=\"argmax\"/>",
            &["<Metric name=\"peak\">", "op 'argmax' needs a where attribute"][..],
        ),
        (
            "fill_between",
            "<Figure name=\"fig\"><Series file=\"run_SO_force.sto\" column=\"r1\"/><fill_between>0 1</fill_between></Figure>",
            &["<fill_between>", "names a series that does not exist"][..],
        ),
    ] {
        let mut f = Files::analyze();
        let line = f.replace(
            "setup.xml",
            "<coordinates_file>motion.mot</coordinates_file>",
            &format!("{element}\n<coordinates_file>motion.mot</coordinates_file>"),
        );
        let mut expected = vec!["setup.xml".to_string(), format!("line {line}")];
        expected.extend(needles.iter().map(|n| n.to_string()));
        let expected: Vec<&str> = expected.iter().map(String::as_str).collect();
        let check = format!("figure_plan_{tag}_check");
        expect_input_error(&check, run_with(&check, &f, "setup.xml", &["--check"]), &expected);
        let test = format!("figure_plan_{tag}");
        expect_input_error(&test, run(&test, &f, "setup.xml"), &expected);
        let out = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
            .join(format!("malformed_{test}"))
            .join("out");
        assert!(
            !out.exists() || std::fs::read_dir(&out).unwrap().next().is_none(),
            "{test}: the run wrote tables before refusing its figure"
        );
    }
}
