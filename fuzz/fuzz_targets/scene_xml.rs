//! `cargo +nightly fuzz run scene_xml`: see [`wavrad_fuzz::Workspace::scene_xml`].
#![no_main]

wavrad_fuzz::workspace_target!(scene_xml);
