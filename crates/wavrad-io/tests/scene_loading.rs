//! Loading valid Mitsuba scenes: geometry, materials, emitters, sensors.

use std::f64::consts::PI;
use std::fs;
use std::path::{Path, PathBuf};

use glam::DVec3;
use wavrad_core::scene::{FovAxis, Patch, PixelFilter, Projection, Rgb, Scene};
use wavrad_io::{load_scene, load_scene_str, load_scene_with};

/// Load `xml`, which must load without warnings.
fn load(xml: &str) -> Scene {
    let loaded =
        load_scene_str(xml, Path::new("."), "test.xml", &[]).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(loaded.warnings, [], "unexpected warnings");
    loaded.scene
}

fn scene(body: &str) -> Scene {
    load(&format!("<scene version=\"3.0.0\">{body}</scene>"))
}

fn close(a: DVec3, b: DVec3) -> bool {
    a.abs_diff_eq(b, 1e-9)
}

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../tests/fixtures")
        .join(name)
}

#[test]
fn cornell_box_written_by_mitsuba_dict_to_xml() {
    let path = fixture("cornell_box_dict_to_xml.xml");
    if !path.exists() {
        eprintln!("skipped: {} is absent", path.display());
        return;
    }
    let s = load_scene(&path).unwrap_or_else(|e| panic!("{e}")).scene;
    // 6 rectangles + 2 cubes × 6 faces, all one-sided.
    assert_eq!(s.surfaces.len(), 18);
    let lights: Vec<_> = s.surfaces.iter().filter(|x| x.is_emitter()).collect();
    assert_eq!(lights.len(), 1);
    assert_eq!(lights[0].name, "light");
    assert_eq!(lights[0].emission, Rgb([18.387, 13.9873, 6.75357]));
    assert!((lights[0].patch.area() - 4.0 * 0.23 * 0.19).abs() < 1e-6);
    assert!(lights[0].patch.normal().y < -0.999, "light faces down");
    let floor = s.surfaces.iter().find(|x| x.name == "floor").unwrap();
    assert!(floor.patch.normal().y > 0.999);
    assert!((floor.brdf.lambertian().unwrap()[0] - 0.885809).abs() < 1e-12);
    let green = s.surfaces.iter().find(|x| x.name == "green-wall").unwrap();
    assert!(
        green.patch.normal().x < -0.999,
        "green wall at x=+1 faces −x"
    );
    // Sensor: fov_axis "smaller" on a square film is x.
    let camera = s.camera.expect("camera");
    match camera.projection {
        Projection::Perspective { fov_x_degrees, .. } => {
            assert!((fov_x_degrees - 39.3077).abs() < 1e-9)
        }
        other => panic!("{other:?}"),
    }
    let eye = camera.world_from_camera.transform_point3(DVec3::ZERO);
    assert!((eye - DVec3::new(0.0, 0.0, 3.9)).length() < 1e-6);
    assert!(
        camera.world_from_camera.z_axis.z < -0.999,
        "looks towards −z"
    );
    assert_eq!((camera.near_clip, camera.far_clip), (0.001, 100.0));
    assert_eq!((s.film.width, s.film.height), (256, 256));
    assert_eq!(s.film.filter, PixelFilter::Gaussian { stddev: 0.5 });
    assert_eq!(s.hints.samples_per_pixel, Some(64));

    // Overrides win over the file's defaults, and change the fov conversion.
    let o = [("spp", "16"), ("resx", "512")].map(|(a, b)| (a.to_string(), b.to_string()));
    let s = load_scene_with(&path, &o).unwrap().scene;
    assert_eq!(s.hints.samples_per_pixel, Some(16));
    assert_eq!((s.film.width, s.film.height), (512, 256));
    let Projection::Perspective {
        fov_x_degrees,
        fov_axis,
    } = s.camera.unwrap().projection
    else {
        panic!()
    };
    // aspect 2 > 1: "smaller" is y, so tan(fx/2) = 2 tan(fy/2).
    assert_eq!(fov_axis, FovAxis::Y);
    let expected = 2.0
        * (2.0 * (39.3077f64.to_radians() / 2.0).tan())
            .atan()
            .to_degrees();
    assert!((fov_x_degrees - expected).abs() < 1e-9);
}

#[test]
fn rectangle_area_normal_and_parametrisation() {
    let s = scene(
        r#"<shape type="rectangle">
            <transform name="to_world">
                <scale x="2" y="3"/>
                <rotate x="1" angle="-90"/>
                <translate y="-1"/>
            </transform>
        </shape>"#,
    );
    assert_eq!(s.surfaces.len(), 1);
    let p = s.surfaces[0].patch;
    assert!((p.area() - 24.0).abs() < 1e-12);
    assert!(close(p.normal(), DVec3::Y));
    let Patch::Parallelogram { origin, edge_s, .. } = p else {
        panic!("{p:?}")
    };
    // uv (0,0) is local (-1,-1,0); (1,0) is local (1,-1,0).
    assert!(close(origin, DVec3::new(-2.0, -1.0, 3.0)));
    assert!(close(edge_s, DVec3::new(4.0, 0.0, 0.0)));
    assert_eq!(
        s.surfaces[0].brdf.lambertian(),
        Some(Rgb::splat(0.5)),
        "Mitsuba's default BSDF"
    );
    assert_eq!(s.surfaces[0].emission, Rgb::ZERO);
    assert!(s.camera.is_none());
    assert_eq!(s.film, wavrad_core::scene::Film::default());
}

#[test]
fn cube_faces_are_outward_parallelograms() {
    let s = scene(
        r#"<shape type="cube"><transform name="to_world">
            <scale value="0.5, 1, 2"/><translate value="10 0 0"/>
        </transform></shape>"#,
    );
    assert_eq!(s.surfaces.len(), 6);
    let area: f64 = s.surfaces.iter().map(|x| x.patch.area()).sum();
    assert!((area - 2.0 * (1.0 * 2.0 + 1.0 * 4.0 + 2.0 * 4.0)).abs() < 1e-12);
    let centre = DVec3::new(10.0, 0.0, 0.0);
    for surface in &s.surfaces {
        assert!(matches!(surface.patch, Patch::Parallelogram { .. }));
        let v = surface.patch.vertices();
        let face_centre = v.iter().sum::<DVec3>() / 4.0;
        assert!(
            surface.patch.normal().dot(face_centre - centre) > 0.0,
            "outward"
        );
    }
}

#[test]
fn mirroring_transform_keeps_mitsubas_normal() {
    // Mitsuba transforms the rectangle's normal as a normal: scale z = −1
    // turns +z into −z although the geometry is unchanged.
    let s = scene(
        r#"<shape type="rectangle"><transform name="to_world"><scale z="-1"/></transform></shape>"#,
    );
    assert!(close(s.surfaces[0].patch.normal(), -DVec3::Z));
}

/// Total area of `s`'s surfaces.
fn area(s: &Scene) -> f64 {
    s.surfaces.iter().map(|x| x.patch.area()).sum()
}

/// Centre of a patch's vertices.
fn centre(p: &Patch) -> DVec3 {
    let v = p.vertices();
    v.iter().sum::<DVec3>() / v.len() as f64
}

#[test]
fn sphere_emits_outwards_with_its_exact_area() {
    let c = DVec3::new(0.0, 1.0, 2.0);
    let s = scene(
        r#"<shape type="sphere" id="ball">
            <point name="center" x="0" y="1" z="2"/>
            <float name="radius" value="0.5"/>
            <emitter type="area"><rgb name="radiance" value="4"/></emitter>
        </shape>"#,
    );
    assert_eq!(s.surfaces.len(), 528);
    assert!((area(&s) - PI).abs() < 1e-12, "4π r² = {}", area(&s));
    for x in &s.surfaces {
        assert!(x.is_emitter() && x.name == "ball");
        let out = (centre(&x.patch) - c).normalize();
        assert!(x.patch.normal().dot(out) > 0.98, "{:?}", x.patch);
        assert!(((centre(&x.patch) - c).length() / 0.5 - 1.0).abs() < 0.01);
    }
    // to_world places the same sphere; flip_normals turns it inwards, and a
    // twosided material doubles it.
    let t = scene(
        r#"<shape type="sphere">
            <transform name="to_world"><scale value="0.5"/><translate x="0" y="1" z="2"/></transform>
            <boolean name="flip_normals" value="true"/>
            <bsdf type="twosided"><bsdf type="diffuse"/></bsdf>
        </shape>"#,
    );
    assert_eq!(t.surfaces.len(), 2 * 528);
    assert!((area(&t) - 2.0 * PI).abs() < 1e-12);
    for (front, x) in t.surfaces.iter().step_by(2).zip(&s.surfaces) {
        assert!(front.patch.normal().dot(x.patch.normal()) < -0.999999);
    }
}

#[test]
fn sheared_sphere_stays_a_sphere_with_a_warning() {
    let loaded = load_scene_str(
        r#"<scene version="3.0.0">
            <shape type="sphere">
                <transform name="to_world"><scale x="2" y="1" z="0.5"/></transform>
            </shape>
        </scene>"#,
        Path::new("."),
        "w.xml",
        &[],
    )
    .unwrap();
    let [warning] = &loaded.warnings[..] else {
        panic!("{:?}", loaded.warnings)
    };
    assert_eq!(warning.line, 3);
    assert!(warning.message.contains("sphere of radius 2"), "{warning}");
    // Mitsuba's sphere: radius |to_world · (1,0,0)|.
    assert!((area(&loaded.scene) - 16.0 * PI).abs() < 1e-10);
}

#[test]
fn disk_keeps_mitsubas_normal_under_mirroring() {
    let s = scene(
        r#"<shape type="disk">
            <transform name="to_world"><scale value="0.5"/><rotate x="1" angle="-90"/></transform>
            <emitter type="area"/>
        </shape>
        <shape type="disk">
            <transform name="to_world"><scale x="-1"/></transform>
        </shape>"#,
    );
    assert_eq!(s.surfaces.len(), 48);
    let (rotated, mirrored) = s.surfaces.split_at(24);
    assert!((area(&Scene::from_surfaces(rotated.to_vec())) - PI / 4.0).abs() < 1e-12);
    assert!(rotated.iter().all(|x| close(x.patch.normal(), DVec3::Y)));
    assert!(rotated.iter().all(|x| x.is_emitter()));
    // Mitsuba transforms the normal as a normal: a mirror in x keeps +z.
    assert!(mirrored.iter().all(|x| close(x.patch.normal(), DVec3::Z)));
}

#[test]
fn cylinder_runs_from_p0_to_p1_open_and_outwards() {
    let (p0, p1, r) = (DVec3::new(1.0, 0.0, 0.0), DVec3::new(1.0, 3.0, 0.0), 0.25);
    let s = scene(
        r#"<shape type="cylinder">
            <point name="p0" x="1" y="0" z="0"/>
            <point name="p1" value="1, 3, 0"/>
            <float name="radius" value="0.25"/>
        </shape>
        <shape type="cylinder">
            <boolean name="flip_normals" value="true"/>
        </shape>"#,
    );
    let (open, flipped) = s.surfaces.split_at(24);
    assert!((area(&Scene::from_surfaces(open.to_vec())) - 2.0 * PI * r * 3.0).abs() < 1e-12);
    for x in open {
        assert!(matches!(x.patch, Patch::Parallelogram { .. }));
        let c = centre(&x.patch);
        let radial = (c - p0) - (c - p0).project_onto(p1 - p0);
        assert!(close(x.patch.normal(), radial.normalize()), "{:?}", x.patch);
        assert!(x
            .patch
            .vertices()
            .iter()
            .all(|v| v.y.abs() < 1e-12 || (v.y - 3.0).abs() < 1e-12));
    }
    for x in flipped {
        let c = centre(&x.patch);
        assert!(
            x.patch.normal().dot(c * DVec3::new(1.0, 1.0, 0.0)) < 0.0,
            "inwards"
        );
    }
}

#[test]
fn twosided_gives_two_surfaces_and_emission_on_the_front_only() {
    let s = scene(
        r#"<shape type="rectangle" id="lamp">
            <bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="0.2 0.4 0.6"/></bsdf></bsdf>
            <emitter type="area"><float name="radiance" value="5"/></emitter>
        </shape>"#,
    );
    assert_eq!(s.surfaces.len(), 2);
    let (front, back) = (&s.surfaces[0], &s.surfaces[1]);
    assert!(close(front.patch.normal(), DVec3::Z));
    assert!(close(back.patch.normal(), -DVec3::Z));
    assert_eq!(front.brdf.lambertian(), Some(Rgb([0.2, 0.4, 0.6])));
    assert_eq!(back.brdf.lambertian(), Some(Rgb([0.2, 0.4, 0.6])));
    assert_eq!(front.emission, Rgb::splat(5.0));
    assert_eq!(back.emission, Rgb::ZERO);
    assert_eq!(front.name, "lamp");

    // Two nested BSDFs: front and back differ.
    let s = scene(
        r#"<shape type="rectangle"><bsdf type="twosided">
            <bsdf type="diffuse"><float name="reflectance" value="0.1"/></bsdf>
            <bsdf type="diffuse"><rgb name="reflectance" value="0.9"/></bsdf>
        </bsdf></shape>"#,
    );
    assert_eq!(s.surfaces[0].brdf.lambertian(), Some(Rgb::splat(0.1)));
    assert_eq!(s.surfaces[1].brdf.lambertian(), Some(Rgb::splat(0.9)));
}

#[test]
fn flip_normals_flips_every_patch_and_the_emitting_side() {
    let s = scene(
        r#"<shape type="cube"><boolean name="flip_normals" value="true"/>
            <emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>"#,
    );
    for surface in &s.surfaces {
        let c = surface.patch.vertices().iter().sum::<DVec3>() / 4.0;
        assert!(surface.patch.normal().dot(c) < 0.0, "inward");
        assert!(surface.is_emitter());
    }
}

#[test]
fn references_and_substitution() {
    let xml = r#"<scene version="2.1.0">
        <default name="refl" value="0.25"/>
        <default name="name" value="grey"/>
        <bsdf type="diffuse" id="$name"><float name="reflectance" value="$refl"/></bsdf>
        <shape type="rectangle"><ref id="grey"/></shape>
        <shape type="rectangle"><ref name="bsdf" id="grey"/></shape>
    </scene>"#;
    let s = load(xml);
    assert_eq!(s.surfaces.len(), 2);
    assert!(s
        .surfaces
        .iter()
        .all(|x| x.brdf.lambertian() == Some(Rgb::splat(0.25))));
    let o = vec![("refl".to_string(), "0.75".to_string())];
    let s = load_scene_str(xml, Path::new("."), "t.xml", &o)
        .unwrap()
        .scene;
    assert_eq!(s.surfaces[0].brdf.lambertian(), Some(Rgb::splat(0.75)));
}

#[test]
fn includes_resolve_beside_the_including_file() {
    let dir = tempfile::tempdir().unwrap();
    fs::create_dir(dir.path().join("parts")).unwrap();
    fs::write(
        dir.path().join("main.xml"),
        r#"<scene version="3.0.0">
            <include filename="parts/materials.xml"/>
            <shape type="rectangle"><ref id="red"/></shape>
        </scene>"#,
    )
    .unwrap();
    // Nested include: beside parts/materials.xml.
    fs::write(
        dir.path().join("parts/materials.xml"),
        r#"<scene version="3.0.0"><include filename="more.xml"/>
            <bsdf type="diffuse" id="red"><rgb name="reflectance" value="0.5 0 0"/></bsdf></scene>"#,
    )
    .unwrap();
    fs::write(
        dir.path().join("parts/more.xml"),
        r#"<scene version="3.0.0"><shape type="cube"/></scene>"#,
    )
    .unwrap();
    let s = load_scene(&dir.path().join("main.xml"))
        .unwrap_or_else(|e| panic!("{e}"))
        .scene;
    assert_eq!(s.surfaces.len(), 7);
    assert_eq!(s.surfaces[6].brdf.lambertian(), Some(Rgb([0.5, 0.0, 0.0])));
}

fn write(dir: &Path, name: &str, bytes: &[u8]) {
    fs::write(dir.join(name), bytes).unwrap();
}

#[test]
fn obj_and_ply_meshes() {
    let dir = tempfile::tempdir().unwrap();
    // A quad (two triangles) plus one degenerate triangle that is skipped.
    write(
        dir.path(),
        "quad.obj",
        b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\nf 1 2 3 4\nf 1 2 5\n",
    );
    write(
        dir.path(),
        "tri.ply",
        b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n0 1 0\n1 0 0\n3 0 1 2\n",
    );
    let mut binary = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n".to_vec();
    for v in [0f32, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 2.0, 0.0] {
        binary.extend_from_slice(&v.to_le_bytes());
    }
    binary.push(3);
    for i in [0i32, 1, 2] {
        binary.extend_from_slice(&i.to_le_bytes());
    }
    write(dir.path(), "tri_bin.ply", &binary);
    let xml = r#"<scene version="3.0.0">
        <shape type="obj"><string name="filename" value="quad.obj"/>
            <transform name="to_world"><translate z="5"/></transform></shape>
        <shape type="ply"><string name="filename" value="tri.ply"/><boolean name="face_normals" value="true"/></shape>
        <shape type="ply"><string name="filename" value="tri_bin.ply"/></shape>
    </scene>"#;
    let loaded = load_scene_str(xml, dir.path(), "m.xml", &[]).unwrap_or_else(|e| panic!("{e}"));
    // The skipped triangle is counted in a warning at the mesh's filename.
    let [warning] = &loaded.warnings[..] else {
        panic!("{:?}", loaded.warnings)
    };
    assert_eq!((warning.file.as_str(), warning.line), ("m.xml", 2));
    assert!(
        warning.to_string().contains("skipped 1 of the 3 triangles")
            && warning.message.contains("quad.obj"),
        "{warning}"
    );
    let s = loaded.scene;
    assert_eq!(s.surfaces.len(), 4);
    for quad in &s.surfaces[..2] {
        assert!(matches!(quad.patch, Patch::Triangle(_)));
        assert!(close(quad.patch.normal(), DVec3::Z));
        assert!((quad.patch.area() - 0.5).abs() < 1e-12);
        assert!(quad.patch.vertices().iter().all(|v| v.z == 5.0));
    }
    // Clockwise in the file as seen from +z: faces −z.
    assert!(close(s.surfaces[2].patch.normal(), -DVec3::Z));
    assert!(close(s.surfaces[3].patch.normal(), DVec3::Z));
    assert!((s.surfaces[3].patch.area() - 2.0).abs() < 1e-12);
}

fn perspective(film: &str, fov: &str) -> (f64, Scene) {
    let s = scene(&format!(
        r#"<sensor type="perspective">{fov}
            <film type="hdrfilm">{film}</film></sensor>"#
    ));
    match s.camera.unwrap().projection {
        Projection::Perspective { fov_x_degrees, .. } => (fov_x_degrees, s),
        other => panic!("{other:?}"),
    }
}

#[test]
fn fov_axis_converts_to_horizontal() {
    let film = r#"<integer name="width" value="200"/><integer name="height" value="100"/>"#;
    let t = |deg: f64| (deg.to_radians() / 2.0).tan();
    let fx = |tan_half: f64| 2.0 * tan_half.atan().to_degrees();
    let cases = [
        ("x", fx(t(40.0))),
        ("y", fx(t(40.0) * 2.0)),
        ("diagonal", fx(t(40.0) / (1.0f64 + 0.25).sqrt())),
        ("smaller", fx(t(40.0) * 2.0)),
        ("larger", fx(t(40.0))),
    ];
    for (axis, expected) in cases {
        let (got, _) = perspective(
            film,
            &format!(r#"<float name="fov" value="40"/><string name="fov_axis" value="{axis}"/>"#),
        );
        assert!((got - expected).abs() < 1e-9, "{axis}: {got} vs {expected}");
    }
    // Diagonal, by hand: tan(fd/2) = tan(fx/2)·sqrt(1 + 1/aspect²).
    let (got, _) = perspective(
        film,
        r#"<float name="fov" value="40"/><string name="fov_axis" value="diagonal"/>"#,
    );
    assert!(((got / 2.0).to_radians().tan() * 1.25f64.sqrt() - t(40.0)).abs() < 1e-12);
    // No fov: Mitsuba's 50 mm lens, a diagonal fov of 46.8°.
    let (got, s) = perspective("", "");
    let aspect: f64 = 768.0 / 576.0;
    let diagonal_half = 36f64.hypot(24.0) / 100.0;
    let expected = fx(diagonal_half / (1.0 + 1.0 / (aspect * aspect)).sqrt());
    assert!((got - expected).abs() < 1e-9);
    let c = s.camera.unwrap();
    assert_eq!((c.near_clip, c.far_clip), (0.01, 1e4));
    assert_eq!(s.hints.samples_per_pixel, None);
}

#[test]
fn film_filter_sampler_and_orthographic() {
    let s = scene(
        r#"<sensor type="orthographic">
            <transform name="to_world"><scale value="3"/><lookat origin="0 0 5" target="0 0 0" up="0 1 0"/></transform>
            <float name="near_clip" value="0.5"/><float name="far_clip" value="50"/>
            <sampler type="stratified"><integer name="sample_count" value="9"/><integer name="seed" value="3"/></sampler>
            <film type="hdrfilm">
                <integer name="width" value="32"/><integer name="height" value="24"/>
                <integer name="crop_width" value="32"/><integer name="crop_offset_x" value="0"/>
                <string name="pixel_format" value="rgba"/><boolean name="banner" value="false"/>
                <rfilter type="box"/>
            </film>
        </sensor>
        <integrator type="path"><integer name="max_depth" value="-1"/></integrator>"#,
    );
    let c = s.camera.unwrap();
    assert_eq!(c.projection, Projection::Orthographic);
    assert_eq!((c.near_clip, c.far_clip), (0.5, 50.0));
    assert!((c.world_from_camera.x_axis.length() - 3.0).abs() < 1e-12);
    assert_eq!(
        (s.film.width, s.film.height, s.film.filter),
        (32, 24, PixelFilter::Box)
    );
    assert_eq!(s.hints.samples_per_pixel, Some(9));

    let s = scene(
        r#"<sampler type="independent"><integer name="sample_count" value="4"/></sampler>
        <sensor type="perspective"><float name="fov" value="30"/>
            <film type="hdrfilm"><rfilter type="gaussian"><float name="stddev" value="0.3"/></rfilter></film>
        </sensor>"#,
    );
    assert_eq!(s.film.filter, PixelFilter::Gaussian { stddev: 0.3 });
    assert_eq!(s.hints.samples_per_pixel, Some(4));
}

#[test]
fn every_mitsuba_rfilter_with_its_defaults() {
    let filter = |rfilter: &str| {
        scene(&format!(
            r#"<sensor type="perspective"><film type="hdrfilm">{rfilter}</film></sensor>"#
        ))
        .film
        .filter
    };
    for (rfilter, expected) in [
        (
            r#"<rfilter type="tent"/>"#,
            PixelFilter::Tent { radius: 1.0 },
        ),
        (
            r#"<rfilter type="tent"><float name="radius" value="1.25"/></rfilter>"#,
            PixelFilter::Tent { radius: 1.25 },
        ),
        (
            r#"<rfilter type="mitchell"/>"#,
            PixelFilter::Mitchell {
                b: 1.0 / 3.0,
                c: 1.0 / 3.0,
            },
        ),
        (
            r#"<rfilter type="mitchell"><float name="B" value="0.25"/><float name="C" value="0.55"/></rfilter>"#,
            PixelFilter::Mitchell { b: 0.25, c: 0.55 },
        ),
        (r#"<rfilter type="catmullrom"/>"#, PixelFilter::CATMULL_ROM),
        (
            r#"<rfilter type="lanczos"/>"#,
            PixelFilter::Lanczos { lobes: 3 },
        ),
        (
            r#"<rfilter type="lanczos"><integer name="lobes" value="4"/></rfilter>"#,
            PixelFilter::Lanczos { lobes: 4 },
        ),
        (r#"<rfilter type="box"/>"#, PixelFilter::Box),
        ("", PixelFilter::Gaussian { stddev: 0.5 }),
    ] {
        assert_eq!(filter(rfilter), expected, "{rfilter}");
    }
}

fn bsdf_of(bsdf: &str) -> wavrad_core::scene::brdf::Brdf {
    let s = scene(&format!("<shape type=\"rectangle\">{bsdf}</shape>"));
    s.surfaces[0].brdf.clone()
}

#[test]
fn glossy_bsdfs_and_their_defaults() {
    use wavrad_core::scene::brdf::fresnel::conductor_ior;
    use wavrad_core::scene::brdf::{
        Brdf, BrdfFlags, BrdfModel, Microfacet, MicrofacetType, RoughConductor, RoughPlastic,
        RoughPlasticParams, Ward, WardVariant,
    };
    // Mitsuba's defaults.
    assert_eq!(
        bsdf_of("<bsdf type=\"ward\"/>"),
        Brdf::Ward(Ward::default())
    );
    assert_eq!(
        bsdf_of("<bsdf type=\"roughconductor\"/>"),
        Brdf::RoughConductor(RoughConductor::default())
    );
    let Brdf::RoughPlastic(p) = bsdf_of("<bsdf type=\"roughplastic\"/>") else {
        panic!()
    };
    assert_eq!(*p.params(), RoughPlasticParams::default());
    // Glossy models are not diffuse.
    assert!(bsdf_of("<bsdf type=\"ward\"/>")
        .flags()
        .contains(BrdfFlags::GLOSSY_REFLECTION));

    // Ward with Mitsuba 0.6 camelCase names.
    let w = bsdf_of(
        r#"<bsdf type="ward"><string name="variant" value="ward-duer"/>
           <float name="alphaU" value="0.05"/><float name="alpha_v" value="0.3"/>
           <rgb name="specularReflectance" value="0.1, 0.2, 0.3"/>
           <spectrum name="diffuse_reflectance" value="0.4"/></bsdf>"#,
    );
    assert_eq!(
        w,
        Brdf::Ward(Ward {
            variant: WardVariant::WardDuer,
            alpha_u: 0.05,
            alpha_v: 0.3,
            specular_reflectance: Rgb([0.1, 0.2, 0.3]),
            diffuse_reflectance: Rgb::splat(0.4),
        })
    );
    // `alpha` sets both directions.
    let Brdf::Ward(w) = bsdf_of(r#"<bsdf type="ward"><float name="alpha" value="0.2"/></bsdf>"#)
    else {
        panic!()
    };
    assert_eq!((w.alpha_u, w.alpha_v), (0.2, 0.2));

    // Conductors: anisotropic GGX with a named metal, or explicit eta/k.
    let au = conductor_ior("Au").unwrap();
    assert_eq!(
        bsdf_of(
            r#"<bsdf type="roughconductor"><string name="distribution" value="GGX"/>
               <float name="alpha_u" value="0.1"/><float name="alpha_v" value="0.4"/>
               <string name="material" value="Au"/></bsdf>"#
        ),
        Brdf::RoughConductor(RoughConductor {
            distribution: Microfacet::new(MicrofacetType::Ggx, 0.1, 0.4),
            eta: au.eta,
            k: au.k,
            specular_reflectance: Rgb::splat(1.0),
        })
    );
    let Brdf::RoughConductor(c) = bsdf_of(
        r#"<bsdf type="roughconductor"><rgb name="eta" value="0.2, 0.9, 1.1"/>
           <float name="k" value="3"/><rgb name="specular_reflectance" value="0.9"/>
           <boolean name="sample_visible" value="true"/></bsdf>"#,
    ) else {
        panic!()
    };
    assert_eq!(
        (c.eta, c.k, c.specular_reflectance),
        (Rgb([0.2, 0.9, 1.1]), Rgb::splat(3.0), Rgb::splat(0.9))
    );

    // Plastic with named indices.
    let Brdf::RoughPlastic(p) = bsdf_of(
        r#"<bsdf type="roughplastic"><string name="distribution" value="ggx"/>
           <float name="alpha" value="0.3"/><string name="int_ior" value="bk7"/>
           <string name="ext_ior" value="water"/><boolean name="nonlinear" value="true"/>
           <rgb name="diffuse_reflectance" value="0.2, 0.6, 0.3"/></bsdf>"#,
    ) else {
        panic!()
    };
    assert_eq!(
        *p.params(),
        RoughPlasticParams {
            distribution: MicrofacetType::Ggx,
            alpha: 0.3,
            int_ior: 1.5046,
            ext_ior: 1.3330,
            specular_reflectance: Rgb::splat(1.0),
            diffuse_reflectance: Rgb([0.2, 0.6, 0.3]),
            nonlinear: true,
        }
    );
    assert!(p == RoughPlastic::new(*p.params()));

    // twosided wraps glossy models too.
    let s = scene(
        r#"<shape type="rectangle"><bsdf type="twosided">
           <bsdf type="roughconductor"/><bsdf type="ward"/></bsdf></shape>"#,
    );
    assert_eq!(s.surfaces.len(), 2);
    assert!(s
        .surfaces
        .iter()
        .any(|x| matches!(x.brdf, Brdf::RoughConductor(_))));
    assert!(s.surfaces.iter().any(|x| matches!(x.brdf, Brdf::Ward(_))));
}

/// The shading normal of every patch of `s` at its parameter points and
/// centre, with the point: what a render shades with there.
fn shading_points(s: &Scene) -> Vec<(DVec3, DVec3)> {
    use glam::DVec2;
    let params = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (0.3, 0.3)].map(DVec2::from);
    s.surfaces
        .iter()
        .flat_map(|x| params.map(|p| (x.patch.point_at(p), x.shading_normal(p))))
        .collect()
}

/// A sphere's shading normal is the radial direction wherever a patch is
/// shaded (within the tessellation's displacement of the points), outwards,
/// inwards after `flip_normals` or a mirroring `to_world` (which turn
/// Mitsuba's sphere inside out), and reversed on a twosided back; a disk
/// has none (flat).
#[test]
fn sphere_shading_normals_are_radial_and_follow_its_front() {
    let c = DVec3::new(0.0, 1.0, 2.0);
    let radial = |p: DVec3| (p - c).normalize();
    let s = scene(
        r#"<shape type="sphere"><point name="center" x="0" y="1" z="2"/>
            <float name="radius" value="0.5"/></shape>"#,
    );
    assert!(s.surfaces.iter().all(|x| x.shading.is_some()));
    for (p, n) in shading_points(&s) {
        // Exact at the corners; between them, the chord's direction.
        assert!(n.dot(radial(p)) > 0.995, "{n} at {p}");
    }
    for (p, n) in shading_points(&s).into_iter().step_by(4) {
        assert!((n - radial(p)).length() < 1e-6, "corner {p}: {n}");
    }
    let inwards = scene(
        r#"<shape type="sphere">
            <transform name="to_world"><scale value="0.5"/><translate x="0" y="1" z="2"/></transform>
            <boolean name="flip_normals" value="true"/>
        </shape>
        <shape type="sphere">
            <transform name="to_world"><scale x="-0.5" y="0.5" z="0.5"/><translate x="0" y="1" z="2"/></transform>
        </shape>"#,
    );
    for (p, n) in shading_points(&inwards) {
        assert!(n.dot(radial(p)) < -0.995, "{n} at {p}");
    }
    let twosided = scene(
        r#"<shape type="sphere"><point name="center" x="0" y="1" z="2"/>
            <float name="radius" value="0.5"/>
            <bsdf type="twosided"><bsdf type="diffuse"/></bsdf></shape>
        <shape type="disk"/>"#,
    );
    let (sides, disk) = twosided.surfaces.split_at(2 * 528);
    for (k, (p, n)) in shading_points(&Scene::from_surfaces(sides.to_vec()))
        .into_iter()
        .enumerate()
    {
        let front = if (k / 4) % 2 == 0 { 1.0 } else { -1.0 };
        assert!(front * n.dot(radial(p)) > 0.995, "{n} at {p}");
    }
    assert!(disk.iter().all(|x| x.shading.is_none()));
}

/// A cylinder's shading normal is radial, with no component along its axis.
#[test]
fn cylinder_shading_normals_are_radial() {
    let s = scene(
        r#"<shape type="cylinder"><point name="p0" x="1" y="0" z="0"/>
            <point name="p1" x="1" y="3" z="0"/><float name="radius" value="0.25"/></shape>"#,
    );
    for (p, n) in shading_points(&s) {
        let radial = DVec3::new(p.x - 1.0, 0.0, p.z).normalize();
        assert!(n.dot(radial) > 0.995 && n.y.abs() < 1e-6, "{n} at {p}");
    }
}

/// A mesh's vertex normals are its shading normals: the interpolated normal
/// is the file's at each vertex (transformed as normals), unless
/// `face_normals` is set; a triangle turned round to face its normals keeps
/// each vertex's.
#[test]
fn mesh_vertex_normals_are_interpolated() {
    let dir = tempfile::tempdir().unwrap();
    // One triangle wound clockwise from +z, its normals leaning out of it.
    write(
        dir.path(),
        "bent.obj",
        b"v 0 0 0\nv 0 1 0\nv 1 0 0\nvn -0.3 0 1\nvn 0 0.4 1\nvn 0.5 0 1\nf 1//1 2//2 3//3\n",
    );
    let xml = r#"<scene version="3.0.0">
        <shape type="obj"><string name="filename" value="bent.obj"/>
            <transform name="to_world"><scale x="2"/></transform></shape>
        <shape type="obj"><string name="filename" value="bent.obj"/>
            <boolean name="face_normals" value="true"/></shape>
    </scene>"#;
    let s = load_scene_str(xml, dir.path(), "m.xml", &[]).unwrap().scene;
    let smooth = &s.surfaces[0];
    assert!(
        close(smooth.patch.normal(), DVec3::Z),
        "turned to its normals"
    );
    // Normals scale by the inverse transpose: x halves.
    let expect = [
        (DVec3::ZERO, DVec3::new(-0.15, 0.0, 1.0)),
        (DVec3::Y, DVec3::new(0.0, 0.4, 1.0)),
        (DVec3::X * 2.0, DVec3::new(0.25, 0.0, 1.0)),
    ];
    for (vertex, normal) in expect {
        let n = smooth.shading_normal(smooth.patch.param_of(vertex));
        assert!((n - normal.normalize()).length() < 1e-6, "{n} at {vertex}");
    }
    assert_eq!(s.surfaces[1].shading, None);
    assert!(close(
        s.surfaces[1].shading_normal(glam::DVec2::ZERO),
        -DVec3::Z
    ));
}

/// A mesh file without normals is shaded smoothly, as Mitsuba shades it:
/// at a vertex, the angle-weighted mean of its triangles' normals, made
/// after `to_world`; `face_normals` keeps it flat.
#[test]
fn a_mesh_without_normals_gets_smooth_ones_unless_face_normals() {
    let dir = tempfile::tempdir().unwrap();
    // Two triangles folded along the y axis at a right angle, facing +z
    // and +x.
    write(
        dir.path(),
        "fold.obj",
        b"v 0 0 0\nv 0 1 0\nv -1 0 0\nv 0 0 -1\nf 1 2 3\nf 1 4 2\n",
    );
    let xml = r#"<scene version="3.0.0">
        <shape type="obj"><string name="filename" value="fold.obj"/>
            <transform name="to_world"><scale x="3"/></transform></shape>
        <shape type="obj"><string name="filename" value="fold.obj"/>
            <boolean name="face_normals" value="true"/></shape>
    </scene>"#;
    let s = load_scene_str(xml, dir.path(), "m.xml", &[]).unwrap().scene;
    let (smooth, flat) = s.surfaces.split_at(2);
    let (x_face, z_face) = (DVec3::new(0.0, 0.0, -1.0), DVec3::new(-3.0, 0.0, 0.0));
    // The triangles' angles after the scale weigh their normals: 90° each
    // at the origin; at (0 1 0), atan 3 on the stretched face and 45° on
    // the other (45° each before it).
    let top = DVec3::X * std::f64::consts::FRAC_PI_4 + DVec3::Z * 3f64.atan();
    let expect = [
        (DVec3::ZERO, DVec3::X + DVec3::Z),
        (DVec3::Y, top),
        (x_face, DVec3::X),
        (z_face, DVec3::Z),
    ];
    let mut checked = 0;
    for x in smooth {
        for (vertex, normal) in expect {
            if !x.patch.vertices().iter().any(|v| close(*v, vertex)) {
                continue;
            }
            checked += 1;
            let n = x.shading_normal(x.patch.param_of(vertex));
            assert!((n - normal.normalize()).length() < 1e-6, "{n} at {vertex}");
        }
    }
    assert_eq!(checked, 6);
    assert!(flat.iter().all(|x| x.shading.is_none()));
}

/// A closed two-sided mesh with nothing inside loses the sides that face
/// its inside (no light reaches them); with a surface inside, it keeps
/// them.
#[test]
fn closed_twosided_meshes_lose_their_empty_insides() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "cube.obj",
        b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
          f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\n",
    );
    let load = |extra: &str| {
        let xml = format!(
            r#"<scene version="3.0.0">
                <shape type="obj"><string name="filename" value="cube.obj"/>
                    <bsdf type="twosided"><bsdf type="diffuse"/></bsdf></shape>
                {extra}
            </scene>"#
        );
        load_scene_str(&xml, dir.path(), "t.xml", &[])
            .unwrap_or_else(|e| panic!("{e}"))
            .scene
    };
    let empty = load("");
    assert_eq!(empty.surfaces.len(), 12);
    let centre = DVec3::splat(0.5);
    for s in &empty.surfaces {
        assert!(
            s.patch.normal().dot(s.patch.centroid() - centre) > 0.0,
            "{s:?}"
        );
    }
    let holding = load(
        r#"<shape type="rectangle"><transform name="to_world">
            <scale value="0.1"/><translate x="0.5" y="0.5" z="0.5"/></transform></shape>"#,
    );
    assert_eq!(holding.surfaces.len(), 2 * 12 + 1);
}
