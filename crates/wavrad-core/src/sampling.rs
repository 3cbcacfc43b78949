//! Reproducible sample numbers: every random choice in rendering is a hash of
//! where it is made (pixel, sample, ray), or a point of a per-pixel scrambled
//! Sobol sequence keyed the same way, so images do not depend on the number
//! of threads or on the order of work.

use glam::{DVec2, DVec3};

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

/// The sample streams of rendering, by what they sample: each draws its
/// points from sequences of its own, keyed by its salt (pbrt-v4's samplers
/// hand out their dimensions the same way). A stream that samples one of
/// many emitters or surfaces picks it with its points' first number too.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stream {
    /// A final gather's shadow rays (an emitter, and a point on it).
    Shadow,
    /// A final gather's area samples of the bright surfaces (a surface,
    /// and a point on it).
    Bright,
    /// A final gather's directions through the mirror images (an image,
    /// and a point on it).
    Mirror,
    /// A final gather's samples of its links' source elements (an
    /// element, and a point on it).
    Linked,
    /// A final gather's cosine-distributed rays.
    Cosine,
    /// A glossy point's light samples (an emitter, and a point on it).
    Light,
    /// A glossy point's BRDF samples (a direction, and with
    /// [`Samples::third`] a lobe).
    Brdf,
    /// A camera ray's choice between reflection and transmission where it
    /// meets glass, and of a rough interface's microfacet normal, one per
    /// interface ([`Samples::interface`]).
    Interface,
}

impl Stream {
    /// The key that picks the stream's sequences.
    fn key(self) -> u64 {
        match self {
            Stream::Shadow => 0x1b87_3593,
            Stream::Bright => 0x3c6e_f372,
            Stream::Mirror => 0x6a09_e667,
            Stream::Linked => 0xbb67_ae85,
            Stream::Cosine => 0x5bd1_e995,
            Stream::Light => 0x2545_f491,
            Stream::Brdf => 0x9e37_79b9,
            Stream::Interface => 0x510e_527f,
        }
    }
}

/// Where one estimate draws its sample points, stream by stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Samples {
    /// Independent of every other estimate: `len` points of a kind are
    /// jittered over a √len × √len grid when `len` is a square, else
    /// stratified along the first dimension only.
    Hashed(u64),
    /// Block `block` of `len` consecutive points of the pixel's own
    /// Owen-scrambled Sobol (0,2)-sequence of each stream (Burley 2020,
    /// "Practical Hash-based Owen Scrambling"). Every aligned block of 2^k
    /// points of such a sequence is stratified in both dimensions at once
    /// (an elementary (0,k,2)-net), and so is the union of a pixel's
    /// blocks: the gathers that share a pixel stratify their samples of
    /// each stream jointly instead of each on its own, while each estimate
    /// stays unbiased by itself.
    Pixel {
        /// Picks the pixel's scramble (one per pixel and stream).
        scramble: u64,
        /// Which block of the sequence this estimate takes.
        block: u32,
    },
}

/// Keys a second set of a pixel's sequences, for the final gathers its
/// camera rays make ([`Samples::final_gather`]).
const FINAL_GATHER: u64 = 0x243f_6a88_85a3_08d3;

impl Samples {
    /// Block `block` of the sequences of the pixel (or texel) numbered
    /// `pixel`.
    pub fn pixel(pixel: u64, block: u32) -> Samples {
        Samples::Pixel {
            scramble: pixel.wrapping_mul(0x9e37_79b9_7f4a_7c15),
            block,
        }
    }

    /// The samples of final gather number `block` made by the pixel's
    /// camera rays, whose own samples these are: a set of the pixel's
    /// sequences apart from theirs, so that the pixel's gathers stratify
    /// jointly among themselves.
    pub fn final_gather(self, block: u32) -> Samples {
        match self {
            Samples::Hashed(seed) => Samples::Hashed(seed ^ FINAL_GATHER),
            Samples::Pixel { scramble, .. } => Samples::Pixel {
                scramble: scramble ^ FINAL_GATHER,
                block,
            },
        }
    }

    /// Point `j` of the `len` points of `stream` this estimate takes, in
    /// [0,1)².
    pub fn point(self, stream: Stream, len: u32, j: u32) -> DVec2 {
        let kind = stream.key();
        match self {
            Samples::Hashed(seed) => {
                let r = hash2(seed ^ kind, u64::from(j));
                let side = f64::from(len).sqrt().round() as u32;
                if side * side == len {
                    DVec2::new(
                        (f64::from(j % side) + r.x) / f64::from(side),
                        (f64::from(j / side) + r.y) / f64::from(side),
                    )
                } else {
                    DVec2::new((f64::from(j) + r.x) / f64::from(len.max(1)), r.y)
                }
            }
            Samples::Pixel { scramble, block } => {
                sobol2(block.wrapping_mul(len).wrapping_add(j), scramble ^ kind)
            }
        }
    }

    /// A third number for point `j` of `stream`, independent of the two of
    /// [`Samples::point`] (a BRDF sample's choice of lobe): Sobol's third
    /// dimension, scrambled on its own, or an independent hash. Two points
    /// of one index but different streams are not independent of each
    /// other (their strata follow the index), so one sample's numbers must
    /// come from one stream.
    pub fn third(self, stream: Stream, len: u32, j: u32) -> f64 {
        let kind = stream.key();
        match self {
            Samples::Hashed(seed) => hash2(seed ^ kind ^ 0x3c6e_f372_fe94_f82b, u64::from(j)).x,
            Samples::Pixel { scramble, block } => {
                sobol(block.wrapping_mul(len).wrapping_add(j), scramble ^ kind, 2)
            }
        }
    }

    /// The numbers in [0, 1) of the `depth`-th glass interface a camera
    /// ray meets (0 the first): `x` chooses between reflection and
    /// transmission, `(y, z)` a rough interface's microfacet normal
    /// ([`crate::scene::glass::Dielectric::scatter`]). Each depth draws
    /// from a sequence of its own, so that a pixel's camera rays stratify
    /// their choices at every depth.
    pub fn interface(self, depth: u32) -> DVec3 {
        let level = u64::from(depth + 1).wrapping_mul(0x9e37_79b9_7f4a_7c15);
        let samples = match self {
            Samples::Hashed(seed) => Samples::Hashed(seed ^ level),
            Samples::Pixel { scramble, block } => Samples::Pixel {
                scramble: scramble ^ level,
                block,
            },
        };
        let point = samples.point(Stream::Interface, 1, 0);
        DVec3::new(point.x, point.y, samples.third(Stream::Interface, 1, 0))
    }

    /// A seed for the estimates nested in this one (light leaving a point
    /// that one of its rays reaches), which sample independently.
    pub fn seed(self) -> u64 {
        match self {
            Samples::Hashed(seed) => seed,
            Samples::Pixel { scramble, block } => scramble ^ u64::from(block).rotate_left(40),
        }
    }
}

/// The key of a pixel's (or texel's) sample sequences, `key`, scrambled by
/// a render's `seed` ([`crate::render::RenderSettings::seed`]; seed 0
/// leaves it as it is): keys below 2³² stay distinct for every seed.
pub fn seeded(key: u64, seed: u32) -> u64 {
    key ^ u64::from(seed) << 32
}

/// Point `index` (below 2^16; higher indices wrap) of the first two
/// dimensions of the Sobol sequence, Owen-scrambled by a hash of
/// `scramble` (`sobol_burley`'s building blocks: its seeded `sample` also
/// shuffles the sequence's order, which would break the aligned blocks
/// [`Samples::Pixel`] relies on).
pub fn sobol2(index: u32, scramble: u64) -> DVec2 {
    DVec2::new(sobol(index, scramble, 0), sobol(index, scramble, 1))
}

/// Dimension `dimension` of point `index` of the Sobol sequence,
/// Owen-scrambled by a hash of `scramble` and the dimension.
fn sobol(index: u32, scramble: u64, dimension: u32) -> f64 {
    use sobol_burley::parts::{hash, owen_scramble_rev, sobol_rev};
    let key = hash((scramble ^ (scramble >> 32)) as u32);
    let index_rev = (index & 0xffff).reverse_bits();
    let bits =
        owen_scramble_rev(sobol_rev(index_rev, dimension), hash(key ^ dimension)).reverse_bits();
    (f64::from(bits) + 0.5) / 4_294_967_296.0
}

/// Multi-jittered positions inside pixel number `pixel` (Chiu, Shirley &
/// Wang, *Multi-jittered sampling*, Graphics Gems IV, 1994): the k-th lies
/// in cell (k mod n, ⌊k/n⌋) of an n×n grid (n = ⌈√spp⌉), and the n² of them
/// also fall one in each of n² equal columns and one in each of n² equal
/// rows. An edge along a pixel axis (a wall's outline, an emitter's) then
/// meets its samples as n² strata rather than n, so its coverage error
/// falls as 1/spp instead of spp^−¾: on the glossy Cornell box, whose light
/// covers a few 64 × 64 pixels, that is most of the error at the light's
/// outline. The sub-cell orders are shuffled per column and per row, and
/// with a jitter, anew in every pixel, so that an edge crossing many pixels
/// at the same sub-pixel position does not get the same coverage error in
/// all of them.
pub fn pixel_offsets(pixel: u64, samples_per_pixel: u32) -> Vec<DVec2> {
    let n = (samples_per_pixel.max(1) as f64).sqrt().ceil() as u32;
    // A permutation of 0..n per column (salt 0) and per row (salt 1)
    // (Fisher–Yates), the 2n of them in one buffer: line `line` of kind
    // `salt` at `(salt · n + line) · n`.
    let side = n as usize;
    let mut orders: Vec<u32> = (0..2 * side * side).map(|t| (t % side) as u32).collect();
    for (index, order) in orders.chunks_exact_mut(side).enumerate() {
        let (salt, line) = ((index / side) as u64, (index % side) as u64);
        let seed = pixel ^ (line << 33 | salt << 32).wrapping_mul(0xd6e8_feb8_6659_fd93);
        for i in (1..side).rev() {
            let r = hash2(seed, i as u64).x;
            order.swap(i, ((r * (i + 1) as f64) as usize).min(i));
        }
    }
    let order = |salt: usize, line: u32, at: u32| {
        orders[(salt * side + line as usize) * side + at as usize]
    };
    let n_f = f64::from(n);
    (0..pixel_offsets_len(samples_per_pixel))
        .map(|k| {
            let (i, j) = (k % n, k / n);
            let r = hash2(pixel, u64::from(k));
            let sub_x = f64::from(order(0, i, j));
            let sub_y = f64::from(order(1, j, i));
            DVec2::new(
                (f64::from(i) + (sub_x + r.x) / n_f) / n_f,
                (f64::from(j) + (sub_y + r.y) / n_f) / n_f,
            )
        })
        .collect()
}

/// Number of positions [`pixel_offsets`] makes for `samples_per_pixel`.
pub fn pixel_offsets_len(samples_per_pixel: u32) -> u32 {
    let n = (samples_per_pixel.max(1) as f64).sqrt().ceil() as u32;
    n * n
}

/// A density over the unit square that interpolates four corner values
/// bilinearly, and the warp that draws points from it (Hart, Pharr,
/// Müller, Lopes, McGuire & Shirley 2020, "Practical product sampling by
/// fitting and composing warps"): fitted to an integrand at the corners, it
/// draws points roughly in proportion to it. The warp is monotone in each
/// dimension, so a stratified set of points stays stratified.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bilinear {
    /// Values at (0,0), (1,0), (0,1), (1,1), normalised to average 1.
    corners: [f64; 4],
}

impl Bilinear {
    /// The density through `corners` (at (0,0), (1,0), (0,1), (1,1)), none
    /// below `floor` times the largest, so that it is positive wherever the
    /// fitted integrand may be; uniform when no corner is positive.
    pub fn fit(corners: [f64; 4], floor: f64) -> Bilinear {
        let top = corners.iter().cloned().fold(0.0, f64::max);
        if top.is_nan() || top <= 0.0 || !top.is_finite() {
            return Bilinear { corners: [1.0; 4] };
        }
        let c = corners.map(|v| v.max(floor * top));
        let mean = c.iter().sum::<f64>() / 4.0;
        Bilinear {
            corners: c.map(|v| v / mean),
        }
    }

    /// Density at `uv` (integrates to one over the square).
    pub fn pdf(&self, uv: DVec2) -> f64 {
        let [a, b, c, d] = self.corners;
        let (u, v) = (uv.x, uv.y);
        (1.0 - v) * ((1.0 - u) * a + u * b) + v * ((1.0 - u) * c + u * d)
    }

    /// The point drawn for the uniform point `xi`: u from the marginal,
    /// v from the conditional at that u, each a linear density.
    pub fn sample(&self, xi: DVec2) -> DVec2 {
        let [a, b, c, d] = self.corners;
        let u = linear(a + c, b + d, xi.x);
        let v = linear((1.0 - u) * a + u * b, (1.0 - u) * c + u * d, xi.y);
        DVec2::new(u, v)
    }
}

/// The point of [0,1] drawn for the uniform `xi` from the density that is
/// linear from `a` at 0 to `b` at 1 (both ≥ 0, not both 0).
fn linear(a: f64, b: f64, xi: f64) -> f64 {
    if (a - b).abs() <= 1e-9 * (a + b) {
        return xi;
    }
    let x = (a - (a * a + (b * b - a * a) * xi).max(0.0).sqrt()) / (a - b);
    x.clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bilinear_warp_draws_points_by_its_density() {
        // The warp's density, estimated from where a grid of uniform
        // points lands (a histogram of 4 × 4 cells), is the bilinear pdf
        // integrated over each cell; and the pdf integrates to one.
        let warp = Bilinear::fit([1.0, 3.0, 0.5, 6.0], 0.05);
        let n = 400;
        let mut counts = [[0u32; 4]; 4];
        for i in 0..n {
            for j in 0..n {
                let xi = DVec2::new((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
                let p = warp.sample(xi);
                counts[((p.x * 4.0) as usize).min(3)][((p.y * 4.0) as usize).min(3)] += 1;
            }
        }
        let m = 64;
        let mut total = 0.0;
        for (cu, row) in counts.iter().enumerate() {
            for (cv, &count) in row.iter().enumerate() {
                let mut mass = 0.0;
                for a in 0..m {
                    for b in 0..m {
                        let uv = DVec2::new(
                            (cu as f64 + (a as f64 + 0.5) / m as f64) / 4.0,
                            (cv as f64 + (b as f64 + 0.5) / m as f64) / 4.0,
                        );
                        mass += warp.pdf(uv) / (16.0 * (m * m) as f64);
                    }
                }
                total += mass;
                let share = f64::from(count) / (n * n) as f64;
                assert!(
                    (share - mass).abs() < 2e-3,
                    "cell {cu},{cv}: {share} vs {mass}"
                );
            }
        }
        assert!((total - 1.0).abs() < 1e-9, "{total}");
        // A corner at zero is raised to the floor; none positive is uniform.
        assert!(Bilinear::fit([0.0, 1.0, 1.0, 1.0], 0.1).pdf(DVec2::ZERO) > 0.0);
        assert_eq!(Bilinear::fit([0.0; 4], 0.1).pdf(DVec2::splat(0.3)), 1.0);
    }

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

    /// Projected on either axis, a pixel's n² positions fall one in each of
    /// n² equal intervals.
    #[test]
    fn offsets_are_stratified_along_each_axis() {
        for (pixel, spp) in [(3u64, 64u32), (12_345, 4096), (7, 9)] {
            let o = pixel_offsets(pixel, spp);
            let m = o.len();
            for axis in [|p: &DVec2| p.x, |p: &DVec2| p.y] {
                let mut seen = vec![false; m];
                for p in &o {
                    let cell = (axis(p) * m as f64) as usize;
                    assert!(!seen[cell], "pixel {pixel}, {spp} spp: cell {cell} twice");
                    seen[cell] = true;
                }
            }
        }
    }

    /// Every aligned block of 2^k points, and two adjacent blocks together,
    /// put exactly one point in each cell of every 2^a × 2^(k−a) grid.
    #[test]
    fn pixel_blocks_are_stratified_alone_and_together() {
        let net = |points: &[DVec2], k: u32| {
            (0..=k).all(|a| {
                let (nx, ny) = (1u32 << a, 1u32 << (k - a));
                let mut seen = vec![0u32; (nx * ny) as usize];
                for p in points {
                    let (cx, cy) = ((p.x * f64::from(nx)) as u32, (p.y * f64::from(ny)) as u32);
                    seen[(cy * nx + cx) as usize] += 1;
                }
                seen.iter().all(|&c| c == 1)
            })
        };
        let block = |b: u32| -> Vec<DVec2> {
            let samples = Samples::Pixel {
                scramble: 0x1234_5678_9abc,
                block: b,
            };
            (0..16)
                .map(|j| samples.point(Stream::Cosine, 16, j))
                .collect()
        };
        for b in 0..8 {
            assert!(net(&block(b), 4), "block {b}");
        }
        let pair = [block(2), block(3)].concat();
        assert!(net(&pair, 5));
        let all: Vec<DVec2> = (0..8).flat_map(block).collect();
        assert!(net(&all, 7));
        // Another stream or pixel is another scramble.
        let other = Samples::Pixel {
            scramble: 0x1234_5678_9abd,
            block: 0,
        };
        assert_ne!(other.point(Stream::Cosine, 16, 0), block(0)[0]);
        let first = |stream| Samples::pixel(5, 0).point(stream, 16, 0);
        assert_ne!(first(Stream::Shadow), first(Stream::Light));
        assert_ne!(first(Stream::Bright), first(Stream::Mirror));
    }

    #[test]
    fn hashed_points_are_jittered_on_a_grid_or_stratified_in_x() {
        let s = Samples::Hashed(9);
        for j in 0..16 {
            let p = s.point(Stream::Cosine, 16, j);
            assert_eq!(((p.x * 4.0) as u32, (p.y * 4.0) as u32), (j % 4, j / 4));
        }
        for j in 0..8 {
            assert_eq!((s.point(Stream::Cosine, 8, j).x * 8.0) as u32, j);
        }
    }

    #[test]
    fn hash_is_roughly_uniform() {
        let n = 10_000;
        let mean: f64 = (0..n).map(|i| hash2(3, i).x).sum::<f64>() / n as f64;
        assert!((mean - 0.5).abs() < 0.01, "{mean}");
    }
}
