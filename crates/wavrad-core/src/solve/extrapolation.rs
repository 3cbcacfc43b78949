//! Extrapolation of Gauss–Seidel's slowest mode: the sweeps still to come,
//! added at once.
//!
//! Gauss–Seidel gathering (with the far field read from the sweep before)
//! is a stationary linear iteration. Once its faster modes have died out,
//! its error is its slowest mode's, which each sweep shrinks by one ratio
//! q: each sweep then changes the solution by q times the change of the
//! sweep before, and all the sweeps still to come add q/(1 − q) times the
//! last change (a geometric series; Aitken's δ² process applied to the
//! whole solution). When a few sweeps in a row shrink the change by the
//! same ratio, [`Extrapolation`] says to add that remainder at once. The
//! faster modes it leaves, and any error in q, are removed by the sweeps
//! that follow, which measure the residual as before: the stopping test is
//! unchanged. Cohen, Chen, Wallace & Greenberg 1988 estimate the same
//! remainder from the scene's mean reflectance (their "ambient term");
//! here it is measured.

/// Ratios of consecutive changes that must agree before extrapolating.
const AGREEING_RATIOS: usize = 3;

/// Largest spread of the agreeing ratios, relative to the last.
const AGREEMENT: f64 = 0.02;

/// Largest ratio extrapolated: at q = 0.95 the remainder is 19 times the
/// last change, and a slower solve is left to its sweeps.
const MAX_RATIO: f64 = 0.95;

/// Watches the change of power per sweep for a steady ratio.
#[derive(Debug, Clone, Default)]
pub(super) struct Extrapolation {
    /// The last sweep's change, since the last extrapolation.
    previous: Option<f64>,
    /// Ratios of consecutive changes since then, the latest last.
    ratios: Vec<f64>,
}

impl Extrapolation {
    /// Whether the next sweep's change may complete a run of agreeing
    /// ratios (the last [`AGREEING_RATIOS`] − 1 agree as closely as a
    /// complete run's must): only then must the radiance before that sweep
    /// be kept for [`Extrapolation::record`]'s factor to extend.
    pub(super) fn may_extrapolate_next(&self) -> bool {
        let Some(first) = self.ratios.len().checked_sub(AGREEING_RATIOS - 1) else {
            return false;
        };
        let (lo, hi) = spread(&self.ratios[first..]);
        // A complete run's spread is at most AGREEMENT times its last
        // ratio, which is at most its least over (1 − AGREEMENT).
        hi < MAX_RATIO && hi - lo <= AGREEMENT / (1.0 - AGREEMENT) * lo
    }

    /// Record one sweep's change of power. `Some(q / (1 − q))`, the
    /// multiple of this sweep's change that the sweeps still to come would
    /// add, when the last [`AGREEING_RATIOS`] ratios of consecutive changes
    /// agree within [`AGREEMENT`] and are below [`MAX_RATIO`]; the caller
    /// adds it, and the watch starts again from the next sweep (whose
    /// change is not comparable with this one's).
    pub(super) fn record(&mut self, changed: f64) -> Option<f64> {
        if let Some(previous) = self.previous.filter(|&p| p > 0.0) {
            self.ratios.push(changed / previous);
        }
        self.previous = Some(changed);
        let last = self.ratios.len().checked_sub(AGREEING_RATIOS)?;
        let recent = &self.ratios[last..];
        let q = recent[AGREEING_RATIOS - 1];
        let (lo, hi) = spread(recent);
        if !(q > 0.0 && hi < MAX_RATIO && hi - lo <= AGREEMENT * q) {
            return None;
        }
        *self = Extrapolation::default();
        Some(q / (1.0 - q))
    }
}

/// The least and largest of `ratios`.
fn spread(ratios: &[f64]) -> (f64, f64) {
    (ratios.iter()).fold((f64::INFINITY, 0.0f64), |(lo, hi), &r| {
        (lo.min(r), hi.max(r))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Changes shrinking by a steady ratio are extrapolated once three
    /// ratios agree, by q/(1 − q): the sum of all the changes to come.
    #[test]
    fn a_steady_ratio_is_summed() {
        let mut watch = Extrapolation::default();
        let changes: Vec<f64> = (0..4).map(|k| 0.5f64.powi(k)).collect();
        let factors: Vec<Option<f64>> = changes.iter().map(|&c| watch.record(c)).collect();
        assert_eq!(&factors[..3], &[None, None, None]);
        let factor = factors[3].expect("three agreeing ratios");
        let mut armed = Extrapolation::default();
        let before: Vec<bool> = (changes.iter())
            .map(|&c| {
                let may = armed.may_extrapolate_next();
                armed.record(c);
                may
            })
            .collect();
        assert_eq!(before, [false, false, false, true]);
        let remainder: f64 = (4..200).map(|k| 0.5f64.powi(k)).sum();
        assert!((factor * changes[3] - remainder).abs() < 1e-12);
        // The watch starts again: the next sweep's change alone says nothing.
        assert_eq!(watch.record(0.01), None);
    }

    /// Every extrapolation was announced the sweep before
    /// ([`Extrapolation::may_extrapolate_next`]), for changes whose ratios
    /// wander near a steady value.
    #[test]
    fn every_extrapolation_is_announced() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut uniform = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut watch, mut change, mut extrapolated) = (Extrapolation::default(), 1.0, 0);
        for _ in 0..100_000 {
            let announced = watch.may_extrapolate_next();
            change *= 0.6 + 0.03 * (uniform() - 0.5);
            if watch.record(change).is_some() {
                assert!(announced);
                extrapolated += 1;
            }
            if change < 1e-200 {
                change = 1.0;
            }
        }
        assert!(extrapolated > 1000, "{extrapolated}");
    }

    /// Ratios that drift, grow towards one, or changes that vanish are not
    /// extrapolated.
    #[test]
    fn unsteady_or_slow_changes_are_left_to_the_sweeps() {
        let never = |changes: &[f64]| {
            let mut watch = Extrapolation::default();
            changes.iter().all(|&c| watch.record(c).is_none())
        };
        // Ratios 0.5, 0.6, 0.7, 0.8: a faster mode still dying out.
        assert!(never(&[1.0, 0.5, 0.3, 0.21, 0.168]));
        // A steady ratio of 0.97: a slow solve is swept to its end.
        assert!(never(&(0..10).map(|k| 0.97f64.powi(k)).collect::<Vec<_>>()));
        // A growing change (a diverging solve) is never extrapolated.
        assert!(never(&(0..10).map(|k| 1.1f64.powi(k)).collect::<Vec<_>>()));
        assert!(never(&[1.0, 0.0, 0.0, 0.0, 0.0, 0.0]));
        assert!(never(&[0.0; 8]));
    }
}
