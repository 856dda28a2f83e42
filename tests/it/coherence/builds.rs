//! What a build of the tables makes: tables only for the effects the scene calls for, and
//! only the eye's table rebuilt when the eye moves.

use glam::DVec3;

use cuberay::coherence::{self, BuildParams, OriginKey, Tables};
use cuberay::scene::{Camera, FovSpan, Projection, Scene};

use super::{scene, small_params, sphere, sweep, tri, World};

/// Origins with a table of their own (all but the fallback origin).
fn tables_of(t: &Tables) -> usize {
    t.flat.origins.iter().filter(|o| o.kind != coherence::OriginKind::Fallback as u32).count()
}

#[test]
fn only_the_effects_the_scene_calls_for() {
    // No lights: no light tables.
    let prims = vec![sphere(DVec3::new(3.0, 0.0, 0.0), 1.0, 0), tri(DVec3::ZERO, DVec3::X, DVec3::Y, 0)];
    let s = scene(DVec3::new(-3.0, 0.0, 0.5), DVec3::new(3.0, 0.0, 0.0), &[DVec3::Z], prims.clone());
    let t = coherence::build(&s, &small_params()).unwrap();
    assert_eq!(tables_of(&t), 2, "eye and one light");
    assert!(!coherence::traces_surface_rays(&s, &small_params()), "no mirror, no glass, no sun");
    let mut dark = s.clone();
    dark.lights.clear();
    let t = coherence::build(&dark, &small_params()).unwrap();
    assert_eq!(tables_of(&t), 1, "eye only");
    assert!(t.flat.light_origin.is_empty());
    // A mirror and a light, but tables for eye rays only (the AOV pass, depth 1 renders).
    let mirror = vec![sphere(DVec3::new(3.0, 0.0, 0.0), 1.0, 1), tri(DVec3::ZERO, DVec3::X, DVec3::Y, 0)];
    let s = scene(DVec3::new(-3.0, 0.0, 0.5), DVec3::new(3.0, 0.0, 0.0), &[DVec3::Z], mirror);
    assert!(s.effects().reflection && s.effects().shadows);
    let t = coherence::build(&s, &small_params()).unwrap();
    assert!(t.flat.light_origin[0] != u32::MAX && coherence::traces_surface_rays(&s, &small_params()));
    let eye_only = BuildParams { effects: Some(cuberay::scene::Effects::default()), ..small_params() };
    let t = coherence::build(&s, &eye_only).unwrap();
    assert_eq!(tables_of(&t), 1, "eye only");
    assert!(!coherence::traces_surface_rays(&s, &eye_only));
    assert!(t.flat.light_origin.iter().all(|&o| o == u32::MAX));
}

#[test]
fn moving_the_eye_rebuilds_only_its_table() {
    // The preview moves the camera: the eye's table is rebuilt, the light tables are kept
    // while they hold, and every ray still agrees with brute force. A move far away, which grows the spawn offset, rebuilds
    // everything.
    let mut prims =
        vec![tri(DVec3::new(-10.0, -10.0, 0.0), DVec3::new(10.0, -10.0, 0.0), DVec3::new(0.0, 10.0, 0.0), 1)];
    for i in 0..5 {
        prims.push(sphere(DVec3::new(-4.0 + 2.0 * i as f64, 0.5 * i as f64, 1.0), 0.6, i % 3));
    }
    prims.push(sphere(DVec3::new(0.0, 6.0, 2.0), 1.5, 2));
    let mut s = scene(DVec3::new(0.0, -14.0, 6.0), DVec3::ZERO, &[DVec3::new(3.0, -2.0, 9.0)], prims);
    let params = BuildParams { image: Some((64, 64)), ..small_params() };
    let mut tables = coherence::build(&s, &params).unwrap();
    let kept: Vec<_> = tables.built[1..].to_vec();
    let check = |s: &Scene, tables: &coherence::Tables| {
        tables.flat.check(s.primitives.len()).unwrap();
        let w = World::of(s, tables.clone());
        for j in 0..16 {
            for i in 0..16 {
                let (o, d) = s.camera.ray(i as f64 * 4.0 + 0.5, j as f64 * 4.0 + 0.5, 64, 64);
                w.check_nearest(OriginKey::Eye, w.p(o), d.as_vec3().normalize()).unwrap();
            }
        }
        sweep(&w, s, OriginKey::Light(0), w.p(s.lights[0].position), 200);
    };
    // A small orbit: only the eye's table changes.
    s.camera = Camera::look_at(
        DVec3::new(3.0, -13.0, 6.5),
        DVec3::ZERO,
        DVec3::Z,
        Projection::Perspective { fov_y: 50f64.to_radians(), span: FovSpan::ImageEdges },
    )
    .unwrap();
    let mut p = params.clone();
    p.spawn_offset = Some(tables.eps);
    assert!(tables.rebuild_eye(&s, &p).unwrap(), "a small move keeps the other tables");
    assert_eq!(tables.built[1..].len(), kept.len());
    for (a, b) in tables.built[1..].iter().zip(&kept) {
        assert_eq!((&a.entries, &a.always, &a.starts), (&b.entries, &b.always, &b.starts));
    }
    check(&s, &tables);
    // Into the glass sphere: the light tables do not depend on what holds the eye.
    s.camera = Camera::look_at(
        DVec3::new(0.0, 6.0, 2.2),
        DVec3::new(0.0, 0.0, 1.0),
        DVec3::Z,
        Projection::Perspective { fov_y: 50f64.to_radians(), span: FovSpan::ImageEdges },
    )
    .unwrap();
    assert!(tables.rebuild_eye(&s, &p).unwrap(), "the eye entered a sphere, nothing else changed");
    check(&s, &tables);
    // Far away: the offset grows with the distance to the eye.
    s.camera = Camera::look_at(
        DVec3::new(0.0, -900.0, 300.0),
        DVec3::ZERO,
        DVec3::Z,
        Projection::Perspective { fov_y: 3f64.to_radians(), span: FovSpan::ImageEdges },
    )
    .unwrap();
    assert!(!tables.rebuild_eye(&s, &params).unwrap(), "the spawn offset grew");
    check(&s, &tables);
}
