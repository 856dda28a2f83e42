//! The Rust twins of the WGSL structs in `shaders/common.wgsl` (one each, `#[repr(C)]`,
//! bytemuck), and packing a [`Scene`] into them.
//!
//! The scene is re-centred on the camera in f64 before the conversion to f32, so that
//! scenes far from the origin keep their precision near the eye. [`TWINS`] lists every
//! twin with its size and member offsets; a test compares it with naga's layout of the
//! composed module. The table structs of `shaders/cube.wgsl` are twinned by
//! [`crate::coherence::flat`]'s `GpuOrigin`, `GpuFace`, `GpuEntry` and `GpuGroup`.

use bytemuck::{Pod, Zeroable};
use glam::DVec3;

use crate::coherence::flat::{GpuEntry, GpuFace, GpuGroup, GpuOrigin};
use crate::scene::{LightKind, Primitive, Projection, Scene, Wrap};

/// Kernel parameters (WGSL `Params`, a uniform).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct Params {
    pub cam_forward: [f32; 3],
    pub cam_scale: f32,
    pub cam_right: [f32; 3],
    pub half_w: f32,
    pub cam_up: [f32; 3],
    pub half_h: f32,
    pub background: [f32; 3],
    pub ortho: u32,
    pub ambient: [f32; 3],
    pub prim_count: u32,
    pub grid_w: u32,
    pub grid_h: u32,
    pub first_point: u32,
    pub point_count: u32,
    pub spp: u32,
    pub lattice_g: u32,
    pub seed_hash: u32,
    pub corners: u32,
    pub max_depth: u32,
    pub light_count: u32,
    /// 0 depth, 1 normal, 2 object id (the `aov` entry point).
    pub aov: u32,
    /// `render` starts samples `sample_first..sample_end` of the `spp`-sample lattice.
    pub sample_first: u32,
    pub sample_end: u32,
    /// `--accel cube`: the eye's origin and the fallback origin (every primitive).
    pub eye_origin: u32,
    pub fallback_origin: u32,
    /// Shadow walks of at most this many entries are traced within the step that found the
    /// hit; longer ones become jobs on the ray stack ([`crate::gpu::render::shadow_inline`]).
    pub shadow_inline: u32,
}

/// One primitive (WGSL `Prim`); see the WGSL comment for the fields per kind.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct Prim {
    pub a: [f32; 4],
    pub b: [f32; 4],
    pub c: [f32; 4],
    pub kind: u32,
    pub material: u32,
    pub flags: u32,
    pub attr: u32,
}

/// Per-vertex normals and texture coordinates of a triangle (WGSL `TriAttr`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct TriAttr {
    pub n0: [f32; 4],
    pub n1: [f32; 4],
    pub n2: [f32; 4],
    pub uv01: [f32; 4],
    pub uv2: [f32; 4],
}

/// WGSL `Material`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct Material {
    pub color: [f32; 3],
    pub kd: f32,
    pub mirror: [f32; 3],
    pub ks: f32,
    pub emission: [f32; 3],
    pub shine: f32,
    pub transmittance: f32,
    pub ior: f32,
    /// Texture index + 1; 0 = none.
    pub texture: u32,
    pub pad: u32,
}

/// WGSL `Light`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct Light {
    pub position: [f32; 3],
    /// 0 point, 1 spot, 2 directional.
    pub kind: u32,
    pub direction: [f32; 3],
    /// 0 = unlimited.
    pub range: f32,
    /// Colour × intensity.
    pub radiance: [f32; 3],
    pub inverse_square: u32,
    pub cos_outer: f32,
    pub span: f32,
    pub pad0: u32,
    pub pad1: u32,
}

/// WGSL `TextureInfo`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct TextureInfo {
    pub offset: u32,
    pub width: u32,
    pub height: u32,
    /// wrap_s (bits 0-1), wrap_t (bits 2-3), bilinear (bit 4).
    pub flags: u32,
}

/// A pending ray of a grid point's ray tree (WGSL `Pending`); a shadow job keeps its light
/// in `depth` and what the light adds unless blocked in `weight`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct Pending {
    pub o: [f32; 3],
    pub kind: u32,
    pub d: [f32; 3],
    pub depth: u32,
    pub weight: [f32; 3],
    pub from_prim: u32,
}

/// Pending rays per grid point (`STACK_SIZE` in common.wgsl).
pub const STACK_SIZE: usize = 16;

/// A table walk interrupted between steps (WGSL `WalkState`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct WalkState {
    pub i: u32,
    pub iend: u32,
    pub j: u32,
    pub jend: u32,
    pub prim: u32,
    pub t: f32,
    pub b1: f32,
    pub b2: f32,
}

/// A grid point's progress between kernel steps (WGSL `PointState`); all zero at the
/// start.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct PointState {
    pub color: [f32; 3],
    pub sp: u32,
    pub sample: u32,
    /// 1 while the top ray's nearest-hit walk continues in the next step.
    pub walking: u32,
    pub pad1: u32,
    pub pad2: u32,
    pub walk: WalkState,
    pub stack: [Pending; STACK_SIZE],
}

/// A twin's name, size and members (name, offset), for the layout test.
pub struct Twin {
    pub name: &'static str,
    pub size: usize,
    pub members: Vec<(&'static str, usize)>,
}

macro_rules! twin {
    ($t:ident { $($f:ident),* $(,)? }) => {
        Twin {
            name: stringify!($t),
            size: std::mem::size_of::<$t>(),
            members: vec![$((stringify!($f), std::mem::offset_of!($t, $f))),*],
        }
    };
}

/// Every WGSL struct shared with the host, with its Rust twin's layout.
pub fn twins() -> Vec<Twin> {
    vec![
        twin!(Params {
            cam_forward,
            cam_scale,
            cam_right,
            half_w,
            cam_up,
            half_h,
            background,
            ortho,
            ambient,
            prim_count,
            grid_w,
            grid_h,
            first_point,
            point_count,
            spp,
            lattice_g,
            seed_hash,
            corners,
            max_depth,
            light_count,
            aov,
            sample_first,
            sample_end,
            eye_origin,
            fallback_origin,
            shadow_inline
        }),
        twin!(Prim { a, b, c, kind, material, flags, attr }),
        twin!(TriAttr { n0, n1, n2, uv01, uv2 }),
        twin!(Material { color, kd, mirror, ks, emission, shine, transmittance, ior, texture, pad }),
        twin!(Light {
            position,
            kind,
            direction,
            range,
            radiance,
            inverse_square,
            cos_outer,
            span,
            pad0,
            pad1
        }),
        twin!(TextureInfo { offset, width, height, flags }),
        twin!(Pending { o, kind, d, depth, weight, from_prim }),
        twin!(WalkState { i, iend, j, jend, prim, t, b1, b2 }),
        twin!(PointState { color, sp, sample, walking, pad1, pad2, walk, stack }),
        twin!(GpuOrigin { n, always_start, always_count, kind }),
        twin!(GpuFace { iu0, iv0, width, height, cell_base, _pad0, _pad1, _pad2 }),
        twin!(GpuEntry { id, d_min }),
        twin!(GpuGroup { cx, cy, cz, radius, first, count, _pad0, _pad1 }),
    ]
}

fn v3(v: DVec3) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

fn v4(v: DVec3, w: f64) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, w as f32]
}

/// A scene packed for the GPU, re-centred on the camera's eye.
pub struct Packed {
    pub prims: Vec<Prim>,
    pub tri_attrs: Vec<TriAttr>,
    pub materials: Vec<Material>,
    pub lights: Vec<Light>,
    pub texture_infos: Vec<TextureInfo>,
    /// RGBA8 texels, R in the low byte.
    pub texels: Vec<u32>,
    /// The camera part of [`Params`], with background, ambient and counts.
    pub params: Params,
}

/// Packs `scene`, subtracting the eye position (in f64) from every position.
pub fn pack(scene: &Scene, width: u32, height: u32) -> Packed {
    let eye = scene.camera.eye;
    let mut tri_attrs = Vec::new();
    let prims = scene
        .primitives
        .iter()
        .map(|p| match p {
            Primitive::Sphere(s) => Prim {
                a: v4(s.center - eye, s.radius),
                kind: 0,
                material: s.material,
                flags: s.inside_only as u32,
                ..Prim::default()
            },
            Primitive::Triangle(t) => {
                let mut flags = 0;
                let mut attr = 0;
                if t.n.is_some() || t.uv.is_some() {
                    let mut a = TriAttr::default();
                    if let Some(n) = t.n {
                        flags |= 2;
                        a.n0 = v4(n[0], 0.0);
                        a.n1 = v4(n[1], 0.0);
                        a.n2 = v4(n[2], 0.0);
                    }
                    if let Some(uv) = t.uv {
                        flags |= 4;
                        a.uv01 = [uv[0].x as f32, uv[0].y as f32, uv[1].x as f32, uv[1].y as f32];
                        a.uv2 = [uv[2].x as f32, uv[2].y as f32, 0.0, 0.0];
                    }
                    attr = tri_attrs.len() as u32;
                    tri_attrs.push(a);
                }
                Prim {
                    a: v4(t.p[0] - eye, 0.0),
                    b: v4(t.p[1] - eye, 0.0),
                    c: v4(t.p[2] - eye, 0.0),
                    kind: 1,
                    material: t.material,
                    flags,
                    attr,
                }
            }
            Primitive::Cylinder(c) => Prim {
                a: v4(c.base - eye, c.base_radius),
                b: v4(c.apex - eye, c.apex_radius),
                kind: 2,
                material: c.material,
                flags: c.inside_only as u32,
                ..Prim::default()
            },
        })
        .collect();
    let materials = scene
        .materials
        .iter()
        .map(|m| Material {
            color: v3(m.color),
            kd: m.kd as f32,
            mirror: v3(m.mirror),
            ks: m.ks as f32,
            emission: v3(m.emission),
            shine: m.shine as f32,
            transmittance: m.transmittance as f32,
            ior: m.ior as f32,
            texture: m.base_color_texture.map_or(0, |t| t.texture + 1),
            pad: 0,
        })
        .collect();
    let lights = scene
        .lights
        .iter()
        .map(|l| {
            let (kind, cos_outer, span) = match l.kind {
                LightKind::Point => (0, 0.0, 1.0),
                LightKind::Spot { inner_cone, outer_cone } => {
                    let co = outer_cone.cos();
                    (1, co, (inner_cone.cos() - co).max(1e-3))
                }
                LightKind::Directional => (2, 0.0, 1.0),
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
    let mut texels = Vec::new();
    let texture_infos = scene
        .textures
        .iter()
        .map(|t| {
            let wrap = |w: Wrap| match w {
                Wrap::Repeat => 0,
                Wrap::MirroredRepeat => 1,
                Wrap::ClampToEdge => 2,
            };
            let info = TextureInfo {
                offset: texels.len() as u32,
                width: t.width,
                height: t.height,
                flags: wrap(t.wrap_s) | wrap(t.wrap_t) << 2 | (t.linear as u32) << 4,
            };
            texels.extend(t.texels.iter().map(|c| u32::from_le_bytes(*c)));
            info
        })
        .collect();

    let cam = &scene.camera;
    // screen_offsets is affine in (x, y): its scale is the difference of unit steps.
    let (x0, _) = cam.screen_offsets(0.0, 0.0, width, height);
    let (x1, _) = cam.screen_offsets(1.0, 0.0, width, height);
    let params = Params {
        cam_forward: v3(cam.forward),
        cam_scale: (x1 - x0) as f32,
        cam_right: v3(cam.right),
        half_w: width as f32 * 0.5,
        cam_up: v3(cam.up),
        half_h: height as f32 * 0.5,
        background: v3(scene.background),
        ortho: matches!(cam.projection, Projection::Orthographic { .. }) as u32,
        ambient: v3(scene.ambient),
        prim_count: scene.primitives.len() as u32,
        light_count: scene.lights.len() as u32,
        shadow_inline: super::render::shadow_inline(scene),
        ..Params::default()
    };
    Packed { prims, tri_attrs, materials, lights, texture_infos, texels, params }
}
