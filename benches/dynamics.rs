//! Model loading and one inverse-dynamics frame, on the shipped example and
//! on the OpenSim validation models when ../shared/validation is present.
//! `cargo bench --bench dynamics`

use std::path::{Path, PathBuf};

use criterion::{criterion_group, criterion_main, Criterion};
use statopt::dynamics::{kinematics, rnea, Data};
use statopt::model::compile;
use statopt::muscles::set::{MuscleFrame, MuscleSet};
use statopt::parse::osim::ModelSpec;

fn models() -> Vec<(String, PathBuf)> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let mut v = vec![(
        "double_pendulum".to_string(),
        root.join("models/double_pendulum.osim"),
    )];
    let val = root.join("../shared/validation");
    for (case, file) in [
        ("arm26", "arm26/inputs/arm26.osim"),
        (
            "leg6dof9musc",
            "leg6dof9musc_stance/inputs/leg6dof9musc.osim",
        ),
        (
            "gait10dof18musc",
            "gait10dof18musc_walk/inputs/subject01.osim",
        ),
    ] {
        if val.join(file).is_file() {
            v.push((case.to_string(), val.join(file)));
        } else {
            eprintln!("SKIP {case}: ../shared/validation is absent");
        }
    }
    let gait2392 = root.join("../shared/models/gait2392/gait2392_thelen2003muscle.osim");
    if gait2392.is_file() {
        v.push(("gait2392".to_string(), gait2392));
    }
    v
}

fn bench(c: &mut Criterion) {
    for (name, path) in models() {
        let path: &Path = &path;
        c.bench_function(&format!("load_model/{name}"), |b| {
            b.iter(|| compile(&ModelSpec::read(path).unwrap()).unwrap())
        });
        let model = compile(&ModelSpec::read(path).unwrap()).unwrap();
        let mut data = Data::new(&model);
        for i in 0..model.nq() {
            data.q[i] = 0.1 * (i as f64 + 1.0).sin();
            data.u[i] = 0.5 * (i as f64).cos();
            data.udot[i] = (2.0 * i as f64).sin();
        }
        let spec = ModelSpec::read(path).unwrap();
        let set = MuscleSet::compile(&spec, &spec.forces, &model).unwrap();
        if !set.is_empty() {
            let mut frame = MuscleFrame::new(&set, &model);
            kinematics::full(&model, &mut data);
            // What static optimization evaluates per frame: paths, unit
            // tension forces, strength and passive force of every muscle.
            c.bench_function(
                &format!("muscle_frame_evaluate/{name} ({} muscles)", set.len()),
                |b| {
                    b.iter(|| {
                        frame.evaluate(&set, &model, &data);
                        std::hint::black_box(frame.max_active_force[0])
                    })
                },
            );
            c.bench_function(
                &format!("muscle_geometry_frame/{name} ({} muscles)", set.len()),
                |b| {
                    b.iter(|| {
                        frame.evaluate(&set, &model, &data);
                        let mut s = 0.0;
                        for m in 0..set.len() {
                            for k in 0..model.nq() {
                                s += frame.moment_arm(&model, &data.q, m, k);
                            }
                        }
                        std::hint::black_box(s)
                    })
                },
            );
        }
        c.bench_function(&format!("inverse_dynamics_frame/{name}"), |b| {
            b.iter(|| {
                kinematics::full(&model, &mut data);
                rnea::inverse_dynamics_after_kinematics(&model, &mut data, true);
                std::hint::black_box(data.tau[0])
            })
        });
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
