//! Placeholder until the storage module lands (see the next commit).
fn main() {
    eprintln!("statopt-tool: not wired yet");
    std::process::exit(1);
}
