//! .sto / .mot reading (whole-file and row-streaming readers) on arbitrary
//! bytes: Ok with finite values, or an input error; never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    // storage::read takes a path: one file per fuzzing process, in the fuzz
    // crate's own target/ (ignored by git), removed after each input.
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("target");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("statopt_fuzz_{}.mot", std::process::id()));
    std::fs::write(&path, data).unwrap();
    match statopt::storage::read(&path) {
        Ok(st) => {
            assert!(st.time.iter().all(|t| t.is_finite()));
            assert!(st
                .rows
                .iter()
                .all(|r| r.len() == st.labels.len() && r.iter().all(|x| x.is_finite())));
        }
        Err(e) => assert_eq!(e.exit_code(), 2, "{e}"),
    }
    if let Ok(mut r) = statopt::storage::open_rows(&path) {
        let mut row = Vec::new();
        loop {
            match r.next_row(&mut row) {
                Ok(Some(_)) => {}
                Ok(None) => break,
                Err(e) => {
                    assert_eq!(e.exit_code(), 2, "{e}");
                    break;
                }
            }
        }
    }
    let _ = std::fs::remove_file(&path);
});
