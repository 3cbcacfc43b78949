//! A fixed partition of the sphere of directions into [`CELLS`] cells of
//! about equal solid angle, over which a cluster keeps its glossy members'
//! light as one directional distribution (Christensen, Lischinski,
//! Stollnitz & Salesin 1997): what they send, per direction
//! ([`crate::solve::cluster_gather`]), so that a cluster link reads it in
//! one look-up instead of summing every member, and what arrives from each
//! direction, handed down the cluster tree to the members.
//!
//! The cells are the texels of an octahedral map (Praun & Hoppe 2003;
//! Engelhardt & Dachsbacher 2008): a direction w is projected onto the
//! octahedron |x|+|y|+|z| = 1, its lower half folded out over the corners
//! of the upper half's square, and the square [-1,1]² cut into
//! 32×32 cells. Written here because the map is a dozen
//! lines; no crate in the field offers it on glam's types.

use glam::DVec3;

/// Cells along each side of the octahedral square: cells of about
/// 4π/1024 sr, 6–7° across, finer than a glossy surface's bins
/// ([`crate::solve::glossy_clusters::BINS`]).
const SIDE: usize = 32;
/// Cells of the sphere.
pub const CELLS: usize = SIDE * SIDE;

/// 1 for non-negative `v` (−0 included), −1 otherwise.
fn sign(v: f64) -> f64 {
    if v >= 0.0 {
        1.0
    } else {
        -1.0
    }
}

/// Direction `w`'s point of the octahedral square [-1,1]².
fn to_square(w: DVec3) -> (f64, f64) {
    let w = w / (w.x.abs() + w.y.abs() + w.z.abs());
    if w.z >= 0.0 {
        (w.x, w.y)
    } else {
        ((1.0 - w.y.abs()) * sign(w.x), (1.0 - w.x.abs()) * sign(w.y))
    }
}

/// The unit direction at point `(x, y)` of the octahedral square.
fn from_square(x: f64, y: f64) -> DVec3 {
    let z = 1.0 - x.abs() - y.abs();
    let (x, y) = if z < 0.0 {
        ((1.0 - y.abs()) * sign(x), (1.0 - x.abs()) * sign(y))
    } else {
        (x, y)
    };
    DVec3::new(x, y, z).normalize()
}

/// Position along a side of the square in cells, from its coordinate in
/// [-1, 1].
fn in_cells(x: f64) -> f64 {
    (x + 1.0) * 0.5 * SIDE as f64
}

/// The cell of direction `w` (any length; the zero vector has cell 0).
pub fn cell_of(w: DVec3) -> usize {
    let (x, y) = to_square(w);
    // NaN (the zero vector) casts to 0.
    let index = |x: f64| (in_cells(x) as usize).min(SIDE - 1);
    index(y) * SIDE + index(x)
}

/// The unit direction at the centre of cell `cell`.
pub fn center(cell: usize) -> DVec3 {
    let at = |i: usize| (i as f64 + 0.5) / SIDE as f64 * 2.0 - 1.0;
    from_square(at(cell % SIDE), at(cell / SIDE))
}

/// Cell `(i, j)` of the square, either index possibly one past its edge:
/// a cell past an edge is the one mirrored across that edge's midpoint
/// (the octahedral map's seams: its outer edges fold onto themselves).
fn wrapped(i: isize, j: isize) -> usize {
    let last = SIDE as isize - 1;
    let (i, j) = match j {
        -1 => (last - i, 0),
        j if j > last => (last - i, last),
        j => (i, j),
    };
    let (i, j) = match i {
        -1 => (0, last - j),
        i if i > last => (last, last - j),
        i => (i, j),
    };
    j as usize * SIDE + i as usize
}

/// The four cells whose centres surround direction `w` on the sphere,
/// with their bilinear weights (summing to 1): a table of values at the
/// cells' centres read at `w`.
pub fn bilinear(w: DVec3) -> [(usize, f64); 4] {
    let (x, y) = to_square(w);
    let corner = |x: f64| {
        let t = in_cells(x) - 0.5;
        let i = t.floor();
        (i as isize, t - i)
    };
    let ((i, fx), (j, fy)) = (corner(x), corner(y));
    [
        (wrapped(i, j), (1.0 - fx) * (1.0 - fy)),
        (wrapped(i + 1, j), fx * (1.0 - fy)),
        (wrapped(i, j + 1), (1.0 - fx) * fy),
        (wrapped(i + 1, j + 1), fx * fy),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `n` directions spread evenly over the sphere (a Fibonacci
    /// lattice).
    fn sphere_points(n: usize) -> impl Iterator<Item = DVec3> {
        let turn = std::f64::consts::PI * (1.0 + 5f64.sqrt());
        (0..n).map(move |i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let (r, phi) = ((1.0 - z * z).sqrt(), turn * (i as f64 + 0.5));
            DVec3::new(r * phi.cos(), r * phi.sin(), z)
        })
    }

    #[test]
    fn every_cell_holds_its_centre_and_directions_stay_within_their_cell() {
        for c in 0..CELLS {
            assert_eq!(cell_of(center(c)), c, "cell {c}");
        }
        // Uniform directions: every cell gets some, from about a third of
        // its share to about 1.6 times it (the map's cells differ in solid
        // angle), and each lies within a cell's width of its cell's centre.
        let mut count = vec![0u32; CELLS];
        let n = 100_000;
        for w in sphere_points(n) {
            let c = cell_of(w);
            count[c] += 1;
            assert!(w.dot(center(c)) > 8f64.to_radians().cos(), "{w}");
        }
        let share = n as f64 / CELLS as f64;
        for (c, &k) in count.iter().enumerate() {
            assert!(
                k as f64 > 0.3 * share && (k as f64) < 1.8 * share,
                "cell {c}: {k}"
            );
        }
        assert_eq!(cell_of(DVec3::ZERO), 0);
    }

    #[test]
    fn bilinear_reads_a_smooth_function_closely_and_its_centres_exactly() {
        let f = |w: DVec3| 2.0 + w.x + 0.5 * w.y * w.z;
        let table: Vec<f64> = (0..CELLS).map(|c| f(center(c))).collect();
        let read = |w: DVec3| bilinear(w).iter().map(|&(c, t)| t * table[c]).sum::<f64>();
        for c in [0, 17, 500, CELLS - 1] {
            assert!((read(center(c)) - table[c]).abs() < 1e-12);
        }
        // Seams and the poles' corners included: within 2 % (the map
        // has a crease along the axes, where bilinear reading is of first
        // order).
        for w in sphere_points(20_000) {
            let weights: f64 = bilinear(w).iter().map(|&(_, t)| t).sum();
            assert!((weights - 1.0).abs() < 1e-12);
            assert!(
                (read(w) - f(w)).abs() < 0.03,
                "{w}: {} against {}",
                read(w),
                f(w)
            );
        }
    }
}
