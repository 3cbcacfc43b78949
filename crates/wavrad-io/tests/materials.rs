//! Materials people use: textures on reflectance, `plastic`, `conductor`,
//! and what `--approximate` puts in place of the rest.

use glam::{DVec2, DVec3};
use wavrad_core::scene::brdf::microfacet::{MicrofacetType, MIN_ALPHA};
use wavrad_core::scene::brdf::{Brdf, BrdfFlags, BrdfModel, Principled};
use wavrad_core::scene::texture::Texture;
use wavrad_core::scene::{Patch, Rgb, Scene};
use wavrad_io::Loaded;

mod common;
use common::repo;

/// `body` in a Mitsuba 3 scene file beside `wall.png`, loaded as
/// `approximate` says.
fn load(body: &str, approximate: bool) -> wavrad_io::Result<Loaded> {
    common::load_beside_wall("3.0.0", body, approximate)
}

fn scene(body: &str) -> Scene {
    let loaded = load(body, false).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(loaded.warnings, [], "unexpected warnings");
    loaded.scene
}

const CHECKER: &str = r#"<texture type="checkerboard" name="reflectance">
    <transform name="to_uv"><scale x="4" y="4"/></transform>
</texture>"#;

#[test]
fn a_checkerboard_is_read_at_mitsubas_uv_and_averaged_over_the_surface() {
    let s = scene(&format!(
        r#"<shape type="rectangle"><bsdf type="diffuse">{CHECKER}</bsdf></shape>"#
    ));
    assert_eq!(s.textures.len(), 1);
    let surface = &s.surfaces[0];
    let mapping = surface.texture.expect("textured");
    // Mitsuba's defaults 0.4 and 0.2, four periods each way: mean 0.3.
    let rho = surface.brdf.lambertian().unwrap();
    assert!((rho[0] - 0.3).abs() < 1e-12, "{rho}");
    // The rectangle's corner (-1, -1) is uv (0, 0): a color0 square.
    let near_corner = DVec2::new(0.05, 0.05);
    assert_eq!(s.lambertian_at(0, near_corner), Some(Rgb::splat(0.4)));
    assert_eq!(mapping.uv_at(DVec2::new(1.0, 0.0)), DVec2::X);
    assert_eq!(
        s.lambertian_at(0, DVec2::new(0.2, 0.05)),
        Some(Rgb::splat(0.2))
    );
}

#[test]
fn a_texture_is_stored_once_and_twosided_sides_read_the_same_point() {
    let s = scene(
        r#"<bsdf type="twosided" id="wall"><bsdf type="diffuse">
               <texture type="bitmap" name="reflectance">
                   <string name="filename" value="wall.png"/>
               </texture>
           </bsdf></bsdf>
           <shape type="rectangle"><ref id="wall"/></shape>
           <shape type="cube"><ref id="wall"/></shape>"#,
    );
    assert_eq!(s.textures.len(), 1, "one image for every surface");
    assert!(matches!(&s.textures[0], Texture::Bitmap(b) if b.width == 16));
    assert_eq!(s.surfaces.len(), 14);
    let (front, back) = (&s.surfaces[0], &s.surfaces[1]);
    let x = front.patch.point_at(DVec2::new(0.3, 0.8));
    let at = |k: usize| {
        let p = &s.surfaces[k].patch;
        s.lambertian_at(k, p.param_of(x)).unwrap()
    };
    assert!(
        (at(0) - at(1)).map(f64::abs).max_channel() < 1e-9,
        "{} {}",
        at(0),
        at(1)
    );
    assert_ne!(front.brdf.lambertian(), Some(Rgb::splat(0.5)));
    assert!(back.texture.is_some());
}

#[test]
fn plastic_and_conductor_are_their_rough_models_smooth_limits() {
    let s = scene(
        r#"<shape type="rectangle"><bsdf type="plastic">
               <rgb name="diffuse_reflectance" value="0.2, 0.4, 0.7"/>
               <float name="int_ior" value="1.5"/>
           </bsdf></shape>
           <shape type="rectangle"><bsdf type="conductor">
               <string name="material" value="Au"/>
           </bsdf></shape>"#,
    );
    match &s.surfaces[0].brdf {
        Brdf::RoughPlastic(p) => {
            assert_eq!(p.params().diffuse_reflectance, Rgb([0.2, 0.4, 0.7]));
            assert_eq!(p.params().int_ior, 1.5);
            assert!(p.params().alpha <= MIN_ALPHA);
        }
        other => panic!("{other:?}"),
    }
    match &s.surfaces[1].brdf {
        Brdf::RoughConductor(c) => assert_eq!(c.distribution.alpha_u, MIN_ALPHA),
        other => panic!("{other:?}"),
    }
    assert!(s.surfaces[1]
        .brdf
        .flags()
        .contains(BrdfFlags::GLOSSY_REFLECTION));
}

#[test]
fn unsupported_plugins_name_their_line_and_suggest_approximate() {
    for (body, plugin) in [
        (
            r#"<bsdf type="roughdielectric"><float name="alpha_u" value="0.1"/><float name="alpha_v" value="0.4"/></bsdf>"#,
            "bsdf \"roughdielectric\" with alpha_u and alpha_v unequal",
        ),
        (
            r#"<bsdf type="principled"><float name="spec_trans" value="0.5"/></bsdf>"#,
            "bsdf \"principled\" with specular transmission",
        ),
        (
            r#"<bsdf type="normalmap"><bsdf type="diffuse"/></bsdf>"#,
            "bsdf \"normalmap\"",
        ),
        (
            r#"<bsdf type="mask"><float name="opacity" value="0.3"/><bsdf type="diffuse"/></bsdf>"#,
            "bsdf \"mask\" with opacity below 1",
        ),
        (
            r#"<bsdf type="roughplastic"><texture type="checkerboard" name="diffuse_reflectance"/></bsdf>"#,
            "a texture on diffuse_reflectance",
        ),
        (
            r#"<bsdf type="blendbsdf"/>"#,
            "unsupported bsdf plugin \"blendbsdf\"",
        ),
    ] {
        let xml = format!("<shape type=\"rectangle\">\n{body}\n</shape>");
        let e = load(&xml, false).unwrap_err().to_string();
        assert!(e.contains("scene.xml:3"), "{e}");
        assert!(e.contains(plugin) && e.contains("--approximate"), "{e}");
    }
}

#[test]
fn approximate_substitutes_the_nearest_model_with_one_warning_per_plugin() {
    let loaded = load(
        r#"<shape type="rectangle"><bsdf type="roughdielectric">
                   <float name="alpha_u" value="0.1"/><float name="alpha_v" value="0.4"/>
               </bsdf></shape>
               <shape type="cube"><bsdf type="thindielectric"/></shape>
               <shape type="rectangle"><bsdf type="roughdielectric">
                   <string name="distribution" value="ggx"/>
                   <float name="alpha_u" value="0.3"/><float name="alpha_v" value="0.2"/>
               </bsdf></shape>
               <shape type="rectangle"><bsdf type="principled">
                   <rgb name="base_color" value="0.8, 0.1, 0.1"/>
                   <float name="roughness" value="0.3"/>
                   <float name="spec_trans" value="0.2"/>
               </bsdf></shape>
               <shape type="rectangle"><bsdf type="bumpmap">
                   <texture type="bitmap"><string name="filename" value="wall.png"/></texture>
                   <bsdf type="diffuse"/>
               </bsdf></shape>"#,
        true,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let messages: Vec<String> = loaded.warnings.iter().map(|w| w.to_string()).collect();
    assert_eq!(messages.len(), 3, "{messages:#?}");
    for plugin in [
        "bsdf \"roughdielectric\" with alpha_u and alpha_v unequal: isotropic",
        "bsdf \"principled\" with specular transmission: its reflection without it",
        "bsdf \"bumpmap\": its nested BSDF",
    ] {
        assert!(
            messages.iter().any(|m| m.contains(plugin)),
            "{plugin}: {messages:#?}"
        );
    }
    let s = loaded.scene;
    // Anisotropic rough glass is isotropic (thin glass is supported as it
    // is), not a surface; principled without its transmission is a red
    // Burley lobe of 0.8 its base, carried as a Lambertian lobe of its
    // albedo at roughness 0.3, under a GGX lobe of α = 0.3²; the bump map's
    // nested diffuse stays.
    let burley = wavrad_core::scene::brdf::principled::burley_albedo(0.3, 0.0);
    let expected = Rgb([0.8, 0.1, 0.1]).map(|c| c * 0.8 * burley);
    let close = |a: Rgb| (0..3).all(|c| (a[c] - expected[c]).abs() < 1e-12);
    assert!(matches!(&s.surfaces[0].brdf,
        Brdf::Principled(p) if close(p.diffuse_reflectance)
            && (p.distribution.alpha_u - 0.09).abs() < 1e-12
            && (p.eta - 1.5).abs() < 1e-12));
    assert!(s.surfaces[0].brdf.lambertian().is_some_and(close));
    assert_eq!(s.surfaces[1].brdf, Brdf::diffuse(Rgb::splat(0.5)));
    let glass: Vec<(bool, usize)> = (s.glass.iter())
        .map(|g| (g.interface.thin, g.faces.len()))
        .collect();
    assert_eq!(glass, [(false, 1), (true, 6), (false, 1)]);
    let roughness: Vec<Option<(MicrofacetType, f64, f64)>> = (s.glass.iter())
        .map(|g| {
            g.interface
                .roughness
                .map(|m| (m.kind, m.alpha_u, m.alpha_v))
        })
        .collect();
    let isotropic = |kind, alpha: f64| {
        move |r: Option<(MicrofacetType, f64, f64)>| {
            r.is_some_and(|(k, u, v)| k == kind && (u - alpha).abs() < 1e-12 && u == v)
        }
    };
    assert!(
        isotropic(MicrofacetType::Beckmann, 0.2)(roughness[0]),
        "{roughness:?}"
    );
    assert_eq!(roughness[1], None);
    assert!(
        isotropic(MicrofacetType::Ggx, 0.06f64.sqrt())(roughness[2]),
        "{roughness:?}"
    );
}

#[test]
fn glass_reads_mitsubas_indices_and_tints() {
    let loaded = load(
        r#"<shape type="sphere"><bsdf type="dielectric">
               <string name="int_ior" value="water"/>
               <float name="ext_ior" value="1.5"/>
               <rgb name="specular_transmittance" value="0.9, 0.8, 0.7"/>
           </bsdf></shape>
           <shape type="rectangle"><bsdf type="thindielectric"/></shape>"#,
        false,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    let s = loaded.scene;
    assert!(s.surfaces.is_empty());
    let [sphere, pane] = &s.glass[..] else {
        panic!("{:?}", s.glass)
    };
    // Water (1.3330) in a medium of 1.5; Mitsuba's default BK7 in air.
    assert!((sphere.interface.eta - 1.333 / 1.5).abs() < 1e-12);
    assert_eq!(sphere.interface.transmittance, Rgb([0.9, 0.8, 0.7]));
    assert_eq!(sphere.interface.reflectance, Rgb::splat(1.0));
    assert!(sphere.faces.iter().all(|(_, n)| n.is_some()));
    // Mitsuba's unit sphere, exact for the rays that meet it.
    assert_eq!(sphere.sphere, Some((glam::DVec3::ZERO, 1.0)));
    assert_eq!(pane.sphere, None);
    assert!(!sphere.interface.thin && pane.interface.thin);
    assert!((pane.interface.eta - 1.5046 / 1.000277).abs() < 1e-12);
    // Glass cannot emit.
    let e = load(
        r#"<shape type="rectangle"><bsdf type="dielectric"/>
               <emitter type="area"/></shape>"#,
        false,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("is glass"), "{e}");
}

/// The `principled` BRDF of a rectangle whose BSDF has the parameters
/// `params`, and the load's warnings.
fn principled(params: &str, approximate: bool) -> (Principled, Vec<String>) {
    let xml = format!(r#"<shape type="rectangle"><bsdf type="principled">{params}</bsdf></shape>"#);
    let loaded = load(&xml, approximate).unwrap_or_else(|e| panic!("{e}"));
    let Brdf::Principled(p) = loaded.scene.surfaces[0].brdf else {
        panic!("{:?}", loaded.scene.surfaces[0].brdf)
    };
    (p, loaded.warnings.iter().map(|w| w.to_string()).collect())
}

/// Without transmission, `principled` is read as it is, with no warning,
/// clearcoat, sheen and flatness included, whatever the sampling rates;
/// a parameter it does not have is an error at its line.
#[test]
fn principled_without_its_unmodelled_lobes_needs_no_approximation() {
    let (p, warnings) = principled(
        r#"<rgb name="base_color" value="0.8, 0.8, 0.8"/>
           <float name="roughness" value="0.4"/>
           <float name="spec_trans" value="0"/>
           <float name="clearcoat" value="0.6"/>
           <float name="clearcoat_gloss" value="0.5"/>
           <float name="sheen" value="0.4"/>
           <float name="sheen_tint" value="0.5"/>
           <float name="diffuse_reflectance_sampling_rate" value="2"/>"#,
        false,
    );
    assert!(warnings.is_empty(), "{warnings:?}");
    assert_eq!((p.burley, p.roughness), (Rgb::splat(0.8), 0.4));
    // The clearcoat's GTR1 roughness halfway between 0.1 and 0.001; a grey
    // base tints the sheen not at all.
    assert_eq!(p.clearcoat, 0.6);
    assert!((p.clearcoat_alpha - 0.0505).abs() < 1e-12);
    assert!(
        (0..3).all(|c| (p.sheen[c] - 0.4).abs() < 1e-12),
        "{}",
        p.sheen
    );
    let e = load(
        r#"<shape type="rectangle">
           <bsdf type="principled"><float name="glossiness" value="0.5"/></bsdf></shape>"#,
        false,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("scene.xml:3") && e.contains("glossiness"), "{e}");
}

/// A texture on `base_color` of a `principled` without metallic or tint
/// is its diffuse lobe's albedo texture, scaled by Burley's albedo as the
/// lobe is, its mean the Lambertian lobe; where the base also tints the
/// specular lobe, the texture is its mean, with `--approximate` only.
#[test]
fn principled_base_color_texture_is_its_diffuse_lobes() {
    let checker = r#"<texture type="checkerboard" name="base_color">
            <rgb name="color0" value="0.8"/><rgb name="color1" value="0.2"/></texture>
        <float name="roughness" value="0.7"/>"#;
    let xml =
        format!(r#"<shape type="rectangle"><bsdf type="principled">{checker}</bsdf></shape>"#);
    let loaded = load(&xml, false).unwrap_or_else(|e| panic!("{e}"));
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    let s = &loaded.scene;
    let burley = wavrad_core::scene::brdf::principled::burley_albedo(0.7, 0.0);
    let Some(mapping) = s.surfaces[0].texture else {
        panic!("no texture")
    };
    let texture = &s.textures[mapping.texture as usize];
    for (uv, v) in [(DVec2::new(0.1, 0.1), 0.8), (DVec2::new(0.6, 0.1), 0.2)] {
        assert!((texture.eval(uv)[0] - v * burley).abs() < 1e-6, "{uv}");
    }
    let rho = s.surfaces[0].brdf.lambertian().unwrap();
    assert!((rho[0] - 0.5 * burley).abs() < 1e-9, "{rho:?}");
    assert!(
        matches!(&s.surfaces[0].brdf, Brdf::Principled(p) if (p.burley[0] - 0.5).abs() < 1e-9),
        "{:?}",
        s.surfaces[0].brdf
    );
    let metallic = format!(
        r#"<shape type="rectangle"><bsdf type="principled">{checker}
           <float name="metallic" value="0.5"/></bsdf></shape>"#
    );
    let e = load(&metallic, false).unwrap_err().to_string();
    assert!(e.contains("scene.xml:2") && e.contains("base_color"), "{e}");
    let approximated = load(&metallic, true).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(approximated.scene.surfaces[0].texture, None);
    assert_eq!(
        approximated.warnings.len(),
        1,
        "{:?}",
        approximated.warnings
    );
}

#[test]
fn approximate_principled_keeps_metallic_eta_and_the_diffuse_weight() {
    let (p, _) = principled(
        r#"<rgb name="base_color" value="0.9, 0.6, 0.2"/>
           <float name="metallic" value="0.25"/>
           <float name="spec_trans" value="0.5"/>
           <float name="eta" value="1.33"/>
           <float name="anisotropic" value="0.5"/>
           <float name="clearcoat" value="0.7"/>"#,
        true,
    );
    // base (1 − metallic)(1 − spec_trans), times Burley's albedo at the
    // default roughness 0.5; η as given; α = 0.25 stretched by √(1 − 0.45).
    let burley = wavrad_core::scene::brdf::principled::burley_albedo(0.5, 0.0);
    let expect = Rgb([0.9, 0.6, 0.2]).map(|c| c * 0.75 * 0.5 * burley);
    assert!((0..3).all(|c| (p.diffuse_reflectance.0[c] - expect.0[c]).abs() < 1e-12));
    assert_eq!((p.metallic, p.eta), (0.25, 1.33));
    let aspect = 0.55f64.sqrt();
    assert!((p.distribution.alpha_u - 0.25 / aspect).abs() < 1e-12);
    assert!((p.distribution.alpha_v - 0.25 * aspect).abs() < 1e-12);
    assert!(p.flags().contains(BrdfFlags::ANISOTROPIC));
    // Head on, a quarter of the metal's Schlick (its base colour) joins
    // three quarters of the dielectric's ((0.33/2.33)²).
    let f0 = 0.75 * (0.33f64 / 2.33).powi(2);
    for (f, b) in p.fresnel(1.0).0.into_iter().zip([0.9, 0.6, 0.2]) {
        assert!((f - (f0 + 0.25 * b)).abs() < 1e-12, "{f}");
    }
    // A non-positive eta is an error at its line.
    let e = load(
        r#"<shape type="rectangle"><bsdf type="principled">
               <float name="eta" value="0"/></bsdf></shape>"#,
        true,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("scene.xml:3") && e.contains("eta"), "{e}");
}

#[test]
fn mesh_texture_coordinates_follow_mitsubas_conventions() {
    // One triangle with uv (0.1, 0.2), (0.3, 0.4), (0.5, 0.6): Mitsuba 3.9.1
    // reads the OBJ's v as 1 − v (flip_tex_coords defaults to true there)
    // and the PLY's as stored.
    let dir = tempfile::tempdir().unwrap();
    let obj = dir.path().join("t.obj");
    std::fs::write(
        &obj,
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.1 0.2\nvt 0.3 0.4\nvt 0.5 0.6\nf 1/1 2/2 3/3\n",
    )
    .unwrap();
    let ply = dir.path().join("t.ply");
    std::fs::write(
        &ply,
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
         property float z\nproperty float u\nproperty float v\nelement face 1\n\
         property list uchar int vertex_indices\nend_header\n\
         0 0 0 0.1 0.2\n1 0 0 0.3 0.4\n0 1 0 0.5 0.6\n3 0 1 2\n",
    )
    .unwrap();
    let wall = repo().join("scenes/textured-cornell-box/wall.png");
    for (file, flip, v0) in [
        ("t.obj", None, 0.8),
        ("t.obj", Some(false), 0.2),
        ("t.ply", None, 0.2),
        ("t.ply", Some(true), 0.8),
    ] {
        let flip = flip.map_or(String::new(), |f| {
            format!("<boolean name=\"flip_tex_coords\" value=\"{f}\"/>")
        });
        let plugin = &file[2..];
        let xml = format!(
            r#"<scene version="3.0.0"><shape type="{plugin}">
                 <string name="filename" value="{}"/>{flip}
                 <bsdf type="diffuse"><texture type="bitmap" name="reflectance">
                     <string name="filename" value="{}"/></texture></bsdf>
               </shape></scene>"#,
            dir.path().join(file).display(),
            wall.display()
        );
        let s = wavrad_io::load_scene_str(&xml, dir.path(), "mesh.xml", &[])
            .unwrap_or_else(|e| panic!("{e}"))
            .scene;
        let uv = s.surfaces[0].texture.unwrap().uv_at(DVec2::ZERO);
        assert!(
            (uv.x - 0.1).abs() < 1e-6 && (uv.y - v0).abs() < 1e-6,
            "{file}: {uv}"
        );
    }
}

/// The texture coordinates the surfaces of `scene` give where the ray from
/// `origin` along `direction` first meets them.
fn uv_along(scene: &Scene, origin: DVec3, direction: DVec3) -> DVec2 {
    let mut nearest = (f64::INFINITY, DVec2::NAN);
    for surface in &scene.surfaces {
        let patch = &surface.patch;
        let (normal, corner) = (patch.normal(), patch.vertices()[0]);
        let t = (corner - origin).dot(normal) / direction.dot(normal);
        let param = patch.param_of(origin + t * direction);
        let inside = match patch {
            Patch::Triangle(_) => param.min_element() >= -1e-9 && param.element_sum() <= 1.0 + 1e-9,
            Patch::Parallelogram { .. } => {
                param.min_element() >= -1e-9 && param.max_element() <= 1.0 + 1e-9
            }
        };
        if t > 1e-9 && t < nearest.0 && inside {
            nearest = (t, surface.texture.expect("textured").uv_at(param));
        }
    }
    nearest.1
}

#[test]
fn curved_shapes_carry_mitsubas_texture_coordinates() {
    use std::f64::consts::{PI, TAU};
    let bsdf = format!(r#"<bsdf type="diffuse">{CHECKER}</bsdf>"#);
    let placed = r#"<transform name="to_world"><scale value="2"/><translate x="1" y="-1" z="0.5"/></transform>"#;
    let scene_of =
        |plugin: &str| scene(&format!(r#"<shape type="{plugin}">{placed}{bsdf}</shape>"#));
    let centre = DVec3::new(1.0, -1.0, 0.5);
    let unwrap = |u: f64, near: f64| u + (near - u).round();
    // Directions all round the axis, across the seam at φ = 0, and away
    // from the sphere's poles, where u is any.
    for k in 0..40 {
        let phi = TAU * (k as f64 + 0.37) / 40.0;
        let around = DVec3::new(phi.cos(), phi.sin(), 0.0);
        let u = phi / TAU;
        for (plugin, origin, direction, expected) in [
            // Mitsuba's sphere: (φ/2π, θ/π).
            (
                "sphere",
                centre,
                around * 0.8 + DVec3::Z * 0.6,
                DVec2::new(u, 0.6f64.acos() / PI),
            ),
            // Its cylinder: (φ/2π, z) for z from 0 to 1 along its axis.
            (
                "cylinder",
                centre + DVec3::Z * 2.0 * 0.3,
                around,
                DVec2::new(u, 0.3),
            ),
            // Its disk: (r, φ/2π).
            (
                "disk",
                centre + around * 2.0 * 0.7 + DVec3::Z,
                -DVec3::Z,
                DVec2::new(0.7, u),
            ),
        ] {
            let uv = uv_along(&scene_of(plugin), origin, direction);
            let uv = match plugin {
                "disk" => DVec2::new(uv.x, unwrap(uv.y, expected.y)),
                _ => DVec2::new(unwrap(uv.x, expected.x), uv.y),
            };
            assert!(
                (uv - expected).abs().max_element() < 0.01,
                "{plugin} at φ = {phi}: {uv} vs {expected}"
            );
        }
    }
    // Each surface's albedo is the checkerboard's mean over it.
    let sphere = scene_of("sphere");
    let mean: f64 = sphere
        .surfaces
        .iter()
        .map(|s| s.brdf.lambertian().unwrap()[0] * s.patch.area())
        .sum::<f64>()
        / sphere.surfaces.iter().map(|s| s.patch.area()).sum::<f64>();
    assert!((mean - 0.3).abs() < 0.01, "{mean}");
}

/// A `principled` whose base all transmits is the glass Mitsuba evaluates
/// it as: a rough dielectric of η from `specular`, GGX α = roughness², its
/// transmission tinted by √`base_color`; partly transmitting, or metallic,
/// it is approximated (its reflection without the transmission).
#[test]
fn a_wholly_transmissive_principled_is_rough_glass() {
    let loaded = load(
        r#"<shape type="sphere"><bsdf type="twosided"><bsdf type="principled">
               <rgb name="base_color" value="0.81, 0.64, 0.25"/>
               <float name="spec_trans" value="1"/>
               <float name="roughness" value="0.4"/>
           </bsdf></bsdf></shape>"#,
        false,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    let glass = &loaded.scene.glass[0].interface;
    assert!((glass.eta - 1.5).abs() < 1e-12 && !glass.thin);
    assert_eq!(glass.reflectance, Rgb::splat(1.0));
    assert!((0..3).all(|c| (glass.transmittance[c] - [0.9, 0.8, 0.5][c]).abs() < 1e-12));
    let m = glass.roughness.unwrap();
    assert_eq!(m.kind, MicrofacetType::Ggx);
    assert!((m.alpha_u - 0.16).abs() < 1e-12 && m.alpha_u == m.alpha_v);
    for partly in [
        r#"<float name="spec_trans" value="0.5"/>"#,
        r#"<float name="spec_trans" value="1"/><float name="metallic" value="0.3"/>"#,
    ] {
        let xml =
            format!(r#"<shape type="rectangle"><bsdf type="principled">{partly}</bsdf></shape>"#);
        let e = load(&xml, false).unwrap_err().to_string();
        assert!(e.contains("specular transmission"), "{e}");
        assert!(load(&xml, true).unwrap().scene.glass.is_empty());
    }
}
