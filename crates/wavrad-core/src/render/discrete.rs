//! A discrete distribution over a list of members (surfaces, mirror images)
//! by weight, sampled by inverting its cumulative distribution (pbrt-v4's
//! `SampleDiscrete`, Pharr, Jakob & Humphreys 2023, §A.1): a uniform number
//! picks a member in O(log n) and is stretched back to a uniform number on
//! that member, so that a stratified set of points stays stratified on each
//! member it picks. A contiguous run of members can be left out of one draw
//! (the surface a gather starts from), the others' probabilities scaled up
//! to match, without rebuilding anything. A [`SurfaceDistribution`] is one
//! over some of a scene's surfaces, looked up by surface.

use glam::DVec2;
use std::ops::Range;

/// Members `0..n` with probabilities in proportion to their weights.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DiscreteDistribution {
    /// `cdf[i]`: the probability of the members before `i` (`n + 1`
    /// entries, from 0 to 1), or empty where no member has weight.
    cdf: Vec<f64>,
}

/// A member drawn from a [`DiscreteDistribution`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Drawn {
    /// The member.
    pub index: usize,
    /// The uniform number that drew it, stretched over its interval back
    /// to \[0,1).
    pub u: f64,
    /// The probability it had of being drawn.
    pub probability: f64,
}

impl DiscreteDistribution {
    /// No members.
    pub const EMPTY: DiscreteDistribution = DiscreteDistribution { cdf: Vec::new() };

    /// Whether no member can be drawn.
    pub fn is_empty(&self) -> bool {
        self.cdf.is_empty()
    }

    /// Members with the given non-negative, finite weights; one of zero
    /// weight is never drawn, and with no positive weight none is.
    pub fn new(weights: impl IntoIterator<Item = f64>) -> DiscreteDistribution {
        let mut cdf = vec![0.0];
        for w in weights {
            debug_assert!(w >= 0.0 && w.is_finite(), "weight {w}");
            cdf.push(cdf[cdf.len() - 1] + w);
        }
        let total = cdf[cdf.len() - 1];
        if total <= 0.0 {
            return DiscreteDistribution::default();
        }
        for c in &mut cdf {
            *c /= total;
        }
        DiscreteDistribution { cdf }
    }

    /// The probability of member `index` in a draw that leaves out the
    /// members `excluded` (0 for one of them, or where all with weight are
    /// left out).
    pub fn probability(&self, index: usize, excluded: Range<usize>) -> f64 {
        if excluded.contains(&index) || index + 1 >= self.cdf.len() {
            return 0.0;
        }
        let kept = self.kept(excluded);
        match kept > 0.0 {
            true => (self.cdf[index + 1] - self.cdf[index]) / kept,
            false => 0.0,
        }
    }

    /// The probability that a draw leaving out the members `excluded`
    /// picks one of the members `members`.
    pub fn run_probability(&self, members: Range<usize>, excluded: Range<usize>) -> f64 {
        let Some(n) = self.cdf.len().checked_sub(1) else {
            return 0.0;
        };
        let kept = self.kept(excluded.clone());
        if kept <= 0.0 {
            return 0.0;
        }
        let mass = |r: Range<usize>| {
            let start = r.start.min(n);
            self.cdf[r.end.clamp(start, n)] - self.cdf[start]
        };
        let overlap = members.start.max(excluded.start)..members.end.min(excluded.end);
        (mass(members) - mass(overlap)).max(0.0) / kept
    }

    /// The member that `u` ∈ \[0,1) picks, leaving out the members
    /// `excluded`: `None` where every member with weight is left out.
    pub fn sample(&self, u: f64, excluded: Range<usize>) -> Option<Drawn> {
        let kept = self.kept(excluded.clone());
        if kept <= 0.0 {
            return None;
        }
        let n = self.cdf.len() - 1;
        let start = excluded.start.min(n);
        let end = excluded.end.clamp(start, n);
        // The kept members lie in two runs, before and after the left-out
        // one: t falls in the first, or, shifted past the left-out
        // interval, in the second (kept from either's upper edge, which
        // rounding could reach).
        let t = u * kept;
        let before = self.cdf[start];
        let (first, t, top) = match t < before || self.cdf[end] >= 1.0 {
            true => (0, t, before),
            false => (end, t + (self.cdf[end] - before), 1.0),
        };
        let t = t.min(top * (1.0 - f64::EPSILON)).max(self.cdf[first]);
        let index = first + self.cdf[first..].partition_point(|&c| c <= t) - 1;
        let (low, high) = (self.cdf[index], self.cdf[index + 1]);
        Some(Drawn {
            index,
            u: ((t - low) / (high - low)).clamp(0.0, 1.0 - f64::EPSILON / 2.0),
            probability: (high - low) / kept,
        })
    }

    /// The probability of the members not in `excluded`.
    fn kept(&self, excluded: Range<usize>) -> f64 {
        let Some(n) = self.cdf.len().checked_sub(1) else {
            return 0.0;
        };
        let start = excluded.start.min(n);
        1.0 - (self.cdf[excluded.end.clamp(start, n)] - self.cdf[start])
    }
}

/// Some of a scene's surfaces (the emitters, the bright surfaces a final
/// gather samples by area) with probabilities in proportion to their
/// weights: a point of \[0,1)² picks a surface and a point of \[0,1)² on
/// it, leaving out the surface the sampling starts from, and the
/// probability of any surface is found by a binary search.
#[derive(Debug, Clone, Default)]
pub struct SurfaceDistribution {
    /// The surfaces, ascending.
    surfaces: Vec<u32>,
    choice: DiscreteDistribution,
}

impl SurfaceDistribution {
    /// The surfaces of `weighted` (surface, non-negative weight) pairs,
    /// each surface once; one of zero weight is never drawn.
    pub fn new(mut weighted: Vec<(u32, f64)>) -> SurfaceDistribution {
        weighted.sort_unstable_by_key(|&(s, _)| s);
        debug_assert!(weighted.windows(2).all(|w| w[0].0 < w[1].0));
        SurfaceDistribution {
            choice: DiscreteDistribution::new(weighted.iter().map(|&(_, w)| w)),
            surfaces: weighted.into_iter().map(|(s, _)| s).collect(),
        }
    }

    /// The surfaces, ascending.
    pub fn surfaces(&self) -> &[u32] {
        &self.surfaces
    }

    /// Whether surface `s` is one of them.
    pub fn contains(&self, s: u32) -> bool {
        self.surfaces.binary_search(&s).is_ok()
    }

    /// The surface that `u` ∈ \[0,1)² picks among those other than
    /// `excluded`, with the point of \[0,1)² it then samples and the
    /// probability it had; `None` where there is none.
    pub fn sample(&self, u: DVec2, excluded: u32) -> Option<(u32, DVec2, f64)> {
        let drawn = self.choice.sample(u.x, self.position(excluded))?;
        let q = self.surfaces[drawn.index];
        Some((q, DVec2::new(drawn.u, u.y), drawn.probability))
    }

    /// The probability that [`SurfaceDistribution::sample`], leaving out
    /// `excluded`, picks surface `q`.
    pub fn probability(&self, q: u32, excluded: u32) -> f64 {
        match self.surfaces.binary_search(&q) {
            Ok(i) => self.choice.probability(i, self.position(excluded)),
            Err(_) => 0.0,
        }
    }

    /// The probability that [`SurfaceDistribution::sample`], leaving out
    /// `excluded`, picks one of the surfaces `run`.
    pub fn run_probability(&self, run: Range<u32>, excluded: u32) -> f64 {
        let members = self.surfaces.partition_point(|&t| t < run.start)
            ..self.surfaces.partition_point(|&t| t < run.end);
        self.choice
            .run_probability(members, self.position(excluded))
    }

    /// Where surface `s` is among them: one position or none.
    fn position(&self, s: u32) -> Range<usize> {
        let i = self.surfaces.partition_point(|&t| t < s);
        i..i + usize::from(self.surfaces.get(i) == Some(&s))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Stratified draws pick each member in proportion to its weight, with
    /// the probability the distribution reports, and stretch the numbers
    /// that picked it evenly over [0,1).
    #[test]
    fn stratified_draws_follow_the_weights() {
        let weights = [1.0, 0.0, 3.0, 4.0];
        let d = DiscreteDistribution::new(weights);
        let n = 8000;
        let mut counts = [0usize; 4];
        let mut stretched: Vec<Vec<f64>> = vec![Vec::new(); 4];
        for k in 0..n {
            let drawn = d.sample((k as f64 + 0.5) / n as f64, 0..0).unwrap();
            counts[drawn.index] += 1;
            stretched[drawn.index].push(drawn.u);
            assert_eq!(drawn.probability, d.probability(drawn.index, 0..0));
        }
        assert_eq!(counts, [1000, 0, 3000, 4000]);
        for (i, us) in stretched.iter().enumerate().filter(|(i, _)| *i != 1) {
            let mean = us.iter().sum::<f64>() / us.len() as f64;
            assert!((mean - 0.5).abs() < 1e-3, "member {i}: mean {mean}");
            assert!(us.iter().all(|&u| (0.0..1.0).contains(&u)));
        }
        assert_eq!(d.probability(2, 0..0), 3.0 / 8.0);
    }

    /// Leaving out a run of members draws the others in proportion to
    /// their weights, never one left out, and scales their probabilities
    /// to sum to one.
    #[test]
    fn left_out_members_are_never_drawn() {
        let d = DiscreteDistribution::new([2.0, 1.0, 5.0, 0.0, 2.0]);
        for excluded in [0..1, 1..3, 2..3, 4..5, 3..5, 0..0] {
            let n = 10_000;
            let mut counts = [0usize; 5];
            for k in 0..n {
                let drawn = d.sample((k as f64 + 0.5) / n as f64, excluded.clone());
                counts[drawn.unwrap().index] += 1;
            }
            let total: f64 = (0..5).map(|i| d.probability(i, excluded.clone())).sum();
            assert!((total - 1.0).abs() < 1e-12, "{excluded:?}: {total}");
            for (i, &c) in counts.iter().enumerate() {
                let expect = d.probability(i, excluded.clone()) * n as f64;
                assert!((c as f64 - expect).abs() <= 1.0, "{excluded:?} {i}: {c}");
            }
        }
        assert_eq!(d.run_probability(0..5, 1..3), 1.0);
        assert!((d.run_probability(1..4, 0..2) - 5.0 / 7.0).abs() < 1e-12);
        assert_eq!(d.run_probability(0..1, 0..5), 0.0);
        assert_eq!(d.sample(0.3, 0..5), None);
        assert_eq!(d.probability(1, 0..5), 0.0);
    }

    /// Draws right at an interval's edge, even at u just below 1, pick a
    /// member of positive weight.
    #[test]
    fn edges_pick_members_of_positive_weight() {
        let d = DiscreteDistribution::new([0.0, 1.0, 0.0, 1.0, 0.0]);
        for u in [0.0, 0.5, 1.0 - f64::EPSILON] {
            for excluded in [0..0, 1..2, 3..4] {
                let drawn = d.sample(u, excluded.clone()).unwrap();
                assert!(
                    [1, 3].contains(&drawn.index) && !excluded.contains(&drawn.index),
                    "u {u}, {excluded:?}: {drawn:?}"
                );
            }
        }
    }

    #[test]
    fn no_weight_draws_nothing() {
        for d in [
            DiscreteDistribution::new([]),
            DiscreteDistribution::new([0.0, 0.0]),
        ] {
            assert_eq!(d.sample(0.5, 0..0), None);
            assert_eq!(d.probability(0, 0..0), 0.0);
        }
    }

    /// Surfaces are found by number whatever order they were given in; the
    /// one left out is never drawn, and a surface not among them has
    /// probability zero.
    #[test]
    fn surfaces_are_drawn_by_weight_leaving_one_out() {
        let d = SurfaceDistribution::new(vec![(9, 1.0), (2, 2.0), (5, 1.0)]);
        assert_eq!(d.surfaces(), [2, 5, 9]);
        assert!(d.contains(5) && !d.contains(4));
        assert_eq!(d.probability(2, u32::MAX), 0.5);
        assert_eq!(d.probability(9, 2), 0.5);
        assert_eq!(d.probability(2, 2), 0.0);
        assert_eq!(d.probability(4, 2), 0.0);
        let n = 1000;
        let mut counts = [0usize; 10];
        for k in 0..n {
            let u = DVec2::new((k as f64 + 0.5) / n as f64, 0.25);
            let (q, uv, p) = d.sample(u, 5).unwrap();
            counts[q as usize] += 1;
            assert_eq!((uv.y, p), (0.25, d.probability(q, 5)));
        }
        assert_eq!((counts[2], counts[5], counts[9]), (667, 0, 333));
        assert_eq!(d.run_probability(2..6, u32::MAX), 0.75);
        assert!((d.run_probability(3..10, 5) - 1.0 / 3.0).abs() < 1e-12);
        assert_eq!(d.run_probability(3..5, 2), 0.0);
        let alone = SurfaceDistribution::new(vec![(3, 1.0)]);
        assert_eq!(alone.sample(DVec2::splat(0.5), 3), None);
    }
}
