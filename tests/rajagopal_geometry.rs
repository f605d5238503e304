//! The Rajagopal 2016 family loads, and its muscle geometry matches OpenSim
//! 4.6 at sampled poses over each coordinate's range: Rajagopal2016.osim and
//! RajagopalLaiUhlrich2023.osim (../shared/models/rajagopal2016/), six poses
//! each, every free coordinate at a fraction of its range, assembled by
//! OpenSim (tests/reference_scripts/rajagopal_geometry_reference.py wrote
//! tests/data/rajagopal_geometry_opensim46.json). At OpenSim's assembled
//! coordinates every muscle's path length must agree within 1e-6 m and its
//! moment arms about the right hip (flexion, adduction), both knees and the
//! right ankle within 1e-5 m.

use std::path::PathBuf;

use statopt::dynamics::{kinematics, Data};
use statopt::muscles::set::{MuscleFrame, MuscleSet};
use statopt::tools::loading::load_model;

#[test]
fn rajagopal_family_muscle_geometry_matches_opensim() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let dir = root.join("../shared/models/rajagopal2016");
    if !dir.is_dir() {
        eprintln!("SKIP rajagopal_family_muscle_geometry_matches_opensim: ../shared/models/rajagopal2016 is absent");
        return;
    }
    let text =
        std::fs::read_to_string(root.join("tests/data/rajagopal_geometry_opensim46.json")).unwrap();
    let reference: serde_json::Value = serde_json::from_str(&text).unwrap();
    let mut failures = Vec::new();
    for (file, poses) in reference.as_object().unwrap() {
        let (spec, model) = load_model(&dir.join(file)).unwrap_or_else(|e| panic!("{file}: {e}"));
        let set = MuscleSet::compile(&spec, &spec.forces, &model)
            .unwrap_or_else(|e| panic!("{file}: {e}"));
        let mut data = Data::new(&model);
        let mut frame = MuscleFrame::new(&set, &model);
        let (mut worst_len, mut worst_ma) = ((0.0f64, String::new()), (0.0f64, String::new()));
        let mut compared = 0usize;
        for pose in poses.as_array().unwrap() {
            let q = pose["q"].as_object().unwrap();
            for (c, coord) in model.coordinates.iter().enumerate() {
                data.q[c] = q[&coord.name].as_f64().unwrap();
            }
            data.u.iter_mut().for_each(|u| *u = 0.0);
            kinematics::full(&model, &mut data);
            frame.evaluate(&set, &model, &data);
            let f = pose["fraction"].as_f64().unwrap();
            for (m, pm) in set.muscles.iter().enumerate() {
                let r = &pose["muscles"][&pm.muscle.name];
                let d = (frame.length[m] - r["length"].as_f64().unwrap()).abs();
                compared += 1;
                if d > 1e-6 {
                    failures.push(format!(
                        "{file} f={f} {}: length off by {d:.3e}",
                        pm.muscle.name
                    ));
                }
                if d > worst_len.0 {
                    worst_len = (d, format!("{} f={f}", pm.muscle.name));
                }
                for (coord, value) in r["moment_arms"].as_object().unwrap() {
                    let k = model.coordinate_index(coord).unwrap();
                    let d =
                        (frame.moment_arm(&model, &data.q, m, k) - value.as_f64().unwrap()).abs();
                    compared += 1;
                    if d > 1e-5 {
                        failures.push(format!(
                            "{file} f={f} {} about {coord}: off by {d:.3e}",
                            pm.muscle.name
                        ));
                    }
                    if d > worst_ma.0 {
                        worst_ma = (d, format!("{} about {coord} f={f}", pm.muscle.name));
                    }
                }
            }
        }
        assert!(compared > 2000, "{file}: only {compared} values compared");
        println!(
            "{file}: {compared} values; worst length {:.2e} m ({}), worst moment arm {:.2e} m ({})",
            worst_len.0, worst_len.1, worst_ma.0, worst_ma.1
        );
    }
    assert!(
        failures.is_empty(),
        "{} out of tolerance, first: {:?}",
        failures.len(),
        &failures[..failures.len().min(10)]
    );
}
