//! `cargo +nightly fuzz run serialized`: see [`wavrad_fuzz::Workspace::serialized`].
#![no_main]

wavrad_fuzz::workspace_target!(serialized);
