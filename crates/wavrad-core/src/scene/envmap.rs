//! An environment map (Mitsuba 3's `envmap`): radiance arriving from every
//! direction that leaves the scene, read from a latitude–longitude image,
//! with Mitsuba's conventions and a distribution to sample directions in
//! proportion to the light it sends.
//!
//! In the map's frame, +y is the zenith: a direction v has
//! u = atan2(v.x, −v.z)/2π and θ = acos(v.y); the image's column i sits at
//! u = i/width (the first column again at u = 1) and its row j at
//! θ = π·j/(height − 1), so the first and last rows are the poles, and the
//! radiance is interpolated bilinearly between them, as Mitsuba 3's
//! `envmap.cpp` reads its padded bitmap.

use crate::scene::Rgb;
use glam::{DMat3, DVec2, DVec3};
use std::f64::consts::PI;

/// A latitude–longitude environment map.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct EnvMap {
    width: usize,
    height: usize,
    /// Linear RGB radiance, row by row from the zenith, times the scale.
    rgb: Vec<[f32; 3]>,
    /// Rotation from world to map directions.
    map_from_world: DMat3,
    /// Cumulative probabilities of the rows of cells, then of the cells of
    /// each row (`height − 1` rows of `width` cells between the pixels).
    rows: Vec<f64>,
    cells: Vec<f64>,
}

impl EnvMap {
    /// The map of `width` × `height` pixels `rgb` (row-major from the
    /// zenith), its radiance multiplied by `scale`, turned into the world
    /// by the rotation `world_from_map`. `None` when the image has fewer
    /// than 2 rows or 1 column, or no light at all.
    pub fn new(
        width: usize,
        height: usize,
        rgb: &[f32],
        scale: f64,
        world_from_map: DMat3,
    ) -> Option<EnvMap> {
        if width < 1 || height < 2 || rgb.len() != width * height * 3 {
            return None;
        }
        let rgb: Vec<[f32; 3]> = (rgb.chunks_exact(3))
            .map(|c| [c[0], c[1], c[2]].map(|v| (f64::from(v.max(0.0)) * scale) as f32))
            .collect();
        // Cells between pixel rows j and j+1, columns i and i+1: their
        // corners' mean luminance times the solid angle of their band.
        let luminance =
            |i: usize, j: usize| Rgb(rgb[j * width + i % width].map(f64::from)).luminance();
        let mut cells = Vec::with_capacity(width * (height - 1));
        let mut rows = Vec::with_capacity(height - 1);
        let mut total = 0.0;
        for j in 0..height - 1 {
            let band = (PI * j as f64 / (height - 1) as f64).cos()
                - (PI * (j + 1) as f64 / (height - 1) as f64).cos();
            let mut row = 0.0;
            for i in 0..width {
                let corners = luminance(i, j)
                    + luminance(i + 1, j)
                    + luminance(i, j + 1)
                    + luminance(i + 1, j + 1);
                row += corners * band;
                cells.push(row);
            }
            total += row;
            rows.push(total);
        }
        if total <= 0.0 {
            return None;
        }
        for (j, &row_total) in rows.iter().enumerate() {
            let row_sum = row_total - if j > 0 { rows[j - 1] } else { 0.0 };
            for c in &mut cells[j * width..(j + 1) * width] {
                *c = if row_sum > 0.0 { *c / row_sum } else { 0.0 };
            }
        }
        for r in &mut rows {
            *r /= total;
        }
        Some(EnvMap {
            width,
            height,
            rgb,
            map_from_world: world_from_map.transpose(),
            rows,
            cells,
        })
    }

    /// Radiance arriving along the world direction `towards` (unit, from
    /// the scene towards the map).
    pub fn radiance(&self, towards: DVec3) -> Rgb {
        let v = self.map_from_world * towards;
        let u = (v.x.atan2(-v.z) / (2.0 * PI)).rem_euclid(1.0);
        let t = v.y.clamp(-1.0, 1.0).acos() / PI;
        let (x, y) = (u * self.width as f64, t * (self.height - 1) as f64);
        let (i, j) = (
            x.floor() as usize,
            (y.floor() as usize).min(self.height - 2),
        );
        let (fx, fy) = (x - i as f64, y - j as f64);
        let at = |i: usize, j: usize| Rgb(self.rgb[j * self.width + i % self.width].map(f64::from));
        (at(i, j) * (1.0 - fx) + at(i + 1, j) * fx) * (1.0 - fy)
            + (at(i, j + 1) * (1.0 - fx) + at(i + 1, j + 1) * fx) * fy
    }

    /// The mean of its largest channel over the sphere of directions.
    pub fn mean_radiance(&self) -> f64 {
        let rows = (self.height - 1) as f64;
        let mut sum = 0.0;
        for j in 0..self.height {
            // Each pixel row stands for the band of half a row either side.
            let t0 = (j as f64 - 0.5).max(0.0) / rows;
            let t1 = (j as f64 + 0.5).min(rows) / rows;
            let band = (PI * t0).cos() - (PI * t1).cos();
            let row = &self.rgb[j * self.width..(j + 1) * self.width];
            let mean = row
                .iter()
                .map(|c| Rgb(c.map(f64::from)).max_channel())
                .sum::<f64>();
            sum += band * mean / self.width as f64;
        }
        sum / 2.0
    }

    /// A world direction drawn from `u` ∈ \[0,1)² in proportion to the
    /// map's luminance (a cell by its corners' mean, then within it by the
    /// bilinear luminance over (φ, θ)), and its solid-angle density. Within
    /// a cell the radiance then follows its density but for the colour and
    /// sinθ, so that few samples estimate a small bright source well.
    pub fn sample(&self, u: DVec2) -> (DVec3, f64) {
        let j = pick(&self.rows, u.y);
        let below = if j > 0 { self.rows[j - 1] } else { 0.0 };
        let uy = ((u.y - below) / (self.rows[j] - below)).clamp(0.0, 1.0);
        let row = &self.cells[j * self.width..(j + 1) * self.width];
        let i = pick(row, u.x);
        let left = if i > 0 { row[i - 1] } else { 0.0 };
        let ux = ((u.x - left) / (row[i] - left)).clamp(0.0, 1.0);
        let [l00, l10, l01, l11] = self.corners(i, j);
        let fy = sample_linear(l00 + l10, l01 + l11, uy);
        let fx = sample_linear(l00 * (1.0 - fy) + l01 * fy, l10 * (1.0 - fy) + l11 * fy, ux);
        let phi = 2.0 * PI * (i as f64 + fx) / self.width as f64;
        let theta = PI * (j as f64 + fy) / (self.height - 1) as f64;
        let v = DVec3::new(
            theta.sin() * phi.sin(),
            theta.cos(),
            -theta.sin() * phi.cos(),
        );
        let towards = (self.map_from_world.transpose() * v).normalize();
        (towards, self.pdf(towards))
    }

    /// The solid-angle density with which [`EnvMap::sample`] draws the
    /// world direction `towards`.
    pub fn pdf(&self, towards: DVec3) -> f64 {
        let v = self.map_from_world * towards;
        let u = (v.x.atan2(-v.z) / (2.0 * PI)).rem_euclid(1.0);
        let theta = v.y.clamp(-1.0, 1.0).acos();
        let sin = theta.sin();
        let rows = self.height - 1;
        let (x, y) = (u * self.width as f64, theta / PI * rows as f64);
        let (i, j) = ((x as usize).min(self.width - 1), (y as usize).min(rows - 1));
        let p_row = self.rows[j] - if j > 0 { self.rows[j - 1] } else { 0.0 };
        let row = &self.cells[j * self.width..(j + 1) * self.width];
        let p_cell = row[i] - if i > 0 { row[i - 1] } else { 0.0 };
        let [l00, l10, l01, l11] = self.corners(i, j);
        let mean = (l00 + l10 + l01 + l11) / 4.0;
        if sin <= 0.0 || mean <= 0.0 {
            return 0.0;
        }
        let (fx, fy) = (
            (x - i as f64).clamp(0.0, 1.0),
            (y - j as f64).clamp(0.0, 1.0),
        );
        let bilinear =
            (l00 * (1.0 - fx) + l10 * fx) * (1.0 - fy) + (l01 * (1.0 - fx) + l11 * fx) * fy;
        // Bilinear in (φ, θ) over the cell: dω = sinθ dθ dφ.
        let cell_area = (2.0 * PI / self.width as f64) * (PI / rows as f64);
        p_row * p_cell * (bilinear / mean) / (cell_area * sin)
    }

    /// The luminance at the corners of cell (i, j): pixels (i, j), (i+1, j),
    /// (i, j+1), (i+1, j+1), the columns wrapping round.
    fn corners(&self, i: usize, j: usize) -> [f64; 4] {
        let l = |i: usize, j: usize| {
            Rgb(self.rgb[j * self.width + i % self.width].map(f64::from))
                .luminance()
                .max(0.0)
        };
        [l(i, j), l(i + 1, j), l(i, j + 1), l(i + 1, j + 1)]
    }
}

/// The point of \[0,1\] drawn from `u` with a density rising linearly
/// from `a` at 0 to `b` at 1 (uniform where both are equal or zero).
fn sample_linear(a: f64, b: f64, u: f64) -> f64 {
    if a + b <= 0.0 || (a - b).abs() <= 1e-9 * (a + b) {
        return u;
    }
    // (b − a)/2·x² + a·x = u·(a + b)/2.
    let denominator = a + (a * a + (b * b - a * a) * u).max(0.0).sqrt();
    match denominator > 0.0 {
        true => (u * (a + b) / denominator).clamp(0.0, 1.0),
        false => 0.0,
    }
}

/// The index of the first entry of the cumulative `cdf` above `u`.
fn pick(cdf: &[f64], u: f64) -> usize {
    cdf.partition_point(|&c| c <= u).min(cdf.len() - 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 16 × 9 map, bright in one pixel on the horizon.
    fn map() -> EnvMap {
        let (w, h) = (16, 9);
        let mut rgb = vec![0.1f32; w * h * 3];
        rgb[(4 * w + 5) * 3..][..3].copy_from_slice(&[50.0, 40.0, 30.0]);
        EnvMap::new(w, h, &rgb, 2.0, DMat3::IDENTITY).unwrap()
    }

    #[test]
    fn radiance_follows_mitsubas_parametrisation() {
        let m = map();
        // Pixel (5, 4): u = 5/16, θ = π/2.
        let phi = 2.0 * PI * 5.0 / 16.0;
        let at = DVec3::new(phi.sin(), 0.0, -phi.cos());
        assert!(
            (m.radiance(at)[0] - 100.0).abs() < 1e-9,
            "{}",
            m.radiance(at)
        );
        assert!((m.radiance(DVec3::Y)[1] - 0.2).abs() < 1e-6);
        // The map turned: the same pixel seen along the turned direction.
        let turn = DMat3::from_rotation_y(0.7);
        let rgb: Vec<f32> = m.rgb.iter().flat_map(|c| c.map(|v| v / 2.0)).collect();
        let turned = EnvMap::new(16, 9, &rgb, 2.0, turn).unwrap();
        assert!((turned.radiance(turn * at)[0] - 100.0).abs() < 1e-9);
    }

    #[test]
    fn sampling_density_integrates_to_one_and_matches_the_samples() {
        let m = EnvMap::new(
            16,
            9,
            &map().rgb.iter().flat_map(|c| *c).collect::<Vec<_>>(),
            1.0,
            DMat3::from_rotation_x(0.3),
        )
        .unwrap();
        // ∫ pdf dω and ∫ L dω over a fine (φ, cosθ) grid.
        let n = 400;
        let (mut integral, mut exact) = (0.0, 0.0);
        for a in 0..n {
            for b in 0..n {
                let phi = 2.0 * PI * (a as f64 + 0.5) / n as f64;
                let z = 1.0 - 2.0 * (b as f64 + 0.5) / n as f64;
                let s = (1.0 - z * z).sqrt();
                let d = DVec3::new(s * phi.cos(), z, s * phi.sin());
                let cell = 4.0 * PI / (n * n) as f64;
                integral += m.pdf(d) * cell;
                exact += m.radiance(d).luminance() * cell;
            }
        }
        assert!((integral - 1.0).abs() < 0.01, "{integral}");
        // E[L/pdf] over samples is ∫ L dω; drawn bilinearly within the
        // cells, L/pdf hardly varies, so a grid of samples is close.
        let mut estimate = 0.0;
        let k = 64;
        for a in 0..k {
            for b in 0..k {
                let u = DVec2::new((a as f64 + 0.5) / k as f64, (b as f64 + 0.5) / k as f64);
                let (d, p) = m.sample(u);
                assert!((p - m.pdf(d)).abs() < 1e-9 * p.max(1.0));
                estimate += m.radiance(d).luminance() / p / (k * k) as f64;
            }
        }
        assert!(
            (estimate - exact).abs() < 0.01 * exact,
            "{estimate} vs {exact}"
        );
    }
}
