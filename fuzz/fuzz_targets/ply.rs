//! `cargo +nightly fuzz run ply`: see [`wavrad_fuzz::Workspace::ply`].
#![no_main]

use std::sync::OnceLock;

use wavrad_fuzz::Workspace;

libfuzzer_sys::fuzz_target!(|input: &[u8]| {
    static WORKSPACE: OnceLock<(tempfile::TempDir, Workspace)> = OnceLock::new();
    WORKSPACE.get_or_init(Workspace::temporary).1.ply(input);
});
