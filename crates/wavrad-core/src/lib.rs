//! wavrad-core: view-independent global illumination by projecting the
//! radiance equation onto Haar wavelets, after Pattanaik & Bouatouch, *Haar
//! Wavelet: A Solution to Global Illumination With General Surface
//! Properties* (EG Rendering Workshop 1994).
//!
//! Data flows as in the paper: a [`scene::Scene`] of planar surfaces →
//! adaptive two-point kernels ([`link::refine_links`], judged by an
//! [`oracle`]) → element hierarchies ([`hierarchy`]) → Gauss–Seidel gathering
//! with push–pull ([`solve`]) → rendering any view ([`render`]).
//!
//! ```
//! use wavrad_core::scene::{Patch, Scene, Surface};
//! use wavrad_core::solve::{solve, Silent, SolveSettings};
//! use glam::DVec3;
//!
//! // A unit cube seen from inside: every face reflects 50 % and emits 1.
//! let faces = wavrad_core::testing::inward_box(DVec3::ZERO, DVec3::ONE);
//! let surfaces = faces
//!     .into_iter()
//!     .map(|patch| Surface { name: "wall".into(), patch, brdf: wavrad_core::brdf::Brdf::diffuse([0.5; 3]), emission: [1.0; 3] })
//!     .collect();
//! let solution = solve(&Scene::from_surfaces(surfaces), &SolveSettings::default(), &Silent).unwrap();
//! // The furnace: radiance is Le / (1 − ρ) = 2 everywhere.
//! assert!((solution.radiance[0][0][0] - 2.0).abs() < 0.02);
//! ```
#![deny(missing_docs)]

pub mod brdf;
pub mod directional;
pub mod element;
mod error;
pub mod exposure;
pub mod haar;
pub mod hierarchy;
pub mod kernel;
pub mod link;
pub mod oracle;
pub mod render;
pub mod scene;
pub mod solve;
pub mod stats;
pub mod testing;
pub mod three_point;
pub mod tracing;
pub mod visibility;

pub use error::{Error, Result};
