//! Fuzzing the readers with proptest: random byte flips, truncations,
//! insertions and splices of the repository's own models, setups and motions
//! go into `xml::parse_str`, the model reader + compile and `storage::read`.
//! Each must return Ok or Err — never panic, never hang. Bounded: 1000 cases
//! per target (seconds in debug). The coverage-guided
//! fuzzers live in `fuzz/` (cargo fuzz; run by .ci/run).

use std::path::{Path, PathBuf};

use proptest::prelude::*;

fn seeds(ext: &[&str]) -> Vec<(String, Vec<u8>)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut out = Vec::new();
    for dir in [
        "models",
        "models/leg_extension",
        "motions",
        "setups",
        "tests/data",
        "fuzz/corpus/model_reader",
        "fuzz/corpus/storage_reader",
    ] {
        let Ok(rd) = std::fs::read_dir(root.join(dir)) else {
            continue;
        };
        let mut paths: Vec<PathBuf> = rd.flatten().map(|e| e.path()).collect();
        paths.sort();
        for p in paths {
            let name = p.file_name().unwrap().to_string_lossy().to_string();
            let big = std::fs::metadata(&p)
                .map(|m| m.len() > 400_000)
                .unwrap_or(true);
            if p.is_file() && !big && ext.iter().any(|e| name.ends_with(e)) {
                out.push((name, std::fs::read(&p).unwrap()));
            }
        }
    }
    assert!(!out.is_empty(), "no seed files for {ext:?}");
    out
}

/// One mutation of a seed, chosen by the strategy's numbers.
#[derive(Debug, Clone)]
enum Mutation {
    Flip {
        at: f64,
        byte: u8,
    },
    Truncate {
        at: f64,
    },
    Insert {
        at: f64,
        text: String,
    },
    Splice {
        at: f64,
        other: usize,
        from: f64,
        len: usize,
    },
    Delete {
        at: f64,
        len: usize,
    },
}

fn mutation() -> impl Strategy<Value = Mutation> {
    let token = prop_oneof![
        Just("NaN".to_string()),
        Just("-Inf".to_string()),
        Just("1e308".to_string()),
        Just("<".to_string()),
        Just("</".to_string()),
        Just("&amp;".to_string()),
        Just("&#0;".to_string()),
        Just("\n".to_string()),
        Just("\t".to_string()),
        Just("endheader\n".to_string()),
        Just("nRows=999999999999\n".to_string()),
        Just("<Body name=\"x\"/>".to_string()),
        "[ -~]{0,12}",
    ];
    prop_oneof![
        (0.0..1.0f64, any::<u8>()).prop_map(|(at, byte)| Mutation::Flip { at, byte }),
        (0.0..1.0f64).prop_map(|at| Mutation::Truncate { at }),
        (0.0..1.0f64, token).prop_map(|(at, text)| Mutation::Insert { at, text }),
        (0.0..1.0f64, 0usize..64, 0.0..1.0f64, 0usize..400).prop_map(|(at, other, from, len)| {
            Mutation::Splice {
                at,
                other,
                from,
                len,
            }
        }),
        (0.0..1.0f64, 0usize..200).prop_map(|(at, len)| Mutation::Delete { at, len }),
    ]
}

fn apply(seed: &[u8], all: &[(String, Vec<u8>)], muts: &[Mutation]) -> Vec<u8> {
    let mut v = seed.to_vec();
    let pos = |v: &Vec<u8>, at: f64| ((at * v.len() as f64) as usize).min(v.len());
    for m in muts {
        match m {
            Mutation::Flip { at, byte } => {
                if !v.is_empty() {
                    let i = pos(&v, *at).min(v.len() - 1);
                    v[i] = *byte;
                }
            }
            Mutation::Truncate { at } => {
                let i = pos(&v, *at);
                v.truncate(i);
            }
            Mutation::Insert { at, text } => {
                let i = pos(&v, *at);
                v.splice(i..i, text.bytes());
            }
            Mutation::Splice {
                at,
                other,
                from,
                len,
            } => {
                let o = &all[other % all.len()].1;
                let s = ((from * o.len() as f64) as usize).min(o.len());
                let e = (s + len).min(o.len());
                let i = pos(&v, *at);
                v.splice(i..i, o[s..e].iter().copied());
            }
            Mutation::Delete { at, len } => {
                let i = pos(&v, *at);
                let e = (i + len).min(v.len());
                v.drain(i..e);
            }
        }
    }
    v
}

fn tmp(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("fuzz_readers");
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 1000, failure_persistence: None, .. ProptestConfig::default() })]

    #[test]
    fn xml_parse_never_panics(which in 0usize..64, muts in prop::collection::vec(mutation(), 1..4)) {
        let all = seeds(&[".osim", ".xml"]);
        let data = apply(&all[which % all.len()].1, &all, &muts);
        let text = String::from_utf8_lossy(&data);
        if let Err(e) = statopt::xml::parse_str(&text, Path::new("fuzz.xml")) {
            prop_assert_eq!(e.exit_code(), 2);
            prop_assert!(e.to_string().contains("fuzz.xml"));
        }
    }

    #[test]
    fn model_read_and_compile_never_panic(which in 0usize..64, muts in prop::collection::vec(mutation(), 1..4)) {
        let all = seeds(&[".osim"]);
        let data = apply(&all[which % all.len()].1, &all, &muts);
        let p = tmp("fuzz.osim");
        std::fs::write(&p, &data).unwrap();
        if let Err(e) = statopt::tools::loading::load_model(&p) {
            prop_assert_eq!(e.exit_code(), 2, "{}", e);
        }
    }

    #[test]
    fn storage_read_never_panics(which in 0usize..64, muts in prop::collection::vec(mutation(), 1..4)) {
        let all = seeds(&[".mot", ".sto"]);
        let (name, seed) = &all[which % all.len()];
        let data = apply(seed, &all, &muts);
        let p = tmp(if name.ends_with(".mot") { "fuzz.mot" } else { "fuzz.sto" });
        std::fs::write(&p, &data).unwrap();
        match statopt::storage::read(&p) {
            Ok(st) => {
                prop_assert!(st.time.iter().all(|t| t.is_finite()));
                prop_assert!(st.rows.iter().all(|r| r.len() == st.labels.len() && r.iter().all(|x| x.is_finite())));
            }
            Err(e) => prop_assert_eq!(e.exit_code(), 2, "{}", e),
        }
        // the streaming reader must agree that the file is readable or not
        let rows = statopt::storage::open_rows(&p).and_then(|mut r| {
            let mut row = Vec::new();
            let mut n = 0usize;
            while r.next_row(&mut row)?.is_some() { n += 1; }
            Ok(n)
        });
        if let Err(e) = rows {
            prop_assert_eq!(e.exit_code(), 2, "{}", e);
        }
    }
}
