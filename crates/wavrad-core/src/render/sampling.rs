//! Reproducible sample numbers: every random choice in rendering is a hash of
//! where it is made (pixel, sample, ray), so images do not depend on the
//! number of threads or on the order of work.

use glam::DVec2;

/// Two uniform numbers in [0,1) from a seed and an index (SplitMix64
/// finaliser).
pub fn hash2(seed: u64, index: u64) -> DVec2 {
    let mix = |mut z: u64| {
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    };
    let h = mix(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ mix(index));
    let to_unit = |bits: u64| (bits >> 11) as f64 / (1u64 << 53) as f64;
    DVec2::new(to_unit(h), to_unit(mix(h)))
}

/// Jittered stratified positions inside pixel number `pixel`: an n×n grid
/// (n = ⌈√spp⌉) with a jitter of its own in every pixel, so that an edge
/// crossing many pixels at the same sub-pixel position does not get the same
/// coverage error in all of them.
pub fn pixel_offsets(pixel: u64, samples_per_pixel: u32) -> Vec<DVec2> {
    let n = (samples_per_pixel.max(1) as f64).sqrt().ceil() as u32;
    (0..pixel_offsets_len(samples_per_pixel))
        .map(|k| {
            let r = hash2(pixel, u64::from(k));
            DVec2::new(
                (f64::from(k % n) + r.x) / f64::from(n),
                (f64::from(k / n) + r.y) / f64::from(n),
            )
        })
        .collect()
}

/// Number of positions [`pixel_offsets`] makes for `samples_per_pixel`.
pub fn pixel_offsets_len(samples_per_pixel: u32) -> u32 {
    let n = (samples_per_pixel.max(1) as f64).sqrt().ceil() as u32;
    n * n
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offsets_stay_inside_their_strata_and_differ_between_pixels() {
        let o = pixel_offsets(5, 16);
        assert_eq!(o.len(), 16);
        for (k, p) in o.iter().enumerate() {
            let (i, j) = (k % 4, k / 4);
            assert!(p.x >= i as f64 / 4.0 && p.x < (i + 1) as f64 / 4.0);
            assert!(p.y >= j as f64 / 4.0 && p.y < (j + 1) as f64 / 4.0);
        }
        assert_ne!(o, pixel_offsets(6, 16));
        assert_eq!(o, pixel_offsets(5, 16));
    }

    #[test]
    fn hash_is_roughly_uniform() {
        let n = 10_000;
        let mean: f64 = (0..n).map(|i| hash2(3, i).x).sum::<f64>() / n as f64;
        assert!((mean - 0.5).abs() < 0.01, "{mean}");
    }
}
