//! The glossy BRDFs against Mitsuba: `roughconductor`, `roughplastic` and
//! `principled` (with clearcoat and sheen) evaluated by Mitsuba 3.9.1 itself, `ward` by a line-for-line Python port
//! of Mitsuba 0.6's `ward.cpp` run as a Mitsuba 3 plugin. The table is
//! written by `tests/data/make_mitsuba_brdf_table.py`; this test only reads
//! it.

use glam::DVec3;
use serde_json::Value;
use wavrad_core::scene::brdf::fresnel::{conductor_ior, dielectric_ior};
use wavrad_core::scene::brdf::{
    Brdf, BrdfModel, Microfacet, MicrofacetType, Principled, PrincipledParams, RoughConductor,
    RoughPlastic, RoughPlasticParams, Ward, WardVariant,
};
use wavrad_core::scene::Rgb;

/// Mitsuba evaluates in float32: values agree to this relative tolerance…
const RELATIVE: f64 = 1e-4;
/// …or are both negligible against the set's largest value.
const NEGLIGIBLE: f64 = 1e-7;

fn color(params: &Value, key: &str, default: f64) -> Rgb {
    match params.get(key) {
        None => Rgb::splat(default),
        Some(Value::Array(v)) => Rgb(std::array::from_fn(|c| v[c].as_f64().unwrap())),
        Some(v) => Rgb::splat(v.as_f64().unwrap()),
    }
}

fn float(params: &Value, key: &str) -> Option<f64> {
    params.get(key).map(|v| v.as_f64().unwrap())
}

fn ior(params: &Value, key: &str, default: f64) -> f64 {
    match params.get(key) {
        None => default,
        Some(Value::String(name)) => dielectric_ior(name).unwrap(),
        Some(v) => v.as_f64().unwrap(),
    }
}

fn distribution(params: &Value) -> Microfacet {
    let kind = params
        .get("distribution")
        .map_or(MicrofacetType::Beckmann, |d| {
            MicrofacetType::from_name(d.as_str().unwrap()).unwrap()
        });
    let alpha = float(params, "alpha").unwrap_or(0.1);
    Microfacet::new(
        kind,
        float(params, "alpha_u").unwrap_or(alpha),
        float(params, "alpha_v").unwrap_or(alpha),
    )
}

fn brdf(params: &Value) -> Brdf {
    match params["type"].as_str().unwrap() {
        "roughconductor" => {
            let named = params
                .get("material")
                .map_or("none", |m| m.as_str().unwrap());
            let ior = conductor_ior(named).unwrap();
            Brdf::RoughConductor(RoughConductor {
                distribution: distribution(params),
                eta: if params.get("eta").is_some() {
                    color(params, "eta", 0.0)
                } else {
                    ior.eta
                },
                k: if params.get("k").is_some() {
                    color(params, "k", 1.0)
                } else {
                    ior.k
                },
                specular_reflectance: color(params, "specular_reflectance", 1.0),
            })
        }
        "roughplastic" => {
            let d = distribution(params);
            Brdf::RoughPlastic(RoughPlastic::new(RoughPlasticParams {
                distribution: d.kind,
                alpha: d.alpha_u,
                int_ior: ior(params, "int_ior", 1.49),
                ext_ior: ior(params, "ext_ior", 1.000277),
                specular_reflectance: color(params, "specular_reflectance", 1.0),
                diffuse_reflectance: color(params, "diffuse_reflectance", 0.5),
                nonlinear: params
                    .get("nonlinear")
                    .is_some_and(|v| v.as_bool().unwrap()),
            }))
        }
        "ward" => {
            let d = distribution(params);
            Brdf::Ward(Ward {
                variant: WardVariant::from_name(params["variant"].as_str().unwrap()).unwrap(),
                alpha_u: d.alpha_u,
                alpha_v: d.alpha_v,
                specular_reflectance: color(params, "specular_reflectance", 0.2),
                diffuse_reflectance: color(params, "diffuse_reflectance", 0.5),
            })
        }
        "principled" => {
            let defaults = PrincipledParams::default();
            let or = |key: &str, default: f64| float(params, key).unwrap_or(default);
            Brdf::Principled(Principled::new(PrincipledParams {
                base_color: color(params, "base_color", 0.5),
                roughness: or("roughness", defaults.roughness),
                anisotropic: or("anisotropic", defaults.anisotropic),
                metallic: or("metallic", defaults.metallic),
                specular: or("specular", defaults.specular),
                eta: float(params, "eta"),
                spec_tint: or("spec_tint", defaults.spec_tint),
                spec_trans: or("spec_trans", defaults.spec_trans),
                clearcoat: or("clearcoat", defaults.clearcoat),
                clearcoat_gloss: or("clearcoat_gloss", defaults.clearcoat_gloss),
                sheen: or("sheen", defaults.sheen),
                sheen_tint: or("sheen_tint", defaults.sheen_tint),
                flatness: or("flatness", defaults.flatness),
            }))
        }
        other => panic!("unknown model {other}"),
    }
}

#[test]
fn brdf_eval_matches_mitsuba() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/mitsuba_brdf_eval.json"
    );
    let table: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let mut report = Vec::new();
    let mut failures = Vec::new();
    for set in table["sets"].as_array().unwrap() {
        let params = &set["params"];
        let model = brdf(params);
        let rows: Vec<[f64; 9]> = set["pairs"]
            .as_array()
            .unwrap()
            .iter()
            .map(|r| std::array::from_fn(|i| r[i].as_f64().unwrap()))
            .collect();
        assert!(rows.len() >= 100);
        let scale = rows
            .iter()
            .flat_map(|r| r[6..9].iter().copied())
            .fold(0.0, f64::max);
        let mut worst = 0.0f64;
        for r in &rows {
            let (wi, wo) = (DVec3::new(r[0], r[1], r[2]), DVec3::new(r[3], r[4], r[5]));
            let ours = model.eval(wo, wi);
            for c in 0..3 {
                let (a, b) = (ours[c], r[6 + c]);
                let diff = (a - b).abs();
                if diff <= NEGLIGIBLE * scale {
                    continue;
                }
                let rel = diff / a.abs().max(b.abs());
                worst = worst.max(rel);
                if rel > RELATIVE {
                    failures.push(format!(
                        "{params}: wi {wi} wo {wo} ch {c}: {a} vs {b} ({rel:.2e})"
                    ));
                }
            }
        }
        report.push(format!("{params}: max rel diff {worst:.2e}"));
    }
    println!("{}", report.join("\n"));
    assert!(
        failures.is_empty(),
        "{} mismatches, first: {:#?}\n{}",
        failures.len(),
        &failures[..failures.len().min(8)],
        report.join("\n")
    );
}
