//! Refinement oracles: when is a kernel projected finely enough?
//!
//! The paper's oracle (§4.2, Compute_2point_Kernel) looks at the kernel
//! alone: a link is kept at a level when every Haar detail coefficient of the
//! kernel one level down is at most a threshold, in the orthonormal
//! normalisation of [`crate::haar`].

use crate::haar;

/// The paper's kernel-smoothness test for a two-point kernel.
///
/// The kernel of the transfer from surface r to diffuse surface p in the
/// paper's parametrisation is K_rp(u,u') = ρ_p · A_r · cosθ cosθ' V/(π r²)
/// (§3; A_r = dx/du). One element of the pair (level `split_level`) is split
/// into four (virtual resolution), the other stays at `other_level`;
/// `child_kernel_means[i]` is the mean of cosθ cosθ' V/(π r²) over child i
/// times the other element. Both directions of the link are tested, so
/// `scale = max(ρ_p A_r, ρ_r A_p)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KernelSmoothness {
    /// Largest allowed detail coefficient (paper: 1e-4).
    pub threshold: f64,
}

impl KernelSmoothness {
    /// Largest absolute Haar detail of the kernel over the split element.
    pub fn largest_detail(
        child_kernel_means: [f64; 4],
        split_level: u32,
        other_level: u32,
        scale: f64,
    ) -> f64 {
        let d = haar::details_2d(child_kernel_means, split_level);
        let other = haar::coefficient_from_average_2d(1.0, other_level);
        scale * other * d.iter().fold(0.0f64, |m, x| m.max(x.abs()))
    }

    /// True when the kernel is smooth enough to keep the link unrefined.
    pub fn accepts(
        &self,
        child_kernel_means: [f64; 4],
        split_level: u32,
        other_level: u32,
        scale: f64,
    ) -> bool {
        Self::largest_detail(child_kernel_means, split_level, other_level, scale) <= self.threshold
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_kernel_has_no_detail() {
        assert_eq!(KernelSmoothness::largest_detail([0.3; 4], 2, 1, 5.0), 0.0);
        let o = KernelSmoothness { threshold: 0.0 };
        assert!(o.accepts([0.3; 4], 0, 0, 1.0));
    }

    #[test]
    fn details_shrink_with_both_levels() {
        let k = [1.0, 0.0, 0.0, 0.0];
        let d00 = KernelSmoothness::largest_detail(k, 0, 0, 1.0);
        assert!((d00 - 0.25).abs() < 1e-15);
        assert!((KernelSmoothness::largest_detail(k, 1, 0, 1.0) - d00 / 2.0).abs() < 1e-15);
        assert!((KernelSmoothness::largest_detail(k, 0, 2, 1.0) - d00 / 4.0).abs() < 1e-15);
    }
}
