//! The candidate tables as the kernels of `shaders/cube.wgsl` read them: built by
//! [`coherence::build`] for the render's image and the GPU's spawn offset, plus one
//! fallback origin, and the loop budget a ray step needs on lavapipe.
//!
//! The fallback origin lists every primitive in its always-test list (`d_min` 0, ascending
//! ids) and has empty faces: a ray whose origin entity has no table walks it, which is brute
//! force with the walker's own code, so the cube kernels need no second query loop.

use crate::coherence::groups::GROUP_BIT;
use crate::coherence::{self, BuildParams, FlatTables, GpuEntry, GpuFace, GpuOrigin, OriginKind};
use crate::error::{Error, Result};
use crate::scene::{Effects, Scene};

use super::shader::Variant;

/// [`GpuOrigin::kind`] of the fallback origin (after eye 0, light 1, surface 2).
pub const FALLBACK_KIND: u32 = 3;

/// Tables ready for upload.
pub struct GpuTables {
    pub flat: FlatTables,
    /// Index of the fallback origin in `flat.origins`.
    pub fallback: u32,
    /// Whether some ray of the render may use the fallback origin.
    pub fallback_reachable: bool,
    /// The longest merged list (cell + always) a nearest-hit walk may meet, an eye ray's
    /// walk, and a shadow walk, in loop iterations (a group entry counts its members too).
    pub worst_closest: u64,
    pub worst_eye: u64,
    pub worst_shadow: u64,
    /// Mean entries per stored cell (a rough cost of one walk, for the tile size).
    pub mean_list: f64,
    /// Building the tables, seconds.
    pub build_s: f64,
    /// What `flat` was flattened from (its own `flat` left empty), for
    /// [`GpuTables::rebuild_eye`].
    source: coherence::Tables,
}

/// The largest distance [`spawn_origin`](../../shaders/geometry.wgsl) moves a hit point in a
/// scene re-centred on the camera, plus f32 rounding of the geometry: the inflation of every
/// origin sphere.
///
/// The kernels move a hit point by `scale·2⁻¹⁶` along the unit normal, where `scale` is the
/// largest of |p|∞, |o|∞ + t (ray origin and distance) and the primitive's extent. With every
/// coordinate that matters (scene bounds, positional lights, the corners of the image plane of
/// an orthographic camera) at most `M` in magnitude, |o|∞ ≤ M and t ≤ 2·√3·M, so
/// `scale ≤ (1 + 2√3)·M`.
pub fn spawn_offset_bound(scene: &Scene, width: u32, height: u32) -> f64 {
    let eye = scene.camera.eye;
    let mut m = coherence::build::recentred_magnitude(scene);
    let (w, h) = (width as f64, height as f64);
    for (x, y) in [(0.0, 0.0), (w, 0.0), (0.0, h), (w, h)] {
        m = m.max((scene.camera.ray(x, y, width, height).0 - eye).abs().max_element());
    }
    let spawn = (1.0 + 2.0 * 3f64.sqrt()) * m * 2f64.powi(-16) * 1.01;
    spawn + 8.0 * m * f32::EPSILON as f64
}

/// The build for kernels `variant`: tables only for the rays they trace.
fn params(scene: &Scene, width: u32, height: u32, variant: Variant) -> BuildParams {
    let effects = Effects {
        shadows: variant.shadows,
        reflection: variant.reflection,
        refraction: variant.refraction,
        ..scene.effects()
    };
    BuildParams {
        image: Some((width, height)),
        spawn_offset: Some(spawn_offset_bound(scene, width, height)),
        effects: Some(effects),
        ..BuildParams::default()
    }
}

/// Builds the tables for a `width`×`height` render of `scene` with kernels `variant`.
pub fn build(scene: &Scene, width: u32, height: u32, variant: Variant) -> Result<GpuTables> {
    let tables = coherence::build(scene, &params(scene, width, height, variant))?;
    finish(scene, tables, variant)
}

impl GpuTables {
    /// The tables after `scene.camera` moved: the eye's table rebuilt, the others kept when
    /// they still hold (see [`coherence::Tables::rebuild_eye`]). Also returns whether only
    /// the eye's table was rebuilt.
    pub fn rebuild_eye(
        self,
        scene: &Scene,
        width: u32,
        height: u32,
        variant: Variant,
    ) -> Result<(GpuTables, bool)> {
        let mut source = self.source;
        let eye_only = source.rebuild_eye(scene, &params(scene, width, height, variant))?;
        Ok((finish(scene, source, variant)?, eye_only))
    }
}

/// Checks the built tables against the scene, measures their longest lists and appends the
/// fallback origin.
fn finish(scene: &Scene, mut tables: coherence::Tables, variant: Variant) -> Result<GpuTables> {
    let build_s = tables.build_s;
    let mut flat = std::mem::take(&mut tables.flat);
    if flat.light_origin.len() != scene.lights.len() || flat.prim_origin.len() != scene.primitives.len() {
        return Err(Error::TablesInvalid("the light or primitive index does not match the scene".into()));
    }
    let reachable = fallback_reachable(scene, &flat, variant);
    let (mut worst_closest, mut worst_eye, mut worst_shadow) = (0u64, 0u64, 0u64);
    for (o, org) in flat.origins.iter().enumerate() {
        let mut longest = 0u64;
        for f in &flat.faces[o * 6..o * 6 + 6] {
            for c in f.cell_base..f.cell_base + f.width * f.height {
                let len = walk_cost(&flat, flat.cell_start[c as usize], flat.cell_start[c as usize + 1]);
                longest = longest.max(len);
            }
        }
        let list = longest + walk_cost(&flat, org.always_start, org.always_start + org.always_count);
        if org.kind == OriginKind::Eye as u32 {
            worst_eye = worst_eye.max(list);
        }
        if org.kind == OriginKind::Light as u32 {
            worst_shadow = worst_shadow.max(list);
        } else {
            worst_closest = worst_closest.max(list);
        }
    }
    // Shadow rays from a light without a table use the surface tables.
    let untabled_light = scene.lights.iter().enumerate().any(|(i, _)| flat.light_origin[i] == u32::MAX);
    if untabled_light {
        worst_shadow = worst_shadow.max(worst_closest);
    }
    let n = scene.primitives.len() as u32;
    if reachable {
        worst_closest = worst_closest.max(n as u64);
        worst_eye = worst_eye.max(n as u64);
        worst_shadow = worst_shadow.max(n as u64);
    }
    let mean_list = flat.entries.len() as f64 / flat.cells().max(1) as f64;
    let fallback = flat.origins.len() as u32;
    let always_start = flat.entries.len() as u32;
    flat.entries.extend((0..n).map(|id| GpuEntry { id, d_min: 0.0 }));
    flat.origins.push(GpuOrigin { n: 1, always_start, always_count: n, kind: FALLBACK_KIND });
    flat.faces.extend([GpuFace::default(); 6]);
    flat.check(scene.primitives.len())?;
    Ok(GpuTables {
        flat,
        fallback,
        fallback_reachable: reachable,
        worst_closest,
        worst_eye,
        worst_shadow,
        mean_list,
        build_s,
        source: tables,
    })
}

/// Loop iterations a walk over `entries[a..b]` may take: one per entry, plus the members of
/// each group entry.
fn walk_cost(flat: &FlatTables, a: u32, b: u32) -> u64 {
    flat.entries[a as usize..b as usize]
        .iter()
        .map(|e| match e.id & GROUP_BIT {
            0 => 1,
            _ => 1 + flat.groups[(e.id & !GROUP_BIT) as usize].count as u64,
        })
        .sum()
}

/// Whether a ray of a render with `variant` can come from an entity without a table: the eye
/// of a non-empty scene, a positional light's shadow rays, the secondary rays of a
/// reflecting or transmitting primitive, or (for lights without a table) the shadow rays of
/// any primitive.
fn fallback_reachable(scene: &Scene, flat: &FlatTables, variant: Variant) -> bool {
    let missing = |id: usize| flat.prim_origin[id] == u32::MAX;
    if flat.eye_origin == u32::MAX && !scene.primitives.is_empty() {
        return true;
    }
    if variant.shadows && flat.light_origin.contains(&u32::MAX) && (0..scene.primitives.len()).any(missing) {
        return true;
    }
    if variant.reflection {
        return scene.primitives.iter().enumerate().any(|(i, p)| {
            let m = &scene.materials[p.material() as usize];
            (m.reflects() || m.transmits()) && missing(i)
        });
    }
    false
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::mirror::{self, Prim32, F32_MAX};

    fn scene(src: &str) -> Scene {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("s.nff");
        std::fs::write(&p, src).unwrap();
        crate::load::load(&p, &Default::default()).unwrap().scene
    }

    const VIEW: &str =
        "v\nfrom 0 -6 2\nat 0 0 0\nup 0 0 1\nangle 40\nhither 0.01\nresolution 16 16\nl 3 -3 5\n";

    fn spheres(material: &str) -> Scene {
        let mut s = format!("{VIEW}f {material}\n");
        for i in 0..5 {
            s += &format!("s {} {} 0 0.4\n", i as f64 - 2.0, (i % 2) as f64);
        }
        s += "p 3\n-3 -3 -0.5\n3 -3 -0.5\n0 3 -0.5\n";
        scene(&s)
    }

    #[test]
    fn the_fallback_origin_walks_every_primitive_like_brute_force() {
        let sc = spheres("1 1 1 0.2 0.8 10 0 1");
        let t = build(&sc, 16, 16, Variant::for_effects(sc.effects(), 5).with_cube(true)).unwrap();
        let f = &t.flat;
        assert_eq!(f.origins[t.fallback as usize].always_count as usize, sc.primitives.len());
        let prims = Prim32::from_scene(&sc, sc.camera.eye);
        for k in 0..200 {
            let a = k as f32 * 0.37;
            let d = Vec3::new(a.cos(), a.sin(), (a * 1.7).sin() * 0.6).normalize();
            let o = Vec3::new(0.1, 0.3, 0.2) * (k % 7) as f32;
            let (hit, tests) = mirror::cube_walk_nearest(f, t.fallback, o, d, F32_MAX, mirror::NO_ID, |id| {
                prims[id as usize].intersect(o, d)
            });
            let want = mirror::brute_nearest(&prims, o, d, F32_MAX, mirror::NO_ID);
            assert_eq!((hit.id, hit.t), want, "ray {k}");
            assert_eq!(tests.tests as usize, sc.primitives.len(), "the fallback never stops early");
        }
    }

    #[test]
    fn matte_scenes_build_no_surface_tables_and_never_need_the_fallback() {
        let sc = spheres("1 0.5 0.5 0.8 0 10 0 1");
        let v = Variant::for_effects(sc.effects(), 5).with_cube(true);
        assert!(!v.reflection);
        let t = build(&sc, 16, 16, v).unwrap();
        assert!(t.flat.origins.iter().all(|o| o.kind != OriginKind::Surface as u32));
        assert!(!t.fallback_reachable);
        assert!(t.flat.light_origin.iter().all(|&o| o != u32::MAX), "the point light has a table");
        // Mirrors: every mirror has a surface table, so no ray needs the fallback either.
        let sc = spheres("1 1 1 0.2 0.8 10 0 1");
        let t = build(&sc, 16, 16, Variant::for_effects(sc.effects(), 5).with_cube(true)).unwrap();
        assert!(t.flat.origins.iter().any(|o| o.kind == OriginKind::Surface as u32));
        assert!(!t.fallback_reachable);
        assert!(t.worst_closest < sc.primitives.len() as u64 + 1);
    }

    #[test]
    fn the_spawn_offset_bound_covers_the_kernels_offset() {
        let sc = spheres("1 1 1 0.2 0.8 10 0 1");
        let bound = spawn_offset_bound(&sc, 16, 16);
        // The largest `scale` the kernels can see: a hit at the far corner of the bounds,
        // reached from the opposite corner.
        let b = sc.bounds();
        let eye = sc.camera.eye;
        let m = (b.min - eye).abs().max_element().max((b.max - eye).abs().max_element());
        let offset = (m + (b.max - b.min).length()) * 2f64.powi(-16);
        assert!(bound >= offset, "{bound} < {offset}");
        assert!(bound < 100.0 * offset, "{bound} is needlessly large");
    }
}
