//! Linear RGB values (reflectance, radiance, kernel coefficients) and their
//! channel-wise arithmetic, after pbrt-v4's `RGB` and `SampledSpectrum`
//! (`util/spectrum.h`, `util/color.h`).
//!
//! Every operator works channel by channel, each channel computed exactly as
//! the scalar expression would be: `a + b * w` is `a[ch] + b[ch] * w` for each
//! channel, in that order.
//!
//! ```
//! use wavrad_core::scene::Rgb;
//!
//! let reflectance = Rgb([0.5, 0.25, 0.0]);
//! let radiance = Rgb::splat(2.0);
//! assert_eq!(reflectance * radiance + Rgb::splat(1.0), Rgb([2.0, 1.5, 1.0]));
//! assert_eq!((reflectance * 4.0).max_channel(), 2.0);
//! ```

use std::fmt;
use std::iter::Sum;
use std::ops::{Add, AddAssign, Div, Index, Mul, Sub};

/// Linear RGB triple (reflectance, radiance), one `f64` per channel.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
#[repr(transparent)]
pub struct Rgb(pub [f64; 3]);

impl Rgb {
    /// Black: zero in every channel.
    pub const ZERO: Rgb = Rgb([0.0; 3]);

    /// The same value in every channel (grey).
    pub const fn splat(value: f64) -> Rgb {
        Rgb([value; 3])
    }

    /// `f` applied to each channel.
    pub fn map(self, f: impl FnMut(f64) -> f64) -> Rgb {
        Rgb(self.0.map(f))
    }

    /// The largest channel, or zero when no channel is positive (pbrt's
    /// `MaxComponentValue`, clamped at zero).
    pub fn max_channel(self) -> f64 {
        self.0.iter().fold(0.0f64, |m, &x| m.max(x))
    }

    /// The mean of the channels, `(r + g + b) / 3` (pbrt's `Average`).
    pub fn average(self) -> f64 {
        (self.0[0] + self.0[1] + self.0[2]) / 3.0
    }

    /// Rec. 709 luminance, `0.212671 r + 0.715160 g + 0.072169 b` (Mitsuba
    /// 0.6's `Spectrum::getLuminance` in RGB mode).
    pub fn luminance(self) -> f64 {
        0.212671 * self.0[0] + 0.715160 * self.0[1] + 0.072169 * self.0[2]
    }
}

/// The channels as an array, `[r, g, b]` (as users wrote them in scene
/// files).
impl fmt::Display for Rgb {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:?}", self.0)
    }
}

impl From<[f64; 3]> for Rgb {
    fn from(channels: [f64; 3]) -> Rgb {
        Rgb(channels)
    }
}

impl Index<usize> for Rgb {
    type Output = f64;
    fn index(&self, channel: usize) -> &f64 {
        &self.0[channel]
    }
}

impl Add for Rgb {
    type Output = Rgb;
    fn add(self, other: Rgb) -> Rgb {
        Rgb([0, 1, 2].map(|ch| self.0[ch] + other.0[ch]))
    }
}

impl AddAssign for Rgb {
    fn add_assign(&mut self, other: Rgb) {
        *self = *self + other;
    }
}

impl Sub for Rgb {
    type Output = Rgb;
    fn sub(self, other: Rgb) -> Rgb {
        Rgb([0, 1, 2].map(|ch| self.0[ch] - other.0[ch]))
    }
}

/// Channel-wise product (reflectance times radiance).
impl Mul for Rgb {
    type Output = Rgb;
    fn mul(self, other: Rgb) -> Rgb {
        Rgb([0, 1, 2].map(|ch| self.0[ch] * other.0[ch]))
    }
}

impl Mul<f64> for Rgb {
    type Output = Rgb;
    fn mul(self, scale: f64) -> Rgb {
        self.map(|x| x * scale)
    }
}

impl Div<f64> for Rgb {
    type Output = Rgb;
    fn div(self, divisor: f64) -> Rgb {
        self.map(|x| x / divisor)
    }
}

/// Channel-wise sum, from −0 as `f64`'s `Sum` (so each channel is exactly
/// the sum of its values, signed zeros included).
impl Sum for Rgb {
    fn sum<I: Iterator<Item = Rgb>>(iter: I) -> Rgb {
        iter.fold(Rgb::splat(-0.0), Add::add)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arithmetic_is_the_scalar_arithmetic_per_channel() {
        let a = Rgb([0.1, 0.2, 0.3]);
        let b = Rgb([0.7, 1e-17, -3.0]);
        let w = 0.37;
        let sum = a + (b - a) * w;
        for ch in 0..3 {
            assert_eq!(sum[ch].to_bits(), (a[ch] + w * (b[ch] - a[ch])).to_bits());
        }
        assert_eq!((a * b / 3.0)[2].to_bits(), (0.3f64 * -3.0 / 3.0).to_bits());
        let zeros = [Rgb([-0.0, 0.0, 1.0]); 2];
        let expect = [0, 1, 2].map(|ch| zeros.iter().map(|z| z[ch]).sum::<f64>());
        assert_eq!(
            zeros.into_iter().sum::<Rgb>().0.map(f64::to_bits),
            expect.map(f64::to_bits)
        );
    }

    #[test]
    fn max_channel_is_at_least_zero() {
        assert_eq!(Rgb([-1.0, -2.0, -0.5]).max_channel(), 0.0);
        assert_eq!(Rgb([0.25, 3.0, 1.0]).max_channel(), 3.0);
        assert_eq!(Rgb::splat(1.5).average(), 1.5);
    }

    #[test]
    fn serialises_and_displays_as_a_plain_array() {
        let rgb = Rgb([1.0, 0.5, 0.0]);
        assert_eq!(serde_json::to_string(&rgb).unwrap(), "[1.0,0.5,0.0]");
        assert_eq!(rgb.to_string(), "[1.0, 0.5, 0.0]");
    }
}
