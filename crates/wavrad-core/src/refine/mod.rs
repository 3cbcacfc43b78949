//! Adaptive projection of the kernels (paper §3.2): two-point links between
//! elements and three-point links through glossy elements, refined until
//! the oracle accepts them, with the light estimates the weighted oracles
//! weigh by.

pub mod estimate;
pub mod importance;
pub mod oracle;
pub mod three_point_projection;
pub mod two_point_projection;
