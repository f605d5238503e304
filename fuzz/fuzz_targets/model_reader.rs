//! XML parse, .osim read and model compile on arbitrary bytes: Ok or Err,
//! never a panic (and every Err is an input error, exit status 2).
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let path = Path::new("fuzz.osim");
    let root = match statopt::xml::parse_str(&text, path) {
        Ok(r) => r,
        Err(e) => {
            assert_eq!(e.exit_code(), 2, "{e}");
            return;
        }
    };
    match statopt::parse::osim::ModelSpec::from_document(&root, path) {
        Ok(spec) => {
            if let Err(e) = statopt::model::compile(&spec) {
                assert_eq!(e.exit_code(), 2, "{e}");
            }
        }
        Err(e) => assert_eq!(e.exit_code(), 2, "{e}"),
    }
});
