//! Forward dynamics keeps M_r's factor between calls at one state (a w0
//! sweep's joint reactions: same positions, other forces). The reuse must
//! give the accelerations a fresh computation gives, bit for bit, and must
//! not survive a change of positions.

use std::path::Path;

use statopt::dynamics::Data;
use statopt::model::load::load_model;
use statopt::reactions::forward_dynamics;

fn udot_bits(d: &Data) -> Vec<u64> {
    d.udot.iter().map(|x| x.to_bits()).collect()
}

/// Generalized forces of a "load case" k on every free coordinate.
fn apply(d: &mut Data, k: f64) {
    for (i, g) in d.applied_gen.iter_mut().enumerate() {
        *g = k * (1.0 + i as f64) * 0.37;
    }
}

#[test]
fn reused_factor_gives_fresh_accelerations_bit_for_bit() {
    // The Rajagopal human has coupled knee coordinates (C is not a
    // selection of columns), so the reduced mass matrix is a real product.
    let (_, model) = load_model(Path::new(
        "models/leg_extension/human_seated_rajagopal.osim",
    ))
    .expect("model loads");
    let nq = model.nq();
    let q0: Vec<f64> = model.coordinates.iter().map(|c| c.default_value).collect();
    let u0: Vec<f64> = (0..nq).map(|i| 0.1 * (i as f64 % 3.0 - 1.0)).collect();
    let fresh = |q: &[f64], k: f64| {
        let mut d = Data::new(&model);
        d.q.copy_from_slice(q);
        d.u.copy_from_slice(&u0);
        apply(&mut d, k);
        forward_dynamics(&model, &mut d, 0.0).expect("forward dynamics");
        udot_bits(&d)
    };

    let mut d = Data::new(&model);
    d.q.copy_from_slice(&q0);
    d.u.copy_from_slice(&u0);
    let mut seen = Vec::new();
    for k in [0.0, 1.0, -2.5] {
        apply(&mut d, k);
        forward_dynamics(&model, &mut d, 0.0).expect("forward dynamics");
        let got = udot_bits(&d);
        assert_eq!(got, fresh(&q0, k), "load case {k} at q0");
        seen.push(got);
    }
    // The load cases differ, so a stale y would have been caught above.
    assert_ne!(seen[0], seen[1]);
    assert_ne!(seen[1], seen[2]);

    // Other positions: the factor is rebuilt.
    let q1: Vec<f64> = q0.iter().map(|x| x + 0.05).collect();
    d.q.copy_from_slice(&q1);
    apply(&mut d, 1.0);
    forward_dynamics(&model, &mut d, 0.0).expect("forward dynamics");
    let got = udot_bits(&d);
    assert_eq!(got, fresh(&q1, 1.0), "after a change of positions");
    assert_ne!(got, seen[1], "the positions change the accelerations");
}
