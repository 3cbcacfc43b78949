//! Curved shapes (`sphere`, `disk`, `cylinder`): tessellated for the solve,
//! exact for camera rays.

use std::path::Path;

use glam::DVec3;
use wavrad_core::geometry::analytic::SeenHit;
use wavrad_core::geometry::tracing::SceneTracer;
use wavrad_core::scene::analytic::ShapeKind;
use wavrad_core::scene::Scene;
use wavrad_io::load_scene_str;

fn scene(body: &str) -> Scene {
    let xml = format!("<scene version=\"3.0.0\">{body}</scene>");
    let loaded = load_scene_str(&xml, Path::new("."), "test.xml", &[]).unwrap();
    assert_eq!(loaded.warnings, [], "unexpected warnings");
    loaded.scene
}

#[test]
fn each_curved_shape_keeps_its_exact_placement_and_the_surfaces_that_tessellate_it() {
    let s = scene(
        r#"<shape type="rectangle"/>
        <shape type="sphere" id="ball">
            <point name="center" x="0" y="1" z="2"/>
            <float name="radius" value="0.5"/>
            <bsdf type="twosided"><bsdf type="diffuse"/></bsdf>
        </shape>
        <shape type="disk">
            <transform name="to_world"><scale value="0.3"/><translate z="1"/></transform>
        </shape>
        <shape type="cylinder">
            <point name="p0" x="1" y="0" z="0"/>
            <point name="p1" x="1" y="3" z="0"/>
            <float name="radius" value="0.25"/>
        </shape>"#,
    );
    let kinds: Vec<_> = s
        .shapes
        .iter()
        .map(|c| (c.kind, c.surfaces.clone()))
        .collect();
    assert_eq!(
        kinds,
        [
            (ShapeKind::Sphere, 1..1057),
            (ShapeKind::Disk, 1057..1081),
            (ShapeKind::Cylinder, 1081..1105)
        ]
    );
    assert_eq!(s.surfaces.len(), 1105);
    let place = |k: usize, p: DVec3| s.shapes[k].world_from_shape.transform_point3(p);
    let close = |a: DVec3, b: DVec3| (a - b).length() < 1e-12;
    assert!(close(place(0, DVec3::ZERO), DVec3::new(0.0, 1.0, 2.0)));
    assert!(close(place(0, DVec3::Y), DVec3::new(0.0, 1.5, 2.0)));
    assert!(close(place(1, DVec3::X), DVec3::new(0.3, 0.0, 1.0)));
    assert!(close(place(2, DVec3::ZERO), DVec3::new(1.0, 0.0, 0.0)));
    assert!(close(place(2, DVec3::Z), DVec3::new(1.0, 3.0, 0.0)));
    let rim = place(2, DVec3::X) - DVec3::new(1.0, 0.0, 0.0);
    assert!((rim.length() - 0.25).abs() < 1e-12 && rim.y.abs() < 1e-12);
    s.check_bounds().unwrap();
}

/// A sphere of radius 0.5 at c = (0, 1, 2) (528 triangles: 24 arcs around
/// z, 12 from pole to pole) before a wall. Along the equator the
/// tessellation's vertices lie 0.72 % outside the sphere and its edges'
/// middles 0.14 % inside: a ray passing the centre at 0.999 r midway
/// between two vertices meets the sphere but not the tessellation, and one
/// passing at 1.003 r through a vertex's direction meets the tessellation
/// but not the sphere.
#[test]
fn a_ray_grazing_the_sphere_sees_it_where_the_tessellation_is_inside_and_only_there() {
    let s = scene(
        r#"<shape type="sphere" id="ball">
            <point name="center" x="0" y="1" z="2"/>
            <float name="radius" value="0.5"/>
        </shape>
        <shape type="rectangle" id="wall">
            <transform name="to_world">
                <scale value="10"/><rotate x="1" angle="90"/><translate y="4" z="2"/>
            </transform>
        </shape>"#,
    );
    let wall = s.surfaces.iter().position(|x| x.name == "wall").unwrap() as u32;
    let tracer = SceneTracer::new(&s);
    let (c, r) = (DVec3::new(0.0, 1.0, 2.0), 0.5);
    let grazing = |degrees: f64, offset: f64| {
        let (sin, cos) = degrees.to_radians().sin_cos();
        let (out, along) = (DVec3::new(cos, sin, 0.0), DVec3::new(-sin, cos, 0.0));
        (c + offset * r * out - 2.0 * along, along)
    };
    let far = f64::INFINITY;

    // Midway between two equator vertices, just inside the sphere.
    let (origin, dir) = grazing(7.5, 0.999);
    let plain = tracer.trace(origin, dir, 0.0, far).unwrap();
    assert_eq!(plain.surface, wall, "the tessellation is missed");
    let Some(SeenHit::Exact { hit, covering, .. }) = tracer.trace_seen(origin, dir, 0.0, far)
    else {
        panic!("the exact sphere is missed")
    };
    assert!(((hit.position - c).length() - r).abs() < 1e-12);
    assert!(
        (hit.normal - (hit.position - c) / r).length() < 1e-9,
        "exact normal"
    );
    let (under, q) = covering.unwrap();
    let surface = &s.surfaces[under as usize];
    assert_eq!(surface.name, "ball");
    assert!(surface.patch.normal().dot(hit.normal) > 0.98);
    let radial = ((q - c).normalize() - hit.normal).length();
    assert!(
        radial < 1e-9,
        "read under the point, along the radius: {radial}"
    );
    assert!(((q - c).length() / r - 1.0).abs() < 0.01);

    // In the direction of a vertex, just outside the sphere.
    let (origin, dir) = grazing(0.0, 1.003);
    let plain = tracer.trace(origin, dir, 0.0, far).unwrap();
    assert_eq!(s.surfaces[plain.surface as usize].name, "ball");
    match tracer.trace_seen(origin, dir, 0.0, far) {
        Some(SeenHit::Surface(h)) => assert_eq!(h.surface, wall, "the sphere is passed"),
        other => panic!("{other:?}"),
    }
}

/// The unit disk at z = 0 (a fan of 24 triangles whose rim vertices lie
/// 0.57 % outside the circle and chords' middles 0.29 % inside) and an open
/// cylinder of radius 1 around z from z = 2 to 3 (24 rectangles, their
/// edges 0.29 % outside the circle and their middles 0.57 % inside),
/// one-sided, above a floor: rays
/// just inside the exact rim midway between two vertices see the shapes
/// (the disk read on the fan triangle of that sector, though the point is
/// past its chord), rays just outside it through a vertex pass them.
#[test]
fn the_disk_and_cylinder_are_seen_to_their_exact_rims() {
    let s = scene(
        r#"<shape type="disk" id="disk"/>
        <shape type="cylinder" id="tube">
            <point name="p0" x="0" y="0" z="2"/>
            <point name="p1" x="0" y="0" z="3"/>
        </shape>
        <shape type="rectangle" id="floor">
            <transform name="to_world"><scale value="10"/><translate z="-1"/></transform>
        </shape>"#,
    );
    let floor = s.surfaces.iter().position(|x| x.name == "floor").unwrap() as u32;
    let tracer = SceneTracer::new(&s);
    let far = f64::INFINITY;
    let at = |degrees: f64, r: f64, z: f64| {
        let (sin, cos) = degrees.to_radians().sin_cos();
        DVec3::new(r * cos, r * sin, z)
    };
    let seen = |origin: DVec3, dir: DVec3| tracer.trace_seen(origin, dir, 0.0, far);

    // Straight down onto the disk's rim.
    let down = -DVec3::Z;
    let inside = at(7.5, 0.998, 1.0);
    assert_eq!(tracer.trace(inside, down, 0.0, far).unwrap().surface, floor);
    let Some(SeenHit::Exact { hit, covering, .. }) = seen(inside, down) else {
        panic!("the exact disk is missed")
    };
    assert!((hit.position - at(7.5, 0.998, 0.0)).length() < 1e-12);
    assert!((hit.normal - DVec3::Z).length() < 1e-12);
    let (under, q) = covering.unwrap();
    assert_eq!(s.surfaces[under as usize].name, "disk");
    let sector = q.y.atan2(q.x).to_degrees();
    assert!(
        (0.0..15.0).contains(&sector),
        "the fan triangle of 0°–15°: {sector}°"
    );
    assert!(q.z.abs() < 1e-12 && (q.truncate().length() - 0.997).abs() < 0.001);
    let outside = at(0.0, 1.004, 1.0);
    assert_eq!(
        s.surfaces[tracer.trace(outside, down, 0.0, far).unwrap().surface as usize].name,
        "disk"
    );
    assert!(matches!(seen(outside, down), Some(SeenHit::Surface(h)) if h.surface == floor));

    // Across the cylinder, grazing its wall at mid-height.
    let across = |degrees: f64, r: f64| {
        let along = at(degrees + 90.0, 1.0, 0.0);
        (at(degrees, r, 2.5) - 3.0 * along, along)
    };
    let (origin, dir) = across(7.5, 0.997);
    assert!(tracer.trace(origin, dir, 0.0, far).is_none());
    let Some(SeenHit::Exact { hit, covering, .. }) = seen(origin, dir) else {
        panic!("the exact cylinder is missed")
    };
    let radial = hit.position - DVec3::new(0.0, 0.0, 2.5);
    assert!((radial.length() - 1.0).abs() < 1e-12);
    assert!((hit.normal - radial).length() < 1e-9, "exact normal");
    let (under, q) = covering.unwrap();
    assert_eq!(s.surfaces[under as usize].name, "tube");
    assert!(
        (q.z - 2.5).abs() < 1e-12
            && (q.truncate().normalize().extend(0.0) - hit.normal).length() < 1e-9
    );
    let (origin, dir) = across(0.0, 1.002);
    assert!(tracer.trace(origin, dir, 0.0, far).is_some());
    assert_eq!(seen(origin, dir), None, "past the cylinder, nothing");
}
