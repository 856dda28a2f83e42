//! The candidate tables against brute force: random scenes of spheres, triangles and
//! cylinders with random rays from every kind of origin (property tests), and directed cases
//! (cell, face, edge and corner directions, −0.0 components, the eye inside bounding spheres,
//! tangent and nested spheres, huge ground polygons), and SPD scenes traced with every ray
//! checked.
//!
//! This module holds the scene construction and the checks against brute force ([`World`],
//! [`sweep`]); the tests are in one sub-module per kind:
//!
//! - `properties`: property tests over random scenes (proptest keeps their seeds in
//!   `tests/proptest-regressions/coherence/properties.txt`, the path it derives from theirs);
//! - `directed`: directed cases;
//! - `builds`: what a build makes (tables only for the effects called for) and rebuilding
//!   the eye's table alone;
//! - `scenes`: the SPD databases and the hard-case scenes, every ray checked.

use glam::{DVec3, Vec3};

use cuberay::arith::closest::{brute_nearest, no_closest, test_prim, TestHit};
use cuberay::arith::geometry::{make_ray, Prim32, PrimHit, Ray};
use cuberay::arith::{FAR, NO_ID};
use cuberay::coherence::walk::{self, AnyHit};
use cuberay::coherence::{self, BuildParams, OriginKey, Tables, WalkCount};
use cuberay::scene::{
    Camera, Cylinder, FovSpan, Light, Material, Primitive, Projection, Scene, Sphere, Triangle,
};

mod builds;
mod directed;
mod properties;
mod scenes;

// ---------------------------------------------------------------------------------------------
// Scene construction

fn materials() -> Vec<Material> {
    vec![
        Material::default(),
        Material { mirror: DVec3::splat(0.5), ks: 0.5, ..Material::default() },
        Material { transmittance: 0.8, ior: 1.5, ..Material::default() },
    ]
}

fn scene(eye: DVec3, at: DVec3, lights: &[DVec3], primitives: Vec<Primitive>) -> Scene {
    let up = if (at - eye).normalize().dot(DVec3::Z).abs() > 0.99 { DVec3::Y } else { DVec3::Z };
    let camera = Camera::look_at(
        eye,
        at,
        up,
        Projection::Perspective { fov_y: 50f64.to_radians(), span: FovSpan::ImageEdges },
    )
    .unwrap();
    let s = Scene {
        camera,
        lights: lights.iter().map(|&p| Light::point(p, DVec3::ONE, 1.0)).collect(),
        ambient: DVec3::splat(0.1),
        background: DVec3::ZERO,
        materials: materials(),
        textures: Vec::new(),
        primitives,
        resolution: Some((64, 64)),
        up: up.normalize(),
        environment: None,
        transfer: Default::default(),
    };
    s.validate().unwrap();
    s
}

fn sphere(c: DVec3, r: f64, material: u32) -> Primitive {
    Primitive::Sphere(Sphere { center: c, radius: r, inside_only: false, material })
}

fn tri(a: DVec3, b: DVec3, c: DVec3, material: u32) -> Primitive {
    Primitive::Triangle(Triangle::new([a, b, c], material))
}

fn cyl(a: DVec3, ra: f64, b: DVec3, rb: f64, material: u32) -> Primitive {
    Primitive::Cylinder(Cylinder {
        base: a,
        base_radius: ra,
        apex: b,
        apex_radius: rb,
        inside_only: false,
        material,
    })
}

/// Small resolutions, so that cells are wide and lists long.
fn small_params() -> BuildParams {
    BuildParams { eye_n: Some(24), light_n: Some(16), ..BuildParams::default() }
}

// ---------------------------------------------------------------------------------------------
// Brute force and walkers

struct World {
    prims: Vec<Prim32>,
    tables: Tables,
    shift: DVec3,
}

impl World {
    fn new(scene: &Scene, params: &BuildParams) -> World {
        let tables = coherence::build(scene, params).unwrap();
        tables.flat.check(scene.primitives.len()).unwrap();
        World::of(scene, tables)
    }

    fn of(scene: &Scene, tables: Tables) -> World {
        let shift = scene.camera.eye;
        World { prims: Prim32::from_scene(scene, shift), tables, shift }
    }

    fn p(&self, p: DVec3) -> Vec3 {
        (p - self.shift).as_vec3()
    }

    fn brute(&self, ray: &Ray, t_max: f32) -> (u32, f32) {
        let b = brute_nearest(&self.prims, ray, t_max, NO_ID);
        (b.prim, b.best_t(FAR))
    }

    /// The entries of the list of a ray from `key` along `d`, in walk order (for failure
    /// messages).
    fn candidates(&self, key: OriginKey, d: Vec3) -> Vec<(u32, f32)> {
        let f = &self.tables.flat;
        let mut w = f.walk_from(key, d);
        let mut out = Vec::new();
        while !walk::walk_done(&w) {
            let e = walk::walk_next(f, &mut w);
            out.push((e.id, e.d_min));
        }
        out
    }

    /// Nearest hit through the walker, unbounded, in steps of a small budget, and with f64
    /// distances; all must agree with brute force.
    fn check_nearest(&self, key: OriginKey, o: Vec3, d: Vec3) -> Result<(), String> {
        let f = &self.tables.flat;
        if f.cube_of(key).is_none() {
            return Err(format!("no table for {key:?}"));
        }
        let ray = make_ray(o, d);
        let test = |id: u32| test_prim(&self.prims[id as usize], &ray, FAR);
        let mut count = WalkCount::default();
        let h = walk::table_nearest(f, key, ray.d, FAR, NO_ID, &mut count, test);
        let want = self.brute(&ray, FAR);
        if (h.prim, h.best_t(FAR)) != want {
            return Err(format!(
                "{key:?} o={o} d={d}: walker {:?} brute {:?}; candidates {:?}",
                (h.prim, h.best_t(FAR)),
                want,
                self.candidates(key, ray.d)
            ));
        }
        // Stepped, as the GPU walks long lists: three iterations per step, resumed; walked
        // again where the tie rule lost the winner.
        let mut best = no_closest::<f32, PrimHit>();
        let mut steps = 0;
        for again in [false, true] {
            if again {
                if !best.lost {
                    break;
                }
                best = best.again();
            }
            let mut w = f.walk_from(key, ray.d);
            while !walk::walk_nearest(f, &mut w, &mut best, FAR, NO_ID, 3, &mut count, test) {
                steps += 1;
            }
        }
        if (best.prim, best.best_t(FAR)) != want {
            return Err(format!(
                "{key:?}: stepped walker ({steps} steps) {:?} brute {want:?}",
                (best.prim, best.t)
            ));
        }
        let g64 = walk::table_nearest(f, key, ray.d, f64::MAX, NO_ID, &mut count, |id| {
            test(id).map(|h| TestHit { t: h.t as f64, err: h.err as f64, hit: () })
        });
        if g64.prim != want.0 {
            return Err(format!("{key:?}: f64 walker {:?} brute {want:?}", (g64.prim, g64.t)));
        }
        Ok(())
    }

    fn check_any(&self, key: OriginKey, o: Vec3, d: Vec3, t_max: f32) -> Result<(), String> {
        let f = &self.tables.flat;
        if f.cube_of(key).is_none() {
            return Err(format!("no table for {key:?}"));
        }
        let ray = make_ray(o, d);
        let hits = |id: u32| self.prims[id as usize].intersect(&ray, t_max).ok;
        let mut count = WalkCount::default();
        let b = walk::table_any(f, key, ray.d, t_max, NO_ID, &mut count, hits);
        let want = self.brute(&ray, t_max).0 != NO_ID;
        if b != want {
            return Err(format!("{key:?} any o={o} d={d} t_max={t_max}: walker {b} brute {want}"));
        }
        let mut w = f.walk_from(key, ray.d);
        let stepped = loop {
            match walk::walk_any(f, &mut w, t_max, NO_ID, 2, &mut count, hits) {
                AnyHit::Unfinished => continue,
                a => break a == AnyHit::Blocked,
            }
        };
        if stepped != want {
            return Err(format!("{key:?}: stepped any {stepped} brute {want}"));
        }
        let g = walk::table_any(f, key, ray.d, t_max as f64, NO_ID, &mut count, hits);
        if g != want {
            return Err(format!("{key:?}: f64 any {g} brute {want}"));
        }
        Ok(())
    }
}

/// True when `d` is inside the camera's frustum for a square image (the eye table covers it).
fn in_frustum(s: &Scene, d: Vec3) -> bool {
    let c = &s.camera;
    let d = d.as_dvec3();
    let Projection::Perspective { fov_y, .. } = c.projection else { return false };
    let f = d.dot(c.forward);
    let t = (fov_y * 0.5).tan() * 0.999;
    f > 0.0 && d.dot(c.right).abs() <= t * f && d.dot(c.up).abs() <= t * f
}

/// A unit direction from three numbers in [-1, 1], or a fallback axis.
fn dir(x: f32, y: f32, z: f32) -> Vec3 {
    let v = Vec3::new(x, y, z);
    if v.length() < 1e-3 {
        Vec3::Z
    } else {
        v.normalize()
    }
}

/// Rays from many points toward random directions; used by the directed cases and scenes.
fn sweep(w: &World, s: &Scene, key: OriginKey, o: Vec3, count: usize) {
    let mut seed = 0x2545f4914f6cdd1du64;
    let mut rnd = || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
    };
    let _ = s;
    for _ in 0..count {
        let d = dir(rnd(), rnd(), rnd());
        if key == OriginKey::Eye && !in_frustum(s, d) {
            continue;
        }
        w.check_nearest(key, o, d).unwrap();
        w.check_any(key, o, d, 1.0 + 4.0 * rnd().abs()).unwrap();
    }
}
