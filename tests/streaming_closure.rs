//! `<close_contacts>` streamed with the states (`contacts::closure::
//! StreamClosure` as the state stream's row transform) against the closure
//! on the whole table (`contacts::closure::close_contacts`, the in-memory
//! path): the leg extension's lever angle, which its motion file lacks,
//! solved on every row so that the roller pad touches the shin.

mod common;

use statopt::contacts::closure::StreamClosure;
use statopt::motion::stream::StateStream;
use statopt::tools::analyze;

#[test]
fn streamed_closure_equals_the_whole_table_closure() {
    let setup_file =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("setups/leg_extension_cam1.xml");
    let (mut setup, _, problem) = common::so_case(&setup_file, None);
    let model = &problem.model;
    let original = setup.coordinates_file.clone().unwrap();
    // The file with the lever angle's column (each row's Newton starts from
    // it) and without (each row starts from the row before's solution).
    let table = statopt::storage::read(&original).unwrap();
    let lever = table
        .column_index(&setup.close_contacts[0].1)
        .expect("the motion has the lever's column");
    let mut without = table.clone();
    without.labels.remove(lever);
    for r in without.rows.iter_mut() {
        r.remove(lever);
    }
    let dir = common::out_dir("streaming_closure");
    let stripped = dir.join("motion_without_lever.mot");
    statopt::storage::write(&stripped, &without, 12).unwrap();
    let closures: Vec<_> = setup
        .close_contacts
        .iter()
        .map(|(contact, coordinate)| {
            let c = problem
                .contacts
                .iter()
                .find(|c| &c.name == contact)
                .unwrap()
                .clone();
            (c, model.coordinate_index(coordinate).unwrap())
        })
        .collect();
    assert!(!closures.is_empty());
    let t0 = setup.initial_time;
    for (file, has_lever) in [(original, true), (stripped, false)] {
        setup.coordinates_file = Some(file.clone());
        setup.initial_time = t0;
        let whole = analyze::load_states_with(&setup, model, &problem.contacts).unwrap();
        let udot = whole.speed_derivatives(&file).unwrap();
        let t_mid = whole.time[whole.time.len() / 3];
        // The whole motion, and from a third of it on (the stream then starts
        // at the file's first row all the same: the closure's chain does).
        for (initial, block) in [(t0, 64), (t_mid, 64), (t0, 1 << 20)] {
            setup.initial_time = initial;
            let opened = StateStream::open_with_block(
                model,
                &file,
                setup.lowpass_cutoff,
                setup.initial_time,
                setup.final_time,
                block,
            )
            .unwrap()
            .with_spline_degree(setup.coordinate_spline);
            let continued: Vec<bool> = closures
                .iter()
                .map(|(_, c)| opened.carried_columns()[*c].is_none())
                .collect();
            assert_eq!(continued.iter().any(|&c| c), !has_lever);
            let added: Vec<usize> = closures.iter().map(|(_, c)| *c).collect();
            let cl = closures.clone();
            let mut stream = opened
                .with_row_transform(&added, move |columns| {
                    Box::new(StreamClosure::new(
                        model,
                        cl,
                        continued,
                        columns.to_vec(),
                        "test".into(),
                    ))
                })
                .unwrap_or_else(|_| panic!("not streamed"));
            assert!(stream.missing.is_empty(), "{:?}", stream.missing);
            let first = stream.first_row;
            assert_eq!(
                first,
                statopt::motion::coordinates::find_index(&whole.time, initial)
            );
            let (mut worst, mut rows, mut equal) = (0.0f64, 0, true);
            while let Some(b) = stream.next_block().unwrap() {
                for k in 0..b.time.len() {
                    let i = b.first + k;
                    assert_eq!(b.time[k], whole.time[i]);
                    for (got, want) in [
                        (&b.q[k], &whole.q[i]),
                        (&b.u[k], &whole.u[i]),
                        (&b.udot[k], &udot[i]),
                    ] {
                        for (g, w) in got.iter().zip(want) {
                            assert!(g.is_finite());
                            worst = worst.max((g - w).abs() / (1.0 + w.abs()));
                            equal &= g == w;
                        }
                    }
                    rows += 1;
                }
            }
            // The rows before the first frame come too (frames are chosen by
            // row index).
            assert_eq!(rows, stream.last_row + 1);
            println!("lever in the file: {has_lever}; from t = {initial}, blocks of {block}: q, u, u̇ within {worst:.1e} (relative)");
            assert!(worst < 1e-9, "{worst}");
            if block > whole.time.len() {
                assert!(equal, "one window: not the in-memory closure's bits");
            }
        }
    }
}
