//! Film: pixel sample positions and the reconstruction filter (Mitsuba 3's
//! `box` and `gaussian` rfilters), so images compare pixel for pixel.

use crate::render::sampling::pixel_offsets;
use crate::scene::{Film, PixelFilter};
use glam::DVec2;
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

    /// 1D filter weight at offset `x` pixels (the 2D filter is separable),
    /// evaluated exactly as Mitsuba 3's JIT variants do.
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

/// Render an image: `radiance(x, y, k)` gives the radiance of the film
/// position (x,y) in pixels for the `k`-th sample of its pixel; samples are
/// filtered with the film's filter.
pub fn develop(
    film: &Film,
    samples_per_pixel: u32,
    radiance: impl Fn(f64, f64, usize) -> [f64; 3] + Sync,
) -> Image {
    let (w, h) = (film.width as usize, film.height as usize);
    let per_pixel = pixel_offsets(0, samples_per_pixel).len();
    // Position (in the pixel) and radiance of every sample, computed once.
    let samples: Vec<(DVec2, [f64; 3])> = (0..w * h)
        .into_par_iter()
        .flat_map_iter(|pixel| {
            let corner = DVec2::new((pixel % w) as f64, (pixel / w) as f64);
            pixel_offsets(pixel as u64, samples_per_pixel)
                .into_iter()
                .enumerate()
                .map(move |(k, o)| (k, o, corner + o))
        })
        .map(|(k, o, p)| (o, radiance(p.x, p.y, k)))
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
                    for (o, s) in &samples[base..base + per_pixel] {
                        let wt =
                            filter.eval(qx as f64 + o.x - cx) * filter.eval(qy as f64 + o.y - cy);
                        if wt > 0.0 {
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
        let img = develop(&film, 4, |_, _, _| [1.0, 2.0, 3.0]);
        assert_eq!(img.rgb.len(), 7 * 5 * 3);
        for px in img.rgb.chunks(3) {
            assert!((px[0] - 1.0).abs() < 1e-6 && (px[2] - 3.0).abs() < 1e-6);
        }
    }
}
