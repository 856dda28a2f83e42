//! What a driver's ray queries do with procedural boxes, measured apart from cuberay's
//! kernels (docs/drivers-and-faults.md, "Ray queries"). It builds one structure of a box per
//! sphere, traces 4096 rays with a kernel that keeps its own nearest hit (as
//! `shaders/shared/rayquery.wgsl` does), once without and once with committing each nearer
//! hit, and prints how many rays disagree with brute force on the CPU and how many
//! candidates a ray was handed.
//!
//! ```sh
//! ( set -a; . target/lavapipe-rq/env; set +a
//!   cargo run --release --example rq_probe                    # 400 random spheres
//!   cargo run --release --example rq_probe -- --line 200000   # rays along a line of spheres
//!   cargo run --release --example rq_probe -- --unchecked     # without naga's query checks
//!   cargo run --release --example rq_probe -- --after 200000  # a plain loop after each query
//!   cargo run --release --example rq_probe -- --in-loop )     # a ray_query declared in a loop
//! ```
//!
//! `--after N` runs a loop of N iterations after each query and prints how many it ran (a
//! driver that cuts loops short shows fewer). `--in-loop` compiles a kernel whose `ray_query`
//! is declared in a loop body, which naga 30.0.1 writes as invalid SPIR-V: expect a device
//! error.

use wgpu::util::DeviceExt;

const KERNEL: &str = r#"
enable wgpu_ray_query;
struct Sphere { c: vec3<f32>, r: f32 }
@group(0) @binding(0) var scene: acceleration_structure;
@group(0) @binding(1) var<storage, read> spheres: array<Sphere>;
@group(0) @binding(2) var<storage, read_write> out: array<vec4<f32>>;
// mode: commit nearer hits (0 or 1), iterations of the loop after the query.
@group(0) @binding(3) var<storage, read> mode: array<u32>;
@group(0) @binding(4) var<storage, read> rays: array<vec4<f32>>;

fn hit(i: u32, o: vec3<f32>, d: vec3<f32>) -> f32 {
    let oc = o - spheres[i].c;
    let b = dot(oc, d);
    let disc = b * b - (dot(oc, oc) - spheres[i].r * spheres[i].r);
    return select(-1.0, -b - sqrt(max(disc, 0.0)), disc >= 0.0);
}

fn trace(o: vec3<f32>, d: vec3<f32>) -> vec4<f32> {
    var q: ray_query;
    rayQueryInitialize(&q, scene, RayDesc(0u, 0xffu, 0.0, 1e4, o, d));
    var best = 1e30;
    var best_id = 0xffffffffu;
    var committed = 1e4;
    var candidates = 0u;
    while rayQueryProceed(&q) {
        candidates += 1u;
        let id = rayQueryGetCandidateIntersection(&q).primitive_index;
        let t = hit(id, o, d);
        if t > 1e-3 && (t < best || (t == best && id < best_id)) {
            best = t;
            best_id = id;
            if mode[0] == 1u && t < committed {
                committed = t;
                rayQueryGenerateIntersection(&q, t);
            }
        }
    }
    var after = 0u;
    for (var k = 0u; k < mode[1]; k++) {
        after += 1u;
    }
    return vec4<f32>(f32(best_id), best, f32(candidates), f32(after));
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if gid.x < arrayLength(&out) {
        out[gid.x] = trace(rays[2u * gid.x].xyz, rays[2u * gid.x + 1u].xyz);
    }
}
"#;

const IN_LOOP: &str = r#"
enable wgpu_ray_query;
@group(0) @binding(0) var scene: acceleration_structure;
@group(0) @binding(2) var<storage, read_write> out: array<vec4<f32>>;
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    var n = 0u;
    for (var k = 0u; k < 2u; k++) {
        var q: ray_query;
        rayQueryInitialize(&q, scene, RayDesc(0u, 0xffu, 0.0, 1e4, vec3<f32>(0.0), vec3<f32>(0.0, 0.0, 1.0)));
        while rayQueryProceed(&q) {
            n += 1u;
        }
    }
    out[gid.x] = vec4<f32>(f32(n));
}
"#;

const RAYS: usize = 4096;

/// A small linear congruential generator: the same scene on every run.
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// The value after `flag` on the command line.
fn arg(flag: &str) -> Option<u32> {
    let args: Vec<String> = std::env::args().collect();
    args.iter().position(|a| a == flag).map(|i| args[i + 1].parse().expect("a number after the flag"))
}

fn main() {
    let flag = |f: &str| std::env::args().any(|a| a == f);
    let line = arg("--line");
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    let adapter =
        pollster::block_on(instance.request_adapter(&Default::default())).expect("a Vulkan adapter");
    let info = adapter.get_info();
    assert!(
        adapter.features().contains(wgpu::Features::EXPERIMENTAL_RAY_QUERY),
        "{} ({}) has no ray queries",
        info.name,
        info.driver_info
    );
    println!(
        "{} ({}), at most {} boxes a structure",
        info.name,
        info.driver_info,
        adapter.limits().max_blas_primitive_count
    );
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        required_features: wgpu::Features::EXPERIMENTAL_RAY_QUERY,
        required_limits: wgpu::Limits::default().using_acceleration_structure_values(adapter.limits()),
        // SAFETY: the kernels keep to what wgpu 30's ray queries support.
        experimental_features: unsafe { wgpu::ExperimentalFeatures::enabled() },
        ..Default::default()
    }))
    .expect("a device with ray queries");
    device.on_uncaptured_error(std::sync::Arc::new(|e: wgpu::Error| eprintln!("device error: {e}")));

    // Spheres at random, or along the z axis at random depths (every ray then crosses all).
    let mut rnd = Lcg(12345);
    let n = line.unwrap_or(400) as usize;
    let mut spheres: Vec<[f32; 4]> = Vec::with_capacity(n);
    for _ in 0..n {
        spheres.push(match line {
            Some(_) => [0.0, 0.0, 1.0 + 999.0 * rnd.next(), 0.01],
            None => [
                20.0 * rnd.next() - 10.0,
                20.0 * rnd.next() - 10.0,
                20.0 * rnd.next() - 10.0,
                0.3 + 1.5 * rnd.next(),
            ],
        });
    }
    let boxes: Vec<[f32; 6]> =
        spheres.iter().map(|&[x, y, z, r]| [x - r, y - r, z - r, x + r, y + r, z + r]).collect();
    let mut rays: Vec<[f32; 4]> = Vec::with_capacity(2 * RAYS);
    for _ in 0..RAYS {
        let (o, d) = match line {
            Some(_) => ([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
            None => {
                let o = [24.0 * rnd.next() - 12.0, 24.0 * rnd.next() - 12.0, 24.0 * rnd.next() - 12.0];
                let d = [rnd.next() - 0.5, rnd.next() - 0.5, rnd.next() - 0.5];
                let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                (o, [d[0] / l, d[1] / l, d[2] / l])
            }
        };
        rays.push([o[0], o[1], o[2], 0.0]);
        rays.push([d[0], d[1], d[2], 0.0]);
    }
    // Brute force on the CPU, in the kernel's arithmetic.
    let expect: Vec<u32> = (0..RAYS)
        .map(|i| {
            let (o, d) = (rays[2 * i], rays[2 * i + 1]);
            let mut best = (f32::INFINITY, u32::MAX);
            for (k, s) in spheres.iter().enumerate() {
                let oc = [o[0] - s[0], o[1] - s[1], o[2] - s[2]];
                let b = oc[0] * d[0] + oc[1] * d[1] + oc[2] * d[2];
                let disc = b * b - (oc[0] * oc[0] + oc[1] * oc[1] + oc[2] * oc[2] - s[3] * s[3]);
                let t = -b - disc.max(0.0).sqrt();
                if disc >= 0.0 && t > 1e-3 && t < 1e4 && t < best.0 {
                    best = (t, k as u32);
                }
            }
            best.1
        })
        .collect();

    let init = |contents: &[u8], usage| {
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: None, contents, usage })
    };
    let aabbs = init(bytemuck::cast_slice(&boxes), wgpu::BufferUsages::BLAS_INPUT);
    let size = wgpu::BlasAABBGeometrySizeDescriptor {
        primitive_count: n as u32,
        flags: wgpu::AccelerationStructureGeometryFlags::OPAQUE,
    };
    let trace = wgpu::AccelerationStructureFlags::PREFER_FAST_TRACE;
    let build = wgpu::AccelerationStructureUpdateMode::Build;
    let blas = device.create_blas(
        &wgpu::CreateBlasDescriptor { label: None, flags: trace, update_mode: build },
        wgpu::BlasGeometrySizeDescriptors::AABBs { descriptors: vec![size.clone()] },
    );
    let mut tlas = device.create_tlas(&wgpu::CreateTlasDescriptor {
        label: None,
        max_instances: 1,
        flags: trace,
        update_mode: build,
    });
    tlas[0] = Some(wgpu::TlasInstance::new(
        &blas,
        [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0],
        0,
        0xff,
    ));
    let geometry =
        wgpu::BlasAabbGeometry { size: &size, stride: 24, aabb_buffer: &aabbs, primitive_offset: 0 };
    let entry =
        wgpu::BlasBuildEntry { blas: &blas, geometry: wgpu::BlasGeometries::AabbGeometries(vec![geometry]) };
    let mut enc = device.create_command_encoder(&Default::default());
    enc.build_acceleration_structures([&entry], [&tlas]);
    queue.submit([enc.finish()]);

    static LOST: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);
    device.set_device_lost_callback(|reason, message| {
        println!("device lost ({reason:?}): {message}");
        LOST.store(true, std::sync::atomic::Ordering::Relaxed);
    });
    let source = if flag("--in-loop") { IN_LOOP } else { KERNEL };
    let invalid = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let desc = wgpu::ShaderModuleDescriptor { label: None, source: wgpu::ShaderSource::Wgsl(source.into()) };
    let module = if flag("--unchecked") {
        let checks = wgpu::ShaderRuntimeChecks {
            ray_query_initialization_tracking: false,
            ..wgpu::ShaderRuntimeChecks::checked()
        };
        // SAFETY: every RayDesc above is valid and each generated t lies within the query's
        // limits, which is what the dropped checks would have ensured.
        unsafe { device.create_shader_module_trusted(desc, checks) }
    } else {
        device.create_shader_module(desc)
    };
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: None,
        layout: None,
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    if let Some(e) = pollster::block_on(invalid.pop()) {
        println!("the kernel was refused: {e}");
        return;
    }
    let _ = device.poll(wgpu::PollType::Poll);
    if LOST.load(std::sync::atomic::Ordering::Relaxed) {
        return;
    }
    let bytes = (RAYS * 16) as u64;
    let out = device.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size: bytes,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let read = device.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size: bytes,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let sphere_buf = init(bytemuck::cast_slice(&spheres), wgpu::BufferUsages::STORAGE);
    let ray_buf = init(bytemuck::cast_slice(&rays), wgpu::BufferUsages::STORAGE);
    for commit in [0u32, 1] {
        let mode =
            init(bytemuck::cast_slice(&[commit, arg("--after").unwrap_or(0)]), wgpu::BufferUsages::STORAGE);
        let mut entries = vec![
            wgpu::BindGroupEntry { binding: 0, resource: tlas.as_binding() },
            wgpu::BindGroupEntry { binding: 2, resource: out.as_entire_binding() },
        ];
        if !flag("--in-loop") {
            for (binding, b) in [(1, &sphere_buf), (3, &mode), (4, &ray_buf)] {
                entries.push(wgpu::BindGroupEntry { binding, resource: b.as_entire_binding() });
            }
        }
        let layout = pipeline.get_bind_group_layout(0);
        let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &layout,
            entries: &entries,
        });
        let mut enc = device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &bind, &[]);
            pass.dispatch_workgroups((RAYS / 64) as u32, 1, 1);
        }
        enc.copy_buffer_to_buffer(&out, 0, &read, 0, bytes);
        queue.submit([enc.finish()]);
        read.slice(..).map_async(wgpu::MapMode::Read, |_| {});
        device.poll(wgpu::PollType::Wait { submission_index: None, timeout: None }).expect("the queue");
        let v: Vec<[f32; 4]> =
            bytemuck::cast_slice(&read.slice(..).get_mapped_range().expect("mapped")).to_vec();
        read.unmap();
        if flag("--in-loop") {
            println!("in-loop kernel: ray 0 counted {}", v[0][0]);
            return;
        }
        let wrong = (0..RAYS)
            .filter(|&i| v[i][0] as u32 != expect[i] && !(expect[i] == u32::MAX && v[i][0] > 4e9))
            .count();
        let mean = v.iter().map(|r| r[2] as f64).sum::<f64>() / RAYS as f64;
        println!(
            "{}: {wrong} of {RAYS} rays disagree with brute force; {mean:.2} candidates a ray (ray 0: {}); the loop after ran {} times",
            if commit == 1 { "committing nearer hits" } else { "no commits" },
            v[0][2],
            v[0][3]
        );
    }
}
