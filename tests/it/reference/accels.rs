//! Brute force, the BVH and the tables' order give identical images, ray counts and AOVs on
//! random scenes, each testing fewer primitives than brute force.

use glam::DVec3;
use indicatif::ProgressBar;

use cuberay::job::Accel;
use cuberay::output::Aov;
use cuberay::reference::render_aov;
use cuberay::sampling::pcg;
use cuberay::scene::{Camera, Cylinder, FovSpan, Light, Material, Primitive, Projection, Scene};

use super::{add_material, check_stats, matte, opts, quad_z, run, scene, sphere, tri};

/// A deterministic random scene of spheres, triangles, cylinders and cones with matte,
/// mirror and glass materials and two lights.
fn random_scene(seed: u32) -> Scene {
    let mut state = pcg(seed);
    let mut rnd = move || {
        state = pcg(state);
        state as f64 / 4294967296.0
    };
    let cam = Camera::look_at(
        DVec3::new(0.0, -12.0, 5.0),
        DVec3::ZERO,
        DVec3::Z,
        Projection::Perspective { fov_y: 60f64.to_radians(), span: FovSpan::ImageEdges },
    )
    .unwrap();
    let mut s = scene(cam);
    s.ambient = DVec3::splat(0.1);
    s.background = DVec3::new(0.1, 0.2, 0.3);
    add_material(&mut s, matte(DVec3::new(0.8, 0.7, 0.6), 0.9));
    add_material(&mut s, Material { ks: 0.6, shine: 20.0, mirror: DVec3::splat(0.6), ..Material::default() });
    add_material(&mut s, Material { kd: 0.1, transmittance: 0.8, ior: 1.4, ..Material::default() });
    s.lights.push(Light::point(DVec3::new(5.0, -5.0, 9.0), DVec3::ONE, 0.7));
    s.lights.push(Light::point(DVec3::new(-6.0, -2.0, 7.0), DVec3::new(1.0, 0.8, 0.6), 0.5));
    s.primitives.extend(quad_z(-20.0, 20.0, -20.0, 20.0, -4.0, 0));
    let mut pt = || DVec3::new(rnd() * 10.0 - 5.0, rnd() * 10.0 - 5.0, rnd() * 6.0 - 3.0);
    for k in 0..60 {
        let m = (k % 3) as u32;
        let c = pt();
        let prim = match k % 4 {
            0 => sphere(c, 0.3 + 0.01 * (k as f64), m),
            1 => tri(c, c + DVec3::new(1.0, 0.2, 0.3), c + DVec3::new(0.1, 0.3, 1.2), m),
            2 => Primitive::Cylinder(Cylinder {
                base: c,
                base_radius: 0.3,
                apex: c + DVec3::new(0.2, 0.3, 1.5),
                apex_radius: if k % 8 == 2 { 0.3 } else { 0.1 },
                inside_only: false,
                material: m,
            }),
            _ => sphere(c, 0.5, m),
        };
        s.primitives.push(prim);
    }
    s.validate().unwrap();
    s
}

#[test]
fn brute_bvh_and_cube_give_identical_images() {
    for seed in 1..=4 {
        let s = random_scene(seed);
        let mut o = opts(40, 30);
        o.accel = Accel::Brute;
        let brute = run(&s, &o);
        o.accel = Accel::Bvh;
        let bvh = run(&s, &o);
        assert_eq!(brute.stats.settings.accel, "brute");
        assert_eq!(bvh.stats.settings.accel, "bvh");
        check_stats(&brute);
        check_stats(&bvh);
        assert!(brute.stats.rays.reflect > 0 && brute.stats.rays.refract > 0 && brute.stats.rays.shadow > 0);
        assert_eq!(brute.image, bvh.image, "seed {seed}: images differ");
        assert_eq!(brute.stats.rays, bvh.stats.rays, "seed {seed}: ray counts differ");
        // The BVH must test fewer primitives per eye ray than testing all 62.
        assert!(bvh.stats.tests_per_ray.eye < brute.stats.tests_per_ray.eye);
        // The direction-cube tables (with the BVH for rays leaving surfaces) choose which
        // primitives the same f64 tests run on.
        o.accel = Accel::Cube;
        let cube = run(&s, &o);
        assert_eq!(cube.stats.settings.accel, "cube");
        check_stats(&cube);
        assert_eq!(brute.image, cube.image, "seed {seed}: cube image differs");
        assert_eq!(brute.stats.rays, cube.stats.rays, "seed {seed}: cube ray counts differ");
        assert!(cube.stats.tests_per_ray.eye < brute.stats.tests_per_ray.eye);
        assert!(cube.stats.tests_per_ray.shadow < brute.stats.tests_per_ray.shadow);
        assert!(cube.stats.tests_per_ray.reflect < brute.stats.tests_per_ray.reflect);
        for aov in [Aov::Id, Aov::Depth] {
            o.accel = Accel::Brute;
            let a = render_aov(&s, &o, aov, &ProgressBar::hidden()).unwrap();
            for accel in [Accel::Bvh, Accel::Cube] {
                o.accel = accel;
                let b = render_aov(&s, &o, aov, &ProgressBar::hidden()).unwrap();
                assert_eq!(a.image, b.image, "seed {seed}: {aov:?} differs with {accel:?}");
            }
        }
    }
}
