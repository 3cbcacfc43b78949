//! `cargo +nightly fuzz run solution`: see [`wavrad_fuzz::Workspace::solution`].
#![no_main]

wavrad_fuzz::workspace_target!(solution);
