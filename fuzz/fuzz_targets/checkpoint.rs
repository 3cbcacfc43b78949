//! `cargo +nightly fuzz run checkpoint`: see [`wavrad_fuzz::Workspace::checkpoint`].
#![no_main]

wavrad_fuzz::workspace_target!(checkpoint);
