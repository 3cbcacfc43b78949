//! Form factors against closed forms from Howell's catalogue of radiation
//! configuration factors, and reciprocity A_a F(a,c) = A_c F(c,a).

use glam::DVec3;
use wavrad_core::geometry::tracing::SceneTracer;
use wavrad_core::kernel::KernelContext;
use wavrad_core::progress::Silent;
use wavrad_core::refine::two_point_projection::{refine_links, root_pairs};
use wavrad_core::scene::{Patch, Scene};
use wavrad_core::solve::SolveSettings;
use wavrad_core::testing::grey;

/// Form factor from surface 0 to surface 1, summed over the adaptive links.
fn adaptive_form_factor(a: Patch, c: Patch) -> (f64, f64) {
    let scene = Scene::from_surfaces(vec![grey(a), grey(c)]);
    let tracer = SceneTracer::new(&scene);
    let settings = SolveSettings::default();
    let ctx = KernelContext::new(&scene, &tracer, settings.quadrature);
    let links = refine_links(&ctx, settings.refine, None, &root_pairs(&ctx), &Silent);
    let t: f64 = links.iter().map(|l| l.throughput).sum();
    (t / a.area(), t / c.area())
}

/// Howell B-11: two parallel, directly opposed rectangles a×b at distance c.
fn parallel_rectangles(a: f64, b: f64, c: f64) -> f64 {
    let (x, y) = (a / c, b / c);
    let (x2, y2) = (x * x, y * y);
    let t1 = (((1.0 + x2) * (1.0 + y2)) / (1.0 + x2 + y2)).sqrt().ln();
    let t2 = x * (1.0 + y2).sqrt() * (x / (1.0 + y2).sqrt()).atan();
    let t3 = y * (1.0 + x2).sqrt() * (y / (1.0 + x2).sqrt()).atan();
    let t4 = x * x.atan() + y * y.atan();
    2.0 / (std::f64::consts::PI * x * y) * (t1 + t2 + t3 - t4)
}

/// Howell B-16: two rectangles w×l and h×l sharing the edge of length l at a
/// right angle; from the w×l one.
fn perpendicular_rectangles(w: f64, h: f64, l: f64) -> f64 {
    let (hh, ww) = (h / l, w / l);
    let s = hh * hh + ww * ww;
    let a = ww * (1.0 / ww).atan() + hh * (1.0 / hh).atan() - s.sqrt() * (1.0 / s.sqrt()).atan();
    let l1 = (1.0 + ww * ww) * (1.0 + hh * hh) / (1.0 + s);
    let l2 = (ww * ww * (1.0 + s) / ((1.0 + ww * ww) * s)).powf(ww * ww);
    let l3 = (hh * hh * (1.0 + s) / ((1.0 + hh * hh) * s)).powf(hh * hh);
    (a + 0.25 * (l1 * l2 * l3).ln()) / (std::f64::consts::PI * ww)
}

#[test]
fn parallel_unit_squares_at_distance_one_match_closed_form() {
    let bottom = Patch::Parallelogram {
        origin: DVec3::ZERO,
        edge_s: DVec3::X,
        edge_t: DVec3::Y,
    };
    let top = Patch::Parallelogram {
        origin: DVec3::Z,
        edge_s: DVec3::Y,
        edge_t: DVec3::X,
    };
    let expect = parallel_rectangles(1.0, 1.0, 1.0);
    assert!(
        (expect - 0.19982).abs() < 1e-4,
        "closed form itself: {expect}"
    );
    let (f, _) = adaptive_form_factor(bottom, top);
    assert!((f - expect).abs() < 1e-3, "{f} vs {expect}");
}

#[test]
fn perpendicular_unit_squares_sharing_an_edge_match_closed_form() {
    let floor = Patch::Parallelogram {
        origin: DVec3::ZERO,
        edge_s: DVec3::X,
        edge_t: DVec3::Y,
    };
    // x = 0 plane, facing +x, sharing the edge along y.
    let wall = Patch::Parallelogram {
        origin: DVec3::ZERO,
        edge_s: DVec3::Y,
        edge_t: DVec3::Z,
    };
    let expect = perpendicular_rectangles(1.0, 1.0, 1.0);
    assert!(
        (expect - 0.20004).abs() < 1e-4,
        "closed form itself: {expect}"
    );
    let (f, _) = adaptive_form_factor(floor, wall);
    assert!((f - expect).abs() < 1e-3, "{f} vs {expect}");
}

#[test]
fn form_factor_reciprocity_for_unequal_rectangles() {
    let floor = Patch::Parallelogram {
        origin: DVec3::ZERO,
        edge_s: DVec3::X * 2.0,
        edge_t: DVec3::Y,
    };
    let wall = Patch::Parallelogram {
        origin: DVec3::new(0.0, 0.0, 0.0),
        edge_s: DVec3::Y,
        edge_t: DVec3::Z * 0.5,
    };
    let (f_fw, f_wf) = adaptive_form_factor(floor, wall);
    let (g_wf, g_fw) = adaptive_form_factor(wall, floor);
    assert!((f_fw * floor.area() - f_wf * wall.area()).abs() < 1e-12);
    // The same pair refined in the other order gives the same factors.
    assert!((f_fw - g_fw).abs() < 1e-3 * f_fw, "{f_fw} vs {g_fw}");
    assert!((f_wf - g_wf).abs() < 1e-3 * f_wf);
    // And they match Howell B-16 (w = 2 along x, h = 0.5, shared l = 1).
    let expect = perpendicular_rectangles(2.0, 0.5, 1.0);
    assert!((f_fw - expect).abs() < 1e-3, "{f_fw} vs {expect}");
}
