//! `cargo +nightly fuzz run scene_xml`: see [`wavrad_fuzz::Workspace::scene_xml`].
#![no_main]

use std::sync::OnceLock;

use wavrad_fuzz::Workspace;

libfuzzer_sys::fuzz_target!(|input: &[u8]| {
    static WORKSPACE: OnceLock<(tempfile::TempDir, Workspace)> = OnceLock::new();
    WORKSPACE
        .get_or_init(Workspace::temporary)
        .1
        .scene_xml(input);
});
