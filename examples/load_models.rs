use statopt::model::compile;
use statopt::parse::osim::ModelSpec;
fn main() {
    for p in std::env::args().skip(1) {
        match ModelSpec::read(std::path::Path::new(&p)).and_then(|s| {
            let m = compile(&s)?;
            Ok((s, m))
        }) {
            Ok((s, m)) => {
                println!(
                    "{p}: {} bodies, {} coords {:?}",
                    m.nbodies(),
                    m.nq(),
                    m.coordinates
                        .iter()
                        .map(|c| format!("{}:{:?}", c.name, c.motion_type))
                        .collect::<Vec<_>>()
                );
                for (w, l) in &s.unsupported {
                    println!("   unsupported {w} at {l}");
                }
                for w in &m.warnings {
                    println!("   warn {w}");
                }
            }
            Err(e) => println!("{p}: ERROR {e}"),
        }
    }
}
