//! Hard cases on a boundary: rays grazing a sphere (1), rays in a triangle's plane (2), rays
//! through shared edges and vertices (3), directions on the tables' cell boundaries (9).

use cuberay::arith::geometry::{make_ray, Prim32};
use cuberay::arith::FAR;
use cuberay::output::Image;

use super::{miss_distance, on_plane_z, run_file, same_surface, sphere_of, Case};

// ---------------------------------------------------------------------------------------------
// 1. Grazing sphere rays

/// Eye rays pass a unit sphere at 1 ± 208 f32 ulps from its centre, about 0.1 ulp apart.
/// Outside a band of `BAND` ulps the GPU's hit or miss must be the exact one (the f64
/// distance of the ray from the centre, for the ray the camera defines); the CPU's must be
/// exact outside a band of 1e-6 ulps. Inside the band either answer is right. No NaN, and
/// GPU hit distances within 1e-3 of the exact near root.
#[test]
fn grazing_sphere_rays() {
    const ULP: f64 = f32::EPSILON as f64; // ulp(1) in f32: 2⁻²³
    const BAND: f64 = 16.0;
    let c = run_file("grazing_sphere.nff", 0.01, 12);
    let (centre, r) = sphere_of(&c.scene, 0);
    let (mut inside_band, mut checked, mut nearest_checked) = (0, 0, f64::MAX);
    // GPU answers that differ from the exact one: how many, and the farthest from the
    // silhouette (in ulps).
    let (mut wrong_gpu, mut worst_wrong_gpu) = (0, 0.0f64);
    for (x, y) in c.pixels() {
        let (o, d) = c.ray(x, y);
        let ulps = (miss_distance(o, d, centre) / r - 1.0) / ULP;
        let hit_exact = ulps < 0.0;
        let (g, k) = (Case::id(&c.gpu_id, x, y), Case::id(&c.cpu_id, x, y));
        if ulps.abs() > 1e-6 {
            assert_eq!(k.is_some(), hit_exact, "CPU at ({x}, {y}), {ulps:.3} ulps from the silhouette");
        }
        if g.is_some() != hit_exact {
            wrong_gpu += 1;
            worst_wrong_gpu = worst_wrong_gpu.max(ulps.abs());
        }
        if ulps.abs() <= BAND {
            inside_band += 1;
            continue;
        }
        checked += 1;
        nearest_checked = nearest_checked.min(ulps.abs());
        assert_eq!(g.is_some(), hit_exact, "GPU at ({x}, {y}), {ulps:.2} ulps from the silhouette");
        if g.is_some() {
            let t = c.gpu_depth.get(x, y)[0] as f64;
            let t_exact =
                (centre - o).dot(d.normalize()) - (r * r - miss_distance(o, d, centre).powi(2)).sqrt();
            assert!((t - t_exact).abs() < 1e-3, "GPU depth {t} vs {t_exact} at ({x}, {y})");
        }
    }
    eprintln!(
        "hard-case grazing_sphere: {checked} rays outside ±{BAND} ulps all exact on the GPU (nearest {nearest_checked:.2} \
         ulps), {inside_band} inside the band; {wrong_gpu} GPU answers differ from the exact one, all within \
         {worst_wrong_gpu:.3} ulps of the silhouette"
    );
    assert!(checked > 3000 && inside_band > 100, "the view must put rays on both sides of the band");
}

// ---------------------------------------------------------------------------------------------
// 2. Rays parallel to a triangle

/// The middle row of eye rays lies in the plane of triangle 0 (determinant 0) and passes
/// triangle 1 within 1e-7 of its plane: triangle 0 is never hit, every other pixel shows the
/// wall or the triangles exactly where the f64 rays meet them, and shadow rays from the
/// light in that plane pass the edge-on triangle to light the wall.
#[test]
fn rays_parallel_to_a_triangle() {
    let c = run_file("parallel_triangles.nff", 0.01, 0);
    let (_, h) = c.size();
    let mid = h / 2;
    for (x, y) in c.pixels() {
        let (g, k) = (Case::id(&c.gpu_id, x, y), Case::id(&c.cpu_id, x, y));
        assert_ne!(g, Some(0), "GPU hit the edge-on triangle at ({x}, {y})");
        assert_ne!(k, Some(0), "CPU hit the edge-on triangle at ({x}, {y})");
        if y != mid && g != k {
            let same = same_surface(&c.scene, g.map_or(-1.0, |i| i as f32), k.map_or(-1.0, |i| i as f32));
            assert!(same, "GPU {g:?} and CPU {k:?} ids at ({x}, {y}) away from the plane");
        }
        assert!(g.is_some(), "({x}, {y}) missed the wall");
        if y == mid {
            assert_eq!(g == Some(1), k == Some(1), "({x}, {y}): GPU {g:?} CPU {k:?} on the tilted triangle");
        }
    }
    // The middle row crosses the tilted triangle (1e-7 out of its plane) at three pixels.
    let tilted = (0..c.size().0).filter(|&x| Case::id(&c.gpu_id, x, mid) == Some(1)).count();
    assert!(tilted >= 3, "the middle row hits the tilted triangle at {tilted} pixels");
    // The light lies in the edge-on triangle's plane: it blocks no shadow ray.
    assert_eq!((c.gpu.stats.rays.shadow_blocked, c.cpu.stats.rays.shadow_blocked), (0, 0));
    eprintln!(
        "hard-case parallel_triangles: triangle 0 never hit; row {mid} hits the tilted triangle at {tilted} pixels \
         on both backends, the wall elsewhere"
    );
}

// ---------------------------------------------------------------------------------------------
// 3. Shared edges and vertices

/// No eye ray slips between the fan's triangles or the grid's: every pixel whose f64 ray
/// meets the fan (a regular 16-gon of circumradius 1) or the grid more than 1e-3 inside its
/// outline sees one of their triangles, on both backends. Tested one by one with the
/// kernels' f32 triangle test, such a ray hits at least one triangle, and the rays through
/// an edge or the fan's centre hit every triangle there (duplicates, counted): the nearest-hit
/// rule keeps one. Every floor pixel whose shadow ray crosses the fan more than 0.02 inside
/// its outline is in shadow: no shadow ray slips through a crack either.
#[test]
fn rays_through_shared_edges_and_vertices() {
    let c = run_file("shared_edges.nff", 0.01, 0);
    const M: f64 = 1e-3;
    let (fan, grid, floor) = (0..16u32, 16..48u32, 48..50u32);
    let inradius = (std::f64::consts::PI / 16.0).cos();
    let light = c.scene.lights[0].position;
    let prims = Prim32::from_scene(&c.scene, c.scene.camera.eye);
    let (mut covered, mut ring, mut duplicates, mut most) = (0, 0, 0, 0);
    let ambient_only = |px: [f32; 4]| {
        // Floor colour 0.8 · kd 0.9 · ambient 0.5, no light: 0.36.
        (px[0] as f64 - 0.36).abs() < 1e-4
    };
    for (x, y) in c.pixels() {
        let (o, d) = c.ray(x, y);
        let p = on_plane_z(o, d, 0.0).unwrap();
        let in_fan = p.truncate().length() < inradius - M;
        let in_grid = p.x > 1.1 + M && p.x < 2.7 - M && p.y > -0.8 + M && p.y < 0.8 - M;
        for (backend, ids) in [("GPU", &c.gpu_id), ("CPU", &c.cpu_id)] {
            let id = Case::id(ids, x, y);
            if in_fan {
                assert!(
                    id.is_some_and(|i| fan.contains(&i)),
                    "{backend}: a crack in the fan at ({x}, {y}): {id:?}"
                );
            }
            if in_grid {
                assert!(
                    id.is_some_and(|i| grid.contains(&i)),
                    "{backend}: a crack in the grid at ({x}, {y}): {id:?}"
                );
            }
        }
        if in_fan || in_grid {
            covered += 1;
            let ray = make_ray((o - c.scene.camera.eye).as_vec3(), d.as_vec3());
            let hits = (0..48).filter(|&i| prims[i].intersect(&ray, FAR).ok).count();
            assert!(hits >= 1, "the f32 test finds no triangle at ({x}, {y})");
            duplicates += hits - 1;
            most = most.max(hits);
        }
        // A floor pixel (by both backends) whose shadow ray towards the light crosses z = 0
        // well inside the fan.
        let f = on_plane_z(o, d, -1.0).unwrap();
        let cross = f + (light - f) * ((0.0 - f.z) / (light.z - f.z));
        let on_floor = |ids: &Image| Case::id(ids, x, y).is_some_and(|i| floor.contains(&i));
        if cross.truncate().length() < inradius - 0.02 && on_floor(&c.cpu_id) && on_floor(&c.gpu_id) {
            ring += 1;
            for (backend, img) in [("GPU", &c.gpu.image), ("CPU", &c.cpu.image)] {
                let px = img.get(x, y);
                assert!(
                    ambient_only(px),
                    "{backend}: light through the fan at floor pixel ({x}, {y}): {px:?}"
                );
            }
        }
    }
    let (w, h) = c.size();
    let centre_hits = {
        let (o, d) = c.ray(w / 2, h / 2);
        let ray = make_ray((o - c.scene.camera.eye).as_vec3(), d.as_vec3());
        (0..16).filter(|&i| prims[i].intersect(&ray, FAR).ok).count()
    };
    eprintln!(
        "hard-case shared_edges: {covered} pixels inside the fan and grid, 0 cracks ({duplicates} duplicate f32 \
         hits on shared edges, up to {most} on one ray, {centre_hits} of 16 at the fan's centre); {ring} floor \
         pixels shadowed through the fan, 0 lit; middle pixel id GPU {:?} CPU {:?}",
        Case::id(&c.gpu_id, w / 2, h / 2),
        Case::id(&c.cpu_id, w / 2, h / 2)
    );
    assert!(covered > 600 && ring > 50, "the view must cover the fan, the grid and the ring");
    assert!(duplicates > 0, "the middle row and column run along edges: some rays hit two triangles");
    assert_eq!(centre_hits, 16, "the ray through the fan's centre meets all 16 triangles");
}

// ---------------------------------------------------------------------------------------------
// 9. Directions on cell boundaries

/// Eye and shadow rays along axes, face diagonals, cube corners and cell boundaries: the
/// tables find exactly what brute force finds (`run`), and the spheres placed on those
/// directions are seen where the f64 rays meet them. The file's −0.0 components are read
/// and normalised away (the camera's rays carry +0.0); directions with −0.0 components are
/// walked one by one in `tests/it/coherence/directed.rs` (`boundary_directions_from_every_origin_kind`).
#[test]
fn directions_on_cell_boundaries() {
    let c = run_file("cell_boundaries.nff", 0.01, 4);
    let (w, h) = c.size();
    // The middle pixel looks along +x, the corners along the cube's corner directions: each
    // ray passes through the centre of a sphere.
    for (x, y) in [(w / 2, h / 2), (0, 0), (w - 1, 0), (0, h - 1), (w - 1, h - 1), (0, h / 2), (w / 2, 0)] {
        let (o, d) = c.ray(x, y);
        let want = (0..c.scene.primitives.len() - 2)
            .find(|&i| miss_distance(o, d, sphere_of(&c.scene, i).0) < 1e-9)
            .unwrap_or_else(|| panic!("no sphere on the ray of pixel ({x}, {y}): {d}"));
        for (backend, ids) in [("GPU", &c.gpu_id), ("CPU", &c.cpu_id)] {
            assert_eq!(Case::id(ids, x, y), Some(want as u32), "{backend} at ({x}, {y}), direction {d}");
        }
    }
    eprintln!("hard-case cell_boundaries: axis, diagonal and corner pixels hit their spheres");
}
