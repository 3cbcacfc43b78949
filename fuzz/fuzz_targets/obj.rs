//! `cargo +nightly fuzz run obj`: see [`wavrad_fuzz::Workspace::obj`].
#![no_main]

wavrad_fuzz::workspace_target!(obj);
