//! The geometric Whitted ray tree in f32, as the kernels spawn it: what one hit spawns (a
//! shadow query per light the surface faces, a reflection ray on surfaces that reflect or
//! transmit, a refraction ray on transmitting ones by Snell's law unless totally internally
//! reflected), up to a maximum depth (the eye ray is depth 1), with the kernels' spawn
//! offset and skip rule. No shading. [`super::audit`] traces it (tests per ray over a whole
//! image).
//!
//! One difference from the kernels: it reflects and refracts about the geometric normal,
//! where the kernels use the shading normal (interpolated vertex normals, where a mesh has
//! them). On such meshes its later rays leave in slightly other directions, so the audit's
//! counts there describe the tables' cost, not the kernels' exact rays.

use glam::{DVec3, Vec3};

use super::walk::OriginKey;
use crate::arith::closest::Closest;
use crate::arith::geometry::{make_ray, surface, Prim32, PrimHit, Ray};
use crate::arith::spawn::{spawn_origin, SpawnPolicy};
use crate::arith::{FAR, NO_ID, SHADOW_END_REL};
use crate::scene::{LightKind, Scene};

/// What a ray of the tree is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Eye,
    Reflect,
    Refract,
}

/// A ray of the tree to trace for its nearest hit.
#[derive(Clone, Copy, Debug)]
pub struct TreeRay {
    pub kind: Kind,
    /// The primitive it leaves (`NO_ID`: the eye).
    pub from: u32,
    pub ray: Ray,
    /// The primitive it need not test (WGSL `leave_skip`), or `NO_ID`.
    pub skip: u32,
    pub depth: u32,
}

impl TreeRay {
    /// The key of the table it walks.
    pub fn key(&self) -> OriginKey {
        match self.from {
            NO_ID => OriginKey::Eye,
            id => OriginKey::Surface(id),
        }
    }
}

/// A shadow query: is light `light` blocked from spawn point `q` on primitive `from`?
#[derive(Clone, Copy, Debug)]
pub struct TreeShadow {
    pub light: usize,
    pub from: u32,
    pub q: Vec3,
    pub to_light: Vec3,
    pub skip: u32,
}

/// The scene in the kernels' f32 frame (re-centred on the eye) and the spawn policy.
pub struct RayTree<'a> {
    pub scene: &'a Scene,
    pub prims: Vec<Prim32>,
    /// Per light: position, kind and direction, in the f32 frame (empty without shadows).
    lights: Vec<(Vec3, LightKind, Vec3)>,
    spawn: SpawnPolicy,
}

impl<'a> RayTree<'a> {
    pub fn new(scene: &'a Scene, spawn: SpawnPolicy, shadows: bool) -> RayTree<'a> {
        let eye = scene.camera.eye;
        let shift = |p: DVec3| (p - eye).as_vec3();
        RayTree {
            scene,
            prims: Prim32::from_scene(scene, eye),
            lights: if shadows {
                scene.lights.iter().map(|l| (shift(l.position), l.kind, l.direction.as_vec3())).collect()
            } else {
                Vec::new()
            },
            spawn,
        }
    }

    /// The eye ray through image position `(x, y)` of a `w`×`h` image.
    pub fn eye_ray(&self, x: f64, y: f64, w: u32, h: u32) -> TreeRay {
        let (o, d) = self.scene.camera.ray(x, y, w, h);
        let o = (o - self.scene.camera.eye).as_vec3();
        TreeRay { kind: Kind::Eye, from: NO_ID, ray: make_ray(o, d.as_vec3()), skip: NO_ID, depth: 1 }
    }

    /// Which primitive a ray leaving primitive `id` towards `dir` need not test (WGSL
    /// `leave_skip`): a triangle, or a sphere left outwards.
    fn leave_skip(&self, id: u32, dir: Vec3, ng: Vec3) -> u32 {
        match self.prims[id as usize] {
            Prim32::Triangle { .. } => id,
            Prim32::Sphere { inside_only: false, .. } if dir.dot(ng) > 0.0 => id,
            _ => NO_ID,
        }
    }

    /// What `hit` of `ray` spawns: its shadow queries into `shadows`, and, below
    /// `max_depth`, its reflection and refraction rays into `rays`.
    pub fn spawn(
        &self,
        ray: &TreeRay,
        hit: &Closest<f32, PrimHit>,
        max_depth: u32,
        shadows: &mut Vec<TreeShadow>,
        rays: &mut Vec<TreeRay>,
    ) {
        if !hit.found {
            return;
        }
        let id = hit.prim;
        let s = surface(&self.prims[id as usize], &ray.ray, &hit.hit);
        let (d, ng) = (ray.ray.d, s.ng);
        if !ng.is_finite() {
            return;
        }
        let outside = d.dot(ng) < 0.0; // arrived from the side the normal points to
        let nf = if outside { ng } else { -ng };
        let spawn = |dir: Vec3| spawn_origin(&s, dir, self.spawn);
        for (light, &(lp, lk, ldir)) in self.lights.iter().enumerate() {
            let to_light = if lk == LightKind::Directional { -ldir } else { (lp - s.p).normalize() };
            if nf.dot(to_light) <= 0.0 {
                continue;
            }
            let skip = self.leave_skip(id, to_light, ng);
            shadows.push(TreeShadow { light, from: id, q: spawn(to_light), to_light, skip });
        }
        if ray.depth >= max_depth {
            return;
        }
        let prim = &self.scene.primitives[id as usize];
        let mat = &self.scene.materials[prim.material() as usize];
        let mut child = |kind: Kind, dir: Vec3| {
            let q = spawn(dir);
            let skip = self.leave_skip(id, dir, ng);
            rays.push(TreeRay { kind, from: id, ray: make_ray(q, dir), skip, depth: ray.depth + 1 });
        };
        if mat.transmits() {
            let eta = if outside { 1.0 / mat.ior as f32 } else { mat.ior as f32 };
            let cosi = -d.dot(nf);
            let k = 1.0 - eta * eta * (1.0 - cosi * cosi);
            if k >= 0.0 {
                child(Kind::Refract, (eta * d + (eta * cosi - k.sqrt()) * nf).normalize());
            }
        }
        // As the renderers do: every hit on glass also spawns a reflection ray (it carries
        // the transmitted share under total internal reflection).
        if mat.reflects() || mat.transmits() {
            child(Kind::Reflect, (d - 2.0 * d.dot(ng) * ng).normalize());
        }
    }

    /// The ray query `s` walks, as the kernels choose (`shadow_walk`): with a table of its
    /// own (`light_table`), a light is traced from itself towards the point; any other
    /// from the point towards the light. `None` when the point is the light.
    pub fn shadow_ray(&self, s: &TreeShadow, light_table: bool) -> Option<(OriginKey, Ray, f32)> {
        let (lp, lk, _) = self.lights[s.light];
        if light_table {
            let v = s.q - lp;
            let dist = v.length();
            return (dist > 0.0)
                .then(|| (OriginKey::Light(s.light), make_ray(lp, v), dist * (1.0 - SHADOW_END_REL)));
        }
        let t_max =
            if lk == LightKind::Directional { FAR } else { (lp - s.q).length() * (1.0 - SHADOW_END_REL) };
        Some((OriginKey::Surface(s.from), make_ray(s.q, s.to_light), t_max))
    }
}
