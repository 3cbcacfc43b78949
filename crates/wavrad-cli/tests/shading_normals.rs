//! A lone sphere lit by a directional light, rendered by the final gather:
//! seen exactly by camera rays, or as its tessellation with its shading
//! normals, it looks round, each pixel within a few per cent of the exact
//! sphere's ρ/π · E · cos θ; its tessellation shaded with the facets'
//! normals instead shows the 15° steps of light.

use std::path::Path;

use glam::{DVec2, DVec3};
use wavrad_core::progress::Silent;
use wavrad_core::render::{RenderSettings, Renderer};
use wavrad_core::scene::Scene;
use wavrad_core::solve::{solve, SolveSettings};

/// Radius and centre of the sphere, direction of the light's travel,
/// irradiance and albedo.
const RADIUS: f64 = 0.8;
const TRAVEL: DVec3 = DVec3::new(-0.6, -0.5, -0.62);
const IRRADIANCE: f64 = 2.0;
const ALBEDO: f64 = 0.6;

fn lone_sphere() -> Scene {
    let xml = format!(
        r#"<scene version="3.0.0">
        <sensor type="perspective">
            <float name="fov" value="40"/>
            <transform name="to_world"><lookat origin="0, 0, 3" target="0, 0, 0" up="0, 1, 0"/></transform>
            <sampler type="independent"><integer name="sample_count" value="16"/></sampler>
            <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="32"/>
                <rfilter type="box"/></film>
        </sensor>
        <emitter type="directional">
            <vector name="direction" x="{}" y="{}" z="{}"/>
            <rgb name="irradiance" value="{IRRADIANCE}"/>
        </emitter>
        <shape type="sphere"><float name="radius" value="{RADIUS}"/>
            <bsdf type="diffuse"><rgb name="reflectance" value="{ALBEDO}"/></bsdf></shape>
    </scene>"#,
        TRAVEL.x, TRAVEL.y, TRAVEL.z
    );
    wavrad_io::load_scene_str(&xml, Path::new("."), "sphere.xml", &[])
        .unwrap()
        .scene
}

/// relRMSE of the render of `scene` against the exact sphere's radiance at
/// each pixel's centre, over the pixels whose centre sees the sphere well
/// inside its outline and lit at more than 15° above its terminator.
fn error_against_the_exact_sphere(scene: &Scene) -> f64 {
    let solution = solve(scene, &SolveSettings::default(), &Silent).unwrap();
    let image = Renderer::new(solution)
        .render(&RenderSettings::for_scene(scene))
        .unwrap();
    let camera = scene.camera.unwrap();
    let (w, h) = (scene.film.width as usize, scene.film.height as usize);
    let to_light = -TRAVEL.normalize();
    let (mut sq, mut sum, mut n) = (0.0, 0.0, 0usize);
    for y in 0..h {
        for x in 0..w {
            let film = DVec2::new((x as f64 + 0.5) / w as f64, (y as f64 + 0.5) / h as f64);
            let ray = camera.ray(film, w as f64 / h as f64);
            // Nearest intersection with the exact sphere.
            let b = ray.origin.dot(ray.direction);
            let disc = b * b - (ray.origin.length_squared() - RADIUS * RADIUS);
            if disc <= 0.0 {
                continue;
            }
            let normal = (ray.origin + ray.direction * (-b - disc.sqrt())) / RADIUS;
            let cos = normal.dot(to_light);
            if normal.dot(-ray.direction) < 0.3 || cos < 0.26 {
                continue;
            }
            let exact = ALBEDO / std::f64::consts::PI * IRRADIANCE * cos;
            let got = f64::from(image.rgb[3 * (y * w + x)]);
            (sq, sum, n) = (sq + (got - exact).powi(2), sum + exact, n + 1);
        }
    }
    assert!(n > 200, "{n} pixels");
    (sq / n as f64).sqrt() / (sum / n as f64)
}

#[test]
fn lone_sphere_is_shaded_round() {
    let scene = lone_sphere();
    assert!(scene.surfaces.iter().all(|s| s.shading.is_some()));
    let exact = error_against_the_exact_sphere(&scene);
    // Camera rays on the tessellation, shaded with its shading normals,
    // then with its facets' normals.
    let mut tessellated = scene.clone();
    tessellated.shapes.clear();
    let smooth = error_against_the_exact_sphere(&tessellated);
    let mut faceted = tessellated.clone();
    for s in &mut faceted.surfaces {
        s.shading = None;
    }
    let flat = error_against_the_exact_sphere(&faceted);
    eprintln!(
        "relRMSE against the exact sphere: exact sphere seen {exact:.4}, tessellation with \
         shading normals {smooth:.4}, facets {flat:.4}"
    );
    assert!(exact < 0.005, "exact sphere: relRMSE {exact}");
    assert!(smooth < 0.015, "shading normals: relRMSE {smooth}");
    assert!(
        flat > 4.0 * smooth,
        "facets {flat} vs shading normals {smooth}"
    );
}
