//! Directed cases of the tables against brute force: cell, face, edge and corner directions
//! and −0.0 components, a zero direction, the eye inside bounding spheres, tangent and nested
//! spheres, a huge ground polygon, cut-out surfaces.

use glam::{DVec3, Vec3};

use cuberay::arith::closest::TestHit;
use cuberay::arith::{FAR, NO_ID};
use cuberay::coherence::walk;
use cuberay::coherence::{BuildParams, OriginKey, WalkCount};
use cuberay::scene::{Alpha, FovSpan, Primitive, Projection};

use super::{cyl, dir, in_frustum, scene, small_params, sphere, sweep, tri, World};

/// Directions exactly on cell boundaries (u = −1 + 2k/N), face diagonals (|x| = |y|), cube
/// corners, axes, and with −0.0 components: every lookup finds what brute force hits.
fn boundary_directions(n: u32) -> Vec<Vec3> {
    let mut out = Vec::new();
    for ax in 0..3 {
        for s in [1.0f32, -1.0] {
            for k in 0..=n {
                for l in [0, n / 2, n / 3, n] {
                    let u = -1.0 + 2.0 * k as f32 / n as f32;
                    let v = -1.0 + 2.0 * l as f32 / n as f32;
                    let mut w = [0.0f32; 3];
                    w[ax] = s;
                    w[(ax + 1) % 3] = u;
                    w[(ax + 2) % 3] = v;
                    out.push(Vec3::from_array(w).normalize());
                }
            }
        }
    }
    for x in [-1.0f32, -0.0, 0.0, 1.0] {
        for y in [-1.0f32, -0.0, 0.0, 1.0] {
            for z in [-1.0f32, -0.0, 0.0, 1.0] {
                let v = Vec3::new(x, y, z);
                if v.length() > 0.0 {
                    out.push(v / v.length());
                }
            }
        }
    }
    out
}

/// A dense shell of small objects around the origin point, so that every boundary direction
/// has something to hit.
fn shell(center: DVec3) -> Vec<Primitive> {
    let mut p = Vec::new();
    let mut k = 0;
    for ax in 0..3 {
        for s in [1.0, -1.0] {
            for i in -2..=2 {
                for j in -2..=2 {
                    let mut c = [0.0; 3];
                    c[ax] = 3.0 * s;
                    c[(ax + 1) % 3] = 1.5 * i as f64;
                    c[(ax + 2) % 3] = 1.5 * j as f64;
                    let c = center + DVec3::from_array(c);
                    p.push(match k % 3 {
                        0 => sphere(c, 0.8, 1),
                        1 => tri(
                            c + DVec3::new(-1.0, -1.0, 0.3),
                            c + DVec3::new(1.2, -0.9, -0.2),
                            c + DVec3::new(0.1, 1.1, 0.1),
                            1,
                        ),
                        _ => cyl(c - DVec3::new(0.0, 0.7, 0.5), 0.5, c + DVec3::new(0.3, 0.7, 0.5), 0.4, 1),
                    });
                    k += 1;
                }
            }
        }
    }
    p
}

#[test]
fn boundary_directions_from_every_origin_kind() {
    let c = DVec3::new(0.25, -0.5, 0.125);
    let mut s = scene(c, c + DVec3::X, &[c], shell(c));
    s.camera.projection = Projection::Perspective { fov_y: 170f64.to_radians(), span: FovSpan::ImageEdges };
    for n in [4u32, 8] {
        let params = BuildParams { eye_n: Some(n), light_n: Some(n), ..small_params() };
        let w = World::new(&s, &params);
        for d in boundary_directions(n) {
            // Eye and light sit at the centre.
            if in_frustum(&s, d) {
                w.check_nearest(OriginKey::Eye, w.p(c), d).unwrap();
            }
            w.check_nearest(OriginKey::Light(0), w.p(c), d).unwrap();
            w.check_any(OriginKey::Light(0), w.p(c), d, 3.2).unwrap();
        }
    }
}

#[test]
fn zero_direction_is_rejected() {
    let s = scene(DVec3::ZERO, DVec3::X, &[DVec3::Z], vec![sphere(DVec3::new(3.0, 0.0, 0.0), 1.0, 0)]);
    let w = World::new(&s, &small_params());
    let f = &w.tables.flat;
    let eye = OriginKey::Eye;
    let mut count = WalkCount::default();
    let h = walk::table_nearest(f, eye, Vec3::ZERO, FAR, NO_ID, &mut count, |_| {
        Some(TestHit { t: 0.0, err: 0.0, hit: () })
    });
    assert_eq!((h.found, h.prim, count.tests), (false, NO_ID, 0));
    let h = walk::table_nearest(f, eye, Vec3::ZERO, f64::MAX, NO_ID, &mut count, |_| {
        Some(TestHit { t: 0.0, err: 0.0, hit: () })
    });
    assert!(!h.found && count.tests == 0);
    assert!(!walk::table_any(f, eye, Vec3::ZERO, FAR, NO_ID, &mut count, |_| true));
}

#[test]
fn eye_inside_bounding_spheres() {
    // The eye inside a glass sphere, inside a cluster's bounding sphere, and inside a
    // cylinder: the enclosing objects are in every cell.
    let prims = vec![
        sphere(DVec3::ZERO, 2.0, 2),
        tri(DVec3::new(-3.0, -3.0, -0.5), DVec3::new(3.0, -3.0, -0.5), DVec3::new(0.0, 3.0, -0.5), 0),
        cyl(DVec3::new(0.0, 0.0, -1.0), 0.5, DVec3::new(0.0, 0.0, 1.0), 0.5, 1),
        sphere(DVec3::new(0.2, 0.1, 0.0), 0.1, 1),
        sphere(DVec3::new(5.0, 0.0, 0.0), 1.0, 1),
        sphere(DVec3::new(0.0, 6.0, 0.0), 1.0, 1),
        sphere(DVec3::new(0.1, 6.2, 0.0), 0.3, 1),
    ];
    let s = scene(DVec3::new(0.05, 0.0, 0.3), DVec3::new(1.0, 0.2, 0.3), &[DVec3::new(0.0, 0.0, 0.9)], prims);
    for params in [small_params(), BuildParams::default()] {
        let w = World::new(&s, &params);
        let eye = w.p(s.camera.eye);
        sweep(&w, &s, OriginKey::Eye, eye, 400);
        sweep(&w, &s, OriginKey::Light(0), w.p(s.lights[0].position), 400);
        // The image sees only the frustum; check rays through the image too.
        for j in 0..32 {
            for i in 0..32 {
                let (o, d) = s.camera.ray(i as f64 * 2.0, j as f64 * 2.0, 64, 64);
                w.check_nearest(OriginKey::Eye, w.p(o), d.as_vec3().normalize()).unwrap();
            }
        }
    }
}

#[test]
fn tangent_and_nested_spheres() {
    // A chain of tangent spheres (each touching the next), a sphere nested inside another,
    // and equal-size spheres touching at one point: neighbours list each other in every
    // cell where they can be seen from the eye and the light.
    let mut prims = Vec::new();
    let mut x = 0.0;
    for i in 0..6 {
        let r = 0.3 + 0.1 * i as f64;
        prims.push(sphere(DVec3::new(x + r, 0.0, 0.0), r, 1));
        x += 2.0 * r;
    }
    prims.push(sphere(DVec3::new(2.0, 3.0, 0.0), 1.5, 2));
    prims.push(sphere(DVec3::new(2.2, 3.1, 0.1), 0.5, 1));
    prims.push(sphere(DVec3::new(-1.0, -1.0, 0.0), 0.5, 1));
    prims.push(sphere(DVec3::new(-1.0, -2.0, 0.0), 0.5, 1));
    let s = scene(
        DVec3::new(1.0, -6.0, 2.0),
        DVec3::new(2.0, 1.0, 0.0),
        &[DVec3::new(-3.0, -3.0, 5.0)],
        prims.clone(),
    );
    for params in [small_params(), BuildParams::default()] {
        let w = World::new(&s, &params);
        sweep(&w, &s, OriginKey::Light(0), w.p(s.lights[0].position), 400);
        for j in 0..16 {
            for i in 0..16 {
                let (o, d) = s.camera.ray(i as f64 * 4.0 + 1.0, j as f64 * 4.0 + 1.0, 64, 64);
                w.check_nearest(OriginKey::Eye, w.p(o), d.as_vec3().normalize()).unwrap();
            }
        }
    }
}

#[test]
fn huge_ground_polygon() {
    // An SPD-like ground (two triangles 2·10^4 wide) with mirror balls resting on it: the
    // ground is bounded by its plane side and cut-off per cell, and every ray still agrees.
    let g = 1.0e4;
    let mut prims = vec![
        tri(DVec3::new(-g, -g, 0.0), DVec3::new(g, -g, 0.0), DVec3::new(g, g, 0.0), 0),
        tri(DVec3::new(-g, -g, 0.0), DVec3::new(g, g, 0.0), DVec3::new(-g, g, 0.0), 0),
    ];
    for i in 0..5 {
        for j in 0..5 {
            let r = 0.2 + 0.05 * ((i * 5 + j) % 4) as f64;
            prims.push(sphere(DVec3::new(i as f64 - 2.0, j as f64 - 2.0, r), r, 1));
        }
    }
    let s = scene(
        DVec3::new(4.0, -5.0, 3.0),
        DVec3::ZERO,
        &[DVec3::new(3.0, 2.0, 6.0), DVec3::new(-20.0, 5.0, 1.0)],
        prims.clone(),
    );
    let w = World::new(&s, &small_params());
    for j in 0..32 {
        for i in 0..32 {
            let (o, d) = s.camera.ray(i as f64 * 2.0 + 0.5, j as f64 * 2.0 + 0.5, 64, 64);
            w.check_nearest(OriginKey::Eye, w.p(o), d.as_vec3().normalize()).unwrap();
        }
    }
    sweep(&w, &s, OriginKey::Light(0), w.p(s.lights[0].position), 300);
    sweep(&w, &s, OriginKey::Light(1), w.p(s.lights[1].position), 300);
}

/// A masked or blended surface never proves a cell covered, or rays through its holes would
/// miss what lies behind: the wall behind a quad stays in the list of the rays through the
/// quad's middle when the quad is masked or blended, and is cut off when it is opaque (so
/// that the cut-off is shown to happen there at all).
#[test]
fn cut_out_surfaces_never_cut_lists_off() {
    let quad = |h: f64, z: f64, m: u32| {
        let c = |x: f64, y: f64| DVec3::new(x * h, y * h, z);
        vec![
            tri(c(-1.0, -1.0), c(1.0, -1.0), c(1.0, 1.0), m),
            tri(c(-1.0, -1.0), c(1.0, 1.0), c(-1.0, 1.0), m),
        ]
    };
    // The quad takes material 0 (its alpha set below), the wall the opaque mirror.
    let mut prims = quad(2.0, 0.0, 0);
    prims.extend(quad(4.0, -1.0, 1));
    for (alpha, cut) in [(Alpha::Opaque, true), (Alpha::Mask { cutoff: 0.5 }, false), (Alpha::Blend, false)] {
        let mut s = scene(DVec3::new(0.0, 0.0, 3.0), DVec3::ZERO, &[], prims.clone());
        s.materials[0].alpha = alpha;
        let w = World::new(&s, &small_params());
        // Away from the diagonal, where a cell lies within one triangle.
        for d in [dir(0.3, -0.15, -1.0), dir(-0.3, 0.2, -1.0), dir(0.2, -0.3, -1.0)] {
            let list = w.candidates(OriginKey::Eye, d);
            let wall = list.iter().any(|&(id, _)| id >= 2);
            assert_eq!(wall, !cut, "{alpha:?} along {d}: {list:?}");
        }
    }
}
