//! Would a light buffer pay for directional lights? An estimate on the CPU, before building
//! one for the kernels.
//!
//! A directional light's shadow rays are parallel, so the direction cube of a point light
//! becomes a parallel projection (the light buffer of Haines and Greenberg, 1986): a grid on
//! the plane facing the light, each cell listing the primitives whose projected bounds
//! overlap it, sorted by how far towards the light their bounds reach (`zmax`). A shadow
//! ray from a point at depth `z` looks up its cell, skips the primitives whose bounds end
//! before `z` (a binary search) and tests the rest, nearest first, until one blocks.
//!
//! For the eye rays' first hits of a `SIZE`² image and every directional light of the scene
//! (with `--env`'s defaults: a glTF model without lights gets the studio's 16), it counts the
//! primitive tests of that walk for grids of G×G cells, checks that it gives the reference
//! BVH's answer for every shadow ray, and prints them beside the reference's binary BVH
//! (whose node visits are not counted) and each grid's memory.
//!
//! `cargo run --release --example light_buffer -- [--size N] SCENE [G...]` (default 128;
//! grids 16 64 256).

use anyhow::{bail, Context};
use cuberay::job::Accel;
use cuberay::load::{self, LoadOptions, Setup};
use cuberay::reference::accel::{OriginKey, ShadowQuery};
use cuberay::reference::build_accel;
use cuberay::reference::geometry::{intersect, spawn_origin, surface, Ray};
use cuberay::scene::{LightKind, Scene};
use cuberay::stats::TestCounts;
use glam::{DVec2, DVec3};

/// One light's buffer: the projection frame, the grid over the projected scene and the
/// cells' sorted lists.
struct LightBuffer {
    u: DVec3,
    v: DVec3,
    w: DVec3,
    lo: DVec2,
    cell: DVec2,
    g: usize,
    /// Per cell, `(zmax, primitive)` in ascending `zmax`.
    cells: Vec<Vec<(f64, u32)>>,
}

impl LightBuffer {
    fn new(scene: &Scene, to_light: DVec3, g: usize) -> LightBuffer {
        let w = to_light.normalize();
        let u = w.any_orthonormal_vector();
        let v = w.cross(u);
        let rects: Vec<(DVec2, DVec2, f64)> = scene
            .primitives
            .iter()
            .map(|p| {
                let b = p.bounds();
                let (mut lo, mut hi, mut zmax) = (DVec2::splat(f64::MAX), DVec2::splat(f64::MIN), f64::MIN);
                for k in 0..8 {
                    let c = DVec3::new(
                        if k & 1 == 0 { b.min.x } else { b.max.x },
                        if k & 2 == 0 { b.min.y } else { b.max.y },
                        if k & 4 == 0 { b.min.z } else { b.max.z },
                    );
                    let q = DVec2::new(c.dot(u), c.dot(v));
                    lo = lo.min(q);
                    hi = hi.max(q);
                    zmax = zmax.max(c.dot(w));
                }
                (lo, hi, zmax)
            })
            .collect();
        let lo = rects.iter().fold(DVec2::splat(f64::MAX), |a, r| a.min(r.0));
        let hi = rects.iter().fold(DVec2::splat(f64::MIN), |a, r| a.max(r.1));
        let cell = ((hi - lo) / g as f64).max(DVec2::splat(1e-300));
        let mut cells = vec![Vec::new(); g * g];
        let index = |q: DVec2| {
            let c = ((q - lo) / cell).floor();
            (c.x.clamp(0.0, (g - 1) as f64) as usize, c.y.clamp(0.0, (g - 1) as f64) as usize)
        };
        for (id, (a, b, zmax)) in rects.iter().enumerate() {
            let ((x0, y0), (x1, y1)) = (index(*a), index(*b));
            for y in y0..=y1 {
                for x in x0..=x1 {
                    cells[y * g + x].push((*zmax, id as u32));
                }
            }
        }
        for c in &mut cells {
            c.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        }
        LightBuffer { u, v, w, lo, cell, g, cells }
    }

    fn bytes(&self) -> usize {
        4 * (self.cells.len() + 1) + self.cells.iter().map(|c| 8 * c.len()).sum::<usize>()
    }

    /// Whether the ray towards the light is blocked, and the primitives it tested.
    fn occluded(&self, scene: &Scene, ray: &Ray) -> (bool, u64) {
        let q = DVec2::new(ray.origin.dot(self.u), ray.origin.dot(self.v));
        let c = ((q - self.lo) / self.cell).floor();
        if c.x < 0.0 || c.y < 0.0 || c.x >= self.g as f64 || c.y >= self.g as f64 {
            return (false, 0);
        }
        let list = &self.cells[c.y as usize * self.g + c.x as usize];
        let z = ray.origin.dot(self.w);
        let first = list.partition_point(|&(zmax, _)| zmax < z);
        let mut tests = 0;
        for &(_, id) in &list[first..] {
            tests += 1;
            if intersect(&scene.primitives[id as usize], ray, f64::INFINITY).is_some() {
                return (true, tests);
            }
        }
        (false, tests)
    }
}

fn main() -> anyhow::Result<()> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut size = 128u32;
    if let Some(i) = args.iter().position(|a| a == "--size") {
        size = args.get(i + 1).context("--size needs a number")?.parse().context("--size")?;
        args.drain(i..i + 2);
    }
    let Some(path) = args.first().cloned() else { bail!("usage: light_buffer [--size N] SCENE [G...]") };
    let grids: Vec<usize> = if args.len() > 1 {
        args[1..].iter().map(|a| a.parse().context("a grid size")).collect::<Result<_, _>>()?
    } else {
        vec![16, 64, 256]
    };
    let mut loaded = load::load(path.as_ref(), &LoadOptions::default())?;
    load::apply_setup(&mut loaded, path.as_ref(), &Setup::default())?;
    let scene = &loaded.scene;
    let lights: Vec<(usize, DVec3)> = scene
        .lights
        .iter()
        .enumerate()
        .filter(|(_, l)| l.kind == LightKind::Directional)
        .map(|(i, l)| (i, -l.direction.normalize()))
        .collect();
    if lights.is_empty() {
        bail!("{path}: no directional light");
    }
    let bvh = build_accel(scene, Accel::Bvh, size, size)?;

    // The shadow rays of the eye rays' first hits, towards every directional light above
    // the surface (as the reference shades, without its texture normals).
    let mut rays: Vec<(usize, usize, ShadowQuery)> = Vec::new();
    for y in 0..size {
        for x in 0..size {
            let (o, d) = scene.camera.ray(x as f64 + 0.5, y as f64 + 0.5, size, size);
            let ray = Ray::new(o, d);
            let mut t = TestCounts::default();
            let Some(h) = bvh.closest(&ray, OriginKey::Eye, f64::INFINITY, &mut t) else { continue };
            let s = surface(&scene.primitives[h.prim as usize], &ray, &h.hit);
            let n = if d.dot(s.ng) < 0.0 { s.ns } else { -s.ns };
            for (k, &(i, dir)) in lights.iter().enumerate() {
                if n.dot(dir) > 0.0 {
                    let q = ShadowQuery {
                        ray: Ray::new(spawn_origin(&s, dir), dir),
                        t_max: f64::INFINITY,
                        object: h.prim,
                        light: i as u32,
                        light_position: None,
                    };
                    rays.push((k, h.prim as usize, q));
                }
            }
        }
    }
    let mut bvh_tests = 0u64;
    let answers: Vec<bool> = rays
        .iter()
        .map(|(_, _, q)| {
            let mut t = TestCounts::default();
            let b = bvh.occluded(q, &mut t);
            bvh_tests += t.total();
            b
        })
        .collect();
    let n = rays.len().max(1) as f64;
    let blocked = answers.iter().filter(|&&b| b).count();
    println!(
        "{path}: {size}², {} primitives, {} directional lights, {} shadow rays ({:.1} % blocked)\n",
        scene.primitives.len(),
        lights.len(),
        rays.len(),
        100.0 * blocked as f64 / n
    );
    println!("| walk | primitive tests a shadow ray | memory, all lights | answers unlike the BVH's |");
    println!("|---|---|---|---|");
    println!("| reference binary BVH (node visits not counted) | {:.2} | – | – |", bvh_tests as f64 / n);
    for &g in &grids {
        let buffers: Vec<LightBuffer> =
            lights.iter().map(|&(_, dir)| LightBuffer::new(scene, dir, g)).collect();
        let mut tests = 0u64;
        let mut unlike = 0;
        for ((k, _, q), &want) in rays.iter().zip(&answers) {
            let (got, t) = buffers[*k].occluded(scene, &q.ray);
            tests += t;
            unlike += usize::from(got != want);
        }
        let mib = buffers.iter().map(LightBuffer::bytes).sum::<usize>() as f64 / (1 << 20) as f64;
        println!("| light buffer {g}×{g} | {:.2} | {mib:.1} MiB | {unlike} |", tests as f64 / n);
    }
    Ok(())
}
