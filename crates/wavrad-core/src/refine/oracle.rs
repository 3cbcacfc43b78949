//! Refinement oracles: when is a kernel projected finely enough?
//!
//! The paper's oracle (§4.2, Compute_2point_Kernel) looks at the kernel
//! alone: a link is kept at a level when every Haar detail coefficient of the
//! kernel one level down is at most a threshold, in the orthonormal
//! normalisation of [`crate::geometry::haar`]. It refines wherever the kernel varies,
//! whether or not light flows there (the paper's §6 calls it overkill).
//!
//! The power-weighted oracle (Hanrahan, Salzman & Aupperle 1991, "BF"
//! refinement) estimates instead the error a link makes in its receiver's
//! radiance: the kernel's variation over the children, in element-average
//! units, times the radiance the source sends through it. The
//! importance-driven oracle (Smits, Arvo & Salesin 1992; Christensen et al.
//! 1996 for glossy surfaces) further weighs that error by how much the
//! receiver matters to the image. Both need an estimate of the solution,
//! so they run in a refine–solve loop ([`crate::solve`]).

use crate::geometry::haar;
use crate::refine::estimate::LightEstimate;
use crate::setting::Choice;

/// Which test decides that a link is projected finely enough.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum Oracle {
    /// The paper's: Haar details of the kernel alone ([`kernel_detail`]).
    #[default]
    Kernel,
    /// The kernel's variation ([`average_detail`] of the receiver's
    /// transfer coefficients) times the radiance it carries, relative to the
    /// brightest emitted radiance.
    Power,
    /// As `Power`, times the receiver's importance for the scene's sensor
    /// relative to the mean importance.
    Importance,
}

impl Oracle {
    /// True for the oracles that weigh the kernel by an estimate of the
    /// solution (and so need a refine–solve loop).
    pub fn is_weighted(self) -> bool {
        self != Oracle::Kernel
    }
}

impl Choice for Oracle {
    const KIND: &'static str = "oracle";
    const ALL: &'static [Self] = &[Oracle::Kernel, Oracle::Power, Oracle::Importance];
    const NAMES: &'static [&'static str] = &["kernel", "power", "importance"];
}
crate::named_choice!(Oracle);

/// Largest Haar detail of a function over the four children of an element,
/// in element-average units (the level-0 normalisation of
/// [`haar::details_2d`]): how far a child's average can be from the parent's.
pub fn average_detail(child_means: [f64; 4]) -> f64 {
    haar::details_2d(child_means, 0)
        .iter()
        .fold(0.0f64, |m, d| m.max(d.abs()))
}

/// The threshold of the weighted oracles by default: a relative radiance
/// error, not a kernel detail.
pub const WEIGHTED_THRESHOLD: f64 = 2e-4;

/// Largest orthonormal Haar detail of a kernel over a split element: the
/// quantity the paper's oracle (§4.2) bounds.
///
/// The kernel of the transfer from surface r to diffuse surface p in the
/// paper's parametrisation is K_rp(u,u') = ρ_p · A_r · cosθ cosθ' V/(π r²)
/// (§3; A_r = dx/du). One element of the pair (level `split_level`) is split
/// into four (virtual resolution), the other stays at `other_level`;
/// `child_kernel_means[i]` is the mean of cosθ cosθ' V/(π r²) over child i
/// times the other element. Both directions of a link are tested, so
/// `scale = max(ρ_p A_r, ρ_r A_p)`.
pub fn kernel_detail(
    child_kernel_means: [f64; 4],
    split_level: u32,
    other_level: u32,
    scale: f64,
) -> f64 {
    let d = haar::details_2d(child_kernel_means, split_level);
    let other = haar::coefficient_from_average_2d(1.0, other_level);
    scale * other * d.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

/// What an oracle test found: whether the kernel passes, and the largest
/// detail in element-average units the weighted oracles saw (zero for the
/// paper's).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Verdict {
    /// Whether the link may be kept at this level.
    pub smooth: bool,
    /// Largest detail seen ([`average_detail`] units).
    pub detail: f64,
}

impl Verdict {
    /// Nothing to object to.
    pub const PASS: Verdict = Verdict {
        smooth: true,
        detail: 0.0,
    };

    /// Both verdicts: smooth when both are, the larger detail.
    pub fn and(self, other: Verdict) -> Verdict {
        Verdict {
            smooth: self.smooth && other.smooth,
            detail: self.detail.max(other.detail),
        }
    }
}

/// The oracle as a projection consults it: the projection's threshold and,
/// for the weighted oracles, the light estimate they weigh by (`None`: the
/// paper's oracle). Every decision to keep or refine a link is made here.
#[derive(Debug, Clone, Copy)]
pub struct Judge<'a> {
    /// Largest allowed kernel detail (the paper's oracle) or relative
    /// radiance error (the weighted ones).
    pub threshold: f64,
    /// The light estimate of the weighted oracles.
    pub estimate: Option<&'a LightEstimate>,
}

impl<'a> Judge<'a> {
    /// True for the weighted oracles.
    pub fn is_weighted(&self) -> bool {
        self.estimate.is_some()
    }

    /// The verdict on a kernel over the children of a split element: the
    /// paper's test of its largest orthonormal detail `kernel_detail`, or,
    /// with an estimate, the weighted test of `weighted(estimate)`: the
    /// detail seen and the errors it makes (detail × light carried), each
    /// at most the threshold (evaluated in order, only as far as needed).
    pub fn verdict<E: IntoIterator<Item = f64>>(
        &self,
        kernel_detail: impl FnOnce() -> f64,
        weighted: impl FnOnce(&'a LightEstimate) -> (f64, E),
    ) -> Verdict {
        match self.estimate {
            None => Verdict {
                smooth: kernel_detail() <= self.threshold,
                detail: 0.0,
            },
            Some(e) => {
                let (detail, errors) = weighted(e);
                Verdict {
                    smooth: errors.into_iter().all(|x| x <= self.threshold),
                    detail,
                }
            }
        }
    }

    /// Whether a kept link still passes under the estimate, from the error
    /// its stored detail makes (`None` when the detail cannot tell and the
    /// link must be tested again). Always, for the paper's oracle.
    pub fn still_accepts(&self, error: impl FnOnce(&'a LightEstimate) -> Option<f64>) -> bool {
        self.estimate
            .is_none_or(|e| error(e).is_some_and(|x| x <= self.threshold))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn oracle_names_round_trip() {
        for name in Oracle::NAMES {
            assert_eq!(name.parse::<Oracle>().unwrap().to_string(), *name);
        }
        let err = "bf".parse::<Oracle>().unwrap_err().to_string();
        assert!(err.contains("kernel, power, importance"), "{err}");
        assert!(!Oracle::Kernel.is_weighted() && Oracle::Power.is_weighted());
    }

    #[test]
    fn average_detail_is_the_largest_child_deviation_pattern() {
        assert_eq!(average_detail([2.0; 4]), 0.0);
        // One bright child of four: each detail is a quarter of its excess.
        assert!((average_detail([1.0, 0.0, 0.0, 0.0]) - 0.25).abs() < 1e-15);
        // Level-independent, unlike the orthonormal details.
        let k = [3.0, 1.0, 1.0, 3.0];
        assert_eq!(average_detail(k), 1.0);
    }

    #[test]
    fn constant_kernel_has_no_detail() {
        assert_eq!(kernel_detail([0.3; 4], 2, 1, 5.0), 0.0);
        let judge = Judge {
            threshold: 0.0,
            estimate: None,
        };
        let verdict = judge.verdict(|| kernel_detail([0.3; 4], 0, 0, 1.0), |_| (1.0, [1.0]));
        assert_eq!(verdict, Verdict::PASS);
    }

    #[test]
    fn details_shrink_with_both_levels() {
        let k = [1.0, 0.0, 0.0, 0.0];
        let d00 = kernel_detail(k, 0, 0, 1.0);
        assert!((d00 - 0.25).abs() < 1e-15);
        assert!((kernel_detail(k, 1, 0, 1.0) - d00 / 2.0).abs() < 1e-15);
        assert!((kernel_detail(k, 0, 2, 1.0) - d00 / 4.0).abs() < 1e-15);
    }
}
