//! Mitsuba 3's point, spot, directional and constant emitters load as the
//! core's lights, with Mitsuba's defaults and conventions.

use glam::DVec3;
use std::path::Path;
use wavrad_core::scene::{Light, Rgb};
use wavrad_io::load_scene_str;

fn lights_of(xml: &str) -> Vec<Light> {
    let xml = format!("<scene version=\"3.0.0\">{xml}</scene>");
    load_scene_str(&xml, Path::new("."), "lights.xml", &[])
        .unwrap()
        .scene
        .lights
}

#[test]
fn lights_load_with_mitsubas_defaults_and_conventions() {
    let lights = lights_of(
        r#"<emitter type="point"><point name="position" x="1" y="2" z="3"/></emitter>
           <emitter type="point">
               <transform name="to_world"><translate x="-1"/></transform>
               <rgb name="intensity" value="2, 3, 4"/>
           </emitter>
           <emitter type="spot">
               <transform name="to_world"><lookat origin="0, 1, 0" target="0, 0, 0" up="0, 0, 1"/></transform>
           </emitter>
           <emitter type="directional"><vector name="direction" x="0" y="-2" z="0"/></emitter>
           <emitter type="constant"><float name="radiance" value="0.5"/></emitter>"#,
    );
    assert_eq!(lights.len(), 5);
    let point = |position: [f64; 3], intensity: Rgb| Light::Point {
        position: DVec3::from_array(position),
        intensity,
    };
    assert_eq!(lights[0], point([1.0, 2.0, 3.0], Rgb::splat(1.0)));
    assert_eq!(lights[1], point([-1.0, 0.0, 0.0], Rgb([2.0, 3.0, 4.0])));
    // A spot shines along its local +z, 20° wide, full within three quarters.
    let Light::Spot {
        position,
        axis,
        cutoff,
        beam_width,
        ..
    } = lights[2]
    else {
        panic!("{lights:?}")
    };
    assert!((position - DVec3::Y).length() < 1e-12);
    assert!((axis + DVec3::Y).length() < 1e-12, "{axis}");
    assert!((cutoff - 20f64.to_radians()).abs() < 1e-12);
    assert!((beam_width - 15f64.to_radians()).abs() < 1e-12);
    // A directional light travels along its (normalised) direction.
    assert_eq!(
        lights[3],
        Light::Directional {
            direction: -DVec3::Y,
            irradiance: Rgb::splat(1.0)
        }
    );
    assert_eq!(
        lights[4],
        Light::Constant {
            radiance: Rgb::splat(0.5)
        }
    );
}

/// `scenes/lights/envmap.xml`'s map, turned 100° about +y: its sun (3000 ×
/// (1, 0.9, 0.75) within 2.5° of (−0.3, 0.85, 0.4) in the map's frame)
/// lies along the turned direction, its zenith is the sky's brightest blue.
#[test]
fn envmap_loads_turned_by_its_to_world() {
    let scene =
        std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes/lights/envmap.xml");
    let lights = wavrad_io::load_scene(&scene).unwrap().scene.lights;
    let [Light::Envmap(map)] = &lights[..] else {
        panic!("{lights:?}")
    };
    let sun = DVec3::new(-0.3, 0.85, 0.4).normalize();
    let turned = glam::DMat3::from_rotation_y(100f64.to_radians()) * sun;
    let l = map.radiance(turned);
    assert!(l[0] > 1000.0 && l[0] > l[2], "{l}");
    assert!(map.radiance(sun)[0] < 10.0);
    let zenith = map.radiance(DVec3::Y);
    assert!((zenith[2] - 1.2).abs() < 1e-3, "{zenith}");
}

/// An envmap image of another format is read as Mitsuba reads it: Radiance
/// HDR as stored (the same map as the OpenEXR of the same values), an 8-bit
/// PNG made linear from sRGB.
#[test]
fn envmaps_of_hdr_and_png_images_read_as_linear_radiance() {
    let dir = tempfile::tempdir().unwrap();
    let sky = |x: u32, y: u32| [0.25 + x as f32, 2.0 * y as f32 + 0.5, 0.125];
    let float = image::Rgb32FImage::from_fn(8, 4, |x, y| image::Rgb(sky(x, y)));
    float.save(dir.path().join("sky.exr")).unwrap();
    float.save(dir.path().join("sky.hdr")).unwrap();
    image::RgbImage::from_pixel(8, 4, image::Rgb([128, 128, 128]))
        .save(dir.path().join("grey.png"))
        .unwrap();
    let map = |file: &str| {
        let xml = format!(
            "<scene version=\"3.0.0\"><emitter type=\"envmap\">\
             <string name=\"filename\" value=\"{file}\"/></emitter></scene>"
        );
        let loaded = wavrad_io::load_scene_str(&xml, dir.path(), "sky.xml", &[]);
        match &loaded.unwrap_or_else(|e| panic!("{e}")).scene.lights[..] {
            [Light::Envmap(map)] => map.clone(),
            other => panic!("{other:?}"),
        }
    };
    let (exr, hdr) = (map("sky.exr"), map("sky.hdr"));
    for k in 0..20 {
        let towards =
            DVec3::new((k as f64).cos(), 0.3 * k as f64 - 3.0, (k as f64).sin()).normalize();
        let (a, b) = (exr.radiance(towards), hdr.radiance(towards));
        // HDR stores 8-bit mantissas with a shared exponent.
        assert!(
            (a - b).0.iter().all(|d| d.abs() <= 0.01 * a.0[1].max(1.0)),
            "{a} vs {b}"
        );
    }
    // sRGB 128 is 0.2158605 linear (Mitsuba's srgb_to_linear).
    let grey = map("grey.png").radiance(DVec3::Y);
    assert!(
        grey.0.iter().all(|v| (v - 0.2158605).abs() < 1e-5),
        "{grey}"
    );
}
