//! The candidate tables against brute force: random scenes of spheres, triangles and
//! cylinders with random rays from every kind of origin (property tests), and directed cases
//! (cell, face, edge and corner directions, −0.0 components, the eye inside bounding spheres,
//! tangent and nested spheres, huge ground polygons), and SPD scenes traced with every ray
//! checked.

use glam::{DVec3, Vec3};
use proptest::prelude::*;

use cuberay::arith::closest::{brute_nearest, no_closest, test_prim, TestHit};
use cuberay::arith::geometry::{make_ray, Prim32, PrimHit, Ray};
use cuberay::arith::{FAR, NO_ID};
use cuberay::coherence::walk::{self, AnyHit};
use cuberay::coherence::{self, audit, BuildParams, OriginKey, Tables, WalkCount};
use cuberay::scene::{
    Alpha, Camera, Cylinder, FovSpan, Light, Material, Primitive, Projection, Scene, Sphere, Triangle,
};

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

// ---------------------------------------------------------------------------------------------
// Property tests

fn arb_vec(r: f64) -> impl Strategy<Value = DVec3> {
    (-r..r, -r..r, -r..r).prop_map(|(x, y, z)| DVec3::new(x, y, z))
}

fn arb_prim() -> impl Strategy<Value = Primitive> {
    let m = 0u32..3;
    prop_oneof![
        (arb_vec(4.0), 0.05f64..1.5, m.clone()).prop_map(|(c, r, m)| sphere(c, r, m)),
        (arb_vec(4.0), arb_vec(1.5), arb_vec(1.5), m.clone()).prop_filter_map(
            "degenerate",
            |(c, a, b, m)| {
                let t = tri(c, c + a, c + b, m);
                match &t {
                    Primitive::Triangle(x) if !x.is_degenerate() && x.cross().length() > 1e-3 => Some(t),
                    _ => None,
                }
            }
        ),
        (arb_vec(4.0), arb_vec(1.5), 0.05f64..0.6, 0.0f64..0.6, m)
            .prop_filter_map("short", |(a, v, ra, rb, m)| {
                (v.length() > 0.05).then(|| cyl(a, ra, a + v, rb.max(0.01), m))
            }),
    ]
}

fn arb_scene() -> impl Strategy<Value = Scene> {
    (
        proptest::collection::vec(arb_prim(), 1..10),
        arb_vec(7.0),
        arb_vec(2.0),
        proptest::collection::vec(arb_vec(7.0), 1..3),
    )
        .prop_filter_map("camera", |(prims, eye, at, lights)| {
            ((at - eye).length() > 0.1).then(|| scene(eye, at, &lights, prims))
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, .. ProptestConfig::default() })]

    /// Eye rays anywhere in the image: the walker's nearest hit is brute force's.
    #[test]
    fn eye_rays_match_brute_force(s in arb_scene(), pts in proptest::collection::vec((0.0f64..64.0, 0.0f64..64.0), 40)) {
        let w = World::new(&s, &small_params());
        for (x, y) in pts {
            let (o, d) = s.camera.ray(x, y, 64, 64);
            w.check_nearest(OriginKey::Eye, w.p(o), d.as_vec3().normalize()).map_err(TestCaseError::fail)?;
        }
    }

    /// Shadow rays from each light toward random points (any-hit with a distance limit) and
    /// nearest hits from the light in any direction.
    #[test]
    fn light_rays_match_brute_force(s in arb_scene(), pts in proptest::collection::vec(arb_vec(6.0), 30), frac in 0.05f32..1.0) {
        let w = World::new(&s, &small_params());
        for (li, l) in s.lights.iter().enumerate() {
            let lp = w.p(l.position);
            for q in &pts {
                let v = w.p(*q) - lp;
                if v.length() < 1e-3 { continue; }
                let d = v.normalize();
                w.check_any(OriginKey::Light(li), lp, d, v.length() * frac).map_err(TestCaseError::fail)?;
                w.check_nearest(OriginKey::Light(li), lp, d).map_err(TestCaseError::fail)?;
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Directed cases

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

/// Rays from many points toward random directions; used by the directed scenes below.
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

/// A small SPD database at 24×24 corners, depth 5, every eye and shadow ray (and the rays
/// leaving surfaces, which walk the fallback origin here) checked against brute force.
fn spd_every_ray_agrees_with_brute_force(name: &str) {
    let path = crate::common::shared(&format!("spd/nff/{name}.nff"));
    let scene = cuberay::load::load(&path, &Default::default()).unwrap().scene;
    let params = BuildParams { eye_n: Some(64), light_cells: 1 << 12, ..BuildParams::default() };
    let tables = coherence::build(&scene, &params).unwrap();
    tables.flat.check(scene.primitives.len()).unwrap();
    let r = audit::trace_counts(
        &scene,
        &tables,
        audit::AuditParams { width: 24, height: 24, corners: true, max_depth: 5, verify_every: 1 },
    );
    assert_eq!(r.mismatches, 0, "{name}: {r:?}");
    assert!(r.verified >= 625, "{name}: {r:?}");
    assert_eq!(r.eye.rays, 625);
    assert_eq!(r.eye.untabled, 0, "{name}: eye rays without a table");
}

cases!(spd_every_ray_agrees_with_brute_force: super::spd_every_ray_agrees_with_brute_force {
    balls => ("balls_s1"),
    gears => ("gears_s1"),
    mount => ("mount_s1"),
    rings => ("rings_s1"),
    teapot => ("teapot_s1"),
    tetra => ("tetra_s1"),
    tree => ("tree_s1"),
});

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

/// Every scene of `scenes/hard/` (the hard-case suite of `tests/it/hard.rs`), with the default
/// build and with small tables: rays from the eye through the image and from every light in
/// every direction (nearest and any-hit) all agree with brute force.
fn hard_scene_tables_match_brute_force(file: &str) {
    let path = crate::common::hard(file);
    let s = cuberay::load::load(&path, &Default::default()).unwrap_or_else(|e| panic!("{e}")).scene;
    for params in [BuildParams::default(), small_params()] {
        let w = World::new(&s, &params);
        for j in 0..24 {
            for i in 0..24 {
                let (o, d) = s.camera.ray(i as f64 * 64.0 / 23.0, j as f64 * 64.0 / 23.0, 64, 64);
                w.check_nearest(OriginKey::Eye, w.p(o), d.as_vec3().normalize()).unwrap();
            }
        }
        for (li, l) in s.lights.iter().enumerate() {
            if w.tables.flat.cube_of(OriginKey::Light(li)).is_some() {
                sweep(&w, &s, OriginKey::Light(li), w.p(l.position), 300);
            }
        }
    }
}

cases!(hard_scene_tables_match_brute_force: super::hard_scene_tables_match_brute_force {
    grazing_sphere => ("grazing_sphere.nff"),
    parallel_triangles => ("parallel_triangles.nff"),
    shared_edges => ("shared_edges.nff"),
    self_intersection => ("self_intersection.nff"),
    offset_origin => ("offset_origin.nff"),
    offset_1e5 => ("offset_1e5.nff"),
    tiny_sphere => ("tiny_sphere.nff"),
    huge_sphere => ("huge_sphere.nff"),
    nested_bounds => ("nested_bounds.nff"),
    camera_inside => ("camera_inside.nff"),
    cell_boundaries => ("cell_boundaries.nff"),
    degenerate_triangles => ("degenerate_triangles.nff"),
    every_field => ("every_field.nff"),
    parallel_mirrors => ("parallel_mirrors.nff"),
    equal_ties => ("equal_ties.nff"),
    light_on_geometry => ("light_on_geometry.nff"),
    coplanar_triangles => ("coplanar_triangles.nff"),
    bad_normals => ("bad_normals.gltf"),
});
