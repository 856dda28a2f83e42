//! Analytic scenes whose pixels the CPU reference must give in closed form: a diffuse sphere,
//! a mirror in uniform surroundings, total internal reflection in a glass sphere, an exact
//! shadow boundary.

use glam::DVec3;
use indicatif::ProgressBar;

use cuberay::output::Aov;
use cuberay::reference::render_aov;
use cuberay::scene::{Camera, FovSpan, Light, Material, Primitive, Projection, Sphere};

use super::{add_material, assert_close, check_stats, matte, opts, ortho, px, quad_z, run, scene, sphere};

/// A unit sphere under one point light (no falloff), seen straight on by an orthographic
/// camera: every pixel is ambient + diffuse + Phong in closed form.
#[test]
fn diffuse_sphere_matches_closed_form() {
    let mut s = scene(ortho(DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, DVec3::Y, 1.2));
    let color = DVec3::new(0.9, 0.6, 0.3);
    let m = add_material(&mut s, Material { color, kd: 0.7, ks: 0.3, shine: 12.0, ..Material::default() });
    s.primitives.push(sphere(DVec3::ZERO, 1.0, m));
    let light_pos = DVec3::new(3.0, 4.0, 6.0);
    s.lights.push(Light::point(light_pos, DVec3::new(1.0, 0.9, 0.8), 0.8));
    s.ambient = DVec3::splat(0.1);
    s.background = DVec3::new(0.0, 0.0, 0.25);
    let (w, h) = (24, 24);
    let r = run(&s, &opts(w, h));
    check_stats(&r);
    let mut hits = 0;
    for j in 0..h {
        for i in 0..w {
            // Orthographic: the pixel centre's ray runs along −z from (x, y, 5).
            let (o, _) = s.camera.ray(i as f64 + 0.5, j as f64 + 0.5, w, h);
            let rho2 = o.x * o.x + o.y * o.y;
            let want = if rho2 >= 1.0 {
                s.background
            } else {
                hits += 1;
                let p = DVec3::new(o.x, o.y, (1.0 - rho2).sqrt());
                let n = p;
                let l = (light_pos - p).normalize();
                let v = DVec3::Z;
                let mut c = s.ambient * color * 0.7;
                let ndl = n.dot(l);
                if ndl > 0.0 {
                    let refl = n * 2.0 * ndl - l;
                    let spec = 0.3 * refl.dot(v).max(0.0).powf(12.0);
                    c += DVec3::new(1.0, 0.9, 0.8) * 0.8 * (color * 0.7 * ndl + DVec3::splat(spec));
                }
                c
            };
            assert_close(px(&r.image, i, j), want, 1e-6, &format!("pixel ({i},{j})"));
        }
    }
    assert!(hits > 100);
    assert_eq!(r.stats.rays.eye_hit, hits);
    // A lone convex sphere never shadows itself: one shadow ray per lit hit, none blocked.
    assert_eq!(r.stats.rays.shadow_blocked, 0);
    assert!(r.stats.rays.shadow > 0 && r.stats.rays.shadow < hits);
}

/// A mirror inside a uniformly emitting, inside-only sky sphere: the mirror shows ρ·E,
/// the sky E; at depth 1 the mirror spawns nothing and is black.
#[test]
fn mirror_reflects_uniform_surroundings() {
    let cam = Camera::look_at(
        DVec3::new(0.0, -3.0, 2.0),
        DVec3::ZERO,
        DVec3::Z,
        Projection::Perspective { fov_y: 50f64.to_radians(), span: FovSpan::ImageEdges },
    )
    .unwrap();
    let mut s = scene(cam);
    let e = DVec3::new(0.2, 0.5, 0.8);
    let sky = add_material(&mut s, Material { kd: 0.0, emission: e, ..Material::default() });
    let rho = DVec3::new(0.9, 0.8, 0.5);
    let mirror = add_material(&mut s, Material { kd: 0.0, mirror: rho, ..Material::default() });
    s.primitives.push(Primitive::Sphere(Sphere {
        center: DVec3::ZERO,
        radius: 50.0,
        inside_only: true,
        material: sky,
    }));
    s.primitives.extend(quad_z(-1.0, 1.0, -1.0, 1.0, 0.0, mirror));
    let (w, h) = (20, 16);
    let r = run(&s, &opts(w, h));
    check_stats(&r);
    let ids = render_aov(&s, &opts(w, h), Aov::Id, &ProgressBar::hidden()).unwrap().image;
    let mut mirror_pixels = 0;
    for j in 0..h {
        for i in 0..w {
            let on_mirror = ids.get(i, j)[0] >= 1.0;
            mirror_pixels += on_mirror as u64;
            let want = if on_mirror { rho * e } else { e };
            assert_close(px(&r.image, i, j), want, 1e-6, &format!("pixel ({i},{j})"));
        }
    }
    assert!(mirror_pixels > 20 && mirror_pixels < (w * h) as u64);
    assert_eq!(r.stats.rays.reflect, mirror_pixels);
    assert_eq!(r.stats.rays.eye_hit, (w * h) as u64);
    // Depth 1: eye rays only.
    let mut o = opts(w, h);
    o.max_depth = 1;
    let r1 = run(&s, &o);
    assert_eq!(r1.stats.rays.reflect, 0);
    for j in 0..h {
        for i in 0..w {
            let want = if ids.get(i, j)[0] >= 1.0 { DVec3::ZERO } else { e };
            assert_close(px(&r1.image, i, j), want, 1e-6, "depth 1");
        }
    }
}

/// The camera sits inside a glass sphere. A ray meeting the wall beyond the critical
/// angle is totally reflected, and chords of a sphere keep their angle, so it stays
/// inside: every hit adds the glass's emission and no refraction ray is ever spawned.
/// Below the critical angle each hit also refracts out to the background. Glass whose
/// transmission is tinted (glTF's KHR_materials_transmission) weights what it transmits by
/// its colour too, per channel.
#[test]
fn total_internal_reflection_in_a_glass_sphere() {
    for tinted in [false, true] {
        total_internal_reflection_in_a_glass_sphere_tinted(tinted);
    }
}

fn total_internal_reflection_in_a_glass_sphere_tinted(tinted: bool) {
    let (radius, ior, depth) = (2.0, 1.5, 5u32);
    let color = DVec3::new(0.3, 0.8, 0.5);
    let tint = if tinted { color } else { DVec3::ONE };
    let e = DVec3::new(0.05, 0.1, 0.2);
    let bg = DVec3::new(0.3, 0.6, 0.9);
    let (mirror, trans) = (0.1, 0.8);
    let build = |offset: f64| {
        // A 1×1 orthographic image: one ray along −z from (offset, 0, 0).
        let mut s = scene(ortho(DVec3::new(offset, 0.0, 0.0), DVec3::new(offset, 0.0, -1.0), DVec3::Y, 1e-3));
        s.background = bg;
        let glass = add_material(
            &mut s,
            Material {
                kd: 0.0,
                mirror: DVec3::splat(mirror),
                transmittance: trans,
                tinted_transmission: tinted,
                color,
                ior,
                emission: e,
                ..Material::default()
            },
        );
        s.primitives.push(sphere(DVec3::ZERO, radius, glass));
        s
    };
    // sin θ = offset / radius; critical: sin θ = 1/1.5.
    let tir = run(&build(0.8 * radius), &opts(1, 1));
    check_stats(&tir);
    assert_eq!(tir.stats.rays.refract, 0, "a refraction ray was spawned under total internal reflection");
    assert_eq!(tir.stats.rays.reflect, (depth - 1) as u64);
    // Each of the `depth` hits adds e, weighted by (mirror + transmittance·tint)^k.
    let w = DVec3::splat(mirror) + trans * tint;
    let want: DVec3 = (0..depth).map(|k| e * w.powf(k as f64)).sum();
    assert_close(px(&tir.image, 0, 0), want, 1e-6, "total internal reflection");

    let out = run(&build(0.3 * radius), &opts(1, 1));
    assert_eq!(out.stats.rays.refract, (depth - 1) as u64);
    assert_eq!(out.stats.rays.reflect, (depth - 1) as u64);
    // V_depth = e; V_k = e + mirror·V_{k+1} + trans·bg.
    let mut v = e;
    for _ in 1..depth {
        v = e + v * mirror + bg * trans * tint;
    }
    assert_close(px(&out.image, 0, 0), v, 1e-6, "partial refraction");
}

/// A square occluder above a floor under a point light, seen from straight above: each
/// floor pixel is lit or in shadow as the line to the light says, with a sharp edge.
#[test]
fn shadow_boundary_is_exact() {
    let mut s = scene(ortho(DVec3::new(0.0, 0.0, 10.0), DVec3::ZERO, DVec3::Y, 2.0));
    let floor = add_material(&mut s, matte(DVec3::ONE, 0.8));
    let blocker = add_material(&mut s, matte(DVec3::new(1.0, 0.0, 0.0), 1.0));
    s.primitives.extend(quad_z(-3.0, 3.0, -3.0, 3.0, 0.0, floor));
    let (bx0, bx1, by0, by1, bz) = (-0.5, 0.4, -0.3, 0.6, 1.0);
    s.primitives.extend(quad_z(bx0, bx1, by0, by1, bz, blocker));
    let lp = DVec3::new(0.7, -0.4, 3.0);
    s.lights.push(Light::point(lp, DVec3::ONE, 1.0));
    s.ambient = DVec3::splat(0.05);
    let (w, h) = (40, 40);
    let r = run(&s, &opts(w, h));
    check_stats(&r);
    let (mut lit, mut dark, mut edge) = (0, 0, 0);
    for j in 0..h {
        for i in 0..w {
            let (o, _) = s.camera.ray(i as f64 + 0.5, j as f64 + 0.5, w, h);
            let p = DVec3::new(o.x, o.y, 0.0);
            if p.x >= bx0 && p.x <= bx1 && p.y >= by0 && p.y <= by1 {
                continue; // the blocker itself
            }
            // Where the segment to the light crosses the blocker's plane.
            let q = p + (lp - p) * (bz / lp.z);
            let margin =
                (q.x - bx0).abs().min((q.x - bx1).abs()).min((q.y - by0).abs()).min((q.y - by1).abs());
            if margin < 1e-9 {
                edge += 1;
                continue; // exactly on the shadow edge: either answer is right
            }
            let shadowed = q.x > bx0 && q.x < bx1 && q.y > by0 && q.y < by1;
            let l = (lp - p).normalize();
            let want = if shadowed {
                dark += 1;
                DVec3::splat(0.05 * 0.8)
            } else {
                lit += 1;
                DVec3::splat(0.05 * 0.8 + 0.8 * l.z)
            };
            assert_close(px(&r.image, i, j), want, 1e-6, &format!("floor pixel ({i},{j})"));
        }
    }
    assert!(lit > 100 && dark > 20, "lit {lit}, dark {dark}");
    // Pixel row 22 projects exactly onto the blocker's edge y = −0.3.
    assert!(edge > 0);
    let blocked = r.stats.rays.shadow_blocked;
    assert!(blocked >= dark && blocked <= dark + edge, "{blocked} blocked, {dark} dark, {edge} on the edge");
}
