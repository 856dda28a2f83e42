//! Tests of the CPU reference renderer: analytic scenes whose pixels are known in closed
//! form, sampling and statistics, brute force against the BVH, and the `render` command.
//!
//! This module holds the scene-building and checking helpers; the tests are in one
//! sub-module per area:
//!
//! - `closed_form`: analytic scenes whose pixels are known in closed form;
//! - `sampling`: corner sampling, samples per pixel and determinism;
//! - `accels`: brute force, the BVH and the tables' order giving identical images;
//! - `shared_scenes`: the SPD databases and glTF sample models, and the SPD reference
//!   images' orientation;
//! - `render_command`: the `render` command's images, statistics and transfers.

use glam::DVec3;
use indicatif::ProgressBar;

use cuberay::job::{RenderOptions, Rendered};
use cuberay::output::Image;
use cuberay::reference::render;
use cuberay::scene::{Camera, Material, Primitive, Projection, Scene, Sphere, Triangle};

mod accels;
mod closed_form;
mod render_command;
mod sampling;
mod shared_scenes;

// ---------------------------------------------------------------------------------------
// Helpers

fn ortho(eye: DVec3, at: DVec3, up: DVec3, half_height: f64) -> Camera {
    Camera::look_at(eye, at, up, Projection::Orthographic { half_height }).unwrap()
}

fn scene(camera: Camera) -> Scene {
    let camera_up = camera.up;
    Scene {
        camera,
        lights: Vec::new(),
        ambient: DVec3::ZERO,
        background: DVec3::ZERO,
        materials: Vec::new(),
        textures: Vec::new(),
        primitives: Vec::new(),
        resolution: None,
        up: camera_up,
        environment: None,
        transfer: Default::default(),
    }
}

fn add_material(s: &mut Scene, m: Material) -> u32 {
    s.materials.push(m);
    (s.materials.len() - 1) as u32
}

fn matte(color: DVec3, kd: f64) -> Material {
    Material { color, kd, ..Material::default() }
}

fn sphere(center: DVec3, radius: f64, material: u32) -> Primitive {
    Primitive::Sphere(Sphere { center, radius, inside_only: false, material })
}

fn tri(p0: DVec3, p1: DVec3, p2: DVec3, material: u32) -> Primitive {
    Primitive::Triangle(Triangle::new([p0, p1, p2], material))
}

/// Two triangles covering the axis-aligned square [x0,x1]×[y0,y1] at height z.
fn quad_z(x0: f64, x1: f64, y0: f64, y1: f64, z: f64, material: u32) -> [Primitive; 2] {
    let a = DVec3::new(x0, y0, z);
    let b = DVec3::new(x1, y0, z);
    let c = DVec3::new(x1, y1, z);
    let d = DVec3::new(x0, y1, z);
    [tri(a, b, c, material), tri(a, c, d, material)]
}

fn opts(w: u32, h: u32) -> RenderOptions {
    RenderOptions::new(w, h)
}

fn run(s: &Scene, o: &RenderOptions) -> Rendered {
    let r = render(s, o, &ProgressBar::hidden()).expect("render");
    assert!(r.image.is_finite(), "non-finite pixel");
    r
}

fn px(img: &Image, x: u32, y: u32) -> DVec3 {
    let p = img.get(x, y);
    DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
}

fn assert_close(got: DVec3, want: DVec3, tol: f64, what: &str) {
    assert!((got - want).abs().max_element() <= tol, "{what}: got {got}, want {want}");
}

/// The statistics invariants every render must satisfy.
fn check_stats(r: &Rendered) {
    let s = &r.stats;
    assert!(s.rays.eye_hit <= s.rays.eye, "eye_hit > eye");
    assert!(s.rays.shadow_blocked <= s.rays.shadow, "shadow_blocked > shadow");
    assert_eq!(s.rays.total, s.rays.eye + s.rays.reflect + s.rays.refract + s.rays.shadow);
    let tpr = &s.tests_per_ray;
    let tests_from_rates = tpr.eye * s.rays.eye as f64
        + tpr.shadow * s.rays.shadow as f64
        + tpr.reflect * s.rays.reflect as f64
        + tpr.refract * s.rays.refract as f64;
    assert!((tests_from_rates - s.tests.total() as f64).abs() < 1e-6 * (1.0 + s.tests.total() as f64));
}
