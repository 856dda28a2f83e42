//! The CPU reference's sampling and statistics: corner sampling traces the pixel corners,
//! samples per pixel are counted and deterministic for a seed.

use glam::DVec3;

use cuberay::sampling::Sampling;
use cuberay::scene::{Camera, FovSpan, Light, Material, Projection, Scene};

use super::{add_material, assert_close, check_stats, opts, ortho, px, quad_z, run, scene, sphere};

fn small_scene() -> Scene {
    let cam = Camera::look_at(
        DVec3::new(0.0, -4.0, 1.0),
        DVec3::ZERO,
        DVec3::Z,
        Projection::Perspective { fov_y: 45f64.to_radians(), span: FovSpan::EdgePixelCenters },
    )
    .unwrap();
    let mut s = scene(cam);
    let m = add_material(&mut s, Material { ks: 0.5, mirror: DVec3::splat(0.5), ..Material::default() });
    s.primitives.push(sphere(DVec3::ZERO, 0.8, m));
    s.primitives.extend(quad_z(-5.0, 5.0, -5.0, 5.0, -0.8, 0));
    s.lights.push(Light::point(DVec3::new(2.0, -2.0, 4.0), DVec3::ONE, 1.0));
    s
}

#[test]
fn corners_sampling_traces_the_pixel_corners() {
    let (w, h, hh) = (7u32, 5u32, 1.5);
    let cam =
        |half_height| ortho(DVec3::new(0.3, -4.0, 1.0), DVec3::new(0.3, 0.0, 0.2), DVec3::Z, half_height);
    let mut s = small_scene();
    s.camera = cam(hh);
    let mut o = opts(w, h);
    o.sampling = Sampling::Corners;
    let r = run(&s, &o);
    check_stats(&r);
    assert_eq!(r.stats.rays.eye, ((w + 1) * (h + 1)) as u64);
    assert_eq!(r.stats.settings.sampling, "corners");
    // An orthographic (W+1)×(H+1) centre-sampled image with the same pixel pitch samples
    // exactly the corners of the W×H image: each corners pixel is the mean of four of its
    // pixels.
    s.camera = cam(hh * (h + 1) as f64 / h as f64);
    let c = run(&s, &opts(w + 1, h + 1));
    for j in 0..h {
        for i in 0..w {
            let mean = (px(&c.image, i, j)
                + px(&c.image, i + 1, j)
                + px(&c.image, i, j + 1)
                + px(&c.image, i + 1, j + 1))
                * 0.25;
            assert_close(px(&r.image, i, j), mean, 1e-6, &format!("pixel ({i},{j})"));
        }
    }
    assert_eq!(r.stats.rays, c.stats.rays, "the same rays are traced");
}

#[test]
fn spp_counts_and_determinism() {
    let s = small_scene();
    let mut o = opts(6, 4);
    o.spp = 3;
    o.seed = 9;
    let a = run(&s, &o);
    check_stats(&a);
    assert_eq!(a.stats.rays.eye, 6 * 4 * 3);
    assert_eq!(a.stats.settings.sampling, "jitter");
    let b = run(&s, &o);
    assert_eq!(a.image, b.image, "same seed, different image");
    o.seed = 10;
    let c = run(&s, &o);
    assert_ne!(a.image, c.image, "the seed changes nothing");
}
