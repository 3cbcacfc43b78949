//! Spectra in scene files and the RGB colour Mitsuba 3's RGB variants make
//! of them (`Properties::get_texture_impl` in its `src/core/properties.cpp`,
//! `spectrum_list_to_srgb` in `src/core/spectrum.cpp`), so that a spectral
//! scene renders in wavrad as in `scalar_rgb`.
//!
//! A spectrum is a constant (`<spectrum value="0.5"/>`) or sampled
//! (`value="400:0.1, 500:0.5, 600:0.8"`, wavelengths in nm increasing, or
//! `filename="x.spd"`, one `wavelength value` pair a line, `#` comments).
//! What it becomes depends on what the colour is for ([`ColorRole`]):
//!
//! | spectrum | reflectance (`diffuse`'s `reflectance`) | unbounded (`eta`, `k`) | emission (`radiance`) |
//! |----------|------------------------------------------|------------------------|------------------------|
//! | constant c | grey c                                 | grey c                 | c · M·(1, 1, 1): the sRGB of an equal-energy spectrum, pinkish |
//! | sampled s(λ) | M·∫ s·D65·(x̄, ȳ, z̄) dλ, clamped to \[0, 1\] | the same, clamped at 0 | M·∫ s·(x̄, ȳ, z̄) dλ, clamped at 0 |
//!
//! with the CIE 1931 2° observer (x̄, ȳ, z̄) normalized to ∫ȳ = 1, the CIE
//! D65 illuminant normalized to unit luminance, M the XYZ → linear sRGB
//! (Rec. 709) matrix, and the integral a 1000-point Riemann sum over
//! 360–830 nm of the spectrum's linear interpolant (zero outside its
//! wavelengths), all exactly as Mitsuba 3 computes them. A clamped colour
//! (out of the sRGB gamut) is a warning, as in Mitsuba.
//!
//! ```text
//! <spectrum name="reflectance" value="400:0.2, 500:0.5, 600:0.8, 700:0.3"/>   → (0.75503, 0.641415, 0.323239)
//! <spectrum name="radiance" value="2"/>                                         → (2.40959, 1.89658, 1.81783)
//! ```

use wavrad_core::scene::Rgb;

/// A spectrum as written in a scene.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Spectrum {
    /// The same value at every wavelength.
    Constant(f64),
    /// Values at increasing wavelengths (nm), at least two, linearly
    /// interpolated between them and zero outside.
    Sampled {
        wavelengths: Vec<f64>,
        values: Vec<f64>,
    },
}

/// What a colour parameter is for; Mitsuba's RGB variants convert spectra
/// differently for each (see the module's table).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum ColorRole {
    /// A reflectance, bounded to \[0, 1\] and seen under D65.
    Reflectance,
    /// An optical constant (index of refraction, absorption): seen under
    /// D65, not bounded above.
    Unbounded,
    /// Emitted radiance: its own illuminant.
    Emission,
}

/// A spectrum's colour, and what it was before the clamp to the sRGB
/// gamut if there was one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Converted {
    pub rgb: Rgb,
    pub clamped_from: Option<Rgb>,
}

impl Spectrum {
    /// Parse a `<spectrum value>`: one number, or `wavelength:value` pairs
    /// separated by commas or white space.
    pub fn parse(text: &str) -> Result<Spectrum, String> {
        let tokens: Vec<&str> = text
            .split(|c: char| c == ',' || c.is_whitespace())
            .filter(|t| !t.is_empty())
            .collect();
        if let [single] = tokens[..] {
            if !single.contains(':') {
                return number(single).map(Spectrum::Constant);
            }
        }
        let mut pairs = Vec::with_capacity(tokens.len());
        for token in tokens {
            let (w, v) = token.split_once(':').ok_or_else(|| {
                format!("\"{token}\" is not a wavelength:value pair (give one number, or pairs)")
            })?;
            pairs.push((number(w)?, number(v)?));
        }
        Spectrum::sampled(pairs)
    }

    /// Parse the text of a spectrum file (Mitsuba's `.spd`): per line a
    /// wavelength and a value, separated by white space; lines starting with
    /// `#` and blank lines are skipped. Errors name the 1-based line.
    pub fn parse_file(text: &str) -> Result<Spectrum, String> {
        let mut pairs = Vec::new();
        for (index, line) in text.lines().enumerate() {
            let line = line.trim();
            if line.is_empty() || line.starts_with('#') {
                continue;
            }
            let fields: Vec<&str> = line.split_whitespace().collect();
            let [w, v] = fields[..] else {
                return Err(format!(
                    "line {}: expected a wavelength and a value, got \"{line}\"",
                    index + 1
                ));
            };
            let pair = (number(w), number(v));
            match pair {
                (Ok(w), Ok(v)) => pairs.push((w, v)),
                (Err(e), _) | (_, Err(e)) => return Err(format!("line {}: {e}", index + 1)),
            }
        }
        Spectrum::sampled(pairs)
    }

    /// A sampled spectrum from (wavelength, value) pairs, checked.
    fn sampled(pairs: Vec<(f64, f64)>) -> Result<Spectrum, String> {
        if pairs.len() < 2 {
            return Err(format!(
                "a sampled spectrum needs at least two wavelength:value pairs, got {}",
                pairs.len()
            ));
        }
        if let Some(w) = pairs.windows(2).find(|w| w[1].0 <= w[0].0) {
            return Err(format!(
                "wavelengths must increase, but {} nm follows {} nm",
                w[1].0, w[0].0
            ));
        }
        let (wavelengths, values) = pairs.into_iter().unzip();
        Ok(Spectrum::Sampled {
            wavelengths,
            values,
        })
    }

    /// The linear sRGB colour Mitsuba 3's RGB variants use for this
    /// spectrum in `role`.
    pub fn to_rgb(&self, role: ColorRole) -> Converted {
        let (wavelengths, values) = match self {
            Spectrum::Constant(c) => {
                let rgb = match role {
                    ColorRole::Emission => xyz_to_srgb([1.0; 3]) * *c,
                    ColorRole::Reflectance | ColorRole::Unbounded => Rgb::splat(*c),
                };
                return Converted {
                    rgb,
                    clamped_from: None,
                };
            }
            Spectrum::Sampled {
                wavelengths,
                values,
            } => (wavelengths, values),
        };
        let d65 = role != ColorRole::Emission;
        let rgb = xyz_to_srgb(integrate_xyz(wavelengths, values, d65));
        let clamped = match role {
            ColorRole::Reflectance => rgb.map(|c| c.clamp(0.0, 1.0)),
            ColorRole::Unbounded | ColorRole::Emission => rgb.map(|c| c.max(0.0)),
        };
        Converted {
            rgb: clamped,
            clamped_from: (clamped != rgb).then_some(rgb),
        }
    }
}

/// A finite number.
fn number(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(format!("malformed number \"{text}\"")),
    }
}

/// The table's range and sampling (Mitsuba's `MI_CIE_MIN`, `MI_CIE_MAX`,
/// `MI_CIE_SAMPLES`): 360–830 nm every 5 nm.
const CIE_MIN: f64 = 360.0;
const CIE_MAX: f64 = 830.0;
const CIE_SAMPLES: usize = 95;

/// Scales the colour matching functions so that a unit spectrum has unit
/// luminance (`MI_CIE_Y_NORMALIZATION`).
const CIE_Y_NORMALIZATION: f64 = 1.0 / 106.750_259_399_414_06;

/// Scales [`D65`] to unit luminance (`MI_CIE_D65_NORMALIZATION`).
const CIE_D65_NORMALIZATION: f64 = 1.0 / 98.997_417_518_762_55;

/// ∫ values(λ)·(D65(λ) if `d65`)·(x̄, ȳ, z̄)(λ) dλ over 360–830 nm, as
/// Mitsuba's `spectrum_list_to_srgb`: 1000 points from 360 to 830 nm
/// inclusive, those outside the spectrum's wavelengths skipped, times
/// (830 − 360) / 1000.
fn integrate_xyz(wavelengths: &[f64], values: &[f64], d65: bool) -> [f64; 3] {
    const STEPS: usize = 1000;
    let mut xyz = [0.0; 3];
    let (first, last) = (wavelengths[0], wavelengths[wavelengths.len() - 1]);
    for i in 0..STEPS {
        let w = CIE_MIN + (i as f64 / (STEPS - 1) as f64) * (CIE_MAX - CIE_MIN);
        if w < first || w > last {
            continue;
        }
        // The interval [w0, w1] holding w (Mitsuba's find_interval).
        let index = wavelengths[1..wavelengths.len() - 1].partition_point(|&x| x <= w);
        let (w0, w1) = (wavelengths[index], wavelengths[index + 1]);
        let (v0, v1) = (values[index], values[index + 1]);
        let v = ((w - w1) * v0 + (w0 - w) * v1) / (w0 - w1);
        let weight = v * if d65 { cie_d65(w) } else { 1.0 };
        let cmf = cie1931_xyz(w);
        for (sum, c) in xyz.iter_mut().zip(cmf) {
            *sum += c * weight;
        }
    }
    xyz.map(|c| c * (CIE_MAX - CIE_MIN) * CIE_Y_NORMALIZATION / STEPS as f64)
}

/// Linear interpolation in a table over 360–830 nm (Mitsuba's
/// `cie1931_xyz`, `cie_d65`): zero outside.
fn interpolate(table: &[f32; CIE_SAMPLES], wavelength: f64) -> f64 {
    if !(CIE_MIN..=CIE_MAX).contains(&wavelength) {
        return 0.0;
    }
    let t = (wavelength - CIE_MIN) * ((CIE_SAMPLES - 1) as f64 / (CIE_MAX - CIE_MIN));
    let i0 = (t as usize).min(CIE_SAMPLES - 2);
    let w1 = t - i0 as f64;
    (1.0 - w1) * f64::from(table[i0]) + w1 * f64::from(table[i0 + 1])
}

/// The CIE 1931 2° colour matching functions at `wavelength` nm.
fn cie1931_xyz(wavelength: f64) -> [f64; 3] {
    let (x, rest) = CIE1931.split_at(CIE_SAMPLES);
    let (y, z) = rest.split_at(CIE_SAMPLES);
    [x, y, z].map(|table| interpolate(table.try_into().expect("95 samples"), wavelength))
}

/// The CIE D65 illuminant at `wavelength` nm, normalized to unit luminance.
fn cie_d65(wavelength: f64) -> f64 {
    interpolate(&D65, wavelength) * CIE_D65_NORMALIZATION
}

/// XYZ to linear sRGB (ITU-R BT.709 primaries, D65 white), Mitsuba's
/// `xyz_to_srgb` with its single-precision coefficients.
fn xyz_to_srgb(xyz: [f64; 3]) -> Rgb {
    const M: [[f32; 3]; 3] = [
        [3.240479, -1.53715, -0.498535],
        [-0.969256, 1.875991, 0.041556],
        [0.055648, -0.204043, 1.057311],
    ];
    Rgb(M.map(|row| (0..3).map(|j| f64::from(row[j]) * xyz[j]).sum()))
}

/// CIE 1931 2° standard observer, x̄ then ȳ then z̄, 360–830 nm every 5 nm
/// (CIE 015:2004, Table T.4; Mitsuba's `cie1931_tbl`).
#[rustfmt::skip]
const CIE1931: [f32; 3 * CIE_SAMPLES] = [
    // x̄
    0.0001299, 0.0002321, 0.0004149, 0.0007416, 0.001368, 0.002236,
    0.004243, 0.00765, 0.01431, 0.02319, 0.04351, 0.07763,
    0.13438, 0.21477, 0.2839, 0.3285, 0.34828, 0.34806,
    0.3362, 0.3187, 0.2908, 0.2511, 0.19536, 0.1421,
    0.09564, 0.05795001, 0.03201, 0.0147, 0.0049, 0.0024,
    0.0093, 0.0291, 0.06327, 0.1096, 0.1655, 0.2257499,
    0.2904, 0.3597, 0.4334499, 0.5120501, 0.5945, 0.6784,
    0.7621, 0.8425, 0.9163, 0.9786, 1.0263, 1.0567,
    1.0622, 1.0456, 1.0026, 0.9384, 0.8544499, 0.7514,
    0.6424, 0.5419, 0.4479, 0.3608, 0.2835, 0.2187,
    0.1649, 0.1212, 0.0874, 0.0636, 0.04677, 0.0329,
    0.0227, 0.01584, 0.01135916, 0.008110916, 0.005790346, 0.004109457,
    0.002899327, 0.00204919, 0.001439971, 0.0009999493, 0.0006900786, 0.0004760213,
    0.0003323011, 0.0002348261, 0.0001661505, 0.000117413, 0.00008307527, 0.00005870652,
    0.00004150994, 0.00002935326, 0.00002067383, 0.00001455977, 0.00001025398, 0.000007221456,
    0.000005085868, 0.000003581652, 0.000002522525, 0.000001776509, 0.000001251141,
    // ȳ
    0.000003917, 0.000006965, 0.00001239, 0.00002202, 0.000039, 0.000064,
    0.00012, 0.000217, 0.000396, 0.00064, 0.00121, 0.00218,
    0.004, 0.0073, 0.0116, 0.01684, 0.023, 0.0298,
    0.038, 0.048, 0.06, 0.0739, 0.09098, 0.1126,
    0.13902, 0.1693, 0.20802, 0.2586, 0.323, 0.4073,
    0.503, 0.6082, 0.71, 0.7932, 0.862, 0.9148501,
    0.954, 0.9803, 0.9949501, 1.0, 0.995, 0.9786,
    0.952, 0.9154, 0.87, 0.8163, 0.757, 0.6949,
    0.631, 0.5668, 0.503, 0.4412, 0.381, 0.321,
    0.265, 0.217, 0.175, 0.1382, 0.107, 0.0816,
    0.061, 0.04458, 0.032, 0.0232, 0.017, 0.01192,
    0.00821, 0.005723, 0.004102, 0.002929, 0.002091, 0.001484,
    0.001047, 0.00074, 0.00052, 0.0003611, 0.0002492, 0.0001719,
    0.00012, 0.0000848, 0.00006, 0.0000424, 0.00003, 0.0000212,
    0.00001499, 0.0000106, 0.0000074657, 0.0000052578, 0.0000037029, 0.0000026078,
    0.0000018366, 0.0000012934, 0.00000091093, 0.00000064153, 0.00000045181,
    // z̄
    0.0006061, 0.001086, 0.001946, 0.003486, 0.006450001, 0.01054999,
    0.02005001, 0.03621, 0.06785001, 0.1102, 0.2074, 0.3713,
    0.6456, 1.0390501, 1.3856, 1.62296, 1.74706, 1.7826,
    1.77211, 1.7441, 1.6692, 1.5281, 1.28764, 1.0419,
    0.8129501, 0.6162, 0.46518, 0.3533, 0.272, 0.2123,
    0.1582, 0.1117, 0.07824999, 0.05725001, 0.04216, 0.02984,
    0.0203, 0.0134, 0.008749999, 0.005749999, 0.0039, 0.002749999,
    0.0021, 0.0018, 0.001650001, 0.0014, 0.0011, 0.001,
    0.0008, 0.0006, 0.00034, 0.00024, 0.00019, 0.0001,
    0.00004999999, 0.00003, 0.00002, 0.00001, 0.0, 0.0,
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    0.0, 0.0, 0.0, 0.0, 0.0,

];

/// CIE standard illuminant D65, relative to its power at 560 nm, 360–830 nm
/// every 5 nm (CIE 015:2004, Table T.1; Mitsuba's `d65_table`).
#[rustfmt::skip]
const D65: [f32; CIE_SAMPLES] = [
    46.6383, 49.3637, 52.0891, 51.0323, 49.9755, 52.3118, 54.6482, 68.7015,
    82.7549, 87.1204, 91.486, 92.4589, 93.4318, 90.057, 86.6823, 95.7736,
    104.865, 110.936, 117.008, 117.41, 117.812, 116.336, 114.861, 115.392,
    115.923, 112.367, 108.811, 109.082, 109.354, 108.578, 107.802, 106.296,
    104.79, 106.239, 107.689, 106.047, 104.405, 104.225, 104.046, 102.023,
    100.0, 98.1671, 96.3342, 96.0611, 95.788, 92.2368, 88.6856, 89.3459,
    90.0062, 89.8026, 89.5991, 88.6489, 87.6987, 85.4936, 83.2886, 83.4939,
    83.6992, 81.863, 80.0268, 80.1207, 80.2146, 81.2462, 82.2778, 80.281,
    78.2842, 74.0027, 69.7213, 70.6652, 71.6091, 72.979, 74.349, 67.9765,
    61.604, 65.7448, 69.8856, 72.4863, 75.087, 69.3398, 63.5927, 55.0054,
    46.4182, 56.6118, 66.8054, 65.0941, 63.3828, 63.8434, 64.304, 61.8779,
    59.4519, 55.7054, 51.959, 54.6998, 57.4406, 58.8765, 60.3125,
];

#[cfg(test)]
mod tests {
    use super::*;

    fn assert_close(a: Rgb, b: [f64; 3], tolerance: f64) {
        for (x, y) in a.0.iter().zip(b) {
            assert!(
                (x - y).abs() <= tolerance * y.abs().max(1e-3),
                "{a} vs {b:?}"
            );
        }
    }

    /// Mitsuba 3.9.1 `scalar_rgb`, a scene's `diffuse` reflectance and `area`
    /// radiance read back with `mi.traverse`.
    #[test]
    fn colours_match_mitsuba_scalar_rgb() {
        let s = Spectrum::parse("400:0.2, 500:0.5, 600:0.8, 700:0.3").unwrap();
        assert_close(
            s.to_rgb(ColorRole::Reflectance).rgb,
            [0.75503, 0.641415, 0.323239],
            2e-5,
        );
        assert_close(
            s.to_rgb(ColorRole::Emission).rgb,
            [0.886932, 0.614419, 0.285147],
            2e-5,
        );
        let wide = Spectrum::parse("300:1 900:1").unwrap();
        assert_close(
            wide.to_rgb(ColorRole::Reflectance).rgb,
            [0.998985, 0.998874, 0.998802],
            2e-5,
        );
        assert_close(
            wide.to_rgb(ColorRole::Emission).rgb,
            [1.20488, 0.948228, 0.909267],
            2e-5,
        );
        let constant = Spectrum::parse(" 2 ").unwrap();
        assert_eq!(constant, Spectrum::Constant(2.0));
        assert_eq!(constant.to_rgb(ColorRole::Reflectance).rgb, Rgb::splat(2.0));
        assert_close(
            constant.to_rgb(ColorRole::Emission).rgb,
            [2.40959, 1.89658, 1.81783],
            2e-6,
        );
    }

    #[test]
    fn out_of_gamut_colours_are_clamped_and_say_so() {
        // A narrow green band: negative red and blue in sRGB.
        let green = Spectrum::parse("500:0, 520:1, 540:0").unwrap();
        let r = green.to_rgb(ColorRole::Reflectance);
        assert_close(r.rgb, [0.0, 0.246295, 0.0], 2e-5);
        let before = r.clamped_from.expect("clamped");
        assert!(before[0] < -0.17 && before[2] < 0.0, "{before}");
        let e = green.to_rgb(ColorRole::Emission);
        assert_close(e.rgb, [0.0, 0.229273, 0.0], 2e-5);
        assert!(e.clamped_from.is_some());
        let fine = Spectrum::parse("400:0.5, 700:0.5").unwrap();
        assert_eq!(fine.to_rgb(ColorRole::Reflectance).clamped_from, None);
    }

    #[test]
    fn equal_energy_is_white_in_xyz_and_d65_is_white_in_srgb() {
        // ∫ȳ = 1 after normalization, and D65 (the sRGB white point) maps to
        // (1, 1, 1) up to the tables' rounding.
        let xyz = integrate_xyz(&[360.0, 830.0], &[1.0, 1.0], false);
        assert!((xyz[1] - 1.0).abs() < 2e-3, "{xyz:?}");
        let white = xyz_to_srgb(integrate_xyz(&[360.0, 830.0], &[1.0, 1.0], true));
        assert_close(white, [1.0, 1.0, 1.0], 2e-3);
    }

    #[test]
    fn malformed_spectra_say_why() {
        for (text, needle) in [
            ("400:0.5", "at least two"),
            ("500:1, 400:1", "must increase"),
            ("400:x, 500:1", "\"x\""),
            ("0.5 0.7", "wavelength:value"),
            ("", "at least two"),
            ("inf", "malformed"),
        ] {
            let msg = Spectrum::parse(text).unwrap_err();
            assert!(msg.contains(needle), "{text}: {msg}");
        }
        let file = "# measured\n400 0.1\n\n500 0.2\n600 0.3\n";
        assert_eq!(
            Spectrum::parse_file(file).unwrap(),
            Spectrum::Sampled {
                wavelengths: vec![400.0, 500.0, 600.0],
                values: vec![0.1, 0.2, 0.3]
            }
        );
        let msg = Spectrum::parse_file("400 0.1\n500\n").unwrap_err();
        assert!(msg.starts_with("line 2:"), "{msg}");
    }
}
