//! A study whose setups' JointReactions read each other's force tables
//! cannot be ordered: the run refuses it before the first setup starts, and
//! `--check` reports the same error (it used to pass such a study).

mod common;

use statopt::tools::{check, run_setup, RunOptions};

#[test]
fn check_reports_a_cycle_of_cross_setup_joint_reactions_as_the_run_does() {
    let dir = common::out_dir("study_cycle");
    std::fs::write(dir.join("block.osim"), common::block_model("")).unwrap();
    let mut motion = String::from(
        "block\nversion=1\nnRows=11\nnColumns=4\ninDegrees=no\nendheader\ntime\ttx\tty\ttz\n",
    );
    for k in 0..11 {
        let t = k as f64 * 0.01;
        motion.push_str(&format!("{t:.6}\t{:.12}\t0\t0\n", 0.2 * (t * 0.5).sin()));
    }
    std::fs::write(dir.join("motion.mot"), motion).unwrap();
    // a's JointReaction reads b's static optimization forces and b's reads
    // a's: neither can run first.
    for (name, other) in [("a", "b"), ("b", "a")] {
        let text = format!(
            r#"<OpenSimDocument Version="40000"><AnalyzeTool name="{name}"><model_file>block.osim</model_file><results_directory>out_{name}</results_directory>
<initial_time>0</initial_time><final_time>100000</final_time>
<AnalysisSet name="Analyses"><objects><StaticOptimization name="SO"/><JointReaction name="JR"><forces_file>out_{other}/{other}_SO_force.sto</forces_file><joint_names>slide</joint_names><apply_on_bodies>child</apply_on_bodies><express_in_frame>ground</express_in_frame></JointReaction></objects></AnalysisSet>
<coordinates_file>motion.mot</coordinates_file></AnalyzeTool></OpenSimDocument>"#
        );
        std::fs::write(dir.join(format!("{name}.xml")), text).unwrap();
    }
    let study = dir.join("study.xml");
    std::fs::write(
        &study,
        r#"<OpenSimDocument Version="40000"><StatoptStudy name="cycle"><setups>a.xml b.xml</setups><results_directory>out_study</results_directory></StatoptStudy></OpenSimDocument>"#,
    )
    .unwrap();
    let ran = run_setup(&study, &RunOptions::default())
        .err()
        .expect("the run refuses the cycle")
        .to_string();
    assert!(ran.contains("waits, in turn"), "{ran}");
    assert!(
        !dir.join("out_a").exists() && !dir.join("out_b").exists(),
        "a setup ran"
    );
    let report = check::run(&study, false);
    let said: Vec<String> = report.errors.iter().map(|e| e.to_string()).collect();
    assert!(
        said.iter().any(|e| e == &ran),
        "--check does not report the run's error\nrun: {ran}\ncheck: {said:?}"
    );
    // Both setups are named: the one whose JointReaction waits (the
    // error's file) and the one it waits for.
    assert!(ran.contains("a.xml") && ran.contains("b.xml"), "{ran}");
}
