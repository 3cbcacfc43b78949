//! Texture plugins: `checkerboard` and `bitmap` (Mitsuba 3), read into the
//! scene's [`Texture`]s once per `<texture>` element however many shapes
//! use it ([`Document::texture_index`]).
//!
//! | plugin         | parameter     | type                                  | default    |
//! |----------------|---------------|---------------------------------------|------------|
//! | `checkerboard` | `color0`      | colour                                | 0.4        |
//! |                | `color1`      | colour                                | 0.2        |
//! |                | `to_uv`       | `<transform>` (its 2D affine part)    | identity   |
//! | `bitmap`       | `filename`    | PNG, JPEG, BMP, TGA, OpenEXR, Radiance HDR | required |
//! |                | `filter_type` | `bilinear`, `nearest`                 | `bilinear` |
//! |                | `wrap_mode`   | `repeat`, `mirror`, `clamp`           | `repeat`   |
//! |                | `raw`         | `<boolean>`: integer texels as stored, not sRGB | false |
//! |                | `to_uv`       | as above                              | identity   |
//!
//! ```xml
//! <texture type="bitmap" name="reflectance">
//!     <string name="filename" value="wood.png"/>
//!     <string name="filter_type" value="nearest"/>
//! </texture>
//! ```
//!
//! In Mitsuba 0.x files, `uscale`, `vscale`, `uoffset`, `voffset` and
//! `uvscale` become `to_uv`, and a bitmap's `filterType` `trilinear` or
//! `ewa` becomes `bilinear` with a warning, when the file is read
//! (`mitsuba/document.rs`, `upgrade_texture`).
//!
//! Images are decoded by the `image` crate. As in Mitsuba 3, integer
//! texels (8 or 16 bits) are sRGB-encoded and made linear unless `raw`;
//! floating-point ones (EXR, HDR) are linear. Grey images give grey
//! texels, an alpha channel is dropped. Images of more than
//! [`MAX_TEXELS`] texels are refused, and so are texels outside \[0, 1\]
//! (a reflectance above 1 would create light). `colorspace` (Mitsuba's
//! spectral-variant option) is accepted when it is `srgb`, wavrad's only one.

use std::path::Path;

use glam::{DMat4, DVec2};
use wavrad_core::scene::texture::{Bitmap, Texture, TextureFilter, UvTransform, WrapMode};
use wavrad_core::scene::Rgb;

use super::params::{Document, Nested, Object};
use crate::error::Result;

/// Largest bitmap texture wavrad reads, in texels (64 Mi: 768 MiB of linear
/// RGB), so that a huge or corrupt image is a clear error rather than
/// memory running out.
pub const MAX_TEXELS: u64 = 1 << 26;

/// The texture plugins wavrad reads, for messages.
pub(crate) const SUPPORTED: &str = "checkerboard, bitmap";

/// The index in the scene's textures of the `<texture>` `n`, read on its
/// first use.
pub(crate) fn parse_texture(n: Nested, doc: &Document) -> Result<u32> {
    doc.texture_index(n.element, || {
        let mut obj = Object::parse(n.element, doc)?;
        let texture = match obj.plugin {
            "checkerboard" => {
                let color0 = obj.color("color0")?.unwrap_or(Rgb::splat(0.4));
                let color1 = obj.color("color1")?.unwrap_or(Rgb::splat(0.2));
                Texture::Checkerboard {
                    color0,
                    color1,
                    to_uv: parse_to_uv(&mut obj)?,
                }
            }
            "bitmap" => Texture::Bitmap(parse_bitmap(&mut obj, doc)?),
            other => {
                return Err(obj.at().error(format!(
                    "unsupported texture plugin \"{other}\" (supported: {SUPPORTED}; with \
                     --approximate: the parameter's default)"
                )))
            }
        };
        if let Some(n) = obj.nested.first() {
            return Err(obj.unexpected(n));
        }
        obj.finish()?;
        Ok(texture)
    })
}

/// `to_uv`: the 2D affine part of a `<transform>` (rows and columns 0, 1
/// and the translation), as Mitsuba 3's `ScalarTransform4f::extract`.
fn parse_to_uv(obj: &mut Object) -> Result<UvTransform> {
    let m: DMat4 = obj.transform("to_uv")?.unwrap_or(DMat4::IDENTITY);
    let (x, y, w) = (m.x_axis, m.y_axis, m.w_axis);
    let to_uv = UvTransform([x.x, y.x, w.x, x.y, y.y, w.y]);
    if !to_uv.0.iter().all(|v| v.is_finite()) {
        return Err(obj
            .location_of("to_uv")
            .error(format!("to_uv of {} is not finite", obj.describe())));
    }
    Ok(to_uv)
}

fn parse_bitmap(obj: &mut Object, doc: &Document) -> Result<Bitmap> {
    let filename = obj.string("filename")?.ok_or_else(|| {
        obj.at()
            .error(format!("{} needs a \"filename\" parameter", obj.describe()))
    })?;
    let filter = match obj.string("filter_type")?.as_deref() {
        None | Some("bilinear") => TextureFilter::Bilinear,
        Some("nearest") => TextureFilter::Nearest,
        Some(other) => {
            return Err(obj.location_of("filter_type").error(format!(
                "unknown filter_type \"{other}\" of {} (known: bilinear, nearest)",
                obj.describe()
            )))
        }
    };
    let wrap = match obj.string("wrap_mode")?.as_deref() {
        None | Some("repeat") => WrapMode::Repeat,
        Some("mirror") => WrapMode::Mirror,
        Some("clamp") => WrapMode::Clamp,
        Some(other) => {
            return Err(obj.location_of("wrap_mode").error(format!(
                "unknown wrap_mode \"{other}\" of {} (known: repeat, mirror, clamp)",
                obj.describe()
            )))
        }
    };
    let raw = obj.boolean("raw")?.unwrap_or(false);
    if let Some(space) = obj.string("colorspace")? {
        if space != "srgb" {
            return Err(obj.location_of("colorspace").error(format!(
                "colorspace \"{space}\" of {} is not supported (wavrad's RGB is srgb)",
                obj.describe()
            )));
        }
    }
    let to_uv = parse_to_uv(obj)?;
    let at = obj.location_of("filename").clone();
    let path = doc.search.resolve(&filename, &at.dir);
    let (width, height, texels) = read_texels(&path, raw).map_err(|e| {
        at.error(format!(
            "bitmap \"{}\" of {}: {e}",
            path.display(),
            obj.describe()
        ))
    })?;
    Ok(Bitmap {
        width,
        height,
        texels,
        filter,
        wrap,
        to_uv,
    })
}

/// The image at `path` as linear RGB texels, row 0 first (Mitsuba's v = 0).
fn read_texels(path: &Path, raw: bool) -> std::result::Result<(u32, u32, Vec<[f32; 3]>), String> {
    let (width, height, texels) = read_linear_rgb(path, raw)?;
    if let Some((i, bad)) = texels
        .iter()
        .enumerate()
        .find(|(_, t)| !t.iter().all(|v| (0.0..=1.0).contains(v)))
    {
        let (x, y) = (i as u32 % width, i as u32 / width);
        return Err(format!(
            "texel ({x}, {y}) is {bad:?}: a reflectance must lie in [0, 1] in every channel"
        ));
    }
    Ok((width, height, texels))
}

/// The image at `path` decoded to linear RGB, row 0 first: integer pixels
/// (8 or 16 bits) sRGB-encoded and made linear unless `raw`, floating-point
/// ones (EXR, HDR) as stored, as Mitsuba 3's `Bitmap` converts them; at
/// most [`MAX_TEXELS`] pixels.
pub(crate) fn read_linear_rgb(
    path: &Path,
    raw: bool,
) -> std::result::Result<(u32, u32, Vec<[f32; 3]>), String> {
    let reader = image::ImageReader::open(path)
        .map_err(|e| format!("cannot open: {e}"))?
        .with_guessed_format()
        .map_err(|e| format!("cannot read: {e}"))?;
    let (width, height) = reader
        .into_dimensions()
        .map_err(|e| format!("cannot decode: {e}"))?;
    let texels = u64::from(width) * u64::from(height);
    if texels > MAX_TEXELS {
        return Err(format!(
            "{width}×{height} texels: wavrad reads bitmaps of at most {MAX_TEXELS} texels"
        ));
    }
    let mut reader = image::ImageReader::open(path)
        .map_err(|e| format!("cannot open: {e}"))?
        .with_guessed_format()
        .map_err(|e| format!("cannot read: {e}"))?;
    let mut limits = image::Limits::default();
    limits.max_alloc = Some(16 * MAX_TEXELS);
    reader.limits(limits);
    let image = reader.decode().map_err(|e| format!("cannot decode: {e}"))?;
    let float = matches!(
        image.color(),
        image::ColorType::Rgb32F | image::ColorType::Rgba32F
    );
    let srgb = !float && !raw;
    let rgb = image.into_rgb32f();
    let texels: Vec<[f32; 3]> = rgb
        .pixels()
        .map(|p| p.0.map(|v| if srgb { srgb_to_linear(v) } else { v }))
        .collect();
    Ok((width, height, texels))
}

/// The sRGB transfer function inverted (IEC 61966-2-1), as Mitsuba 3's
/// `srgb_to_linear`.
fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// The mean of a texture over one tile of its coordinates: what a
/// constant replacing it would be.
pub(crate) fn texture_mean(texture: &Texture) -> Rgb {
    let n = 64;
    let mut sum = Rgb::ZERO;
    for i in 0..n {
        for j in 0..n {
            let uv = DVec2::new((f64::from(i) + 0.5) / 64.0, (f64::from(j) + 0.5) / 64.0);
            sum += texture.eval(uv);
        }
    }
    sum / f64::from(n * n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_texels_are_made_linear_as_mitsuba_does() {
        // Mitsuba 3.9.1's bitmap of wall.png at texel (0, 0), sRGB (40, 30, 60).
        let wall = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../scenes/textured-cornell-box/wall.png");
        let (w, h, texels) = read_texels(&wall, false).unwrap();
        assert_eq!((w, h), (16, 16));
        for (value, mitsuba) in texels[0].iter().zip([0.021219, 0.012983, 0.045186]) {
            assert!(
                (f64::from(*value) - mitsuba).abs() < 1e-6,
                "{:?}",
                texels[0]
            );
        }
        // raw: the stored value over 255, as Mitsuba's raw bitmap.
        let (_, _, raw) = read_texels(&wall, true).unwrap();
        assert!((raw[0][0] - 40.0 / 255.0).abs() < 1e-6);
    }

    #[test]
    fn bitmaps_that_are_not_reflectances_or_images_are_clear_errors() {
        let dir = tempfile::tempdir().unwrap();
        let bright = dir.path().join("bright.exr");
        let pixels =
            image::Rgb32FImage::from_fn(2, 2, |x, _| image::Rgb([0.5, 2.0 * x as f32, 0.1]));
        pixels.save(&bright).unwrap();
        let e = read_texels(&bright, false).unwrap_err();
        assert!(e.contains("texel (1, 0)") && e.contains("[0, 1]"), "{e}");
        let junk = dir.path().join("junk.png");
        std::fs::write(&junk, b"not an image").unwrap();
        let e = read_texels(&junk, false).unwrap_err();
        assert!(e.contains("cannot"), "{e}");
        let e = read_texels(&dir.path().join("missing.png"), false).unwrap_err();
        assert!(e.contains("cannot open"), "{e}");
    }
}
