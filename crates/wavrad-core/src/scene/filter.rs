//! The film's pixel reconstruction filter: Mitsuba 3's `rfilter` plugins
//! (`src/rfilters/*.cpp`), each a separable 1D weight function with a
//! support radius in pixels.
//!
//! | filter        | parameters (Mitsuba's defaults)   | radius        |
//! |---------------|-----------------------------------|---------------|
//! | `box`         |                                   | 0.5           |
//! | `tent`        | `radius` (1)                      | `radius`      |
//! | `gaussian`    | `stddev` (0.5)                    | 4·`stddev`    |
//! | `mitchell`    | `B`, `C` (1/3, 1/3)               | 2             |
//! | `catmullrom`  | (`mitchell` with B = 0, C = 1/2)  | 2             |
//! | `lanczos`     | `lobes` (3)                       | `lobes`       |
//!
//! Filters with negative lobes (`mitchell`, `catmullrom`, `lanczos`) are
//! normalized by the sum of the weights that reach a pixel, as Mitsuba's
//! `hdrfilm` does ([`crate::render::film`]).
//!
//! ```
//! use wavrad_core::scene::PixelFilter;
//!
//! let tent = PixelFilter::Tent { radius: 1.0 };
//! assert_eq!(tent.eval(0.25), 0.75);
//! let catmull_rom = PixelFilter::CATMULL_ROM;
//! assert_eq!(catmull_rom.radius(), 2.0);
//! assert!(catmull_rom.eval(1.5) < 0.0); // a negative lobe
//! assert!(PixelFilter::Gaussian { stddev: 5.0 }.validate().is_err()); // reaches 20 pixels
//! ```

use crate::error::{Error, Result};

/// Pixel reconstruction filter of the film (Mitsuba's `rfilter`).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum PixelFilter {
    /// Box of radius 0.5 pixel.
    Box,
    /// Tent (triangle) `max(0, 1 − |x| / radius)`.
    Tent {
        /// Radius in pixels (Mitsuba's default 1).
        radius: f64,
    },
    /// Gaussian with the given standard deviation in pixels, truncated at
    /// 4·stddev and shifted to vanish there (Mitsuba 3's `gaussian`,
    /// default stddev 0.5).
    Gaussian {
        /// Standard deviation in pixels.
        stddev: f64,
    },
    /// Mitchell & Netravali's cubic (*Reconstruction Filters in Computer
    /// Graphics*, SIGGRAPH 1988, eq. 8), radius 2.
    Mitchell {
        /// The paper's B (Mitsuba's default 1/3).
        b: f64,
        /// The paper's C (Mitsuba's default 1/3).
        c: f64,
    },
    /// Lanczos-windowed sinc, `sinc(x)·sinc(x / lobes)` for |x| < lobes.
    Lanczos {
        /// Side lobes, also the radius in pixels (Mitsuba's default 3).
        lobes: u32,
    },
}

impl PixelFilter {
    /// The Catmull-Rom spline: Mitchell–Netravali with B = 0, C = 1/2
    /// (Mitsuba's `catmullrom`).
    pub const CATMULL_ROM: PixelFilter = PixelFilter::Mitchell { b: 0.0, c: 0.5 };

    /// The largest support radius accepted, in pixels. The film keeps, for
    /// every pixel, its samples' weighted sums towards each pixel its filter
    /// reaches, `(2⌈r − ½⌉ + 1)²` of them, over `2⌈r − ½⌉ + 1` rows at once:
    /// memory grows with the cube of the radius (at 6 pixels, 70 kB per
    /// column of the image), so larger footprints are refused up front.
    pub const MAX_RADIUS: f64 = 6.0;

    /// Support radius in pixels.
    pub fn radius(&self) -> f64 {
        match *self {
            PixelFilter::Box => 0.5,
            PixelFilter::Tent { radius } => radius,
            PixelFilter::Gaussian { stddev } => 4.0 * stddev,
            PixelFilter::Mitchell { .. } => 2.0,
            PixelFilter::Lanczos { lobes } => f64::from(lobes),
        }
    }

    /// 1D filter weight at offset `x` pixels (the 2D filter is separable),
    /// evaluated as Mitsuba 3's JIT variants do. The box is half-open,
    /// \[−½, ½), so that a sample on the edge between two pixels counts
    /// once.
    pub fn eval(&self, x: f64) -> f64 {
        let a = x.abs();
        match *self {
            PixelFilter::Box => f64::from(u8::from((-0.5..0.5).contains(&x))),
            PixelFilter::Tent { radius } => (1.0 - a / radius).max(0.0),
            PixelFilter::Gaussian { stddev } => {
                let alpha = -1.0 / (2.0 * stddev * stddev);
                let r = self.radius();
                ((alpha * a * a).exp() - (alpha * r * r).exp()).max(0.0)
            }
            PixelFilter::Mitchell { b, c } => {
                let (a2, a3) = (a * a, a * a * a);
                let cubic = if a < 1.0 {
                    (12.0 - 9.0 * b - 6.0 * c) * a3
                        + (-18.0 + 12.0 * b + 6.0 * c) * a2
                        + (6.0 - 2.0 * b)
                } else if a < 2.0 {
                    (-b - 6.0 * c) * a3
                        + (6.0 * b + 30.0 * c) * a2
                        + (-12.0 * b - 48.0 * c) * a
                        + (8.0 * b + 24.0 * c)
                } else {
                    0.0
                };
                cubic / 6.0
            }
            PixelFilter::Lanczos { lobes } => {
                let r = f64::from(lobes);
                if a < f64::EPSILON {
                    1.0
                } else if a > r {
                    0.0
                } else {
                    let x1 = std::f64::consts::PI * a;
                    let x2 = x1 / r;
                    (x1.sin() * x2.sin()) / (x1 * x2)
                }
            }
        }
    }

    /// Check the parameters: finite, positive where they are sizes, and a
    /// support of at most [`PixelFilter::MAX_RADIUS`] pixels.
    ///
    /// # Errors
    /// [`Error::InvalidSetting`] naming the filter and the parameter.
    pub fn validate(&self) -> Result<()> {
        let positive = |name: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(Error::InvalidSetting(format!(
                    "{self}: {name} must be a positive number, got {v}"
                )))
            }
        };
        match *self {
            PixelFilter::Box => {}
            PixelFilter::Tent { radius } => positive("radius", radius)?,
            PixelFilter::Gaussian { stddev } => positive("stddev", stddev)?,
            PixelFilter::Mitchell { b, c } => {
                if !(b.is_finite() && c.is_finite()) {
                    return Err(Error::InvalidSetting(format!(
                        "{self}: B and C must be finite"
                    )));
                }
            }
            PixelFilter::Lanczos { lobes } => positive("lobes", f64::from(lobes))?,
        }
        if self.radius() > Self::MAX_RADIUS {
            return Err(Error::InvalidSetting(format!(
                "{self} reaches {} pixels; wavrad accepts filters of radius at most {} pixels \
                 (the film's memory grows with the cube of the radius)",
                self.radius(),
                Self::MAX_RADIUS
            )));
        }
        Ok(())
    }
}

impl std::fmt::Display for PixelFilter {
    /// Mitsuba's plugin name and parameters, e.g. `tent filter (radius 1.5)`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            PixelFilter::Box => write!(f, "box filter"),
            PixelFilter::Tent { radius } => write!(f, "tent filter (radius {radius})"),
            PixelFilter::Gaussian { stddev } => write!(f, "gaussian filter (stddev {stddev})"),
            PixelFilter::Mitchell { b, c } => write!(f, "mitchell filter (B {b}, C {c})"),
            PixelFilter::Lanczos { lobes } => write!(f, "lanczos filter ({lobes} lobes)"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gaussian_vanishes_at_its_radius_and_box_is_one_pixel() {
        let g = PixelFilter::Gaussian { stddev: 0.5 };
        assert_eq!(g.radius(), 2.0);
        assert_eq!(g.eval(2.0), 0.0);
        assert!(g.eval(0.0) > g.eval(0.7));
        assert_eq!(PixelFilter::Box.eval(0.49), 1.0);
        assert_eq!(PixelFilter::Box.eval(0.51), 0.0);
        // Half-open: an edge sample belongs to the pixel on its right.
        assert_eq!(PixelFilter::Box.eval(-0.5), 1.0);
        assert_eq!(PixelFilter::Box.eval(0.5), 0.0);
    }

    #[test]
    fn mitchell_is_a_partition_of_unity_and_catmull_rom_interpolates() {
        // Mitchell & Netravali (1988), §4: any B, C with the cubic's form sum
        // to one over integer shifts; Catmull-Rom (B = 0) is 1 at 0 and 0 at
        // every other integer.
        for filter in [
            PixelFilter::Mitchell {
                b: 1.0 / 3.0,
                c: 1.0 / 3.0,
            },
            PixelFilter::CATMULL_ROM,
            PixelFilter::Mitchell { b: 1.0, c: 0.0 },
        ] {
            for x in [0.0, 0.1, 0.37, 0.5, 0.9] {
                let sum: f64 = (-3..=3).map(|k| filter.eval(x + f64::from(k))).sum();
                assert!((sum - 1.0).abs() < 1e-12, "{filter} at {x}: {sum}");
            }
        }
        let cr = PixelFilter::CATMULL_ROM;
        assert_eq!(cr.eval(0.0), 1.0);
        assert!(cr.eval(1.0).abs() < 1e-15 && cr.eval(2.0) == 0.0);
        assert!(cr.eval(1.5) < 0.0);
    }

    #[test]
    fn lanczos_and_tent_match_their_closed_forms() {
        let l = PixelFilter::Lanczos { lobes: 3 };
        assert_eq!(l.radius(), 3.0);
        assert_eq!(l.eval(0.0), 1.0);
        for k in 1..=3 {
            assert!(l.eval(f64::from(k)).abs() < 1e-15, "zero at {k}");
        }
        // sinc(0.5)·sinc(1/6) with sinc(x) = sin(πx)/(πx).
        let sinc = |x: f64| (std::f64::consts::PI * x).sin() / (std::f64::consts::PI * x);
        assert!((l.eval(-0.5) - sinc(0.5) * sinc(0.5 / 3.0)).abs() < 1e-15);
        assert!(l.eval(1.5) < 0.0 && l.eval(3.5) == 0.0);
        let t = PixelFilter::Tent { radius: 1.25 };
        assert_eq!(t.eval(-0.625), 0.5);
        assert_eq!(t.eval(1.3), 0.0);
    }

    #[test]
    fn validate_refuses_bad_parameters_and_huge_footprints() {
        for ok in [
            PixelFilter::Box,
            PixelFilter::Tent { radius: 6.0 },
            PixelFilter::Gaussian { stddev: 1.5 },
            PixelFilter::CATMULL_ROM,
            PixelFilter::Lanczos { lobes: 6 },
        ] {
            ok.validate().unwrap();
        }
        for (bad, word) in [
            (PixelFilter::Tent { radius: 0.0 }, "radius"),
            (PixelFilter::Tent { radius: f64::NAN }, "radius"),
            (PixelFilter::Gaussian { stddev: -1.0 }, "stddev"),
            (PixelFilter::Lanczos { lobes: 0 }, "lobes"),
            (
                PixelFilter::Mitchell {
                    b: f64::INFINITY,
                    c: 0.0,
                },
                "finite",
            ),
            (PixelFilter::Lanczos { lobes: 1000 }, "at most 6"),
            (PixelFilter::Gaussian { stddev: 1e9 }, "at most 6"),
        ] {
            let msg = bad.validate().unwrap_err().to_string();
            assert!(msg.contains(word), "{msg}");
        }
    }
}
