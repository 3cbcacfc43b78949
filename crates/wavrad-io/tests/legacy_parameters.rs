//! Mitsuba 0.x parameters that mean something in the files people still
//! have: a texture's `uscale`/`vscale`/`uoffset`/`voffset`/`uvscale`, a
//! bitmap's MIP-map `filterType`, and a `<spectrum>` listing three values.

mod common;

use wavrad_core::scene::texture::{Texture, TextureFilter, UvTransform};
use wavrad_core::scene::Rgb;
use wavrad_io::Loaded;

/// `body` in a scene file of `version` beside `wall.png`.
fn load(version: &str, body: &str) -> wavrad_io::Result<Loaded> {
    common::load_beside_wall(version, body, false)
}

fn checker(params: &str) -> String {
    format!(
        r#"<shape type="rectangle"><bsdf type="diffuse">
             <texture type="checkerboard" name="reflectance">{params}</texture>
           </bsdf></shape>"#
    )
}

fn to_uv(loaded: &Loaded) -> UvTransform {
    match &loaded.scene.textures[0] {
        Texture::Checkerboard { to_uv, .. } => *to_uv,
        Texture::Bitmap(b) => b.to_uv,
    }
}

#[test]
fn uv_scale_and_offset_are_mitsuba_0x_texture_transform() {
    // Mitsuba 0.6's Texture2D looks up (u·uscale + uoffset, v·vscale + voffset).
    let loaded = load(
        "0.5.0",
        &checker(
            r#"<float name="uscale" value="4"/><float name="vscale" value="2"/>
               <float name="uoffset" value="0.25"/><float name="voffset" value="-0.5"/>"#,
        ),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(to_uv(&loaded).0, [4.0, 0.0, 0.25, 0.0, 2.0, -0.5]);
    // uvscale sets both scales; uscale still wins for u.
    let loaded = load(
        "0.6.0",
        &checker(r#"<float name="uvscale" value="3"/><float name="uscale" value="5"/>"#),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(to_uv(&loaded).0, [5.0, 0.0, 0.0, 0.0, 3.0, 0.0]);
    // Bitmaps take them too.
    let loaded = load(
        "0.5.0",
        r#"<shape type="rectangle"><bsdf type="diffuse">
             <texture type="bitmap" name="reflectance">
               <string name="filename" value="wall.png"/>
               <float name="uscale" value="10"/><float name="vscale" value="10"/>
             </texture></bsdf></shape>"#,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(to_uv(&loaded).0, [10.0, 0.0, 0.0, 0.0, 10.0, 0.0]);
}

#[test]
fn uv_parameters_are_mitsuba_0x_only_and_checked() {
    // A Mitsuba 3 file has no uscale (Mitsuba 3 refuses it as well).
    let e = load("3.0.0", &checker(r#"<float name="uscale" value="4"/>"#))
        .unwrap_err()
        .to_string();
    assert!(e.contains("scene.xml:3") && e.contains("uscale"), "{e}");
    // Given with a to_uv of its own, the texture has two.
    let e = load(
        "0.5.0",
        &checker(
            r#"<float name="uscale" value="4"/>
               <transform name="to_uv"><scale x="2"/></transform>"#,
        ),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("to_uv"), "{e}");
    // A value that is no number is an error at its line.
    let e = load("0.5.0", &checker(r#"<float name="vscale" value="big"/>"#))
        .unwrap_err()
        .to_string();
    assert!(e.contains("scene.xml:3") && e.contains("vscale"), "{e}");
}

#[test]
fn mip_map_filter_types_become_bilinear_with_a_warning() {
    for (filter, warned) in [("trilinear", true), ("ewa", true), ("nearest", false)] {
        let loaded = load(
            "0.5.0",
            &format!(
                r#"<shape type="rectangle"><bsdf type="diffuse">
                     <texture type="bitmap" name="reflectance">
                       <string name="filename" value="wall.png"/>
                       <string name="filterType" value="{filter}"/>
                     </texture></bsdf></shape>"#
            ),
        )
        .unwrap_or_else(|e| panic!("{filter}: {e}"));
        let Texture::Bitmap(b) = &loaded.scene.textures[0] else {
            panic!("{filter}: not a bitmap")
        };
        let expect = match warned {
            true => TextureFilter::Bilinear,
            false => TextureFilter::Nearest,
        };
        assert_eq!(b.filter, expect, "{filter}");
        let messages: Vec<String> = loaded.warnings.iter().map(|w| w.to_string()).collect();
        assert_eq!(
            messages
                .iter()
                .any(|m| m.contains(filter) && m.contains("bilinear")),
            warned,
            "{filter}: {messages:#?}"
        );
    }
    // Mitsuba 3 has no trilinear filter.
    let e = load(
        "3.0.0",
        r#"<shape type="rectangle"><bsdf type="diffuse">
             <texture type="bitmap" name="reflectance">
               <string name="filename" value="wall.png"/>
               <string name="filter_type" value="trilinear"/>
             </texture></bsdf></shape>"#,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("trilinear"), "{e}");
}

#[test]
fn three_valued_spectra_of_mitsuba_0x_are_rgb() {
    // Mitsuba 0.6's RGB build has three spectral samples: a list of three
    // values without wavelengths is red, green and blue.
    let body = r#"<shape type="rectangle">
                    <emitter type="area"><spectrum name="radiance" value="8.0 4.0, 2.0"/></emitter>
                  </shape>"#;
    let loaded = load("0.5.0", body).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(loaded.scene.surfaces[0].emission, Rgb([8.0, 4.0, 2.0]));
    // Mitsuba 3 refuses it (a spectrum is one value or wavelength:value pairs).
    assert!(load("3.0.0", body).is_err());
}
