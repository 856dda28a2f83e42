//! The scene's buffers on the GPU: the packed scene and, with `--accel cube`, the flattened
//! tables (uploaded once), and the kernels' outputs and per-point state (sized for a tile),
//! with their one bind group.

use wgpu::util::DeviceExt;

use super::GpuContext;
use crate::coherence::FlatTables;
use crate::layout::counters::COUNTER_BYTES;
use crate::layout::{Packed, Params, PointState};

/// A packed scene's buffers on the GPU with their bind group (the bindings of
/// `shaders/shared/layout.wgsl` and `shaders/shared/tables.wgsl`), sized for tiles of up to
/// `tile` grid points. Positions are
/// relative to the eye: a camera move rewrites `prims`, `lights` and `params`.
pub struct SceneBuffers {
    pub params: wgpu::Buffer,
    pub prims: wgpu::Buffer,
    pub lights: wgpu::Buffer,
    /// One `vec4<f32>` per point of the tile: the radiance summed by `render` so far.
    pub out: wgpu::Buffer,
    /// The 64-bit counters (`COUNTER_COUNT` of them, low word first).
    pub counters: wgpu::Buffer,
    /// One [`PointState`] per point of the tile (one only for the `aov` kernel).
    pub states: wgpu::Buffer,
    /// One `u32`: grid points with work left after a step.
    pub active: wgpu::Buffer,
    pub bind: wgpu::BindGroup,
    pub tile: u64,
}

/// Uploads `packed` (and the candidate tables, when traced) and creates the kernels'
/// buffers for tiles of up to `tile` grid points (`stepped`: with a point state each, for
/// the `render` kernel).
pub fn upload(
    ctx: &GpuContext,
    layout: &wgpu::BindGroupLayout,
    packed: &Packed,
    tables: Option<&FlatTables>,
    tile: u64,
    stepped: bool,
) -> SceneBuffers {
    let device = &ctx.device;
    let storage = |label: &str, bytes: &[u8], extra: wgpu::BufferUsages| {
        // Storage bindings may not be empty.
        let contents = if bytes.is_empty() { &[0u8; 256][..] } else { bytes };
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents,
            usage: wgpu::BufferUsages::STORAGE | extra,
        })
    };
    let none = wgpu::BufferUsages::empty();
    let prims = storage("prims", bytemuck::cast_slice(&packed.prims), wgpu::BufferUsages::COPY_DST);
    let materials = storage("materials", bytemuck::cast_slice(&packed.materials), none);
    let lights = storage("lights", bytemuck::cast_slice(&packed.lights), wgpu::BufferUsages::COPY_DST);
    let attrs = storage("tri_attrs", bytemuck::cast_slice(&packed.tri_attrs), none);
    let infos = storage("texture_infos", bytemuck::cast_slice(&packed.texture_infos), none);
    let texels = storage("texels", bytemuck::cast_slice(&packed.texels), none);
    let table = |label: &str, bytes: Option<&[u8]>| storage(label, bytes.unwrap_or(&[]), none);
    let origins = table("origins", tables.map(|f| bytemuck::cast_slice(&f.origins)));
    let faces = table("faces", tables.map(|f| bytemuck::cast_slice(&f.faces)));
    let cell_start = table("cell_start", tables.map(|f| bytemuck::cast_slice(&f.cell_start)));
    let entries = table("entries", tables.map(|f| bytemuck::cast_slice(&f.entries)));
    let prim_origin = table("prim_origin", tables.map(|f| bytemuck::cast_slice(&f.prim_origin)));
    let light_origin = table("light_origin", tables.map(|f| bytemuck::cast_slice(&f.light_origin)));
    let prim_patches = table("prim_patches", tables.map(|f| bytemuck::cast_slice(&f.prim_patches)));
    let groups = table("groups", tables.map(|f| bytemuck::cast_slice(&f.groups)));
    let group_prims = table("group_prims", tables.map(|f| bytemuck::cast_slice(&f.group_prims)));
    let params = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("params"),
        size: std::mem::size_of::<Params>() as u64,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let out = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("out"),
        size: tile * 16,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let counters = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("counters"),
        contents: &[0u8; COUNTER_BYTES as usize],
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
    });
    let state_bytes = std::mem::size_of::<PointState>() as u64;
    let states = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("point states"),
        size: if stepped { tile * state_bytes } else { state_bytes },
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let active = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("active"),
        size: 4,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("scene"),
        layout,
        entries: &[
            (0, &params),
            (1, &prims),
            (2, &materials),
            (3, &lights),
            (4, &attrs),
            (5, &infos),
            (6, &texels),
            (7, &out),
            (8, &counters),
            (9, &states),
            (10, &active),
            (11, &origins),
            (12, &faces),
            (13, &cell_start),
            (14, &entries),
            (15, &prim_origin),
            (16, &light_origin),
            (17, &prim_patches),
            (18, &groups),
            (19, &group_prims),
        ]
        .map(|(binding, b)| wgpu::BindGroupEntry { binding, resource: b.as_entire_binding() }),
    });
    SceneBuffers { params, prims, lights, out, counters, states, active, bind, tile }
}
