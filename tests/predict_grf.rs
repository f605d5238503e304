//! Ground reactions predicted from kinematics alone, held against the force
//! plates of the two development cases (issue 14; docs/grf_prediction.md).
//! The bars (mean over the feet: vertical rho >= 0.97 and RMSE <= 8 %
//! body weight; anteroposterior >= 0.90 and <= 5 %; mediolateral >= 0.70 and
//! <= 3 %) are not all met yet; these tests hold what the method reaches
//! today so that it cannot slip back, and print every number.

use std::path::Path;

use statopt::parse::setup::Setup;
use statopt::tools::predict_grf::{self, AxisMetrics};
use statopt::tools::RunOptions;

mod common;

fn predict(case: &str) -> Option<(Vec<AxisMetrics>, predict_grf::Prediction)> {
    let root = common::validation_dir(&format!("predict_grf {case}"))?;
    let setup = match Setup::read(&root.join(case).join("setup_SO.xml")).unwrap() {
        Setup::Analyze(s) => s,
        _ => unreachable!(),
    };
    let out = common::out_dir(&format!("predict_grf_{case}"));
    let opts = RunOptions {
        results_dir: Some(out.clone()),
        verbose: false,
        ..Default::default()
    };
    let p = predict_grf::run(&setup, &opts).unwrap_or_else(|e| panic!("{case}: {e}"));
    for f in [
        "_predicted_grf.sto",
        "_grf_comparison.csv",
        "_foot_contacts.xml",
    ] {
        assert!(
            out.join(format!("{}{f}", setup.name)).is_file(),
            "{case}: {f} written"
        );
    }
    for m in &p.metrics {
        println!(
            "{case}: foot {} axis {}: rho {:.3}, RMSE {:.1} N = {:.2} % BW, peak error {:.1} N",
            m.side, m.axis, m.rho, m.rmse_n, m.rmse_bw, m.peak_error_n
        );
    }
    Some((p.metrics.clone(), p))
}

/// Mean over the two feet of (rho, RMSE in % body weight) on one axis.
fn mean(metrics: &[AxisMetrics], axis: char) -> (f64, f64) {
    let m: Vec<&AxisMetrics> = metrics.iter().filter(|m| m.axis == axis).collect();
    (
        m.iter().map(|m| m.rho).sum::<f64>() / m.len() as f64,
        m.iter().map(|m| m.rmse_bw).sum::<f64>() / m.len() as f64,
    )
}

#[test]
fn gait10dof18musc_treadmill_walk_against_force_plates() {
    let Some((metrics, p)) = predict("gait10dof18musc_walk") else {
        return;
    };
    // Treadmill: the stance feet move back at about 1.1 m/s.
    assert!(
        p.contacts.belt_velocity.x < -0.9 && p.contacts.belt_velocity.x > -1.4,
        "{:?}",
        p.contacts.belt_velocity
    );
    assert_eq!(p.summary.failed, 0);
    let (rho_v, rmse_v) = mean(&metrics, 'y');
    let (rho_ap, rmse_ap) = mean(&metrics, 'x');
    println!("gait10dof18musc: vertical rho {rho_v:.3} / {rmse_v:.1} % BW; AP rho {rho_ap:.3} / {rmse_ap:.1} % BW");
    assert!(rho_v >= 0.97 && rmse_v <= 10.5, "vertical {rho_v} {rmse_v}");
    assert!(
        rho_ap >= 0.83 && rmse_ap <= 6.5,
        "anteroposterior {rho_ap} {rmse_ap}"
    );
    // The root residuals carry little: the feet carry the body.
    let (f, _) = p.summary.root_force_peak.clone().unwrap();
    assert!(f < 0.05 * p.body_weight, "root residual {f} N");
}

#[test]
fn moco_walk3d_overground_walk_against_force_plates() {
    let Some((metrics, p)) = predict("moco_walk3d") else {
        return;
    };
    assert_eq!(p.contacts.belt_velocity.norm(), 0.0, "overground: no belt");
    assert_eq!(p.summary.failed, 0);
    let (rho_v, rmse_v) = mean(&metrics, 'y');
    let (rho_ap, rmse_ap) = mean(&metrics, 'x');
    let (rho_ml, rmse_ml) = mean(&metrics, 'z');
    println!("moco_walk3d: vertical {rho_v:.3} / {rmse_v:.1} % BW; AP {rho_ap:.3} / {rmse_ap:.1} % BW; ML {rho_ml:.3} / {rmse_ml:.1} % BW");
    assert!(rho_v >= 0.97 && rmse_v <= 10.5, "vertical {rho_v} {rmse_v}");
    assert!(
        rho_ap >= 0.90 && rmse_ap <= 6.0,
        "anteroposterior {rho_ap} {rmse_ap}"
    );
    assert!(
        rho_ml >= 0.70 && rmse_ml <= 3.0,
        "mediolateral {rho_ml} {rmse_ml}"
    );
}

/// A model without the gait2392/Rajagopal foot bodies gets an error naming
/// what to provide.
#[test]
fn a_model_without_calcn_and_toes_is_told_what_to_provide() {
    let model = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/double_pendulum.osim");
    let (_, m) = statopt::tools::loading::load_model(&model).unwrap();
    let e = statopt::contacts::feet::foot_points(&m)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("calcn_r") && e.contains("force_set_files"),
        "{e}"
    );
}
