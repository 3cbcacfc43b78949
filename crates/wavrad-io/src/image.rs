//! Images out (EXR, PNG) and in (EXR), plus the error metric the tests use
//! against path-traced references.
//!
//! Pixel buffers are row-major, top row first, three linear-RGB `f32` values
//! per pixel.

use std::fs;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};

/// Write `rgb` (`width·height·3` linear values, row-major from the top) to
/// `path`, choosing the format by extension:
///
/// - `.exr`: linear 32-bit float channels `R`, `G`, `B` (lossless);
/// - `.png`: 8-bit sRGB — values clamped to [0, 1] then encoded with the
///   sRGB transfer function, as Mitsuba converts when saving PNG.
///
/// The image is written to a temporary file in the same directory and then
/// renamed over `path`, so a failed write never leaves a truncated file nor
/// destroys an existing one.
pub fn write_image(path: &Path, width: u32, height: u32, rgb: &[f32]) -> Result<()> {
    let expected = (width as usize)
        .checked_mul(height as usize)
        .and_then(|n| n.checked_mul(3));
    if width == 0 || height == 0 || expected != Some(rgb.len()) {
        return Err(Error::image(
            path,
            format!(
                "a {width}x{height} RGB image needs {} values, got {}",
                expected.map_or_else(|| "too many".to_string(), |n| n.to_string()),
                rgb.len()
            ),
        ));
    }
    let format = match extension(path).as_deref() {
        Some("exr") => Format::Exr,
        Some("png") => Format::Png,
        _ => {
            return Err(Error::image(
                path,
                "unsupported image format (supported extensions: .exr, .png)",
            ))
        }
    };
    write_atomically(path, |file| {
        match format {
            Format::Exr => encode_exr(file, width, height, rgb),
            Format::Png => encode_png(file, width, height, rgb),
        }
        .map_err(|m| Error::image(path, m))
    })
}

/// Read the `R`, `G`, `B` channels of the first layer that has them, at full
/// resolution. Returns `(width, height, rgb)` in the layout of
/// [`write_image`].
pub fn read_exr_rgb(path: &Path) -> Result<(u32, u32, Vec<f32>)> {
    use exr::prelude::*;

    struct Pixels {
        width: usize,
        rgb: Vec<f32>,
    }
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .rgb_channels(
            |size, _| Pixels {
                width: size.width(),
                rgb: vec![0.0; size.area() * 3],
            },
            |pixels: &mut Pixels, at, (r, g, b): (f32, f32, f32)| {
                let i = (at.y() * pixels.width + at.x()) * 3;
                if let Some(px) = pixels.rgb.get_mut(i..i + 3) {
                    px.copy_from_slice(&[r, g, b]);
                }
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .map_err(|e| crate::Error::image(path, format!("cannot read EXR: {e}")))?;
    let size = image.layer_data.size;
    let pixels = image.layer_data.channel_data.pixels;
    let (width, height) = (u32::try_from(size.width()), u32::try_from(size.height()));
    match (width, height) {
        (Ok(w), Ok(h)) => Ok((w, h, pixels.rgb)),
        _ => Err(crate::Error::image(path, "EXR image too large")),
    }
}

/// Relative root-mean-square error of `a` against `b_reference`:
/// `sqrt(mean((a − b)²)) / mean(b)` over every channel value.
///
/// Returns NaN when the lengths differ or the buffers are empty, and infinity
/// when the reference averages to zero while `a` differs from it.
pub fn relative_rmse(a: &[f32], b_reference: &[f32]) -> f64 {
    if a.len() != b_reference.len() || a.is_empty() {
        return f64::NAN;
    }
    let n = a.len() as f64;
    let squared: f64 = a
        .iter()
        .zip(b_reference)
        .map(|(&x, &y)| (f64::from(x) - f64::from(y)).powi(2))
        .sum();
    let mean_reference: f64 = b_reference.iter().map(|&y| f64::from(y)).sum::<f64>() / n;
    (squared / n).sqrt() / mean_reference
}

/// The sRGB opto-electronic transfer function on [0, 1].
fn srgb_encode(linear: f32) -> f32 {
    let v = if linear.is_nan() {
        0.0
    } else {
        linear.clamp(0.0, 1.0)
    };
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

enum Format {
    Exr,
    Png,
}

fn extension(path: &Path) -> Option<String> {
    path.extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
}

/// Write `bytes` to `path` atomically (temporary file in the same folder,
/// then rename), as [`write_image`] does; for statistics and other outputs.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomically(path, |file| {
        file.write_all(bytes).map_err(|e| Error::io(path, e))
    })
}

/// Check, before long work, that [`write_atomic`] could write `path`: it is
/// not a directory and a file can be made beside it (nothing is left behind).
pub fn check_writable(path: &Path) -> Result<()> {
    if path.is_dir() {
        return Err(Error::io(
            path,
            std::io::Error::new(std::io::ErrorKind::IsADirectory, "is a directory"),
        ));
    }
    temporary_beside(path).map(drop)
}

/// A temporary file in the folder of `path`, to be renamed onto it. A
/// folder that does not exist or cannot be written is named in the error
/// (not the temporary file's name).
fn temporary_beside(path: &Path) -> Result<tempfile::NamedTempFile> {
    let dir: PathBuf = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    tempfile::Builder::new()
        .prefix(".wavrad-")
        .suffix(".tmp")
        .tempfile_in(&dir)
        .map_err(|e| {
            // tempfile's error names the temporary file, not the folder.
            let cause = if dir.is_dir() {
                e.kind().to_string()
            } else {
                "no such folder".to_string()
            };
            let message = format!(
                "cannot make a file in the folder \"{}\": {cause}",
                dir.display()
            );
            Error::io(path, std::io::Error::new(e.kind(), message))
        })
}

/// Write `path` atomically: `encode` writes a temporary sibling of it,
/// which is then renamed into place; on an error nothing is renamed and the
/// temporary file is removed, so `path` is either what it was or complete.
pub(crate) fn write_atomically(
    path: &Path,
    encode: impl FnOnce(&mut fs::File) -> Result<()>,
) -> Result<()> {
    let mut tmp = temporary_beside(path)?;
    encode(tmp.as_file_mut())?;
    tmp.as_file().sync_all().map_err(|e| Error::io(path, e))?;
    // Temporary files are private (0600); give the result ordinary
    // permissions, or those of the file it replaces.
    let permissions = match fs::metadata(path) {
        Ok(m) => Some(m.permissions()),
        Err(_) => default_permissions(tmp.as_file()),
    };
    if let Some(p) = permissions {
        let _ = tmp.as_file().set_permissions(p);
    }
    tmp.persist(path).map_err(|e| Error::io(path, e.error))?;
    Ok(())
}

#[cfg(unix)]
fn default_permissions(file: &fs::File) -> Option<fs::Permissions> {
    use std::os::unix::fs::PermissionsExt;
    let mut p = file.metadata().ok()?.permissions();
    p.set_mode(0o644);
    Some(p)
}

#[cfg(not(unix))]
fn default_permissions(_file: &fs::File) -> Option<fs::Permissions> {
    None
}

fn encode_exr(
    file: &mut fs::File,
    width: u32,
    height: u32,
    rgb: &[f32],
) -> std::result::Result<(), String> {
    use exr::prelude::*;

    let w = width as usize;
    let channels = SpecificChannels::rgb(|at: Vec2<usize>| {
        let i = (at.y() * w + at.x()) * 3;
        (rgb[i], rgb[i + 1], rgb[i + 2])
    });
    let image = Image::from_encoded_channels(
        (width as usize, height as usize),
        Encoding::SMALL_LOSSLESS,
        channels,
    );
    image
        .write()
        .to_buffered(BufWriter::new(file))
        .map_err(|e| format!("cannot encode EXR: {e}"))
}

fn encode_png(
    file: &mut fs::File,
    width: u32,
    height: u32,
    rgb: &[f32],
) -> std::result::Result<(), String> {
    let bytes: Vec<u8> = rgb
        .iter()
        .map(|&v| (srgb_encode(v) * 255.0 + 0.5) as u8)
        .collect();
    let mut out = BufWriter::new(file);
    let mut encoder = png::Encoder::new(&mut out, width, height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    let mut writer = encoder
        .write_header()
        .map_err(|e| format!("cannot encode PNG: {e}"))?;
    writer
        .write_image_data(&bytes)
        .map_err(|e| format!("cannot encode PNG: {e}"))?;
    writer
        .finish()
        .map_err(|e| format!("cannot encode PNG: {e}"))?;
    out.flush().map_err(|e| format!("cannot write PNG: {e}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gradient(w: u32, h: u32) -> Vec<f32> {
        (0..w * h * 3).map(|i| i as f32 * 0.37).collect()
    }

    #[test]
    fn exr_round_trip_is_exact() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.exr");
        let rgb = gradient(5, 3);
        write_image(&path, 5, 3, &rgb).unwrap();
        let (w, h, back) = read_exr_rgb(&path).unwrap();
        assert_eq!((w, h), (5, 3));
        assert_eq!(back, rgb);
    }

    #[test]
    fn png_uses_srgb_and_clamps() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.PNG");
        let rgb = [0.0, 0.5, 2.0, -1.0, 0.002, f32::NAN];
        write_image(&path, 2, 1, &rgb).unwrap();
        let decoder = png::Decoder::new(std::io::BufReader::new(fs::File::open(&path).unwrap()));
        let mut reader = decoder.read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buf).unwrap();
        assert_eq!(info.color_type, png::ColorType::Rgb);
        // sRGB(0.5) = 0.7354 → 188; sRGB(0.002) = 0.02584 → 7.
        assert_eq!(&buf[..6], &[0, 188, 255, 0, 7, 0]);
    }

    #[test]
    fn srgb_curve_matches_known_values() {
        assert_eq!(srgb_encode(0.0), 0.0);
        assert!((srgb_encode(1.0) - 1.0).abs() < 1e-6);
        assert!((srgb_encode(0.18) - 0.4614).abs() < 1e-3);
    }

    #[test]
    fn bad_extension_and_size_are_errors_and_write_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let bmp = dir.path().join("a.bmp");
        let e = write_image(&bmp, 1, 1, &[0.0; 3]).unwrap_err().to_string();
        assert!(
            e.contains("a.bmp") && e.contains(".exr") && e.contains(".png"),
            "{e}"
        );
        let exr = dir.path().join("a.exr");
        assert!(write_image(&exr, 2, 2, &[0.0; 3]).is_err());
        assert_eq!(
            fs::read_dir(dir.path()).unwrap().count(),
            0,
            "no stray files"
        );
    }

    #[test]
    fn failed_write_keeps_the_existing_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("keep.exr");
        write_image(&path, 1, 1, &[1.0, 2.0, 3.0]).unwrap();
        assert!(write_image(&path, 1, 1, &[1.0]).is_err());
        assert_eq!(read_exr_rgb(&path).unwrap().2, vec![1.0, 2.0, 3.0]);
        let missing_dir = dir.path().join("no/such/dir/x.png");
        let e = write_image(&missing_dir, 1, 1, &[0.0; 3])
            .unwrap_err()
            .to_string();
        assert!(e.contains("x.png"), "{e}");
    }

    #[test]
    fn relative_rmse_of_known_buffers() {
        assert_eq!(relative_rmse(&[1.0, 1.0], &[1.0, 1.0]), 0.0);
        // Errors ±1 on a reference of mean 2: rmse 1, relative 0.5.
        let r = relative_rmse(&[2.0, 2.0], &[1.0, 3.0]);
        assert!((r - 0.5).abs() < 1e-12);
        assert!(relative_rmse(&[1.0], &[1.0, 2.0]).is_nan());
    }

    #[test]
    fn reading_garbage_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.exr");
        fs::write(&path, b"not an exr").unwrap();
        let e = read_exr_rgb(&path).unwrap_err().to_string();
        assert!(e.contains("bad.exr"), "{e}");
    }
}
