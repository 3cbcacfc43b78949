//! Film: pixel sample positions and the reconstruction filter (Mitsuba 3's
//! rfilters, [`PixelFilter`]) applied as Mitsuba's `hdrfilm` does, each pixel
//! the weighted mean of the samples its filter reaches, so images compare
//! pixel for pixel.

use crate::progress::Progress;
use crate::sampling::{pixel_offsets, seeded};
use crate::scene::{Film, PixelFilter, Rgb};
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

/// A filter's 1D weights tabulated finely over its radius (linear
/// interpolation; relative error below 1e-6 for the Gaussian), so that
/// weighting costs no exponential per sample and pixel.
struct FilterTable {
    values: Vec<f64>,
    scale: f64,
    boxed: bool,
}

impl FilterTable {
    const STEPS: usize = 4096;

    fn new(filter: PixelFilter) -> FilterTable {
        let radius = filter.radius();
        let scale = Self::STEPS as f64 / radius;
        let values = (0..=Self::STEPS + 1)
            .map(|i| filter.eval(i as f64 / scale))
            .collect();
        FilterTable {
            values,
            scale,
            boxed: filter == PixelFilter::Box,
        }
    }

    fn eval(&self, x: f64) -> f64 {
        if self.boxed {
            return PixelFilter::Box.eval(x);
        }
        let t = x.abs() * self.scale;
        let i = t as usize;
        if i >= Self::STEPS {
            return 0.0;
        }
        let f = t - i as f64;
        self.values[i] * (1.0 - f) + self.values[i + 1] * f
    }
}

/// Bytes of partial sums held in memory at once.
const WINDOW_BYTES: usize = 1 << 25;

/// Render an image: pixel (x, y) gets `samples(x, y)` samples (rounded up
/// to a square, [`pixel_offsets`], placed as `seed` scrambles them) and `radiance(x, y, k, n)` gives the
/// radiance of the film position (x, y) in pixels for the `k`-th of the `n`
/// samples of its pixel. Samples are filtered with the film's filter, each
/// pixel's samples weighing as much in total as any other pixel's whatever
/// their number (a pixel's contribution to a neighbour is the mean over its
/// own samples), so that sample counts may differ between pixels.
///
/// The filter is separable, so each pixel's samples are reduced once, as
/// they are made, to their weighted sums towards every pixel the filter
/// reaches (`(2r+1)²` of them for reach r); a pixel's value is then the
/// ratio of the sums its neighbours hold for it. Rows are developed in
/// bands, and the partial sums of a band and of the rows its filter reaches
/// are kept in a sliding window, so memory stays bounded whatever the image
/// size and sample count. The filter must be valid
/// ([`PixelFilter::validate`], which bounds its radius).
///
/// Each row is a step of `progress`'s phase `rendering`; once the work is
/// asked to stop ([`Progress::interrupted`]) no more samples are taken and
/// there is no image (`None`).
pub fn develop(
    film: &Film,
    samples: impl Fn(usize, usize) -> u32 + Sync,
    radiance: impl Fn(f64, f64, usize, usize) -> Rgb + Sync,
    seed: u32,
    progress: &dyn Progress,
) -> Option<Image> {
    develop_in_window(film, (samples, seed), radiance, WINDOW_BYTES, progress)
}

fn develop_in_window(
    film: &Film,
    (samples, seed): (impl Fn(usize, usize) -> u32 + Sync, u32),
    radiance: impl Fn(f64, f64, usize, usize) -> Rgb + Sync,
    window_bytes: usize,
    progress: &dyn Progress,
) -> Option<Image> {
    debug_assert!(film.filter.validate().is_ok(), "{}", film.filter);
    let (w, h) = (film.width as usize, film.height as usize);
    let table = FilterTable::new(film.filter);
    let reach = (film.filter.radius() - 0.5).ceil().max(0.0) as usize;
    let span = 2 * reach + 1;
    // Per source pixel: for each target offset (dy, dx), Σ w·L (3) and Σ w.
    let stride = span * span * 4;
    let band = (window_bytes / (8 * w * stride).max(1))
        .saturating_sub(2 * reach)
        .max(1);
    // The partial sums of every pixel of row y, towards the pixels at
    // offsets (dy − reach, dx − reach) from it.
    let partial_row = |y: usize| -> Vec<f64> {
        (0..w)
            .into_par_iter()
            .flat_map_iter(|x| {
                let pixel = (y * w + x) as u64;
                let mut sums = vec![0.0f64; stride];
                if progress.interrupted() {
                    return sums;
                }
                let (mut wx, mut wy) = (vec![0.0; span], vec![0.0; span]);
                let offsets = pixel_offsets(seeded(pixel, seed), samples(x, y));
                let n = offsets.len();
                for (k, o) in offsets.into_iter().enumerate() {
                    let l =
                        radiance(x as f64 + o.x, y as f64 + o.y, k, n).map(|v| f64::from(v as f32));
                    for d in 0..span {
                        // Target pixel centre at offset d − reach: x + d − reach + 0.5.
                        let shift = d as f64 - reach as f64 + 0.5;
                        wx[d] = table.eval(o.x - shift);
                        wy[d] = table.eval(o.y - shift);
                    }
                    for (dy, &fy) in wy.iter().enumerate().filter(|(_, &f)| f != 0.0) {
                        for (dx, &fx) in wx.iter().enumerate().filter(|(_, &f)| f != 0.0) {
                            let wt = fy * fx;
                            let cell = &mut sums[4 * (dy * span + dx)..][..4];
                            for ch in 0..3 {
                                cell[ch] += wt * l[ch];
                            }
                            cell[3] += wt;
                        }
                    }
                }
                let mean = 1.0 / n as f64;
                sums.iter_mut().for_each(|v| *v *= mean);
                sums
            })
            .collect()
    };
    let mut rgb = Vec::with_capacity(3 * w * h);
    // window[i] holds the partial sums of row first_row + i.
    let (mut window, mut first_row): (Vec<Vec<f64>>, usize) = (Vec::new(), 0);
    progress.start("rendering", h as u64);
    for b0 in (0..h).step_by(band) {
        let b1 = (b0 + band).min(h);
        let (lo, hi) = (b0.saturating_sub(reach), (b1 + reach).min(h));
        let drop = lo.saturating_sub(first_row).min(window.len());
        window.drain(..drop);
        first_row += drop;
        if window.is_empty() {
            first_row = lo;
        }
        while first_row + window.len() < hi {
            let row = partial_row(first_row + window.len());
            if progress.interrupted() {
                progress.finish();
                return None;
            }
            window.push(row);
            progress.advance(1);
        }
        // Each pixel gathers what its neighbours hold for it.
        let band_rgb: Vec<f32> = (b0 * w..b1 * w)
            .into_par_iter()
            .flat_map_iter(|pixel| {
                let (px, py) = (pixel % w, pixel / w);
                let mut sum = [0.0f64; 4];
                for qy in py.saturating_sub(reach)..=(py + reach).min(h - 1) {
                    let row = &window[qy - first_row];
                    let dy = py + reach - qy;
                    for qx in px.saturating_sub(reach)..=(px + reach).min(w - 1) {
                        let dx = px + reach - qx;
                        let cell = &row[qx * stride + 4 * (dy * span + dx)..][..4];
                        (0..4).for_each(|i| sum[i] += cell[i]);
                    }
                }
                let inv = if sum[3] > 0.0 { 1.0 / sum[3] } else { 0.0 };
                [sum[0], sum[1], sum[2]].map(|x| (x * inv) as f32)
            })
            .collect();
        rgb.extend(band_rgb);
    }
    progress.finish();
    Some(Image {
        width: film.width,
        height: film.height,
        rgb,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::progress::Silent;
    use std::sync::atomic::Ordering;

    /// One of each family, with a negative-lobed filter of each kind.
    const FILTERS: [PixelFilter; 6] = [
        PixelFilter::Box,
        PixelFilter::Tent { radius: 1.0 },
        PixelFilter::Gaussian { stddev: 0.5 },
        PixelFilter::Gaussian { stddev: 0.3 },
        PixelFilter::CATMULL_ROM,
        PixelFilter::Lanczos { lobes: 3 },
    ];

    #[test]
    fn table_matches_the_filter() {
        for filter in FILTERS {
            let t = FilterTable::new(filter);
            for i in 0..1000 {
                let x = i as f64 * 0.0071 - 3.5;
                assert!(
                    (t.eval(x) - filter.eval(x)).abs() < 1e-6,
                    "{filter:?} at {x}"
                );
            }
        }
    }

    #[test]
    fn bands_do_not_change_the_image() {
        // A film wide enough for several bands and an image-dependent signal.
        for filter in [
            PixelFilter::Gaussian { stddev: 0.5 },
            PixelFilter::Lanczos { lobes: 3 },
        ] {
            let film = Film {
                width: 300,
                height: 40,
                filter,
            };
            let f = |x: f64, y: f64, _k: usize, _n: usize| {
                Rgb([x.sin() + 1.0, y * 0.1, (x * y).cos() + 1.0])
            };
            let reach = (filter.radius() - 0.5).ceil() as usize;
            let span = 2 * reach + 1;
            // Bands of 3 rows.
            let window = 8 * 300 * span * span * 4 * (3 + 2 * reach);
            let img = develop_in_window(&film, (|_, _| 64, 0), f, window, &Silent).unwrap();
            assert_eq!(
                Some(&img),
                develop(&film, |_, _| 64, f, 0, &Silent).as_ref()
            );
            // Pixel (150, 20) recomputed directly from its neighbourhood.
            let (px, py) = (150usize, 20usize);
            let (mut sum, mut weight) = (0.0, 0.0);
            for qy in py - reach..=py + reach {
                for qx in px - reach..=px + reach {
                    for o in pixel_offsets((qy * 300 + qx) as u64, 64) {
                        let (x, y) = (qx as f64 + o.x, qy as f64 + o.y);
                        let wt = film.filter.eval(x - px as f64 - 0.5)
                            * film.filter.eval(y - py as f64 - 0.5);
                        sum += wt * f64::from(f(x, y, 0, 64)[0] as f32);
                        weight += wt;
                    }
                }
            }
            let pixel = f64::from(img.rgb[3 * (py * 300 + px)]);
            assert!((pixel - sum / weight).abs() < 1e-5, "{filter}");
        }
    }

    /// Counts the rows developed and asks to stop after `stop_after` of
    /// them.
    struct Rows {
        stop_after: u64,
        done: std::sync::atomic::AtomicU64,
        total: std::sync::atomic::AtomicU64,
    }

    impl Progress for Rows {
        fn start(&self, phase: &str, total: u64) {
            assert_eq!(phase, "rendering");
            self.total.store(total, Ordering::SeqCst);
        }
        fn advance(&self, steps: u64) {
            self.done.fetch_add(steps, Ordering::SeqCst);
        }
        fn interrupted(&self) -> bool {
            self.done.load(Ordering::SeqCst) >= self.stop_after
        }
    }

    #[test]
    fn each_row_is_a_step_and_a_stop_leaves_no_image() {
        let film = Film {
            width: 9,
            height: 7,
            filter: PixelFilter::Box,
        };
        let radiance = |_: f64, _: f64, _: usize, _: usize| Rgb::splat(1.0);
        let rows = |stop_after| Rows {
            stop_after,
            done: Default::default(),
            total: Default::default(),
        };
        let whole = rows(u64::MAX);
        assert!(develop(&film, |_, _| 4, radiance, 0, &whole).is_some());
        assert_eq!(whole.done.load(Ordering::SeqCst), 7);
        assert_eq!(whole.total.load(Ordering::SeqCst), 7);
        // Stopped after 3 rows: no image, and no row sampled after.
        let sampled = std::sync::atomic::AtomicU64::new(0);
        let counted = |x: f64, y: f64, k: usize, n: usize| {
            sampled.fetch_add(1, Ordering::SeqCst);
            radiance(x, y, k, n)
        };
        let cut = rows(3);
        assert!(develop(&film, |_, _| 4, counted, 0, &cut).is_none());
        assert_eq!(cut.done.load(Ordering::SeqCst), 3);
        assert_eq!(sampled.load(Ordering::SeqCst), 3 * 9 * 4);
    }

    #[test]
    fn constant_radiance_develops_to_a_constant_image() {
        // Normalized by the weights' sum, negative lobes included.
        for filter in FILTERS {
            let film = Film {
                width: 7,
                height: 5,
                filter,
            };
            let img = develop(
                &film,
                |x, _| 1 + x as u32,
                |_, _, _, _| Rgb([1.0, 2.0, 3.0]),
                0,
                &Silent,
            )
            .unwrap();
            assert_eq!(img.rgb.len(), 7 * 5 * 3);
            for px in img.rgb.chunks(3) {
                assert!(
                    (px[0] - 1.0).abs() < 1e-6 && (px[2] - 3.0).abs() < 1e-6,
                    "{filter}: {px:?}"
                );
            }
        }
    }
}
