//! The scene's buffers on the GPU: the packed scene and, with `--accel cube`, the
//! flattened tables (with `cube` and rays leaving surfaces, the flattened BVH or the ray
//! queries' structure too), with `--accel bvh` the flattened BVH, or with `--accel rayquery`
//! the ray queries' structure (built by the driver, [`RqStructure`]), all uploaded once, and
//! the kernels' outputs and the wavefront's queues (sized for a tile), with their one bind
//! group.

use super::bindings::SceneBinding;
use super::GpuContext;
use crate::coherence::FlatTables;
use crate::error::{Error, Result};
use crate::layout::counters::COUNTER_BYTES;
use crate::layout::rayquery::RqBox;
use crate::layout::{Packed, QUEUE_SHADOW, QUEUE_WORDS, WORKGROUP};

/// A packed scene's buffers on the GPU with their bind group: one buffer for each binding
/// of the scene's family ([`SceneBinding`], indexed by it: `buffers[SceneBinding::Prims]`),
/// the ray queries' structure where the kernels use them, and the dispatch arguments, sized
/// for tiles of up to `tile` grid points. Positions are relative to the eye: a camera move
/// rewrites the primitives, the lights, the BVH and the params.
pub struct SceneBuffers {
    /// The buffers of [`SceneBinding::BUFFERS`], in its order.
    bound: Vec<wgpu::Buffer>,
    /// The dispatch arguments of the current pass, copied from the queues (a buffer the
    /// kernel writes cannot also be its dispatch's argument buffer).
    pub indirect: wgpu::Buffer,
    /// The ray queries' acceleration structure, where the kernels use ray queries.
    pub rq: Option<RqStructure>,
    pub bind: wgpu::BindGroup,
    pub tile: u64,
    /// Jobs each ray queue and each shadow queue holds (`Params::ray_queue`,
    /// `Params::shadow_queue`).
    pub ray_queue: u32,
    pub shadow_queue: u32,
}

impl std::ops::Index<SceneBinding> for SceneBuffers {
    type Output = wgpu::Buffer;

    /// The buffer bound at `b` (every binding but the ray queries' structure).
    fn index(&self, b: SceneBinding) -> &wgpu::Buffer {
        &self.bound[slot(b)]
    }
}

/// Where the buffer of binding `b` is in [`SceneBinding::BUFFERS`].
fn slot(b: SceneBinding) -> usize {
    SceneBinding::BUFFERS.iter().position(|&x| x == b).expect("a binding of a buffer")
}

impl SceneBuffers {
    /// Writes the eye-dependent parts of `packed` (the same scene re-centred on another eye,
    /// with its BVH) into these buffers, when they were made for a BVH at least as large:
    /// a camera move then allocates nothing (new buffers of a tile's queues cost their
    /// zeroing). Returns whether it did.
    pub fn rewrite_moved(&self, ctx: &GpuContext, packed: &Packed) -> bool {
        use SceneBinding::*;
        // The driver's structure is built over eye-relative boxes: a new eye builds anew.
        let Some(bvh) = packed.bvh.as_ref().filter(|_| self.rq.is_none() && packed.rq.is_none()) else {
            return false;
        };
        let parts: [(SceneBinding, &[u8]); 3] = [
            (BvhNodes, bytemuck::cast_slice(&bvh.nodes)),
            (BvhPrims, bytemuck::cast_slice(&bvh.prims)),
            (BvhParents, bytemuck::cast_slice(&bvh.parents)),
        ];
        let fits =
            |(b, bytes): &(SceneBinding, &[u8])| !bytes.is_empty() && bytes.len() as u64 <= self[*b].size();
        let prims: Vec<_> =
            data_parts(packed, None).into_iter().filter(|(b, _)| SceneBinding::PRIMS.contains(b)).collect();
        if !parts.iter().all(fits) || prims.iter().any(|&(b, p)| p.len() as u64 != self[b].size()) {
            return false;
        }
        let queue = &ctx.queue;
        for (b, p) in prims {
            queue.write_buffer(&self[b], 0, p);
        }
        if !packed.lights.is_empty() {
            queue.write_buffer(&self[Lights], 0, bytemuck::cast_slice(&packed.lights));
        }
        for (b, bytes) in parts {
            queue.write_buffer(&self[b], 0, bytes);
        }
        true
    }

    /// Writes `flat` into the tables' buffers when each part fits in its buffer (the
    /// preview's eye table, rebuilt for a resting camera, into buffers made with room).
    /// Returns whether it did.
    pub fn rewrite_tables(&self, ctx: &GpuContext, flat: &FlatTables) -> bool {
        let parts = table_parts(Some(flat));
        if parts.iter().any(|&(b, p)| p.len() as u64 > self[b].size()) {
            return false;
        }
        for (b, p) in parts {
            if !p.is_empty() {
                ctx.queue.write_buffer(&self[b], 0, p);
            }
        }
        true
    }
}

/// The tables' buffers' contents (empty without tables).
fn table_parts(flat: Option<&FlatTables>) -> [(SceneBinding, &[u8]); 5] {
    use SceneBinding::*;
    let bytes = |part: fn(&FlatTables) -> &[u8]| flat.map_or(&[][..], part);
    [
        (Origins, bytes(|f| bytemuck::cast_slice(&f.origins))),
        (Faces, bytes(|f| bytemuck::cast_slice(&f.faces))),
        (CellStart, bytes(|f| bytemuck::cast_slice(&f.cell_start))),
        (Entries, bytes(|f| bytemuck::cast_slice(&f.entries))),
        (LightOrigin, bytes(|f| bytemuck::cast_slice(&f.light_origin))),
    ]
}

/// What the buffers of the scene's data hold: `packed` (its BVH, if any) and the tables.
fn data_parts<'a>(packed: &'a Packed, tables: Option<&'a FlatTables>) -> Vec<(SceneBinding, &'a [u8])> {
    use SceneBinding::*;
    let bvh = packed.bvh.as_ref();
    let bvh_part = |part: fn(&crate::layout::bvh::GpuBvh) -> &[u8]| bvh.map_or(&[][..], part);
    // Split over bindings of `prims_per_binding` primitives each where one cannot hold them.
    let prim_bytes = packed.prim_bytes();
    let per_binding = packed.params.prims_per_binding as usize * packed.prim_size();
    let mut parts: Vec<(SceneBinding, &[u8])> = match per_binding {
        0 => vec![(Prims, prim_bytes)],
        n => SceneBinding::PRIMS.into_iter().zip(prim_bytes.chunks(n)).collect(),
    };
    parts.extend([
        (Materials, bytemuck::cast_slice(&packed.materials)),
        (Lights, bytemuck::cast_slice(&packed.lights)),
        (TriAttrs, bytemuck::cast_slice(&packed.tri_attrs)),
        (TextureInfos, bytemuck::cast_slice(&packed.texture_infos)),
        (Texels, bytemuck::cast_slice(&packed.texels)),
        (BvhNodes, bvh_part(|b| bytemuck::cast_slice(&b.nodes))),
        (BvhPrims, bvh_part(|b| bytemuck::cast_slice(&b.prims))),
        (BvhParents, bvh_part(|b| bytemuck::cast_slice(&b.parents))),
    ]);
    parts.extend(table_parts(tables));
    parts
}

/// The size and usage of the buffer of binding `b` the kernels fill (the params, the
/// outputs, the queues), for buffers of `sizes` and jobs of `job_bytes`; `None` for a
/// binding of the scene's data.
fn work_buffer(b: SceneBinding, sizes: BufferSizes, job_bytes: u64) -> Option<(u64, wgpu::BufferUsages)> {
    use wgpu::BufferUsages as U;
    use SceneBinding::*;
    Some(match b {
        Params => (std::mem::size_of::<crate::layout::Params>() as u64, U::STORAGE | U::COPY_DST),
        OutColor => (sizes.tile * 16, U::STORAGE | U::COPY_SRC),
        // COPY_DST: a tile that runs again restores the counts saved before it.
        Counters => (COUNTER_BYTES, U::STORAGE | U::COPY_SRC | U::COPY_DST),
        Jobs => (sizes.jobs_bytes.max(job_bytes), U::STORAGE),
        Queues => (4 * QUEUE_WORDS as u64, U::STORAGE | U::COPY_SRC | U::COPY_DST),
        PassDesc => (std::mem::size_of::<crate::layout::PassDesc>() as u64, U::STORAGE | U::COPY_DST),
        // Each tile point's radiance in fixed point (6 words a point).
        Accum => (if sizes.sums { sizes.tile * 24 } else { 24 }, U::STORAGE | U::COPY_DST),
        _ => return None,
    })
}

/// The platform's ray-tracing structure over the scene's boxes ([`RqBox`], one per
/// primitive): one bottom-level structure of procedural boxes, one instance of it (identity
/// transform) in the top-level one the kernels bind. The driver builds both; wgpu 30 does not
/// say how many bytes they take, so [`RqStructure::input_bytes`] counts the boxes only.
pub struct RqStructure {
    /// The boxes the bottom level was built from (`BLAS_INPUT`).
    pub boxes: wgpu::Buffer,
    /// `None` without primitives: the top level then holds no instance.
    pub blas: Option<wgpu::Blas>,
    pub tlas: wgpu::Tlas,
    /// The build's time, submission to completion (host clock).
    pub build_s: f64,
    pub input_bytes: u64,
}

/// Builds the ray queries' structure over `boxes` and waits for it (timed).
fn build_rq(ctx: &GpuContext, boxes: &[RqBox]) -> Result<RqStructure> {
    let device = &ctx.device;
    let max = device.limits().max_blas_primitive_count;
    if boxes.len() as u64 > max as u64 {
        return Err(Error::Options(format!(
            "{} primitives are more than {}'s ray queries take in one structure ({max}); use --accel cube \
             --surface-walk bvh",
            boxes.len(),
            ctx.info.name
        )));
    }
    let start = std::time::Instant::now();
    let bytes: &[u8] = bytemuck::cast_slice(boxes);
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("ray query boxes"),
        size: (bytes.len() as u64).max(std::mem::size_of::<RqBox>() as u64),
        usage: wgpu::BufferUsages::BLAS_INPUT | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    if !bytes.is_empty() {
        ctx.queue.write_buffer(&buffer, 0, bytes);
    }
    let fast_trace = wgpu::AccelerationStructureFlags::PREFER_FAST_TRACE;
    let build = wgpu::AccelerationStructureUpdateMode::Build;
    let mut tlas = device.create_tlas(&wgpu::CreateTlasDescriptor {
        label: Some("ray query instances"),
        max_instances: 1,
        flags: fast_trace,
        update_mode: build,
    });
    let size = wgpu::BlasAABBGeometrySizeDescriptor {
        primitive_count: boxes.len() as u32,
        flags: wgpu::AccelerationStructureGeometryFlags::OPAQUE
            | wgpu::AccelerationStructureGeometryFlags::NO_DUPLICATE_ANY_HIT_INVOCATION,
    };
    let blas = (!boxes.is_empty()).then(|| {
        device.create_blas(
            &wgpu::CreateBlasDescriptor {
                label: Some("ray query boxes"),
                flags: fast_trace,
                update_mode: build,
            },
            wgpu::BlasGeometrySizeDescriptors::AABBs { descriptors: vec![size.clone()] },
        )
    });
    let mut enc =
        device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("ray query build") });
    match &blas {
        Some(b) => {
            const IDENTITY: [f32; 12] = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0];
            tlas[0] = Some(wgpu::TlasInstance::new(b, IDENTITY, 0, 0xff));
            let entry = wgpu::BlasBuildEntry {
                blas: b,
                geometry: wgpu::BlasGeometries::AabbGeometries(vec![wgpu::BlasAabbGeometry {
                    size: &size,
                    stride: std::mem::size_of::<RqBox>() as u64,
                    aabb_buffer: &buffer,
                    primitive_offset: 0,
                }]),
            };
            enc.build_acceleration_structures([&entry], [&tlas]);
        }
        None => enc.build_acceleration_structures(std::iter::empty::<&wgpu::BlasBuildEntry>(), [&tlas]),
    }
    ctx.queue.submit([enc.finish()]);
    ctx.wait()?;
    Ok(RqStructure {
        boxes: buffer,
        blas,
        tlas,
        build_s: start.elapsed().as_secs_f64(),
        input_bytes: bytes.len() as u64,
    })
}

/// How large the wavefront's queues are for one point of a tile: rays of one depth per eye
/// ray (2^(depth−1) at most where glass splits every ray; a tile that overflows runs again
/// in halves), and shadow rays per ray (the lights, with shadows).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct QueueSizes {
    pub rays_per_point: u32,
    pub shadows_per_ray: u32,
}

impl QueueSizes {
    /// Jobs per point of a tile, all queues together.
    fn jobs_per_point(&self) -> u64 {
        let rays = self.rays_per_point as u64;
        QUEUE_SHADOW as u64 * rays + 3 * rays * self.shadows_per_ray as u64
    }
}

/// Checks every storage buffer (`(name, bytes)`) against the adapter's limits on one binding
/// and one buffer; the error names the buffer and the limit.
pub fn check_limits(buffers: &[(&str, u64)], limits: &wgpu::Limits) -> Result<()> {
    for &(name, bytes) in buffers {
        for (limit, max) in [
            ("max_storage_buffer_binding_size", limits.max_storage_buffer_binding_size),
            ("max_buffer_size", limits.max_buffer_size),
        ] {
            if bytes > max {
                // Textures do not shrink with the image: say what would help.
                let advice = if name == "texels" {
                    "the scene's textures are too large for one binding: use smaller images, or --backend cpu"
                } else {
                    "render a smaller image or scene, or with --backend cpu"
                };
                return Err(Error::Options(format!(
                    "the GPU buffer {name} needs {bytes} bytes, over this adapter's {limit} of {max}: {advice}"
                )));
            }
        }
    }
    Ok(())
}

/// The largest tile of at most `tile` points (a multiple of the workgroup) whose per-point
/// buffers (`per_point` bytes a point) stay within one binding of `max_binding` bytes: a
/// large image is split into more tiles rather than refused. At least one workgroup (which
/// [`check_limits`] then refuses on an adapter too small even for that).
pub fn fit_tile(tile: u64, per_point: u64, max_binding: u64) -> u64 {
    let group = WORKGROUP as u64;
    tile.min((max_binding / per_point / group * group).max(group))
}

/// The sizes of a render's per-tile buffers: the grid points a tile holds, the jobs each ray
/// queue and each shadow queue holds, and the bytes of all the queues.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BufferSizes {
    pub tile: u64,
    pub ray_queue: u32,
    pub shadow_queue: u32,
    pub jobs_bytes: u64,
    /// Whether the buffers hold each tile point's radiance sum (the wavefront's and the tree
    /// form's; else the `aov` kernel's buffers).
    pub sums: bool,
}

impl BufferSizes {
    /// The sizes for tiles of up to `tile` points, with the wavefront's queues of `queues`
    /// per point (`None`: none, for the tree form or the `aov` kernel) of jobs of
    /// `job_bytes`, and with the points' radiance sums where `sums`, on an adapter whose
    /// bindings hold `max_binding` bytes (fewer points where it calls for it).
    pub fn fit(
        tile: u64,
        queues: Option<QueueSizes>,
        sums: bool,
        job_bytes: u64,
        max_binding: u64,
    ) -> BufferSizes {
        let bare = if sums { 24 } else { 16 };
        let per_point = queues.map_or(bare, |q| (q.jobs_per_point() * job_bytes).max(24));
        let tile = fit_tile(tile, per_point, max_binding);
        let ray_queue = queues.map_or(0, |q| tile * q.rays_per_point as u64) as u32;
        let shadow_queue = queues.map_or(0, |q| ray_queue as u64 * q.shadows_per_ray as u64) as u32;
        let jobs_bytes = (QUEUE_SHADOW as u64 * ray_queue as u64 + 3 * shadow_queue as u64) * job_bytes;
        BufferSizes { tile, ray_queue, shadow_queue, jobs_bytes, sums }
    }

    /// The same tiles without the queues (the tree form's buffers).
    pub fn without_queues(self) -> BufferSizes {
        BufferSizes { ray_queue: 0, shadow_queue: 0, jobs_bytes: 0, ..self }
    }
}

/// Uploads `packed` (with its BVH, if any, and the candidate tables, when traced) and creates the kernels'
/// buffers of `sizes` ([`BufferSizes::fit`]). A buffer over the adapter's limits is refused
/// before anything is created, and a failed allocation is an error, not a lost device.
pub fn upload(
    ctx: &GpuContext,
    layout: &wgpu::BindGroupLayout,
    packed: &Packed,
    tables: Option<&FlatTables>,
    sizes: BufferSizes,
) -> Result<SceneBuffers> {
    let device = &ctx.device;
    let job_bytes = packed.job_bytes();
    let data = data_parts(packed, tables);
    let mut limited: Vec<(&str, u64)> =
        data.iter().map(|(b, p)| (b.binding().name, p.len() as u64)).collect();
    limited.extend([("out", sizes.tile * 16), ("ray queues", sizes.jobs_bytes)]);
    check_limits(&limited, &device.limits())?;
    // A device that is gone (its loss reported on the next poll) creates nothing.
    let _ = device.poll(wgpu::PollType::Poll);
    ctx.fault()?;
    // Built and waited for before the error scopes: a fault in the build is the device's.
    let rq = packed.rq.as_deref().map(|boxes| build_rq(ctx, boxes)).transpose()?;
    let out_of_memory = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
    let invalid = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let bound: Vec<wgpu::Buffer> = SceneBinding::BUFFERS
        .iter()
        .map(|&b| match work_buffer(b, sizes, job_bytes) {
            // New buffers are zeroed.
            Some((size, usage)) => device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(b.binding().name),
                size,
                usage,
                mapped_at_creation: false,
            }),
            None => {
                let bytes = data.iter().find(|(d, _)| *d == b).map_or(&[][..], |(_, p)| p);
                storage_buffer(ctx, b.binding().name, bytes)
            }
        })
        .collect();
    let indirect = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("dispatch arguments"),
        size: 12,
        usage: wgpu::BufferUsages::INDIRECT | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let bind = bind_group(device, layout, &bound, rq.as_ref());
    let buffers = SceneBuffers {
        bind,
        bound,
        indirect,
        rq,
        tile: sizes.tile,
        ray_queue: sizes.ray_queue,
        shadow_queue: sizes.shadow_queue,
    };
    let failed = [pollster::block_on(invalid.pop()), pollster::block_on(out_of_memory.pop())];
    if let Some(e) = failed.into_iter().flatten().next() {
        let mib = limited.iter().map(|s| s.1).sum::<u64>() as f64 / (1u64 << 20) as f64;
        return Err(Error::Gpu(format!("cannot create the scene's buffers ({mib:.0} MiB and more): {e}")));
    }
    Ok(buffers)
}

/// A storage buffer holding `bytes`. Storage bindings may not be empty: an empty one holds a
/// placeholder. The contents go through the queue (not a buffer mapped at creation, whose
/// mapping panics on a lost device); every buffer holds 32-bit words, so its length is a
/// whole number of copy units.
fn storage_buffer(ctx: &GpuContext, label: &str, bytes: &[u8]) -> wgpu::Buffer {
    let contents = if bytes.is_empty() { &[0u8; 256][..] } else { bytes };
    assert_eq!(contents.len() as u64 % wgpu::COPY_BUFFER_ALIGNMENT, 0, "{label}: not whole words");
    let buffer = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: contents.len() as u64,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    ctx.queue.write_buffer(&buffer, 0, contents);
    buffer
}

/// The scene family's bind group over the buffers `bound` (of [`SceneBinding::BUFFERS`]),
/// with the ray queries' structure `rq` where there is one.
fn bind_group(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    bound: &[wgpu::Buffer],
    rq: Option<&RqStructure>,
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry> = SceneBinding::family(rq.is_some())
        .map(|b| wgpu::BindGroupEntry {
            binding: b.binding().number,
            resource: match (b, rq) {
                (SceneBinding::RqScene, Some(rq)) => rq.tlas.as_binding(),
                _ => bound[slot(b)].as_entire_binding(),
            },
        })
        .collect();
    device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("scene"), layout, entries: &entries })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn buffers_over_a_limit_are_refused_by_name() {
        let limits = wgpu::Limits { max_storage_buffer_binding_size: 1 << 20, ..wgpu::Limits::default() };
        assert!(check_limits(&[("prims", 1 << 20), ("entries", 12)], &limits).is_ok());
        let e = check_limits(&[("prims", 100), ("entries", (1 << 20) + 8)], &limits).unwrap_err().to_string();
        assert!(e.contains("entries") && e.contains("max_storage_buffer_binding_size"), "{e}");
        let e = check_limits(&[("texels", (1 << 20) + 4)], &limits).unwrap_err().to_string();
        assert!(e.contains("texels") && e.contains("smaller images"), "{e}");
        let limits = wgpu::Limits { max_buffer_size: 64, ..limits };
        let e = check_limits(&[("out", 65)], &limits).unwrap_err().to_string();
        assert!(e.contains("out") && e.contains("max_buffer_size"), "{e}");
    }

    #[test]
    fn tiles_shrink_to_the_limits_in_whole_workgroups() {
        let limits =
            wgpu::Limits { max_storage_buffer_binding_size: 1000 * 64 + 5, ..wgpu::Limits::default() };
        let max = limits.max_storage_buffer_binding_size;
        assert_eq!(fit_tile(4096, 1000, max), 64);
        assert_eq!(fit_tile(32, 1000, max), 32);
        let small = wgpu::Limits { max_storage_buffer_binding_size: 10, ..limits };
        assert_eq!(fit_tile(4096, 1000, 10), WORKGROUP as u64);
        assert!(check_limits(&[("ray queues", WORKGROUP as u64 * 1000)], &small).is_err());
    }
}
