//! wavrad's file formats: Mitsuba 3 XML scenes in, OBJ/PLY meshes in,
//! EXR/PNG images out.
//!
//! The core crate (`wavrad-core`) never sees a file; this crate turns files
//! into its [`Scene`](wavrad_core::scene::Scene) and its pixels into files.
//!
//! - [`load_scene`], [`load_scene_with`], [`load_scene_str`]: the Mitsuba 3
//!   XML subset wavrad solves (see [`mitsuba`]), as a [`Loaded`] scene with
//!   its [`Warning`]s;
//! - [`mesh::read_obj`], [`mesh::read_ply`], [`mesh::read_serialized`]:
//!   triangle meshes;
//! - [`write_image`], [`read_exr_rgb`], [`relative_rmse`]: images and the
//!   error metric against references;
//! - [`block_links`]: a planned solve's blocks of items and of projected
//!   links as bytes, between the processes of a distributed solve;
//! - [`solution_file`]: solutions written to `.wavrad` files and read back
//!   to render, checked against their scene.
//!
//! Every failure is an [`Error`] whose message names the file — and for
//! scene files the line — and the offending name, e.g.
//! `scenes/x.xml:12: unsupported shape plugin "bsplinecurve" (supported:
//! rectangle, cube, disk, cylinder, sphere, obj, ply, serialized)`.
//!
//! ```
//! use std::path::Path;
//! let xml = r#"<scene version="3.0.0">
//!     <shape type="cube"/>
//! </scene>"#;
//! let scene = wavrad_io::load_scene_str(xml, Path::new("."), "box.xml", &[]).unwrap().scene;
//! assert_eq!(scene.surfaces.len(), 6);
//! let area: f64 = scene.surfaces.iter().map(|s| s.patch.area()).sum();
//! assert!((area - 24.0).abs() < 1e-12);
//! ```

#![deny(missing_docs)]

pub mod block_links;
mod error;
pub mod image;
pub mod mesh;
pub mod mitsuba;
pub mod solution_file;

pub use error::{Error, Result};
pub use image::{check_writable, read_exr_rgb, relative_rmse, write_atomic, write_image};
pub use mitsuba::{
    load_scene, load_scene_str, load_scene_with, load_scene_with_options, LoadOptions, Loaded,
    Warning,
};
