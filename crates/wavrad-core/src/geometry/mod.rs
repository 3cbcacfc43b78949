//! The geometry the method works on: clusters of surfaces, a surface's dyadic
//! elements and their hierarchy, the Haar basis over them (paper eqs. 5–8), the pair
//! hierarchies that hold directional radiance (Figure 2), textures averaged
//! over elements, and ray queries (camera rays also against curved shapes as
//! they are).

pub mod analytic;
pub mod cluster;
pub mod element;
pub mod haar;
pub mod hierarchy;
pub mod pair_tree;
pub mod texture;
pub mod tracing;
pub mod visibility;
