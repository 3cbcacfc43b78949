//! Fresnel reflectance of dielectric and conducting interfaces, and the
//! named indices of refraction Mitsuba 3 accepts.
//!
//! The formulas are Mitsuba 3's (`mitsuba/render/fresnel.h`): the exact
//! unpolarised Fresnel equations for a real relative index η (Hecht,
//! *Optics*, eqs. 4.34 and 4.40), and for a complex index η + ik the form of
//! K. D. Möller, *Optics* (1988), which Mitsuba uses per colour channel.
//!
//! [`CONDUCTORS`] holds the complex indices Mitsuba 3.9 uses in its RGB
//! variants for each `material` name of `roughconductor` (the spectral
//! `data/ior/*.spd` tables projected to linear sRGB by Mitsuba itself; read
//! back with `mi.traverse` from `scalar_rgb`). [`DIELECTRICS`] is Mitsuba's
//! `ior.h` table of real indices (Hecht, at ≈589 nm).

use crate::scene::Rgb;

/// Unpolarised Fresnel reflectance of a dielectric interface of relative
/// index `eta` (interior over exterior) for a ray whose cosine with the
/// normal is `cos_theta_i` (negative: arriving from inside).
///
/// Returns `(R, cos_theta_t, eta_it, eta_ti)` as Mitsuba 3's `fresnel()`:
/// the reflectance, the signed cosine of the refracted ray (pointing to the
/// other side), and the relative indices along and against the direction of
/// travel. Total internal reflection gives `R = 1`, `cos_theta_t = 0`.
pub fn fresnel_dielectric(cos_theta_i: f64, eta: f64) -> (f64, f64, f64, f64) {
    let outside = cos_theta_i >= 0.0;
    let (eta_it, eta_ti) = if outside {
        (eta, 1.0 / eta)
    } else {
        (1.0 / eta, eta)
    };
    // Snell's law for the squared cosine of the transmitted ray
    let cos_t_sqr = 1.0 - (1.0 - cos_theta_i * cos_theta_i) * eta_ti * eta_ti;
    let cos_i = cos_theta_i.abs();
    let cos_t = cos_t_sqr.max(0.0).sqrt();
    let r = if eta == 1.0 {
        0.0
    } else if cos_i == 0.0 {
        1.0
    } else {
        let a_s = (cos_i - eta_it * cos_t) / (cos_i + eta_it * cos_t);
        let a_p = (cos_t - eta_it * cos_i) / (cos_t + eta_it * cos_i);
        0.5 * (a_s * a_s + a_p * a_p)
    };
    let cos_theta_t = if cos_theta_i >= 0.0 { -cos_t } else { cos_t };
    (r.min(1.0), cos_theta_t, eta_it, eta_ti)
}

/// Unpolarised Fresnel reflectance of a conductor of complex relative index
/// `eta + i k` at incidence cosine `cos_theta_i` ∈ [0, 1] (Möller 1988, as
/// Mitsuba 3's `fresnel_conductor`). With η = 0, k = 1 it is 1 at every
/// angle: a perfect mirror.
pub fn fresnel_conductor(cos_theta_i: f64, eta: f64, k: f64) -> f64 {
    let cos2 = cos_theta_i * cos_theta_i;
    let sin2 = 1.0 - cos2;
    let sin4 = sin2 * sin2;
    let temp1 = eta * eta - k * k - sin2;
    let a2pb2 = (temp1 * temp1 + 4.0 * k * k * eta * eta).max(0.0).sqrt();
    let a = (0.5 * (a2pb2 + temp1)).max(0.0).sqrt();
    let term1 = a2pb2 + cos2;
    let term2 = 2.0 * cos_theta_i * a;
    let r_s = (term1 - term2) / (term1 + term2);
    let term3 = a2pb2 * cos2 + sin4;
    let term4 = term2 * sin2;
    let r_p = r_s * (term3 - term4) / (term3 + term4);
    0.5 * (r_s + r_p)
}

/// [`fresnel_conductor`] per RGB channel.
pub fn fresnel_conductor_rgb(cos_theta_i: f64, eta: Rgb, k: Rgb) -> Rgb {
    Rgb(std::array::from_fn(|c| {
        fresnel_conductor(cos_theta_i, eta[c], k[c])
    }))
}

/// A complex index of refraction η + ik per RGB channel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ComplexIor {
    /// Real part η.
    pub eta: Rgb,
    /// Imaginary part (extinction coefficient) k.
    pub k: Rgb,
}

/// The complex index of a named conductor (`material` of Mitsuba's
/// `roughconductor`); `"none"` is Mitsuba's default, η = 0, k = 1, a
/// perfect mirror. Names are case-sensitive, as Mitsuba's file names.
pub fn conductor_ior(name: &str) -> Option<ComplexIor> {
    if name == "none" {
        return Some(ComplexIor {
            eta: Rgb::ZERO,
            k: Rgb::splat(1.0),
        });
    }
    CONDUCTORS
        .iter()
        .find(|(n, _, _)| *n == name)
        .map(|&(_, eta, k)| ComplexIor {
            eta: eta.into(),
            k: k.into(),
        })
}

/// The real index of a named dielectric (Mitsuba's `ior.h`; names are
/// matched case-insensitively, as Mitsuba does).
pub fn dielectric_ior(name: &str) -> Option<f64> {
    let lower = name.to_ascii_lowercase();
    DIELECTRICS
        .iter()
        .find(|(n, _)| *n == lower)
        .map(|&(_, v)| v)
}

/// Named dielectric indices of refraction (Mitsuba 3 `ior.h`, from Hecht,
/// *Optics*, 4th ed., 0–20 °C at ≈589 nm).
pub const DIELECTRICS: &[(&str, f64)] = &[
    ("vacuum", 1.0),
    ("helium", 1.000036),
    ("hydrogen", 1.000132),
    ("air", 1.000277),
    ("carbon dioxide", 1.00045),
    ("water", 1.3330),
    ("acetone", 1.36),
    ("ethanol", 1.361),
    ("carbon tetrachloride", 1.461),
    ("glycerol", 1.4729),
    ("benzene", 1.501),
    ("silicone oil", 1.52045),
    ("bromine", 1.661),
    ("water ice", 1.31),
    ("fused quartz", 1.458),
    ("pyrex", 1.470),
    ("acrylic glass", 1.49),
    ("polypropylene", 1.49),
    ("bk7", 1.5046),
    ("sodium chloride", 1.544),
    ("amber", 1.55),
    ("pet", 1.5750),
    ("diamond", 2.419),
];

/// Complex indices (name, η, k) per linear-sRGB channel, exactly as
/// Mitsuba 3.9.1's RGB variants use them for `material="name"` (every
/// material in its `data/ior` folder; `_palik` names are Palik's tables).
#[rustfmt::skip]
pub const CONDUCTORS: &[(&str, [f64; 3], [f64; 3])] = &[
    ("a-C", [2.94404578, 2.22713637, 1.9681617], [0.887464881, 0.799298525, 0.815289974]),
    ("Ag", [0.155276194, 0.116727956, 0.138387635], [4.82835436, 3.12222242, 2.14690113]),
    ("Al", [1.65750086, 0.880404711, 0.521244466], [9.22381115, 6.26950216, 4.83700418]),
    ("AlAs", [3.6052959, 3.23293781, 2.21631861], [0.000679437304, 0.0, 0.00751270913]),
    ("AlAs_palik", [3.6052959, 3.23293781, 2.21631861], [0.000679437304, 0.0, 0.00751270913]),
    ("AlSb", [0.0, 4.13937473, 4.6692543], [0.0, 0.094009079, 1.30057001]),
    ("AlSb_palik", [0.0, 4.13937473, 4.6692543], [0.0, 0.094009079, 1.30057001]),
    ("Au", [0.143035978, 0.375307083, 1.44204533], [3.98299694, 2.38555646, 1.60335922]),
    ("Be", [4.18501234, 3.18502927, 2.78406119], [3.83546591, 3.0101223, 2.868994]),
    ("Be_palik", [4.18501234, 3.18502927, 2.78406119], [3.83546591, 3.0101223, 2.868994]),
    ("Cr", [4.36966753, 2.91650534, 1.6549046], [5.20654678, 4.23130608, 3.75469875]),
    ("CsI", [2.14489961, 1.70231891, 1.66242719], [0.0, 0.0, 0.0]),
    ("CsI_palik", [2.14489961, 1.70231891, 1.66242719], [0.0, 0.0, 0.0]),
    ("Cu", [0.201005474, 0.923749506, 1.10221541], [3.91326213, 2.45304513, 2.14208984]),
    ("Cu2O", [3.55177259, 2.94986963, 2.7518754], [0.114207022, 0.19389686, 0.606133878]),
    ("Cu2O_palik", [3.55177259, 2.94986963, 2.7518754], [0.114207022, 0.19389686, 0.606133878]),
    ("Cu_palik", [0.213228509, 0.919715405, 1.10241079], [3.92187333, 2.45733166, 2.13658404]),
    ("CuO", [3.24754095, 2.44780517, 2.21021962], [0.521089554, 0.570030749, 0.722178936]),
    ("CuO_palik", [3.24754095, 2.44780517, 2.21021962], [0.521089554, 0.570030749, 0.722178936]),
    ("d-C", [2.70871973, 2.31882572, 2.22889757], [0.0, 0.0, 0.0]),
    ("d-C_palik", [2.70871973, 2.31882572, 2.22889757], [0.0, 0.0, 0.0]),
    ("Hg", [2.39893866, 1.44002795, 0.909570396], [6.32758713, 4.37192488, 3.42176366]),
    ("Hg_palik", [2.39893866, 1.44002795, 0.909570396], [6.32758713, 4.37192488, 3.42176366]),
    ("HgTe", [4.77903986, 3.23119617, 2.65990114], [1.63161266, 1.58081043, 1.72928739]),
    ("HgTe_palik", [4.77903986, 3.23119617, 2.65990114], [1.63161266, 1.58081043, 1.72928739]),
    ("Ir", [3.0862999, 2.08219051, 1.61791456], [5.59215307, 4.06708813, 3.26731205]),
    ("Ir_palik", [3.0862999, 2.08219051, 1.61791456], [5.59215307, 4.06708813, 3.26731205]),
    ("K", [0.0640431866, 0.0464097671, 0.0381849147], [2.10419965, 1.34894001, 0.913125873]),
    ("K_palik", [0.0640431866, 0.0464097671, 0.0381849147], [2.10419965, 1.34894001, 0.913125873]),
    ("Li", [0.265790939, 0.195618317, 0.220948622], [3.54015493, 2.31112337, 1.66860723]),
    ("Li_palik", [0.265790939, 0.195618317, 0.220948622], [3.54015493, 2.31112337, 1.66860723]),
    ("MgO", [2.08958387, 1.65072346, 1.59487903], [4.33269523e-12, 0.0, 2.49864573e-11]),
    ("MgO_palik", [2.08958387, 1.65072346, 1.59487903], [4.33269523e-12, 0.0, 2.49864573e-11]),
    ("Mo", [4.48397398, 3.52513075, 2.77631044], [4.11143732, 3.42082691, 3.15060735]),
    ("Mo_palik", [4.48397398, 3.52513075, 2.77631044], [4.11143732, 3.42082691, 3.15060735]),
    ("Na_palik", [0.0602693558, 0.0561409481, 0.061988432], [3.17927337, 2.11249042, 1.57904112]),
    ("Nb", [3.42007399, 2.79009318, 2.39562941], [3.44139457, 2.73766613, 2.57974577]),
    ("Nb_palik", [3.42007399, 2.79009318, 2.39562941], [3.44139457, 2.73766613, 2.57974577]),
    ("Ni_palik", [2.36730456, 1.66337311, 1.46707809], [4.49881172, 3.05015302, 2.3454392]),
    ("Rh", [2.5857935, 1.86021638, 1.55426335], [6.78226042, 4.70298719, 3.97607303]),
    ("Rh_palik", [2.5857935, 1.86021638, 1.55426335], [6.78226042, 4.70298719, 3.97607303]),
    ("Se", [4.05831146, 2.84293509, 2.82085347], [0.75404954, 0.63844353, 0.521807551]),
    ("Se-e", [5.72284889, 4.1657362, 4.08133841], [0.871136308, 1.10515749, 1.56532025]),
    ("Se-e_palik", [5.72284889, 4.1657362, 4.08133841], [0.871136308, 1.10515749, 1.56532025]),
    ("Se_palik", [4.05831146, 2.84293509, 2.82085347], [0.75404954, 0.63844353, 0.521807551]),
    ("SiC", [3.17234159, 2.52597165, 2.47937059], [7.53766358e-07, 0.0, 1.01925307e-05]),
    ("SiC_palik", [3.17234159, 2.52597165, 2.47937059], [7.53766358e-07, 0.0, 1.01925307e-05]),
    ("SnTe", [4.52424955, 1.98164499, 1.2815913], [0.0, 0.0, 0.0]),
    ("SnTe_palik", [4.52424955, 1.98164499, 1.2815913], [0.0, 0.0, 0.0]),
    ("Ta", [2.06272101, 2.39293885, 2.62792873], [2.40835977, 1.74148643, 1.9470278]),
    ("Ta_palik", [2.06272101, 2.39293885, 2.62792873], [2.40835977, 1.74148643, 1.9470278]),
    ("Te", [7.39023352, 4.48210478, 2.63710594], [3.25602221, 3.52705884, 3.29205418]),
    ("Te-e", [7.50890684, 4.29642868, 2.36998773], [5.58392859, 4.94720507, 3.99759221]),
    ("Te-e_palik", [7.50890684, 4.29642868, 2.36998773], [5.58392859, 4.94720507, 3.99759221]),
    ("Te_palik", [7.39023352, 4.48210478, 2.63710594], [3.25602221, 3.52705884, 3.29205418]),
    ("ThF4", [1.83071363, 1.44222856, 1.38764763], [0.0, 0.0, 0.0]),
    ("ThF4_palik", [1.83071363, 1.44222856, 1.38764763], [0.0, 0.0, 0.0]),
    ("TiC", [3.70052838, 2.83742213, 2.58228707], [3.26563501, 2.3515892, 2.17279053]),
    ("TiC_palik", [3.70052838, 2.83742213, 2.58228707], [3.26563501, 2.3515892, 2.17279053]),
    ("TiN", [1.64844966, 1.15051603, 1.37982345], [3.36832809, 1.94349813, 1.10206771]),
    ("TiN_palik", [1.64844966, 1.15051603, 1.37982345], [3.36832809, 1.94349813, 1.10206771]),
    ("TiO2", [3.45660996, 2.80173588, 2.90517497], [0.000105264837, 0.0, 0.00065288652]),
    ("TiO2-e", [3.10656452, 2.51316833, 2.58244443], [2.97516053e-05, 0.0, 0.000182698088]),
    ("TiO2-e_palik", [3.10656452, 2.51316833, 2.58244443], [2.97516053e-05, 0.0, 0.000182698088]),
    ("TiO2_palik", [3.45660996, 2.80173588, 2.90517497], [0.000105264837, 0.0, 0.00065288652]),
    ("V_palik", [4.27758217, 3.51294875, 2.76107144], [3.49130082, 2.88945484, 3.11152196]),
    ("VC", [3.65756607, 2.75273609, 2.53267193], [3.06830072, 2.19868731, 1.9631927]),
    ("VC_palik", [3.65756607, 2.75273609, 2.53267193], [3.06830072, 2.19868731, 1.9631927]),
    ("VN", [2.86560225, 2.11918902, 1.94009113], [3.03224254, 2.05611563, 1.6163063]),
    ("VN_palik", [2.86560225, 2.11918902, 1.94009113], [3.03224254, 2.05611563, 1.6163063]),
    ("W", [4.37081671, 3.30024648, 2.99840736], [3.50064063, 2.6048739, 2.27323318]),];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dielectric_normal_incidence_and_total_internal_reflection() {
        let (r, cos_t, _, _) = fresnel_dielectric(1.0, 1.5);
        assert!((r - 0.04).abs() < 1e-12 && (cos_t + 1.0).abs() < 1e-12);
        // From inside glass beyond the critical angle: everything reflects.
        let (r, cos_t, _, _) = fresnel_dielectric(-0.2, 1.5);
        assert_eq!((r, cos_t), (1.0, 0.0));
        assert_eq!(fresnel_dielectric(0.3, 1.0).0, 0.0);
    }

    #[test]
    fn conductor_limits() {
        // η = 0, k = 1 is a perfect mirror at every angle.
        for c in [0.01, 0.3, 0.7, 1.0] {
            assert!((fresnel_conductor(c, 0.0, 1.0) - 1.0).abs() < 1e-12);
        }
        // k = 0 is a dielectric.
        for c in [0.1, 0.5, 1.0] {
            let d = fresnel_dielectric(c, 1.7).0;
            assert!((fresnel_conductor(c, 1.7, 0.0) - d).abs() < 1e-12, "{c}");
        }
        // Normal incidence: ((η−1)² + k²) / ((η+1)² + k²).
        let (e, k) = (0.2, 3.9);
        let r0 = ((e - 1.0) * (e - 1.0) + k * k) / ((e + 1.0) * (e + 1.0) + k * k);
        assert!((fresnel_conductor(1.0, e, k) - r0).abs() < 1e-12);
    }

    #[test]
    fn named_indices() {
        assert_eq!(conductor_ior("none").unwrap().k, Rgb::splat(1.0));
        assert!(conductor_ior("Au").unwrap().eta[0] < 0.2);
        assert!(conductor_ior("gold").is_none());
        assert_eq!(dielectric_ior("BK7"), Some(1.5046));
        assert_eq!(dielectric_ior("Acrylic Glass"), Some(1.49));
        assert!(dielectric_ior("unobtainium").is_none());
    }
}
