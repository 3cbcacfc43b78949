//! Haar bases in the paper's orthonormal normalisation, and the conversions to
//! the element averages wavrad stores.
//!
//! The 1D scaling function φ_{J,k} is 2^{J/2} on its dyadic interval of length
//! 2^{-J}; over a surface parametrised on the unit square the 2D scaling
//! function of an element at level J is the product of two, 2^J on the element
//! (parameter area 4^{-J}). Hence, for a function f,
//!
//! * 2D coefficient ⟨f, φ_J⟩ = 2^{-J} · (average of f over the element);
//! * 4D coefficient over a pair of elements at levels J_a, J_c =
//!   2^{-J_a-J_c} · (average over the pair), 2^{-2J} when both are at J.
//!
//! The paper's factor 2^{J/2} in eqs. (5)–(8) is the 1D value of φ inside its
//! support (φ_{J,k}² = 2^{J/2} φ_{J,k}); [`haar_product_factor`] gives it, and
//! the tests check that eq. (8) in coefficients equals the element-average
//! transfer `L_a = Σ R · L_c` that the solver uses.
//!
//! Detail coefficients ([`details_2d`]) decide the paper's adaptive projection:
//! a kernel is kept at a level when all details of its children are at most
//! the threshold.

/// Orthonormal coefficient of the 2D scaling function of an element at
/// `level` from the average of the function over it.
pub fn coefficient_from_average_2d(average: f64, level: u32) -> f64 {
    average * 0.5f64.powi(level as i32)
}

/// Element average from the orthonormal 2D coefficient (inverse of
/// [`coefficient_from_average_2d`]).
pub fn average_from_coefficient_2d(coefficient: f64, level: u32) -> f64 {
    coefficient * 2f64.powi(level as i32)
}

/// Orthonormal coefficient of φ_a ⊗ φ_c (4D) from the average over the pair.
pub fn coefficient_from_average_4d(average: f64, level_a: u32, level_c: u32) -> f64 {
    average * 0.5f64.powi((level_a + level_c) as i32)
}

/// Value of a 1D Haar scaling function inside its support, 2^{J/2}: the
/// factor in φ_{J,k}(u)·φ_{J,k}(u) = 2^{J/2} φ_{J,k}(u) (paper, before eq. 5).
pub fn haar_product_factor(level: u32) -> f64 {
    2f64.powf(level as f64 / 2.0)
}

/// The three 2D Haar detail coefficients (orthonormal) of a function whose
/// averages over the four children of an element at `level` are `child` (in
/// [`crate::scene::Patch::subdivide`] order for parallelograms: (0,0), (1,0),
/// (0,1), (1,1)).
///
/// Each detail is ⟨f, ψ⟩ with ψ = ±2^{level} on the quarters, i.e.
/// 2^{-level}/4 · Σ ±child_i. For triangles the same sign patterns over the
/// four midpoint children give three orthogonal zero-mean functions of the
/// same norm, so the formula applies unchanged.
pub fn details_2d(child: [f64; 4], level: u32) -> [f64; 3] {
    let [c00, c10, c01, c11] = child;
    let scale = 0.25 * 0.5f64.powi(level as i32);
    [
        scale * (c00 - c10 + c01 - c11),
        scale * (c00 + c10 - c01 - c11),
        scale * (c00 - c10 - c01 + c11),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Numerically integrate f·g over [0,1]² on a fine grid.
    fn inner(f: impl Fn(f64, f64) -> f64, g: impl Fn(f64, f64) -> f64) -> f64 {
        let n = 256;
        let h = 1.0 / n as f64;
        let mut sum = 0.0;
        for i in 0..n {
            for j in 0..n {
                let (x, y) = ((i as f64 + 0.5) * h, (j as f64 + 0.5) * h);
                sum += f(x, y) * g(x, y);
            }
        }
        sum * h * h
    }

    /// φ_{J,(k,l)} in 2D, orthonormal.
    fn phi(level: u32, k: usize, l: usize) -> impl Fn(f64, f64) -> f64 {
        let n = 1usize << level;
        move |x, y| {
            let inside = (x * n as f64) as usize == k && (y * n as f64) as usize == l;
            if inside {
                2f64.powi(level as i32)
            } else {
                0.0
            }
        }
    }

    #[test]
    fn coefficient_is_inner_product_with_scaling_function() {
        let f = |x: f64, y: f64| 1.0 + 3.0 * x + x * y;
        for level in 0..3 {
            let (k, l) = (1usize.min((1 << level) - 1), 0);
            let n = (1u32 << level) as f64;
            // Average of f over the element by the same grid.
            let avg = inner(f, |x, y| {
                if (x * n) as usize == k && (y * n) as usize == l {
                    n * n
                } else {
                    0.0
                }
            });
            let c = inner(f, phi(level, k, l));
            assert!((coefficient_from_average_2d(avg, level) - c).abs() < 1e-9);
            assert!((average_from_coefficient_2d(c, level) - avg).abs() < 1e-9);
        }
    }

    #[test]
    fn details_are_inner_products_with_wavelets() {
        let f = |x: f64, y: f64| (3.0 * x).sin() + y * y + 0.3 * x * y;
        let level = 1;
        let (k, l) = (1usize, 0usize);
        // Children averages of the element (k,l) at level 1.
        let n = 4.0;
        let child_avg = |i: usize, j: usize| {
            inner(f, |x, y| {
                if (x * n) as usize == 2 * k + i && (y * n) as usize == 2 * l + j {
                    n * n
                } else {
                    0.0
                }
            })
        };
        let child = [
            child_avg(0, 0),
            child_avg(1, 0),
            child_avg(0, 1),
            child_avg(1, 1),
        ];
        let d = details_2d(child, level);
        // ψ patterns at level 1 on element (1,0): ±2^level on the quarters.
        let psi = |sx: [f64; 4]| {
            move |x: f64, y: f64| {
                let (cx, cy) = ((x * 2.0) as usize, (y * 2.0) as usize);
                if cx != k || cy != l {
                    return 0.0;
                }
                let i = ((x * 4.0) as usize) % 2;
                let j = ((y * 4.0) as usize) % 2;
                2f64.powi(level as i32) * sx[i + 2 * j]
            }
        };
        let expect = [
            inner(f, psi([1.0, -1.0, 1.0, -1.0])),
            inner(f, psi([1.0, 1.0, -1.0, -1.0])),
            inner(f, psi([1.0, -1.0, -1.0, 1.0])),
        ];
        for (a, b) in d.iter().zip(expect) {
            assert!((a - b).abs() < 1e-9, "{a} vs {b}");
        }
    }

    /// Flatland, level J, kernels and radiance constant per element (pair):
    /// the paper's coefficient equations give the same element averages as
    /// the transfer the solver uses, `L̄_a = Σ_c |c|·avg(K over a×c)·L̄_c`.
    /// Eq. (12), diffuse source: L_k = Σ_m K_{k,m} L_m. Eq. (8), directional
    /// source: L_{k,l} = 2^{J/2} Σ_m K_{k,l,m} L_{m,k}.
    #[test]
    fn eq8_and_eq12_in_coefficients_equal_element_average_transfer() {
        let level = 2u32;
        let n = 1usize << level;
        let width = 1.0 / n as f64;
        let s = 2f64.powf(-(level as f64) / 2.0); // 1D coefficient per average
        let kernel_avg =
            |a: usize, b: usize, c: usize| 0.3 + 0.1 * a as f64 - 0.05 * c as f64 + 0.02 * b as f64;
        let radiance_avg = |c: usize, a: usize| 1.0 + c as f64 + 0.5 * a as f64;
        for a in 0..n {
            // Eq. (12): 2D kernel coefficient s²·avg, 1D radiance s·avg.
            let coeff: f64 = (0..n)
                .map(|c| kernel_avg(a, 0, c) * s * s * radiance_avg(c, 0) * s)
                .sum();
            let direct: f64 = (0..n)
                .map(|c| width * kernel_avg(a, 0, c) * radiance_avg(c, 0))
                .sum();
            assert!((coeff / s - direct).abs() < 1e-12);
            // Eq. (8): 3D kernel coefficient s³·avg, 2D radiance s²·avg.
            for b in 0..n {
                let coeff: f64 = haar_product_factor(level)
                    * (0..n)
                        .map(|c| kernel_avg(a, b, c) * s * s * s * radiance_avg(c, a) * s * s)
                        .sum::<f64>();
                let direct: f64 = (0..n)
                    .map(|c| width * kernel_avg(a, b, c) * radiance_avg(c, a))
                    .sum();
                assert!((coeff / (s * s) - direct).abs() < 1e-12);
            }
        }
        assert!((coefficient_from_average_4d(2.0, 1, 2) - 0.25).abs() < 1e-15);
    }
}
