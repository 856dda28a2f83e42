//! The kernels' intersection arithmetic on the GPU against its Rust twins
//! (`cuberay::arith::geometry`, `cuberay::layout::bvh::WideNode::hits`): a test kernel runs
//! the composed `shaders/shared/intersect.wgsl` and the BVH's node test of
//! `shaders/shared/bvh.wgsl` on many random rays and primitives (grazing spheres and
//! cylinders, rays through triangles' edges and vertices, axis-parallel rays, boxes touched
//! at their faces), and each answer is compared with the twin's. Each primitive's box is one
//! child, in a slot of its own and inner or a leaf, of a wide node whose other children are
//! random boxes around it: the node test decodes all eight and orders them by the ray's
//! octant.
//!
//! The twins claim the same operations in the same order, but Vulkan lets a driver fuse a
//! multiply and an add (rounding once instead of twice) and divide or take square roots to
//! within a few ulps, so bit for bit holds only where no such step mattered (about two
//! thirds of the hits here); the bounds are stated, not assumed: hit or miss agree except
//! where the hit lies within [`NEAR`] of the boundary (a barycentric coordinate, a grazing
//! ray's cosine, a cylinder's end, `t_max`: a few ulps decide those), and a shared hit's t
//! and barycentrics agree within [`T_ULPS`] and [`B_ULPS`] ulps of the numbers they are
//! computed from. The node test approximates nothing and, on lavapipe, fuses nothing: it agrees bit for bit. A one-sided change of a twin (a term dropped, an operation of another
//! precision) breaks far more cases than that.

use cuberay::arith::geometry::{make_ray, Prim32, PrimHit, Ray};
use cuberay::gpu::shaders::{compose_root, Accel, Variant};
use cuberay::gpu::GpuContext;
use cuberay::layout::bvh::{box_ray, WideNode};
use cuberay::layout::Prim;
use glam::Vec3;

use super::cases::{cases, Case, Shape};

/// How far a shared hit's t may differ between the twins (spheres, triangles, cylinders), in
/// ulps of the largest number it is computed from, times the cosine between the ray and the
/// surface (a grazing ray's root moves by its inputs' error over that cosine). Measured on
/// lavapipe (Mesa 22.3): 2, 2, 3.
const T_ULPS: [u32; 3] = [8, 8, 8];
/// How far its barycentrics may differ, in ulps of 1 (they lie in [0, 1]), scaled alike and
/// by the triangle's size over that largest number. Measured: 4.6.
const B_ULPS: f32 = 16.0;

/// The test kernel: one case per invocation, its primitive's hit and its box's test.
const KERNEL: &str = r#"
#include "shared/trace.wgsl"

struct Case {
    o: vec3<f32>,
    prim: u32,
    d: vec3<f32>,
    t_max: f32,
}

@group(0) @binding(30) var<storage, read> cases: array<Case>;
@group(0) @binding(31) var<storage, read_write> answers: array<vec4<u32>>;

@compute @workgroup_size(64)
fn twins(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= arrayLength(&cases) {
        return;
    }
    let c = cases[i];
    let ray = make_ray(c.o, c.d);
    let h = intersect_prim(prims[c.prim], ray, c.t_max);
    let boxed = node_hits(bvh_nodes[c.prim], box_ray(ray), c.t_max);
    let flags = select(0u, 1u, h.ok);
    answers[2u * i] = vec4<u32>(flags, bitcast<u32>(h.t), bitcast<u32>(h.b1), bitcast<u32>(h.b2));
    answers[2u * i + 1u] = vec4<u32>(bitcast<u32>(h.err), boxed.inner, boxed.prims, 0u);
}
"#;

/// What the GPU answered for each case: (hit, t, b1, b2, err bits, the node test's inner
/// and primitive masks).
fn on_the_gpu(shapes: &[Shape], cases: &[Case]) -> Vec<[u32; 7]> {
    let ctx = GpuContext::new().unwrap_or_else(|e| panic!("{e}"));
    let variant = Variant { counters: false, ..Variant::full(Accel::Bvh) };
    let source = compose_root(KERNEL, variant).expect("the test kernel composes");
    let device = &ctx.device;
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("twins"),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("twins"),
        layout: None,
        module: &module,
        entry_point: Some("twins"),
        compilation_options: Default::default(),
        cache: None,
    });
    use wgpu::util::DeviceExt;
    let storage = |label: &str, bytes: &[u8], usage: wgpu::BufferUsages| {
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: bytes,
            usage,
        })
    };
    let read = wgpu::BufferUsages::STORAGE;
    let prims: Vec<Prim> = shapes.iter().map(|s| s.packed).collect();
    let nodes: Vec<WideNode> = shapes.iter().map(|s| s.node).collect();
    let answer_bytes = (cases.len() * 32) as u64;
    let buffers = [
        (1, storage("prims", bytemuck::cast_slice(&prims), read)),
        (20, storage("bvh_nodes", bytemuck::cast_slice(&nodes), read)),
        (30, storage("cases", bytemuck::cast_slice(cases), read)),
        (
            31,
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("answers"),
                size: answer_bytes,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
        ),
    ];
    let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("twins"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &buffers
            .iter()
            .map(|(binding, b)| wgpu::BindGroupEntry { binding: *binding, resource: b.as_entire_binding() })
            .collect::<Vec<_>>(),
    });
    let readback = ctx.readback_buffer("answers readback", answer_bytes);
    let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
    {
        let mut pass =
            enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: None, timestamp_writes: None });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups((cases.len() as u32).div_ceil(64), 1, 1);
    }
    enc.copy_buffer_to_buffer(&buffers[3].1, 0, &readback, 0, answer_bytes);
    ctx.queue.submit([enc.finish()]);
    let bytes = ctx.read(&readback, answer_bytes).expect("the answers read back");
    let words: &[[u32; 8]] = bytemuck::cast_slice(&bytes);
    words.iter().map(|w| [w[0], w[1], w[2], w[3], w[4], w[5], w[6]]).collect()
}

/// Where a hit at distance `t` along `c`'s ray lies on `s`, computed in f64: the cosine
/// between the ray and the surface's normal there (small for a grazing ray, whose t the
/// rounding of its inputs moves by about their error over this cosine), and how near the
/// point is to the primitive's boundary, as a number that is small there (a triangle's least
/// barycentric coordinate, a cylinder's nearer end as a share of its height, and the hit's
/// distance from `t_max` as a share of t).
fn hit_geometry(s: &Shape, c: &Case, t: f32) -> (f64, f64) {
    let o = Vec3::from(c.o).as_dvec3();
    let d = Vec3::from(c.d).as_dvec3().normalize();
    let p = o + d * t as f64;
    let to_end = if c.t_max < f32::MAX { ((c.t_max as f64 - t as f64) / t as f64).abs() } else { f64::MAX };
    let (cosine, edge) = match s.prim {
        Prim32::Triangle { p: v } => {
            let [a, b, cc] = v.map(|x| x.as_dvec3());
            let n = (b - a).cross(cc - a);
            let area = n.length_squared();
            let b1 = (p - a).cross(cc - a).dot(n) / area;
            let b2 = (b - a).cross(p - a).dot(n) / area;
            (n.normalize().dot(d).abs(), b1.min(b2).min(1.0 - b1 - b2).abs())
        }
        Prim32::Sphere { c: centre, .. } => ((p - centre.as_dvec3()).normalize().dot(d).abs(), f64::MAX),
        Prim32::Cylinder { base, apex, .. } => {
            let (b, a) = (Vec3::from_slice(&base).as_dvec3(), Vec3::from_slice(&apex).as_dvec3());
            let axis = (a - b).normalize();
            let along = (p - b).dot(axis) / (a - b).length();
            let radial = (p - b) - axis * (p - b).dot(axis);
            let slope = (apex[3] as f64 - base[3] as f64) / (a - b).length();
            let normal = (radial.normalize_or_zero() - axis * slope).normalize_or_zero();
            (normal.dot(d).abs(), along.abs().min((1.0 - along).abs()))
        }
    };
    (cosine, edge.min(to_end))
}

/// How near the boundary of `s` a hit at `t` lies: the least of [`hit_geometry`]'s two
/// numbers.
fn margin(s: &Shape, c: &Case, t: f32) -> f64 {
    let (cosine, edge) = hit_geometry(s, c, t);
    cosine.min(edge)
}

/// Below this [`margin`], the twins may disagree on hit or miss (a few ulps decide it), and
/// a hit's t is ill-conditioned (a grazing ray's root).
const NEAR: f64 = 1e-3;

/// How far the twins' error bounds (`PrimHit::err`) may differ, relative: they are computed
/// alike from t and numbers that differ by the ulps above, but a quadric's bound divides by
/// the square root of its discriminant, which is itself ill-conditioned where the ray comes
/// near grazing (a fused multiply-add moves it most there). Measured on lavapipe (Mesa
/// 22.3): 2.7e-2. Each bound is also checked for what it claims: t lies within it of the
/// exact root of the same f32 inputs, on the GPU and the CPU.
const ERR_REL: f64 = 5e-2;

/// The exact root, in f64, of the f32 inputs a test computes `t` from: `c`'s origin and the
/// ray's f32 unit direction taken as they are, and the primitive's f32 numbers; of two
/// roots, the one nearer `t`.
fn exact_root(s: &Shape, c: &Case, ray: &Ray, t: f32) -> f64 {
    let o = Vec3::from(c.o).as_dvec3();
    let d = ray.d.as_dvec3();
    let nearer = |a: f64, b: f64, cc: f64| {
        // a·t² + 2b·t + cc = 0
        let disc = (b * b - a * cc).max(0.0).sqrt();
        let (r0, r1) = ((-b - disc) / a, (-b + disc) / a);
        if (r0 - t as f64).abs() <= (r1 - t as f64).abs() {
            r0
        } else {
            r1
        }
    };
    match s.prim {
        Prim32::Sphere { c: centre, r, .. } => {
            let f = o - centre.as_dvec3();
            let r = r as f64;
            nearer(d.dot(d), f.dot(d), f.dot(f) - r * r)
        }
        Prim32::Triangle { p } => {
            let [a, b, cc] = p.map(|x| x.as_dvec3());
            let n = (b - a).cross(cc - a);
            n.dot(a - o) / n.dot(d)
        }
        Prim32::Cylinder { base, apex, .. } => {
            let (b, a) = (Vec3::from_slice(&base).as_dvec3(), Vec3::from_slice(&apex).as_dvec3());
            let height = (a - b).length();
            let axis = (a - b) / height;
            let slope = (apex[3] as f64 - base[3] as f64) / height;
            let w = o - b;
            let (s0, ds) = (w.dot(axis), d.dot(axis));
            let (r_o, r_d) = (w - axis * s0, d - axis * ds);
            let (r0, dr) = (base[3] as f64 + slope * s0, slope * ds);
            nearer(r_d.dot(r_d) - dr * dr, r_o.dot(r_d) - r0 * dr, r_o.dot(r_o) - r0 * r0)
        }
    }
}

/// What the comparison of all cases found: counts, the worst differences within the stated
/// bounds, and a line per difference beyond them.
#[derive(Default)]
struct Tally {
    /// Cases the CPU twin hits.
    hits: u32,
    /// Cases whose primitive's slot the CPU node test hits.
    boxes: u32,
    /// Shared hits whose t and barycentrics agree bit for bit.
    exact: u32,
    /// Hit-or-miss answers that differ near the boundary.
    boundary: u32,
    /// Shared hits near the boundary, left unchecked.
    ill: u32,
    /// The largest t difference in ulps, for spheres, triangles and cylinders.
    worst_t: [u32; 3],
    /// The largest barycentric difference, in ulps of 1.
    worst_b: f32,
    /// The largest relative difference between the twins' error bounds.
    worst_err_diff: f64,
    /// The largest distance of a t from the exact root, as a share of its bound.
    worst_used: f64,
    /// A line per difference beyond the stated bounds.
    failures: Vec<String>,
}

/// Compares the GPU's answer `g` for case `c` (on `s`, its ray `ray`) with the CPU twin's
/// hit `cpu`: hit or miss must agree away from the boundary, and a shared hit away from it
/// must agree as [`compare_shared_hit`] says. Counts and failures go to `tally`.
fn compare_hit(tally: &mut Tally, s: &Shape, c: &Case, ray: &Ray, cpu: &PrimHit, g: &[u32; 7]) {
    let g_hit = g[0] & 1 != 0;
    let g_t = f32::from_bits(g[1]);
    tally.hits += cpu.ok as u32;
    let near = margin(s, c, if cpu.ok { cpu.t } else { g_t }) < NEAR;
    if g_hit != cpu.ok {
        if near {
            tally.boundary += 1;
        } else {
            tally.failures.push(format!("{:?}: GPU hit {g_hit} (t {g_t}), CPU {cpu:?}; {c:?}", s.prim));
        }
    } else if cpu.ok && near {
        tally.ill += 1;
    } else if cpu.ok {
        compare_shared_hit(tally, s, c, ray, cpu, g);
    }
}

/// Compares a hit both twins find away from the boundary: t and the barycentrics within
/// [`T_ULPS`] and [`B_ULPS`], the error bounds within [`ERR_REL`] of each other, and each
/// twin's t within its bound of the exact root. Worst cases and failures go to `tally`.
fn compare_shared_hit(tally: &mut Tally, s: &Shape, c: &Case, ray: &Ray, cpu: &PrimHit, g: &[u32; 7]) {
    let g_t = f32::from_bits(g[1]);
    // t's error scales with the numbers it is computed from: the origin's and the
    // primitive's coordinates (relative to one another), counted in their ulps.
    // Both scaled by the cosine between the ray and the surface: a grazing ray's root
    // moves by its inputs' error over that cosine, whatever computes it.
    let (cosine, _) = hit_geometry(s, c, cpu.t);
    let scale = Vec3::from(c.o).abs().max_element().max(s.extent()).max(cpu.t);
    let t_ulps = ((g_t - cpu.t).abs() as f64 * cosine / (scale * f32::EPSILON) as f64).ceil() as u32;
    // Barycentrics lie in [0, 1]: their error counts in ulps of 1, and their point
    // moves with t, over the triangle's size.
    let size = (s.hi[0] - s.lo[0]).max(s.hi[1] - s.lo[1]).max(s.hi[2] - s.lo[2]);
    let db = (f32::from_bits(g[2]) - cpu.b1).abs().max((f32::from_bits(g[3]) - cpu.b2).abs()) as f64;
    let b_err = (db * cosine * (size / scale) as f64 / f32::EPSILON as f64) as f32;
    let kind = match s.prim {
        Prim32::Sphere { .. } => 0,
        Prim32::Triangle { .. } => 1,
        Prim32::Cylinder { .. } => 2,
    };
    tally.exact += (g_t == cpu.t && b_err == 0.0) as u32;
    tally.worst_t[kind] = tally.worst_t[kind].max(t_ulps);
    tally.worst_b = tally.worst_b.max(b_err);
    compare_error_bounds(tally, s, c, ray, cpu, g);
    if t_ulps > T_ULPS[kind] || b_err > B_ULPS {
        tally.failures.push(format!(
            "{:?}: GPU (t, b1, b2) {:?} against CPU {cpu:?}: t {t_ulps} ulps, b {b_err} ulps of 1; {c:?}",
            s.prim,
            [1, 2, 3].map(|k| f32::from_bits(g[k]))
        ));
    }
}

/// Compares the twins' error bounds of a shared hit (within [`ERR_REL`] of each other) and
/// checks what each claims: its twin's t lies within it of the exact root. Worst cases and
/// failures go to `tally`.
fn compare_error_bounds(tally: &mut Tally, s: &Shape, c: &Case, ray: &Ray, cpu: &PrimHit, g: &[u32; 7]) {
    let g_t = f32::from_bits(g[1]);
    // The tie rule's error bound: the twins compute it alike, and it bounds how far
    // each t lies from the exact root of the same f32 inputs.
    let g_err = f32::from_bits(g[4]);
    let err_diff = ((g_err - cpu.err).abs() / cpu.err) as f64;
    tally.worst_err_diff = tally.worst_err_diff.max(err_diff);
    if err_diff > ERR_REL {
        tally.failures.push(format!("{:?}: GPU err {g_err}, CPU {}; {c:?}", s.prim, cpu.err));
    }
    let exact_t = exact_root(s, c, ray, cpu.t);
    for (who, t, err) in [("GPU", g_t, g_err), ("CPU", cpu.t, cpu.err)] {
        let used = (t as f64 - exact_t).abs() / err as f64;
        tally.worst_used = tally.worst_used.max(used);
        if used > 1.0 {
            tally.failures.push(format!(
                "{:?}: {who} t {t} is {} from the exact {exact_t}, over its bound {err}; {c:?}",
                s.prim,
                (t as f64 - exact_t).abs()
            ));
        }
    }
}

/// Compares the GPU's node test for case `c` with the CPU's, bit for bit, and asserts that
/// the slot of a primitive that is hit (`cpu_hit`) is hit too. Counts and failures go to
/// `tally`.
fn compare_node_test(tally: &mut Tally, s: &Shape, c: &Case, ray: &Ray, cpu_hit: bool, g: &[u32; 7]) {
    // The node test takes differences, products, sums, minima and maxima: nothing is
    // approximated, and lavapipe fuses no product into a sum, so the answer is the same
    // bit for bit (a driver that fused would move a few answers at a slab's edge, where
    // the slabs' margin keeps every box the primitive's hit needs).
    let r = box_ray(c.o, ray.d.to_array());
    let (inner, prims) = s.node.hits(&r, c.t_max);
    let cpu_box = s.slot_hit(inner, prims, r.octant);
    tally.boxes += cpu_box as u32;
    if (g[5], g[6]) != (inner, prims) {
        tally.failures.push(format!(
            "node {:?}: GPU (inner, prims) ({:#b}, {:#b}), CPU ({inner:#b}, {prims:#b}), ray {c:?}",
            s.node, g[5], g[6]
        ));
    }
    // Every decoded box holds its primitive: a hit on the primitive is a hit on its slot.
    if cpu_hit {
        assert!(cpu_box, "the node test missed the slot of a primitive that is hit: {:?} {c:?}", s.prim);
    }
}

#[test]
fn the_intersection_tests_and_the_box_test_match_their_rust_twins_on_the_gpu() {
    let (shapes, cases) = cases(24_000);
    let gpu = on_the_gpu(&shapes, &cases);
    let mut tally = Tally::default();
    for (c, g) in cases.iter().zip(&gpu) {
        let s = &shapes[c.prim as usize];
        let ray = make_ray(Vec3::from(c.o), Vec3::from(c.d));
        let cpu: PrimHit = s.prim.intersect(&ray, c.t_max);
        compare_hit(&mut tally, s, c, &ray, &cpu, g);
        compare_node_test(&mut tally, s, c, &ray, cpu.ok, g);
    }
    let Tally { hits, boxes, exact, boundary, ill, worst_t, worst_b, worst_err_diff, worst_used, failures } =
        tally;
    let n = cases.len();
    eprintln!(
        "arith twins: {n} cases, {hits} hits ({exact} bit for bit; t within {worst_t:?} ulps for spheres, triangles, cylinders, barycentrics within {worst_b} ulps of 1), {boxes} boxes hit, all as on the CPU; \
         {boundary} hit-or-miss answers differ, all near the boundary; {ill} shared hits near it unchecked; \
         error bounds within {worst_err_diff:.1e} of each other, t from the exact root at most {worst_used:.3} of its bound"
    );
    assert!(
        failures.is_empty(),
        "{} of {n} cases differ beyond the stated bounds:\n{}",
        failures.len(),
        failures[..failures.len().min(10)].join("\n")
    );
    // The cases do reach what they are for.
    assert!(hits as usize > n / 5 && (hits as usize) < n, "{hits} hits of {n}");
    // A few ulps decide the cases aimed at edges, vertices and silhouettes, but not more
    // than a few of all (measured: 385 of 24000).
    assert!(boundary < (n / 40) as u32, "{boundary} boundary cases of {n}");
}
