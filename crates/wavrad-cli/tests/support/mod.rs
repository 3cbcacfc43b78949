//! Running the `wavrad` binary from integration tests.

use std::path::Path;
use std::process::{Command, Output};

/// Run `wavrad` with `args` and collect its output.
pub fn wavrad(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_wavrad"))
        .args(args)
        .output()
        .expect("run wavrad")
}

/// The run's standard error as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Write `text` to `dir/name` and return the path.
pub fn write(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.display().to_string()
}
