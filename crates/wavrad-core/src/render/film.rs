//! Film: pixel sample positions and the reconstruction filter (Mitsuba 3's
//! `box` and `gaussian` rfilters), so images compare pixel for pixel.

use crate::scene::{Film, PixelFilter};
use rayon::prelude::*;

/// A linear RGB image, row-major from the top-left pixel.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `3 · width · height` values.
    pub rgb: Vec<f32>,
}

impl PixelFilter {
    /// Support radius in pixels.
    pub fn radius(&self) -> f64 {
        match *self {
            PixelFilter::Box => 0.5,
            PixelFilter::Gaussian { stddev } => 4.0 * stddev,
        }
    }

    /// 1D filter weight at offset `x` pixels (the 2D filter is separable).
    pub fn eval(&self, x: f64) -> f64 {
        match *self {
            PixelFilter::Box => f64::from(u8::from(x.abs() < 0.5)),
            PixelFilter::Gaussian { stddev } => {
                let alpha = -1.0 / (2.0 * stddev * stddev);
                let r = self.radius();
                ((alpha * x * x).exp() - (alpha * r * r).exp()).max(0.0)
            }
        }
    }
}

/// Stratified sample offsets inside a pixel: an n×n grid (n = ⌈√spp⌉)
/// jittered by a fixed hash, so images are deterministic.
pub fn pixel_offsets(samples_per_pixel: u32) -> Vec<[f64; 2]> {
    let n = (samples_per_pixel.max(1) as f64).sqrt().ceil() as u32;
    let mut out = Vec::with_capacity((n * n) as usize);
    for j in 0..n {
        for i in 0..n {
            let jitter = |k: u32| {
                // Weyl sequence: well spread, reproducible.
                let v = (k as f64 * 0.618_033_988_749_895 + 0.5).fract();
                0.25 + 0.5 * v
            };
            out.push([
                (i as f64 + jitter(2 * (i + n * j))) / n as f64,
                (j as f64 + jitter(2 * (i + n * j) + 1)) / n as f64,
            ]);
        }
    }
    out
}

/// Render an image: `radiance(x, y)` gives the radiance of the film position
/// (x,y) in pixels; samples are filtered with the film's filter.
pub fn develop(
    film: &Film,
    samples_per_pixel: u32,
    radiance: impl Fn(f64, f64) -> [f64; 3] + Sync,
) -> Image {
    let (w, h) = (film.width as usize, film.height as usize);
    let offsets = pixel_offsets(samples_per_pixel);
    let per_pixel = offsets.len();
    // Radiance of every sample, computed once.
    let samples: Vec<[f64; 3]> = (0..w * h * per_pixel)
        .into_par_iter()
        .map(|i| {
            let (pixel, k) = (i / per_pixel, i % per_pixel);
            let (px, py) = ((pixel % w) as f64, (pixel / w) as f64);
            radiance(px + offsets[k][0], py + offsets[k][1])
        })
        .collect();
    // Weighted average of the samples within the filter's radius.
    let filter = film.filter;
    let reach = (filter.radius() - 0.5).ceil().max(0.0) as i64;
    let rgb: Vec<f32> = (0..w * h)
        .into_par_iter()
        .flat_map_iter(|pixel| {
            let (px, py) = ((pixel % w) as i64, (pixel / w) as i64);
            let (cx, cy) = (px as f64 + 0.5, py as f64 + 0.5);
            let (mut sum, mut weight) = ([0.0f64; 3], 0.0f64);
            for qy in (py - reach).max(0)..=(py + reach).min(h as i64 - 1) {
                for qx in (px - reach).max(0)..=(px + reach).min(w as i64 - 1) {
                    let base = (qy as usize * w + qx as usize) * per_pixel;
                    for (k, o) in offsets.iter().enumerate() {
                        let wt =
                            filter.eval(qx as f64 + o[0] - cx) * filter.eval(qy as f64 + o[1] - cy);
                        if wt > 0.0 {
                            let s = samples[base + k];
                            for ch in 0..3 {
                                sum[ch] += wt * s[ch];
                            }
                            weight += wt;
                        }
                    }
                }
            }
            let inv = if weight > 0.0 { 1.0 / weight } else { 0.0 };
            sum.map(|x| (x * inv) as f32)
        })
        .collect();
    Image {
        width: film.width,
        height: film.height,
        rgb,
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
    }

    #[test]
    fn constant_radiance_develops_to_a_constant_image() {
        let film = Film {
            width: 7,
            height: 5,
            filter: PixelFilter::Gaussian { stddev: 0.5 },
        };
        let img = develop(&film, 4, |_, _| [1.0, 2.0, 3.0]);
        assert_eq!(img.rgb.len(), 7 * 5 * 3);
        for px in img.rgb.chunks(3) {
            assert!((px[0] - 1.0).abs() < 1e-6 && (px[2] - 3.0).abs() < 1e-6);
        }
    }

    #[test]
    fn offsets_stay_inside_their_strata() {
        let o = pixel_offsets(16);
        assert_eq!(o.len(), 16);
        for (k, p) in o.iter().enumerate() {
            let (i, j) = (k % 4, k / 4);
            assert!(p[0] >= i as f64 / 4.0 && p[0] < (i + 1) as f64 / 4.0);
            assert!(p[1] >= j as f64 / 4.0 && p[1] < (j + 1) as f64 / 4.0);
        }
    }
}
