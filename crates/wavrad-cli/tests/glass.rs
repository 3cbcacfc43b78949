//! Glass: an emitter of radiance L seen through a glass slab at normal
//! incidence shows L·(1 − R)/(1 + R) (the light passing the two interfaces
//! after any even number of reflections between them, R the Fresnel
//! reflectance at normal incidence), whether the slab is a solid
//! (`dielectric`, refracting in and out) or a thin pane
//! (`thindielectric`); a tilted slab shifts what is seen through it
//! sideways by Snell's law; and glass between a light (or the sky) and a
//! floor dims the floor by its transmittance (the photons of
//! `render/caustics.rs`).

use std::path::Path;

use glam::{DVec2, DVec3};
use wavrad_core::progress::Silent;
use wavrad_core::render::{RenderSettings, Renderer};
use wavrad_core::scene::Scene;
use wavrad_core::solve::{solve, SolveSettings};

/// Radiance of the emitter behind the glass.
const RADIANCE: f64 = 2.0;

/// Relative index of the glass.
const ETA: f64 = 1.5;

/// A camera on the z axis looking at the origin (`fov`°, `res`² pixels,
/// `spp` camera rays, box filter), a black emitter of [`RADIANCE`] facing
/// it from z = −3 as the `emitter_to_world` transform places it (reflecting
/// nothing the glass sends back), and the glass
/// `bsdf` on a `shape` (`cube`, `rectangle`) placed by `glass_to_world`.
fn scene_behind_glass(
    (fov, res, spp): (f64, u32, u32),
    emitter_to_world: &str,
    (shape, bsdf, glass_to_world): (&str, &str, &str),
) -> Scene {
    let xml = format!(
        r#"<scene version="3.0.0">
        {}
        {}
        <shape type="{shape}">
            <transform name="to_world">{glass_to_world}</transform>
            {bsdf}
        </shape>
    </scene>"#,
        sensor(6.0, (fov, res, spp)),
        black_emitter(emitter_to_world),
    );
    wavrad_io::load_scene_str(&xml, Path::new("."), "glass.xml", &[])
        .unwrap()
        .scene
}

/// A camera at height `z` on the z axis looking at the origin (`fov`°,
/// `res`² pixels, `spp` camera rays, box filter).
fn sensor(z: f64, (fov, res, spp): (f64, u32, u32)) -> String {
    format!(
        r#"<sensor type="perspective">
            <float name="fov" value="{fov}"/>
            <transform name="to_world"><lookat origin="0, 0, {z}" target="0, 0, 0" up="0, 1, 0"/></transform>
            <sampler type="independent"><integer name="sample_count" value="{spp}"/></sampler>
            <film type="hdrfilm"><integer name="width" value="{res}"/><integer name="height" value="{res}"/>
                <rfilter type="box"/></film>
        </sensor>"#
    )
}

/// A black rectangle emitting [`RADIANCE`] from its front, placed by
/// `to_world`: it reflects nothing the glass sends back.
fn black_emitter(to_world: &str) -> String {
    format!(
        r#"<shape type="rectangle">
            <transform name="to_world">{to_world}</transform>
            <emitter type="area"><rgb name="radiance" value="{RADIANCE}"/></emitter>
            <bsdf type="diffuse"><rgb name="reflectance" value="0"/></bsdf>
        </shape>"#
    )
}

/// The rendered image's red channel.
fn render(scene: &Scene) -> Vec<f64> {
    let solution = solve(scene, &SolveSettings::default(), &Silent).unwrap();
    let image = Renderer::new(solution)
        .render(&RenderSettings::for_scene(scene))
        .unwrap();
    image.rgb.chunks(3).map(|px| f64::from(px[0])).collect()
}

#[test]
fn an_emitter_seen_through_glass_at_normal_incidence_loses_its_fresnel_reflections() {
    let r = ((ETA - 1.0) / (ETA + 1.0)).powi(2);
    let expected = RADIANCE * (1.0 - r) / (1.0 + r);
    let big = "<scale value=\"5\"/><translate z=\"-3\"/>";
    // A solid slab, and one thin pane (a thin cube would be two).
    for (shape, bsdf) in [("cube", "dielectric"), ("rectangle", "thindielectric")] {
        let glass = format!(
            r#"<bsdf type="{bsdf}"><float name="int_ior" value="{ETA}"/><float name="ext_ior" value="1"/></bsdf>"#
        );
        let slab = "<scale x=\"2\" y=\"2\" z=\"0.3\"/>";
        let scene = scene_behind_glass((8.0, 8, 256), big, (shape, &glass, slab));
        assert_eq!(scene.glass.len(), 1);
        let image = render(&scene);
        let mean = image.iter().sum::<f64>() / image.len() as f64;
        eprintln!("{bsdf}: {mean:.5} against {expected:.5}");
        assert!((mean / expected - 1.0).abs() < 0.01, "{bsdf}: {mean}");
        assert!(image.iter().all(|&v| v < RADIANCE * 1.0001), "{bsdf}");
    }
}

/// Vector form of Snell's law (Glassner, *An Introduction to Ray
/// Tracing*, 1989): the direction `d` refracted at a surface of normal `n`
/// (facing against `d`) with index ratio `eta` (incident over transmitted).
fn refract(d: DVec3, n: DVec3, eta: f64) -> DVec3 {
    let cos_i = -d.dot(n);
    let k = 1.0 - eta * eta * (1.0 - cos_i * cos_i);
    eta * d + (eta * cos_i - k.sqrt()) * n
}

#[test]
fn a_tilted_slab_shifts_what_is_seen_through_it_by_snells_law() {
    // The emitter covers x < 0 behind a solid slab of thickness 2t turned
    // by θ about the y axis: each camera ray refracts into the slab and
    // out parallel to itself, shifted sideways, and the emitter's edge
    // shows where the shifted ray meets x = 0 on the emitter.
    let (theta, t) = (30f64.to_radians(), 0.3);
    let n = DVec3::new(theta.sin(), 0.0, theta.cos());
    let half_plane = "<scale x=\"2\" y=\"4\"/><translate x=\"-2\" z=\"-3\"/>";
    let glass = format!(
        r#"<bsdf type="dielectric"><float name="int_ior" value="{ETA}"/><float name="ext_ior" value="1"/></bsdf>"#
    );
    let slab = format!(
        "<scale x=\"3\" y=\"3\" z=\"{t}\"/><rotate y=\"1\" angle=\"{}\"/>",
        theta.to_degrees()
    );
    let res = 64;
    let scene = scene_behind_glass((6.0, res, 64), half_plane, ("cube", &glass, &slab));
    let image = render(&scene);
    let camera = scene.camera.unwrap();
    // Where the ray through film column boundary `col` of the middle row
    // meets the emitter's plane, through the slab, and without it.
    let x_at = |col: f64| {
        let ray = camera.ray(DVec2::new(col / f64::from(res), 0.5), 1.0);
        let plane = |p: DVec3, d: DVec3, offset: f64| p + d * (offset - n.dot(p)) / n.dot(d);
        let entry = plane(ray.origin, ray.direction, t);
        let inside = refract(ray.direction, n, 1.0 / ETA);
        let exit = plane(entry, inside, -t);
        let out = refract(inside, n, ETA);
        let to_emitter = |p: DVec3, d: DVec3| p.x + d.x * (-3.0 - p.z) / d.z;
        (to_emitter(exit, out), to_emitter(ray.origin, ray.direction))
    };
    let crossing = |through: bool| {
        (0..res).position(|c| {
            let (a, b) = (x_at(f64::from(c)), x_at(f64::from(c + 1)));
            let (a, b) = if through { (a.0, b.0) } else { (a.1, b.1) };
            (a < 0.0) != (b < 0.0)
        })
    };
    let (expected, unbent) = (crossing(true).unwrap(), crossing(false).unwrap());
    // Where the middle row crosses half the transmitted radiance.
    let row = &image[(res as usize / 2) * res as usize..][..res as usize];
    let half = 0.5 * row.iter().cloned().fold(0.0, f64::max);
    let seen = row
        .iter()
        .position(|&v| (v < half) != (row[0] < half))
        .unwrap();
    eprintln!("edge seen in column {seen}: Snell's law puts it in {expected}, no slab in {unbent}");
    assert!(seen.abs_diff(expected) <= 1, "{seen} vs {expected}");
    // The slab moves it many pixels.
    assert!(expected.abs_diff(unbent) > 5);
}

#[test]
fn an_emitter_mirrored_in_glass_shows_in_every_camera_ray_that_meets_the_glass() {
    // A thin pane turned 45° about the y axis mirrors the camera's rays
    // (along −z) towards +x, onto a wide emitter facing them; through the
    // pane there is nothing. Every pixel shows the emitter dimmed by the
    // pane's reflectance, 2R/(1 + R) at its centre's angle: the
    // reflection is split off each camera ray, not chosen by a few percent
    // of them (with the choice, stratified, pixels were up to 1.3 % off
    // here, and a highlight smaller than a pixel is found only now and
    // then).
    let mirrored = r#"<scale value="5"/><rotate y="1" angle="-90"/><translate x="3"/>"#;
    let glass = format!(
        r#"<bsdf type="thindielectric"><float name="int_ior" value="{ETA}"/><float name="ext_ior" value="1"/></bsdf>"#
    );
    let pane = r#"<scale value="2"/><rotate y="1" angle="45"/>"#;
    let scene = scene_behind_glass((8.0, 8, 64), mirrored, ("rectangle", &glass, pane));
    let image = render(&scene);
    let camera = scene.camera.unwrap();
    let normal = DVec3::new(1.0, 0.0, 1.0).normalize();
    let worst = (0..64)
        .map(|p| {
            let at = DVec2::new(
                (f64::from(p % 8) + 0.5) / 8.0,
                (f64::from(p / 8) + 0.5) / 8.0,
            );
            let r = fresnel(-camera.ray(at, 1.0).direction.dot(normal), ETA);
            image[p as usize] / (RADIANCE * 2.0 * r / (1.0 + r)) - 1.0
        })
        .fold(
            0.0f64,
            |worst, e| if e.abs() > worst.abs() { e } else { worst },
        );
    eprintln!(
        "pixels off their centre's reflection by at most {:.3} %",
        100.0 * worst
    );
    assert!(worst.abs() < 0.002, "{worst}");
}

/// The floor of a scene lit from straight above by a small black emitter,
/// seen from below the `glass` element (none, or a shape between them),
/// as an image's red channel.
fn floor_under(glass: &str) -> Vec<f64> {
    let light =
        black_emitter("<scale value=\"0.5\"/><rotate x=\"1\" angle=\"180\"/><translate z=\"10\"/>");
    floor_lit_by(&light, glass)
}

/// The floor of a scene lit by the `light` element, seen from below the
/// `glass` element, as an image's red channel.
fn floor_lit_by(light: &str, glass: &str) -> Vec<f64> {
    let xml = format!(
        r#"<scene version="3.0.0">
        {}
        <shape type="rectangle">
            <bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf>
        </shape>
        {}
        {glass}
    </scene>"#,
        sensor(2.0, (30.0, 8, 16)),
        light,
    );
    let scene = wavrad_io::load_scene_str(&xml, Path::new("."), "floor.xml", &[])
        .unwrap()
        .scene;
    render(&scene)
}

#[test]
fn glass_between_a_light_and_a_floor_passes_its_fresnel_transmittance() {
    // Light from a small emitter straight above, at height d = 10, through
    // a pane or a slab: the floor's irradiance is the open floor's times
    // the glass's transmittance at normal incidence, (1 − R)/(1 + R), and
    // for a slab of thickness t, which brings the emitter's image nearer by
    // t(1 − 1/η), times (d / (d − t(1 − 1/η)))² as well. The solve and the
    // shadow rays let the light through whole; the photons shot through
    // the glass make the difference. The glass is nearer the light than
    // the floor, so that what the slab's sides reflect inwards lands beyond
    // the floor (halfway, they would mirror the light onto its middle).
    let r = ((ETA - 1.0) / (ETA + 1.0)).powi(2);
    let transmittance = (1.0 - r) / (1.0 + r);
    let (d, t) = (10.0, 0.3);
    let nearer = (d / (d - t * (1.0 - 1.0 / ETA))).powi(2);
    let open = floor_under("");
    for (shape, bsdf, place, expected) in [
        (
            "rectangle",
            "thindielectric",
            "<scale value=\"1.3\"/><translate z=\"8\"/>".to_string(),
            transmittance,
        ),
        (
            "cube",
            "dielectric",
            format!(
                "<scale x=\"1.3\" y=\"1.3\" z=\"{}\"/><translate z=\"8\"/>",
                t / 2.0
            ),
            transmittance * nearer,
        ),
    ] {
        let glass = format!(
            r#"<shape type="{shape}"><transform name="to_world">{place}</transform>
                <bsdf type="{bsdf}"><float name="int_ior" value="{ETA}"/><float name="ext_ior" value="1"/></bsdf>
            </shape>"#
        );
        let covered = floor_under(&glass);
        let ratio = covered.iter().sum::<f64>() / open.iter().sum::<f64>();
        let worst = (covered.iter().zip(&open))
            .map(|(c, o)| (c / o / expected - 1.0).abs())
            .fold(0.0, f64::max);
        eprintln!("{bsdf}: covered/open {ratio:.5} against {expected:.5}, worst pixel {worst:.4}");
        assert!((ratio / expected - 1.0).abs() < 0.005, "{bsdf}: {ratio}");
        // The photons' density estimate is noisy at the scale of its disc.
        assert!(worst < 0.05, "{bsdf}: {worst}");
    }
}

#[test]
fn glass_dims_point_and_directional_lights_as_it_dims_emitters() {
    // A point light at height 10 through a pane, and parallel light
    // straight down through a slab (which cannot bring parallel light
    // nearer): both dim the floor by the transmittance at normal
    // incidence, the photons leaving the light itself.
    let r = ((ETA - 1.0) / (ETA + 1.0)).powi(2);
    let transmittance = (1.0 - r) / (1.0 + r);
    let point = r#"<emitter type="point"><point name="position" x="0" y="0" z="10"/>
        <rgb name="intensity" value="50"/></emitter>"#;
    let parallel = r#"<emitter type="directional"><vector name="direction" x="0" y="0" z="-1"/>
        <rgb name="irradiance" value="1"/></emitter>"#;
    for (light, shape, bsdf, scale) in [
        (
            point,
            "rectangle",
            "thindielectric",
            "<scale value=\"1.3\"/>",
        ),
        (
            parallel,
            "cube",
            "dielectric",
            "<scale x=\"1.3\" y=\"1.3\" z=\"0.15\"/>",
        ),
    ] {
        let glass = format!(
            r#"<shape type="{shape}"><transform name="to_world">{scale}<translate z="8"/></transform>
                <bsdf type="{bsdf}"><float name="int_ior" value="{ETA}"/><float name="ext_ior" value="1"/></bsdf>
            </shape>"#
        );
        let (open, covered) = (floor_lit_by(light, ""), floor_lit_by(light, &glass));
        let ratio = covered.iter().sum::<f64>() / open.iter().sum::<f64>();
        let worst = (covered.iter().zip(&open))
            .map(|(c, o)| (c / o / transmittance - 1.0).abs())
            .fold(0.0, f64::max);
        eprintln!(
            "{bsdf}: covered/open {ratio:.5} against {transmittance:.5}, worst pixel {worst:.4}"
        );
        assert!(
            (ratio / transmittance - 1.0).abs() < 0.005,
            "{bsdf}: {ratio}"
        );
        assert!(worst < 0.05, "{bsdf}: {worst}");
    }
}

/// Mitsuba's unpolarised Fresnel reflectance of a dielectric interface of
/// relative index `eta`, light arriving at angle θ with cos θ = `cos_i`
/// from outside (Born & Wolf's equations).
fn fresnel(cos_i: f64, eta: f64) -> f64 {
    let sin_t = (1.0 - cos_i * cos_i).sqrt() / eta;
    let cos_t = (1.0 - sin_t * sin_t).sqrt();
    let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    0.5 * (rs * rs + rp * rp)
}

#[test]
fn glass_dims_the_skys_light_by_its_transmittance_over_the_directions_it_covers() {
    // A constant sky of radiance L over a wide floor, under a thin pane of
    // half-width a at height h, the camera between them looking down: a
    // floor point p has lost L ∫ (1 − T(θ)) cos θ dω over the directions
    // through the pane, T(θ) = (1 − R)/(1 + R) the pane's transmittance at
    // incidence θ; over the pane's points q, dω cos θ = h² / |q − p|⁴ dA.
    // (What the pane reflects down comes from the floor, which the sky's
    // photons do not carry: light reflected by surfaces passes glass
    // unchanged.)
    let (a, h) = (3.0, 1.0);
    let sky = r#"<emitter type="constant"><rgb name="radiance" value="1"/></emitter>"#;
    let pane = format!(
        r#"<shape type="rectangle"><transform name="to_world"><scale value="{a}"/><translate z="{h}"/></transform>
            <bsdf type="thindielectric"><float name="int_ior" value="{ETA}"/><float name="ext_ior" value="1"/></bsdf>
        </shape>"#
    );
    let (res, fov, camera_z) = (8usize, 90.0, 0.9);
    let floor = |glass: &str| {
        let xml = format!(
            r#"<scene version="3.0.0">
            {}
            <shape type="rectangle"><transform name="to_world"><scale value="50"/></transform>
                <bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf></shape>
            {sky}
            {glass}
        </scene>"#,
            sensor(camera_z, (fov, res as u32, 16)),
        );
        let scene = wavrad_io::load_scene_str(&xml, Path::new("."), "sky.xml", &[])
            .unwrap()
            .scene;
        (render(&scene), scene.camera.unwrap())
    };
    let ((open, camera), (covered, _)) = (floor(""), floor(&pane));
    let lost = |p: DVec2| {
        let n = 400;
        let step = 2.0 * a / f64::from(n);
        let mut sum = 0.0;
        for i in 0..n {
            for j in 0..n {
                let q = DVec2::new(
                    -a + (f64::from(i) + 0.5) * step,
                    -a + (f64::from(j) + 0.5) * step,
                );
                let r2 = (q - p).length_squared() + h * h;
                let r = fresnel(h / r2.sqrt(), ETA);
                sum += (1.0 - (1.0 - r) / (1.0 + r)) * h * h / (r2 * r2) * step * step;
            }
        }
        sum / std::f64::consts::PI
    };
    let mut worst: f64 = 0.0;
    let (mut seen, mut expected) = (0.0, 0.0);
    for (k, (c, o)) in covered.iter().zip(&open).enumerate() {
        let film = DVec2::new((k % res) as f64 + 0.5, (k / res) as f64 + 0.5) / res as f64;
        let ray = camera.ray(film, 1.0);
        let at = ray.origin + ray.direction * (-ray.origin.z / ray.direction.z);
        let ratio = 1.0 - lost(DVec2::new(at.x, at.y));
        worst = worst.max((c / o / ratio - 1.0).abs());
        (seen, expected) = (seen + c / o, expected + ratio);
    }
    let (seen, expected) = (seen / open.len() as f64, expected / open.len() as f64);
    eprintln!(
        "sky through a pane: covered/open {seen:.5} against {expected:.5}, worst pixel {worst:.4}"
    );
    // The pane takes away a tenth of the sky's light.
    assert!(expected < 0.9);
    assert!(
        (seen / expected - 1.0).abs() < 0.005,
        "{seen} against {expected}"
    );
    // Photons from grazing directions carry most of the loss, so the
    // density estimate is noisier than under one light.
    assert!(worst < 0.06, "{worst}");
}
