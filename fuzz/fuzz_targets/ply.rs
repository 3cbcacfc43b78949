//! `cargo +nightly fuzz run ply`: see [`wavrad_fuzz::Workspace::ply`].
#![no_main]

wavrad_fuzz::workspace_target!(ply);
