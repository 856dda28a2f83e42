//! The GPU against the CPU reference, scene by scene (FLIP mean, ray counts): the showcase
//! (its statistics, jittered and corner sampling, far from the origin, its AOVs), the SPD
//! databases at sizes 1 and 2, and the self-hits of a spawn offset too small.

use crate::common::renderer;
use cuberay::arith::spawn::SpawnPolicy;
use cuberay::compare::compare;
use cuberay::job::{Accel, RenderOptions};
use cuberay::output::Aov;
use cuberay::reference;
use cuberay::sampling::Sampling;
use cuberay::scene::Primitive;
use glam::DVec3;

use super::{agree, hidden, showcase, spd};

#[test]
fn showcase_agrees_with_the_cpu() {
    let (g, c) = agree("showcase", &showcase(), &RenderOptions::new(96, 72), 0.01);
    // Every kind of ray is exercised.
    assert!(g.stats.rays.reflect > 0 && g.stats.rays.refract > 0 && g.stats.rays.shadow_blocked > 0);
    // The same statistics keys on both backends, and GPU kernel times when measured.
    let keys = |s: &str| {
        let v: serde_json::Value = serde_json::from_str(s).unwrap();
        let mut k = Vec::new();
        for (group, inner) in v.as_object().unwrap() {
            match inner.as_object() {
                Some(o) => k.extend(o.keys().map(|n| format!("{group}.{n}"))),
                None => k.push(group.clone()),
            }
        }
        k
    };
    assert_eq!(keys(&g.stats.to_json()), keys(&c.stats.to_json()));
    assert_eq!(g.stats.settings.backend, "gpu");
    assert_eq!(g.stats.time.gpu_s.is_some(), renderer().ctx.timestamps);
    // The wavefront's kernels ran: their times add up to the total.
    let k = g.stats.time.gpu_kernel_s;
    if let Some(total) = g.stats.time.gpu_s {
        let parts = [k.nearest, k.shade, k.shadow, k.resolve].map(|t| t.unwrap_or(0.0));
        assert!(k.nearest.is_some() && k.shade.is_some() && k.resolve.is_some(), "{k:?}");
        assert!((parts.iter().sum::<f64>() - total).abs() <= 1e-9 * total.max(1.0), "{k:?} against {total}");
        // By depth, the same passes: the depths' times add up to nearest + shade + shadow,
        // and every depth of the render ran.
        let depths = g.stats.time.gpu_depth_s.as_ref().expect("timed by depth");
        assert_eq!(depths.iter().map(|d| d.depth).collect::<Vec<_>>(), (1..=5).collect::<Vec<_>>());
        let by_depth: f64 = depths.iter().map(|d| d.all).sum();
        assert!((by_depth - parts[..3].iter().sum::<f64>()).abs() <= 1e-9 * total.max(1.0), "{depths:?}");
    }
    assert_eq!(k.aov, None);
    // Lane coherence: the eye pass had one invocation per grid point, in full groups (96·72
    // points are whole workgroups), so that a group pays at least its mean and a group of 32
    // at least one of 8; the CPU has none.
    let lanes = &g.stats.lanes;
    let eye = lanes.nearest[0];
    assert_eq!((eye.depth, eye.invocations), (1, 96 * 72));
    assert!(eye.steps > 0.0 && eye.max8 >= eye.steps && eye.max32 >= eye.max8, "{eye:?}");
    assert!(lanes.nearest.len() >= 2 && !lanes.shade.is_empty(), "{lanes:?}");
    assert!(lanes.nearest.iter().chain(&lanes.shade).all(|l| l.steps > 0.0 && l.max8 > 0.0), "{lanes:?}");
    assert!(c.stats.lanes.nearest.is_empty());
}

#[test]
fn jitter_and_corners_sample_where_the_cpu_does() {
    let scene = showcase();
    let jitter = RenderOptions { spp: 4, seed: 7, ..RenderOptions::new(48, 36) };
    agree("showcase jitter", &scene, &jitter, 0.01);
    let corners = RenderOptions { sampling: Sampling::Corners, ..RenderOptions::new(48, 36) };
    let (g, _) = agree("showcase corners", &scene, &corners, 0.01);
    assert_eq!(g.stats.rays.eye, 49 * 37);
}

/// The showcase moved far from the origin: re-centring on the camera keeps f32 precise.
#[test]
fn a_scene_far_from_the_origin_keeps_its_precision() {
    let mut scene = showcase();
    let shift = DVec3::new(3.0e5, -2.0e5, 1.0e5);
    scene.camera.eye += shift;
    for l in &mut scene.lights {
        l.position += shift;
    }
    for p in &mut scene.primitives {
        match p {
            Primitive::Sphere(s) => s.center += shift,
            Primitive::Triangle(t) => t.p.iter_mut().for_each(|v| *v += shift),
            Primitive::Cylinder(c) => {
                c.base += shift;
                c.apex += shift;
            }
        }
    }
    agree("showcase far away", &scene, &RenderOptions::new(64, 48), 0.01);
}

#[test]
fn aovs_match_the_cpu() {
    let scene = showcase();
    let opts = RenderOptions::new(64, 48);
    let g = renderer().render_aov(&scene, &opts, Aov::Id, &hidden()).unwrap();
    let c = reference::render_aov(&scene, &opts, Aov::Id, &hidden()).unwrap();
    let same = g.image.pixels.iter().zip(&c.image.pixels).filter(|(a, b)| a == b).count();
    // Only pixels whose centre grazes an edge may differ between f32 and f64.
    assert!(same as f64 >= 0.995 * g.image.pixels.len() as f64, "ids agree at {same} pixels");
    let g = renderer().render_aov(&scene, &opts, Aov::Depth, &hidden()).unwrap();
    let c = reference::render_aov(&scene, &opts, Aov::Depth, &hidden()).unwrap();
    let close = g
        .image
        .pixels
        .iter()
        .zip(&c.image.pixels)
        .filter(|(a, b)| (a[0] - b[0]).abs() <= 1e-4 * b[0].abs().max(1.0) && a[3] == b[3])
        .count();
    assert!(close as f64 >= 0.995 * g.image.pixels.len() as f64, "depths agree at {close} pixels");
    assert_eq!(g.stats.rays.eye, 64 * 48);
}

/// An SPD size-1 database, 64×64, the SPD depth 5, on the tables (forced: for so small an
/// image `auto` would take the BVH for most origins).
fn spd_size_1_agrees_with_the_cpu(db: &str) {
    let name = format!("{db}_s1");
    let opts = RenderOptions { accel: Accel::Cube, ..RenderOptions::new(64, 64) };
    let (g, _) = agree(&name, &spd(&name), &opts, 0.01);
    assert_eq!(g.stats.settings.accel, "cube");
}
spd_cases!(spd_size_1_agrees_with_the_cpu: super::spd_size_1_agrees_with_the_cpu => [balls, gears, jacks, lattice, mount, rings, shells, sombrero, teapot, tetra, tree]);

/// An SPD size-2 database, 48×48 with SPD corner sampling, on the tables.
fn spd_size_2_agrees_with_the_cpu(db: &str) {
    let name = format!("{db}_s2");
    let opts =
        RenderOptions { sampling: Sampling::Corners, accel: Accel::Cube, ..RenderOptions::new(48, 48) };
    let (g, _) = agree(&name, &spd(&name), &opts, 0.01);
    assert_eq!(g.stats.settings.accel, "cube");
}
spd_cases!(spd_size_2_agrees_with_the_cpu: super::spd_size_2_agrees_with_the_cpu => [balls, gears, jacks, lattice, mount, rings, shells, sombrero, teapot, tetra, tree]);

/// `rays.self_hits` counts spawned rays that hit within 4 spawn offsets of their origin.
/// With a fixed offset below the rounding error of the hit points, rays re-hit the surface
/// they leave (rings: cylinders, which a ray leaving them still tests; mount: the facets
/// next to the one left) and the count says so, as the image does; with the default offset
/// it is 0, as on the f64 reference.
fn a_spawn_offset_too_small_shows_as_self_hits(name: &str, epsilon: f32, at_least: u64) {
    let scene = spd(name);
    let opts = |spawn| RenderOptions { spawn, ..RenderOptions::new(64, 64) };
    let render = |spawn| renderer().render(&scene, &opts(spawn), &hidden()).unwrap();
    let (scaled, tiny) = (render(SpawnPolicy::Scaled), render(SpawnPolicy::Fixed(epsilon)));
    let cpu = reference::render(&scene, &opts(SpawnPolicy::Scaled), &hidden()).unwrap();
    let (flip_scaled, flip_tiny) = (
        compare(&cpu.image, &scaled.image, 0.0).0.flip_mean,
        compare(&cpu.image, &tiny.image, 0.0).0.flip_mean,
    );
    let (s, t) = (scaled.stats.rays, tiny.stats.rays);
    eprintln!(
        "{name}: self-hits scaled {} of {} rays (FLIP {flip_scaled:.5}), fixed {epsilon:e} {} of {} (FLIP \
         {flip_tiny:.5}), cpu {}",
        s.self_hits, s.total, t.self_hits, t.total, cpu.stats.rays.self_hits
    );
    assert_eq!((s.self_hits, cpu.stats.rays.self_hits), (0, 0), "{name}: self-hits with the default offset");
    assert!(t.self_hits >= at_least, "{name}: only {} self-hits with a {epsilon:e} offset", t.self_hits);
    assert!(flip_tiny > flip_scaled, "{name}: the acne does not show ({flip_tiny} <= {flip_scaled})");
}
cases!(a_spawn_offset_too_small_shows_as_self_hits: super::a_spawn_offset_too_small_shows_as_self_hits {
    rings => ("rings_s1", 1e-7, 100),
    mount => ("mount_s1", 1e-8, 1000),
});
