//! wavrad-core: view-independent global illumination by projecting the
//! radiance equation onto Haar wavelets, after Pattanaik & Bouatouch, *Haar
//! Wavelet: A Solution to Global Illumination With General Surface
//! Properties* (EG Rendering Workshop 1994).
//!
//! The modules are the stages of the paper's data flow, each importing only
//! from earlier ones: a [`scene::Scene`] of planar surfaces and their BRDFs →
//! the [`geometry`] of elements, hierarchies and Haar bases → [`kernel`]
//! quadrature → adaptive projection of the kernels into links
//! ([`refine::two_point_projection::refine_links`], judged by a
//! [`refine::oracle`]) → Gauss–Seidel gathering with push–pull ([`solve`]) →
//! rendering any view ([`render`]).
//!
//! ```
//! use wavrad_core::scene::{Patch, Rgb, Scene, Surface};
//! use wavrad_core::solve::{solve, SolveSettings};
//! use wavrad_core::progress::Silent;
//! use glam::DVec3;
//!
//! // A unit cube seen from inside: every face reflects 50 % and emits 1.
//! let faces = wavrad_core::testing::inward_box(DVec3::ZERO, DVec3::ONE);
//! let surfaces = faces
//!     .into_iter()
//!     .map(|patch| Surface { name: "wall".into(), patch, brdf: wavrad_core::scene::brdf::Brdf::diffuse(Rgb::splat(0.5)), emission: Rgb::splat(1.0), texture: None, shading: None })
//!     .collect();
//! let solution = solve(&Scene::from_surfaces(surfaces), &SolveSettings::default(), &Silent).unwrap();
//! // The furnace: radiance is Le / (1 − ρ) = 2 everywhere.
//! assert!((solution.radiance[0][0][0] - 2.0).abs() < 0.02);
//! ```
#![deny(missing_docs)]

// The stages, in the order data flows; a module imports only from its own
// stage and earlier ones (checked by `tests/stage_imports.rs`).

// 0. Foundations: errors, settings' descriptions, progress reporting,
// sample streams.
mod error;
pub mod progress;
pub mod sampling;
pub mod setting;

// 1. Scene description: surfaces, BRDFs, sensor; test fixtures built of them.
pub mod scene;
pub mod testing;

// 2. Geometry: elements, hierarchies, Haar bases, ray queries.
pub mod geometry;

// 3. Kernel quadrature: two- and three-point coefficients, exposure.
pub mod kernel;

// 4. Refinement: projecting kernels adaptively, judged by the oracles.
pub mod refine;

// 5. Solve: gathering, push–pull, shooting, statistics.
pub mod solve;

// 6. Render: any view of a solution.
pub mod render;

pub use error::{Error, Result};
