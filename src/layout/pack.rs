//! Packing a [`Scene`] into the kernels' buffers ([`Packed`]): primitives, triangle
//! attributes, materials, lights and textures, and the camera part of [`Params`]. The scene
//! is re-centred on the camera in f64 before the conversion to f32, so that scenes far from
//! the origin keep their precision near the eye.

use glam::{DVec2, DVec3, DVec4};

use super::bvh::{pack_bvh, GpuBvh};
use super::rayquery::{rq_boxes, RqBox};
use super::structs::*;
use crate::arith::spawn::SpawnPolicy;
use crate::scene::{
    Alpha, Environment, LightKind, Material as SceneMaterial, Primitive, Scene, Texture, TextureRef,
    Triangle, Wrap,
};

fn v3(v: DVec3) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

fn v4(v: DVec3, w: f64) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, w as f32]
}

/// A scene packed for the GPU, re-centred on the camera's eye.
pub struct Packed {
    pub prims: Vec<Prim>,
    /// The primitives in f64, for the F64 kernel variant ([`Packed::use_f64`]); empty
    /// otherwise. The kernels get these in place of `prims`.
    pub prims64: Vec<Prim64>,
    pub tri_attrs: Vec<TriAttr>,
    pub materials: Vec<Material>,
    pub lights: Vec<Light>,
    pub texture_infos: Vec<TextureInfo>,
    /// RGBA8 texels, R in the low byte.
    pub texels: Vec<u32>,
    /// Whether the parts that do not depend on the eye (materials, triangle attributes,
    /// textures) are packed: [`pack`] packs them, [`pack_moved`] leaves them out.
    pub fixed: bool,
    /// The camera part of [`Params`], with background, ambient and counts.
    pub params: Params,
    /// `--accel bvh`, or `cube` when rays leave surfaces and walk it: the BVH over these
    /// primitives ([`Packed::with_bvh`]).
    pub bvh: Option<GpuBvh>,
    /// `--accel rayquery`, or `cube` when rays leave surfaces and take ray queries: the
    /// boxes the driver's structure is built over ([`Packed::add_rq`]).
    pub rq: Option<Vec<RqBox>>,
    /// Seconds spent building the BVH or the ray queries' boxes.
    pub bvh_s: f64,
}

impl Packed {
    /// Packs the parts of `scene` that do not depend on the eye, where [`pack_moved`] left
    /// them out.
    pub fn add_fixed(&mut self, scene: &Scene) {
        if self.fixed {
            return;
        }
        let mut tri_attrs = Vec::new();
        for (p, packed) in scene.primitives.iter().zip(&self.prims) {
            if let Primitive::Triangle(t) = p {
                if attr_entries(t) > 0 {
                    debug_assert_eq!(
                        packed.attr as usize,
                        tri_attrs.len(),
                        "attribute entries counted apart"
                    );
                    tri_attr(t, &mut tri_attrs);
                }
            }
        }
        self.tri_attrs = tri_attrs;
        self.materials = scene.materials.iter().map(gpu_material).collect();
        (self.texture_infos, self.texels) = pack_textures(&scene.textures, scene.environment.as_ref());
        self.fixed = true;
    }

    /// Adds the BVH of `scene` (packed into `self`) and points the params at it; its shadow
    /// walks get an inline budget of loop iterations ([`super::budget::bvh_shadow_inline`]).
    pub fn with_bvh(mut self, scene: &Scene) -> Packed {
        self.add_bvh(scene);
        self
    }

    /// Readies `self` (packed from `scene` under `spawn`) for the F64 kernel variant
    /// (`--precision f64`): the primitives in f64, and the spawn offset scaled to f64's
    /// rounding ([`SpawnPolicy::rel_abs_f64`]). The BVH's boxes and the candidate tables
    /// stay as they are: both are conservative for the f64 primitives (see
    /// `docs/architecture.md`, "Precision").
    pub fn use_f64(&mut self, scene: &Scene, spawn: SpawnPolicy) {
        let eye = scene.camera.eye;
        self.prims64 = scene
            .primitives
            .iter()
            .zip(&self.prims)
            .map(|(p, n)| wide_prim(p, eye, n.attr, n.flags))
            .collect();
        self.params.set_f64_spawn(spawn);
    }

    /// The primitives as the kernels read them: f64 after [`Packed::use_f64`], else f32.
    pub fn prim_bytes(&self) -> &[u8] {
        if self.prims64.is_empty() {
            bytemuck::cast_slice(&self.prims)
        } else {
            bytemuck::cast_slice(&self.prims64)
        }
    }

    /// The bytes of one primitive as the kernels read it ([`Prim`], or [`Prim64`] after
    /// [`Packed::use_f64`]).
    pub fn prim_size(&self) -> usize {
        if self.prims64.is_empty() {
            std::mem::size_of::<Prim>()
        } else {
            std::mem::size_of::<Prim64>()
        }
    }

    /// The bytes of one queued ray ([`Job`], or [`Job64`] after [`Packed::use_f64`]).
    pub fn job_bytes(&self) -> u64 {
        if self.prims64.is_empty() {
            std::mem::size_of::<Job>() as u64
        } else {
            std::mem::size_of::<Job64>() as u64
        }
    }

    /// [`Packed::with_bvh`] in place.
    pub fn add_bvh(&mut self, scene: &Scene) {
        let start = std::time::Instant::now();
        let bvh = pack_bvh(scene);
        self.params.set_bvh(bvh.nodes.len() as u32, super::budget::bvh_shadow_inline(scene));
        self.bvh = Some(bvh);
        self.bvh_s += start.elapsed().as_secs_f64();
    }

    /// Adds the boxes of the platform's ray queries (`--accel rayquery`, or the rays leaving
    /// surfaces under `cube`; [`super::rayquery`]).
    pub fn add_rq(&mut self, scene: &Scene) {
        let start = std::time::Instant::now();
        self.rq = Some(rq_boxes(scene));
        self.bvh_s += start.elapsed().as_secs_f64();
    }
}

/// Packs `scene` for a `width`×`height` image whose rays spawn under `spawn`, subtracting the
/// eye position (in f64) from every position.
pub fn pack(scene: &Scene, width: u32, height: u32, spawn: SpawnPolicy) -> Packed {
    let mut packed = pack_moved(scene, width, height, spawn);
    packed.add_fixed(scene);
    packed
}

/// The entries of [`TriAttr`] triangle `t` takes: none without attributes, else normals and
/// set 0; then tangents and set 1 where it has either or colours; then colours (the layout
/// `shaders/shared/layout.wgsl` documents, which [`tri_attr`] writes).
fn attr_entries(t: &Triangle) -> u32 {
    let more = has_more(t);
    let any = more || t.n.is_some() || t.uv.is_some();
    any as u32 + more as u32 + t.color.is_some() as u32
}

/// Whether triangle `t` takes a second attribute entry (tangents, set 1; or a third).
fn has_more(t: &Triangle) -> bool {
    t.uv1.is_some() || t.tangent.is_some() || t.color.is_some()
}

/// What of `scene` depends on the eye, packed as [`pack`] packs it: the primitives
/// re-centred on the eye (pointing at their attributes' entries), the lights and the
/// params. Materials, triangle attributes and textures are left out, and
/// [`Packed::fixed`] is false: a camera move of the preview writes only these into its
/// buffers (packing DamagedHelmet's four 2048² maps again took 30 ms a frame), and
/// [`Packed::add_fixed`] adds the rest where it must upload anew.
pub fn pack_moved(scene: &Scene, width: u32, height: u32, spawn: SpawnPolicy) -> Packed {
    let eye = scene.camera.eye;
    let mut entries = 0;
    let prims = scene
        .primitives
        .iter()
        .map(|p| {
            let mut attr = 0;
            if let Primitive::Triangle(t) = p {
                let n = attr_entries(t);
                if n > 0 {
                    attr = entries;
                    entries += n;
                }
            }
            let m = &scene.materials[p.material() as usize];
            let cutout = if m.alpha.cutoff(false).is_some() { FLAG_CUTOUT } else { 0 }
                | if m.alpha.cutoff(true).is_some() { FLAG_CUTOUT_SHADOW } else { 0 };
            Prim::from(&wide_prim(p, eye, attr, cutout))
        })
        .collect();
    let lights = scene
        .lights
        .iter()
        .map(|l| {
            let (kind, cos_outer, span) = match l.kind {
                LightKind::Point => (LIGHT_POINT, 0.0, 1.0),
                LightKind::Spot { inner_cone, outer_cone } => {
                    let co = outer_cone.cos();
                    (LIGHT_SPOT, co, (inner_cone.cos() - co).max(1e-3))
                }
                LightKind::Directional => (LIGHT_DIRECTIONAL, 0.0, 1.0),
            };
            Light {
                position: v3(l.position - eye),
                kind,
                direction: v3(l.direction),
                range: l.range.unwrap_or(0.0) as f32,
                radiance: v3(l.color * l.intensity),
                inverse_square: l.inverse_square as u32,
                cos_outer: cos_outer as f32,
                span: span as f32,
                pad0: 0,
                pad1: 0,
            }
        })
        .collect();
    let params = Params::of_scene(scene, width, height, spawn);
    Packed {
        prims,
        prims64: Vec::new(),
        tri_attrs: Vec::new(),
        materials: Vec::new(),
        lights,
        texture_infos: Vec::new(),
        texels: Vec::new(),
        fixed: false,
        params,
        bvh: None,
        rq: None,
        bvh_s: 0.0,
    }
}

/// The textures as the kernels read them: one [`TextureInfo`] each, and all their texels in
/// one array (RGBA8 in a `u32`), then the environment map's (shared-exponent RGB in a `u32`,
/// `Params::env_texture`).
fn pack_textures(textures: &[Texture], env: Option<&Environment>) -> (Vec<TextureInfo>, Vec<u32>) {
    let mut texels = Vec::new();
    let infos = textures
        .iter()
        .map(|t| {
            let wrap = |w: Wrap| match w {
                Wrap::Repeat => WRAP_REPEAT,
                Wrap::MirroredRepeat => WRAP_MIRRORED_REPEAT,
                Wrap::ClampToEdge => WRAP_CLAMP_TO_EDGE,
            };
            let info = TextureInfo {
                offset: texels.len() as u32,
                width: t.width,
                height: t.height,
                flags: wrap(t.wrap_s)
                    | wrap(t.wrap_t) << 2
                    | if t.linear { TEX_BILINEAR } else { 0 }
                    | if t.srgb { TEX_SRGB } else { 0 },
            };
            texels.extend(t.texels.iter().map(|c| u32::from_le_bytes(*c)));
            info
        })
        .collect::<Vec<_>>();
    let mut infos = infos;
    if let Some(e) = env {
        infos.push(TextureInfo { offset: texels.len() as u32, width: e.width, height: e.height, flags: 0 });
        texels.extend_from_slice(&e.texels);
    }
    (infos, texels)
}

/// Appends the attribute entries of triangle `t` ([`attr_entries`] of them) to `out`.
fn tri_attr(t: &Triangle, out: &mut Vec<TriAttr>) {
    let mut a = TriAttr::default();
    let v2 = |p: DVec2, q: DVec2| [p.x as f32, p.y as f32, q.x as f32, q.y as f32];
    if let Some(n) = t.n {
        (a.n0, a.n1, a.n2) = (v4(n[0], 0.0), v4(n[1], 0.0), v4(n[2], 0.0));
    }
    if let Some(uv) = t.uv {
        a.uv01 = v2(uv[0], uv[1]);
        a.uv2_1 = v2(uv[2], DVec2::ZERO);
    }
    let mut more = TriAttr::default();
    if let Some(uv) = t.uv1.as_deref() {
        a.uv2_1[2..].copy_from_slice(&v2(uv[0], uv[0])[..2]);
        more.uv01 = v2(uv[1], uv[2]);
    }
    if let Some(tg) = t.tangent.as_deref() {
        let w = |v: DVec4| [v.x as f32, v.y as f32, v.z as f32, v.w as f32];
        (more.n0, more.n1, more.n2) = (w(tg[0]), w(tg[1]), w(tg[2]));
    }
    out.push(a);
    if has_more(t) {
        out.push(more);
    }
    if let Some(c) = &t.color {
        let (c0, c1, c2) = (v4(c[0], 1.0), v4(c[1], 1.0), v4(c[2], 1.0));
        out.push(TriAttr { n0: c0, n1: c1, n2: c2, ..TriAttr::default() });
    }
}

/// A texture reference as the kernels read it (none: all zero).
fn tex_ref(r: Option<TextureRef>) -> TexRef {
    match r {
        None => TexRef::default(),
        Some(r) => {
            let m = r.transform;
            let (c0, c1, t) = (m.matrix2.x_axis, m.matrix2.y_axis, m.translation);
            TexRef {
                row0: [c0.x as f32, c1.x as f32, t.x as f32],
                texture: r.texture + 1,
                row1: [c0.y as f32, c1.y as f32, t.y as f32],
                texcoord: r.texcoord,
            }
        }
    }
}

/// Material `m` as the kernels read it.
fn gpu_material(m: &SceneMaterial) -> Material {
    let maps = m.maps.as_deref();
    let coat = m.clearcoat.as_deref();
    let flags = if m.tinted_transmission { MATERIAL_TINTED_TRANSMISSION } else { 0 }
        | if maps.is_some() { MATERIAL_MAPS } else { 0 }
        | if m.alpha == Alpha::Blend { MATERIAL_BLEND } else { 0 };
    // Alpha is never below −1: that cutoff lets every hit count.
    let cutoff = |shadow: bool| m.alpha.cutoff(shadow).map_or(-1.0, |c| c as f32);
    Material {
        color: v3(m.color),
        kd: m.kd as f32,
        mirror: v3(m.mirror),
        ks: m.ks as f32,
        emission: v3(m.emission),
        shine: m.shine as f32,
        transmittance: m.transmittance as f32,
        ior: m.ior as f32,
        flags,
        opacity: m.opacity as f32,
        metallic: maps.map_or(0.0, |p| p.metallic as f32),
        roughness: maps.map_or(0.0, |p| p.roughness as f32),
        transmission: maps.map_or(0.0, |p| p.transmission as f32),
        alpha_cutoff: cutoff(false),
        emission_factor: maps.map_or([0.0; 3], |p| v3(p.emission)),
        shadow_cutoff: cutoff(true),
        normal_scale: m.normal_map.map_or(1.0, |n| n.scale as f32),
        base: tex_ref(m.base_color_texture),
        metallic_roughness: tex_ref(maps.and_then(|p| p.metallic_roughness)),
        emissive: tex_ref(maps.and_then(|p| p.emissive)),
        transmission_map: tex_ref(maps.and_then(|p| p.transmission_texture)),
        normal: tex_ref(m.normal_map.map(|n| n.texture)),
        // Only a transmitting body attenuates; a coefficient beyond f32 is all absorbed anyway.
        attenuation: if m.attenuates() { v3(m.attenuation.min(DVec3::splat(1e30))) } else { [0.0; 3] },
        specular: maps.map_or(1.0, |p| p.specular as f32),
        specular_color: maps.map_or([1.0; 3], |p| v3(p.specular_color)),
        clearcoat: coat.map_or(0.0, |c| c.factor as f32),
        clearcoat_roughness: coat.map_or(0.0, |c| c.roughness as f32),
        clearcoat_normal_scale: coat.and_then(|c| c.normal_map).map_or(1.0, |n| n.scale as f32),
        clearcoat_map: tex_ref(coat.and_then(|c| c.texture)),
        clearcoat_roughness_map: tex_ref(coat.and_then(|c| c.roughness_texture)),
        clearcoat_normal: tex_ref(coat.and_then(|c| c.normal_map.map(|n| n.texture))),
        specular_map: tex_ref(maps.and_then(|p| p.specular_texture)),
        specular_color_map: tex_ref(maps.and_then(|p| p.specular_color_texture)),
        ..Material::default()
    }
}

/// Primitive `p` re-centred on `eye`, in f64, its triangle attributes at `attr`, with
/// `extra` flags: the one packing of a primitive, which [`Prim`] rounds to f32.
fn wide_prim(p: &Primitive, eye: DVec3, attr: u32, extra: u32) -> Prim64 {
    let w4 = |v: DVec3, w: f64| [v.x, v.y, v.z, w];
    let inside = |inside_only: bool| if inside_only { FLAG_INSIDE_ONLY } else { 0 };
    match p {
        Primitive::Sphere(s) => Prim64 {
            a: w4(s.center - eye, s.radius),
            kind: KIND_SPHERE,
            material: s.material,
            flags: inside(s.inside_only) | extra,
            ..Prim64::default()
        },
        Primitive::Triangle(t) => Prim64 {
            a: w4(t.p[0] - eye, 0.0),
            b: w4(t.p[1] - eye, 0.0),
            c: w4(t.p[2] - eye, 0.0),
            kind: KIND_TRIANGLE,
            material: t.material,
            flags: if t.n.is_some() { FLAG_NORMALS } else { 0 }
                | if t.uv.is_some() { FLAG_UVS } else { 0 }
                | if t.uv1.is_some() { FLAG_UV1 } else { 0 }
                | if t.tangent.is_some() { FLAG_TANGENTS } else { 0 }
                | if t.color.is_some() { FLAG_COLORS } else { 0 }
                | extra,
            attr,
            ..Prim64::default()
        },
        Primitive::Cylinder(c) => Prim64 {
            a: w4(c.base - eye, c.base_radius),
            b: w4(c.apex - eye, c.apex_radius),
            kind: KIND_CYLINDER,
            material: c.material,
            flags: inside(c.inside_only) | extra,
            ..Prim64::default()
        },
    }
}

impl From<&Prim64> for Prim {
    /// Rounds the coordinates to f32.
    fn from(p: &Prim64) -> Prim {
        let narrow = |v: [f64; 4]| v.map(|x| x as f32);
        Prim {
            a: narrow(p.a),
            b: narrow(p.b),
            c: narrow(p.c),
            kind: p.kind,
            material: p.material,
            flags: p.flags,
            attr: p.attr,
        }
    }
}
