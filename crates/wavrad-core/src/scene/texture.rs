//! Textures on a diffuse surface's reflectance: Mitsuba 3's `checkerboard`
//! and `bitmap`, evaluated at texture coordinates as Mitsuba 3 evaluates
//! them (`src/textures/checkerboard.cpp`, `bitmap.cpp` and Dr.Jit's
//! `Texture`).
//!
//! | texture        | parameter     | meaning                                                  | default    |
//! |----------------|---------------|----------------------------------------------------------|------------|
//! | `checkerboard` | `color0`      | value where both coordinates' fractional parts are ≤ ½ or both > ½ | 0.4 |
//! |                | `color1`      | value elsewhere                                          | 0.2        |
//! |                | `to_uv`       | affine map applied to the surface's uv first             | identity   |
//! | `bitmap`       | `filename`    | the image (linear RGB texels, row 0 at v = 0)            |            |
//! |                | `filter_type` | `bilinear` (between texel centres) or `nearest`          | `bilinear` |
//! |                | `wrap_mode`   | `repeat`, `mirror` or `clamp` outside \[0,1\]²           | `repeat`   |
//! |                | `to_uv`       | as above                                                 | identity   |
//!
//! A scene holds its textures once ([`crate::scene::Scene::textures`]); a
//! surface refers to one by index with its texture coordinates
//! ([`TextureMapping`]), so the triangles of a textured mesh share the
//! image. The solver gives each element the texture's average over it
//! ([`TextureMapping::average`]); a render reads it at the point hit.
//!
//! ```
//! use wavrad_core::scene::texture::{Texture, UvTransform};
//! use wavrad_core::scene::Rgb;
//! use glam::DVec2;
//!
//! let checker = Texture::Checkerboard {
//!     color0: Rgb::splat(0.4),
//!     color1: Rgb::splat(0.2),
//!     to_uv: UvTransform::scale(4.0, 4.0),
//! };
//! assert_eq!(checker.eval(DVec2::new(0.1, 0.1)), Rgb::splat(0.4));
//! assert_eq!(checker.eval(DVec2::new(0.2, 0.1)), Rgb::splat(0.2));
//! ```

use crate::scene::{Patch, Rgb};
use glam::{DVec2, Vec2};

/// An affine map of texture coordinates, `uv ↦ A·uv + b` (Mitsuba's
/// `to_uv`, a 3×3 matrix acting on (u, v, 1)), stored row by row as
/// `[a00, a01, b0, a10, a11, b1]`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct UvTransform(pub [f64; 6]);

impl Default for UvTransform {
    fn default() -> Self {
        UvTransform::scale(1.0, 1.0)
    }
}

impl UvTransform {
    /// Scaling by `su` along u and `sv` along v.
    pub fn scale(su: f64, sv: f64) -> UvTransform {
        UvTransform([su, 0.0, 0.0, 0.0, sv, 0.0])
    }

    /// The transformed coordinates.
    pub fn apply(&self, uv: DVec2) -> DVec2 {
        let m = &self.0;
        DVec2::new(
            m[0] * uv.x + m[1] * uv.y + m[2],
            m[3] * uv.x + m[4] * uv.y + m[5],
        )
    }

    /// |det A|: how areas in uv scale.
    fn area_scale(&self) -> f64 {
        (self.0[0] * self.0[4] - self.0[1] * self.0[3]).abs()
    }
}

/// How a bitmap is read between texel centres (Mitsuba's `filter_type`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum TextureFilter {
    /// The texel containing the point.
    Nearest,
    /// Bilinear interpolation between the four nearest texel centres.
    Bilinear,
}

/// How a bitmap continues outside \[0,1\]² (Mitsuba's `wrap_mode`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum WrapMode {
    /// Tiled.
    Repeat,
    /// Tiled, every other tile mirrored.
    Mirror,
    /// The edge texels extended.
    Clamp,
}

impl WrapMode {
    /// Texel index `i` of a row of `n` wrapped into `0..n` (Dr.Jit's
    /// `Texture::wrap`).
    fn wrap(self, i: i64, n: i64) -> usize {
        let i = match self {
            WrapMode::Repeat => i.rem_euclid(n),
            WrapMode::Clamp => i.clamp(0, n - 1),
            WrapMode::Mirror => {
                let i = i.rem_euclid(2 * n);
                if i >= n {
                    2 * n - 1 - i
                } else {
                    i
                }
            }
        };
        i as usize
    }
}

/// An image of linear RGB texels (Mitsuba's `bitmap` texture after its
/// sRGB-to-linear conversion), row 0 at v = 0.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Bitmap {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// Texels row by row, `width × height` of them.
    pub texels: Vec<[f32; 3]>,
    /// Nearest or bilinear.
    pub filter: TextureFilter,
    /// Behaviour outside \[0,1\]².
    pub wrap: WrapMode,
    /// Applied to the surface's uv first.
    pub to_uv: UvTransform,
}

impl Bitmap {
    fn texel(&self, x: i64, y: i64) -> Rgb {
        let x = self.wrap.wrap(x, i64::from(self.width));
        let y = self.wrap.wrap(y, i64::from(self.height));
        let t = self.texels[y * self.width as usize + x];
        Rgb(t.map(f64::from))
    }

    fn eval(&self, uv: DVec2) -> Rgb {
        let size = DVec2::new(f64::from(self.width), f64::from(self.height));
        match self.filter {
            TextureFilter::Nearest => {
                let p = (uv * size).floor();
                self.texel(p.x as i64, p.y as i64)
            }
            TextureFilter::Bilinear => {
                let p = uv * size - 0.5;
                let (p0, f) = (p.floor(), p - p.floor());
                let (x, y) = (p0.x as i64, p0.y as i64);
                let row = |y| self.texel(x, y) * (1.0 - f.x) + self.texel(x + 1, y) * f.x;
                row(y) * (1.0 - f.y) + row(y + 1) * f.y
            }
        }
    }
}

/// A texture on reflectance.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Texture {
    /// Mitsuba 3's `checkerboard`: `color0` where the fractional parts of
    /// the transformed u and v are both above ½ or both not, else `color1`.
    Checkerboard {
        /// Value on the squares containing uv (0.25, 0.25).
        color0: Rgb,
        /// Value on the others.
        color1: Rgb,
        /// Applied to the surface's uv first.
        to_uv: UvTransform,
    },
    /// Mitsuba 3's `bitmap`.
    Bitmap(Bitmap),
}

impl Texture {
    /// The value at texture coordinates `uv` (before `to_uv`).
    pub fn eval(&self, uv: DVec2) -> Rgb {
        match self {
            Texture::Checkerboard {
                color0,
                color1,
                to_uv,
            } => {
                let uv = to_uv.apply(uv);
                let upper = |x: f64| x - x.floor() > 0.5;
                if upper(uv.x) == upper(uv.y) {
                    *color0
                } else {
                    *color1
                }
            }
            Texture::Bitmap(b) => b.eval(b.to_uv.apply(uv)),
        }
    }

    /// The texture times `factor`, channel by channel (a reflectance that
    /// a lobe's albedo scales).
    pub fn scaled(&self, factor: Rgb) -> Texture {
        match self {
            Texture::Checkerboard {
                color0,
                color1,
                to_uv,
            } => Texture::Checkerboard {
                color0: *color0 * factor,
                color1: *color1 * factor,
                to_uv: *to_uv,
            },
            Texture::Bitmap(b) => Texture::Bitmap(Bitmap {
                texels: (b.texels.iter())
                    .map(|t| [0, 1, 2].map(|c| (f64::from(t[c]) * factor[c]) as f32))
                    .collect(),
                ..b.clone()
            }),
        }
    }

    /// The largest value in each channel anywhere.
    pub fn max(&self) -> Rgb {
        let max = |a: Rgb, b: Rgb| Rgb([0, 1, 2].map(|c| a[c].max(b[c])));
        match self {
            Texture::Checkerboard { color0, color1, .. } => max(*color0, *color1),
            Texture::Bitmap(b) => (b.texels.iter())
                .map(|t| Rgb(t.map(f64::from)))
                .fold(Rgb::ZERO, max),
        }
    }

    /// Features (squares, texels) per unit area of the surface's uv.
    fn features_per_unit_uv(&self) -> f64 {
        match self {
            Texture::Checkerboard { to_uv, .. } => 4.0 * to_uv.area_scale(),
            Texture::Bitmap(b) => f64::from(b.width) * f64::from(b.height) * b.to_uv.area_scale(),
        }
    }
}

/// Fewest and most points per side of the grid averaging a texture over an
/// element ([`TextureMapping::average`]).
const AVERAGE_GRID: (u32, u32) = (4, 64);

/// A surface's texture: which of the scene's textures, and the texture
/// coordinates at its parameters (0,0), (1,0) and (0,1), between which they
/// vary linearly (a triangle's vertices, a parallelogram's corners). Single
/// precision: 28 bytes per surface.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TextureMapping {
    /// Index into [`crate::scene::Scene::textures`].
    pub texture: u32,
    /// uv at the parameters (0,0), (1,0), (0,1).
    pub uv: [Vec2; 3],
}

impl TextureMapping {
    /// Texture coordinates at the patch parameter `param` ([`Patch::point_at`]).
    pub fn uv_at(&self, param: DVec2) -> DVec2 {
        let [a, b, c] = self.uv.map(|v| v.as_dvec2());
        a + param.x * (b - a) + param.y * (c - a)
    }

    /// The average of `texture` over `element`, a part of the surface
    /// `patch` (or the whole of it): a midpoint rule with about two points
    /// per texture feature (square, texel) along each side, between
    /// 4 and 64 points per side.
    pub fn average(&self, texture: &Texture, patch: &Patch, element: &Patch) -> Rgb {
        let [a, b, c] = self.uv.map(|v| v.as_dvec2());
        let uv_area = ((b - a).perp_dot(c - a)).abs() * element.area() / patch.area();
        let features = texture.features_per_unit_uv() * uv_area;
        let side = (2.0 * features.sqrt()).ceil();
        let n = (side as u32).clamp(AVERAGE_GRID.0, AVERAGE_GRID.1);
        let mut sum = Rgb::ZERO;
        for i in 0..n {
            for j in 0..n {
                let square = DVec2::new(
                    (f64::from(i) + 0.5) / f64::from(n),
                    (f64::from(j) + 0.5) / f64::from(n),
                );
                let x = element.point_at(element.square_to_param(square));
                sum += texture.eval(self.uv_at(patch.param_of(x)));
            }
        }
        sum / f64::from(n * n)
    }
}

/// Texture coordinates at the parameters (0,0), (1,0), (0,1) of `patch`
/// ([`TextureMapping::uv`]) moved to those of [`Patch::flipped`], which
/// reparametrises it, so that every point keeps its coordinates.
pub fn flipped_uv(uv: [Vec2; 3], patch: &Patch) -> [Vec2; 3] {
    flipped_corners(uv, patch)
}

/// Values at the parameters (0,0), (1,0), (0,1) of `patch` of a quantity
/// affine over it, moved to those of [`Patch::flipped`], so that every point
/// keeps its value.
pub(crate) fn flipped_corners<T>(values: [T; 3], patch: &Patch) -> [T; 3]
where
    T: Copy + std::ops::Add<Output = T> + std::ops::Sub<Output = T>,
{
    let [a, b, c] = values;
    match patch {
        Patch::Parallelogram { .. } => [b, a, b + c - a],
        Patch::Triangle(_) => [a, c, b],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    /// `scenes/textured-cornell-box/wall.png` as texels: red rising along
    /// x, green along y, blue a 4-texel checker (sRGB 8-bit, made linear).
    fn wall(filter: TextureFilter, wrap: WrapMode) -> Texture {
        let linear = |v: f64| {
            let v = v.round() / 255.0;
            if v <= 0.04045 {
                v / 12.92
            } else {
                ((v + 0.055) / 1.055).powf(2.4)
            }
        };
        let texels = (0..256)
            .map(|k| {
                let (x, y) = (f64::from(k % 16), f64::from(k / 16));
                let blue = if ((k % 16) / 4 + (k / 16) / 4) % 2 == 0 {
                    60.0
                } else {
                    220.0
                };
                [40.0 + 200.0 * x / 15.0, 30.0 + 180.0 * y / 15.0, blue].map(|v| linear(v) as f32)
            })
            .collect();
        Texture::Bitmap(Bitmap {
            width: 16,
            height: 16,
            texels,
            filter,
            wrap,
            to_uv: UvTransform::default(),
        })
    }

    #[test]
    fn bitmap_reads_as_mitsuba_3_reads_it() {
        // `mi.load_dict({'type': 'bitmap', ...}).eval(si)` in Mitsuba 3.9.1
        // (scalar_rgb) at these uv, for wall.png.
        use TextureFilter::{Bilinear, Nearest};
        use WrapMode::{Clamp, Mirror, Repeat};
        let cases: [(TextureFilter, WrapMode, [f64; 2], [f64; 3]); 10] = [
            (
                Bilinear,
                Repeat,
                [0.01, 0.01],
                [0.310269, 0.227692, 0.34611],
            ),
            (Bilinear, Repeat, [0.5, 0.5], [0.263161, 0.188453, 0.38044]),
            (
                Bilinear,
                Repeat,
                [0.97, 0.2],
                [0.854364, 0.049203, 0.702283],
            ),
            (
                Bilinear,
                Repeat,
                [-0.45, 1.7],
                [0.309699, 0.344411, 0.045186],
            ),
            (
                Bilinear,
                Mirror,
                [1.3, -0.2],
                [0.473219, 0.049203, 0.045186],
            ),
            (Bilinear, Clamp, [-0.45, 1.7], [0.021219, 0.64448, 0.715694]),
            (Nearest, Repeat, [0.3, 0.99], [0.109462, 0.64448, 0.045186]),
            (Nearest, Repeat, [1.3, -0.2], [0.109462, 0.423268, 0.045186]),
            (Nearest, Mirror, [-0.45, 1.7], [0.23455, 0.076185, 0.045186]),
            (Nearest, Clamp, [1.3, -0.2], [0.871367, 0.012983, 0.715694]),
        ];
        for (filter, wrap, uv, mitsuba) in cases {
            let value = wall(filter, wrap).eval(DVec2::from(uv));
            for c in 0..3 {
                assert!(
                    (value[c] - mitsuba[c]).abs() < 2e-6,
                    "{filter:?} {wrap:?} at {uv:?}: {value} against {mitsuba:?}"
                );
            }
        }
    }

    #[test]
    fn checkerboard_is_mitsubas() {
        let checker = Texture::Checkerboard {
            color0: Rgb::splat(0.4),
            color1: Rgb::splat(0.2),
            to_uv: UvTransform::scale(4.0, 4.0),
        };
        // Mitsuba 3.9.1 at the same uv.
        for (uv, value) in [
            ([0.1, 0.1], 0.4),
            ([0.2, 0.1], 0.2),
            ([0.1, 0.2], 0.2),
            ([0.2, 0.2], 0.4),
            ([-0.1, 0.1], 0.2),
        ] {
            assert_eq!(checker.eval(DVec2::from(uv)), Rgb::splat(value), "{uv:?}");
        }
        assert_eq!(checker.max(), Rgb::splat(0.4));
    }

    #[test]
    fn averages_over_elements_are_the_texture_means() {
        // A 4×4 checker on a square: the whole has the mean of both
        // colours; a quarter aligned with the squares likewise; a
        // sixteenth is one square.
        let checker = Texture::Checkerboard {
            color0: Rgb::splat(1.0),
            color1: Rgb::ZERO,
            to_uv: UvTransform::scale(2.0, 2.0),
        };
        let square = Patch::Parallelogram {
            origin: DVec3::ZERO,
            edge_s: DVec3::X * 3.0,
            edge_t: DVec3::Y * 3.0,
        };
        let mapping = TextureMapping {
            texture: 0,
            uv: [Vec2::ZERO, Vec2::X, Vec2::Y],
        };
        let mean = |element: &Patch| mapping.average(&checker, &square, element)[0];
        assert!((mean(&square) - 0.5).abs() < 1e-12);
        let quarter = square.subdivide()[0];
        assert!((mean(&quarter) - 0.5).abs() < 1e-12);
        assert_eq!(mean(&quarter.subdivide()[0]), 1.0);
        // A triangle's parameters are barycentric: its mapping follows its
        // vertices, and the flipped triangle reads the same texture.
        let triangle = Patch::Triangle([DVec3::ZERO, DVec3::X, DVec3::Y]);
        let bitmap = wall(TextureFilter::Bilinear, WrapMode::Repeat);
        let x = triangle.point_at(DVec2::new(0.2, 0.3));
        let flipped = triangle.flipped();
        let back = TextureMapping {
            uv: flipped_uv(mapping.uv, &triangle),
            ..mapping
        };
        assert!(
            (back.uv_at(flipped.param_of(x)) - mapping.uv_at(triangle.param_of(x))).length()
                < 1e-12
        );
        let (a, b) = (
            mapping.average(&bitmap, &triangle, &triangle),
            back.average(&bitmap, &flipped, &flipped),
        );
        assert!((a - b).max_channel().abs() < 0.01, "{a} {b}");
    }

    #[test]
    fn flipped_parallelogram_reads_the_same_texture_at_each_point() {
        let p = Patch::Parallelogram {
            origin: DVec3::ZERO,
            edge_s: DVec3::X * 2.0,
            edge_t: DVec3::Y,
        };
        let mapping = TextureMapping {
            texture: 0,
            uv: [
                Vec2::new(0.1, 0.2),
                Vec2::new(0.9, 0.3),
                Vec2::new(0.0, 0.8),
            ],
        };
        let f = p.flipped();
        let back = TextureMapping {
            uv: flipped_uv(mapping.uv, &p),
            ..mapping
        };
        for param in [DVec2::new(0.2, 0.7), DVec2::new(0.9, 0.1)] {
            let x = p.point_at(param);
            assert!((back.uv_at(f.param_of(x)) - mapping.uv_at(param)).length() < 1e-6);
        }
    }
}
