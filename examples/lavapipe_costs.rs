//! What a driver charges a compute kernel for the operations the wavefront's state traffic is
//! made of, measured apart from cuberay's kernels (issue 55's accounting; docs/performance.md,
//! "What lavapipe charges"). Each case is a kernel of 2²⁰ invocations (workgroups of 64) that
//! runs one operation 64 times in a loop and writes one word; its time less that of the bare
//! loop, over the 2²⁶ operations, is what the operation costs an invocation:
//!
//! - `uniform load`: a storage load whose address is the same in every lane;
//! - `varying load`: a storage load whose address differs per lane (a job's field);
//! - `varying store`: a storage store whose address differs per lane;
//! - `atomic`: an `atomicAdd` per lane (a queue append, a radiance add);
//! - `if, never taken`: a 16-multiply body behind a condition no lane meets (a rare path);
//! - `if, always taken`: the same body, every lane taking it (the body's own cost);
//! - `dispatch`: one more dispatch of one workgroup (a pass), timed over 2000 in one
//!   submission.
//!
//! ```sh
//! cargo run --release --example lavapipe_costs                      # the adapter found first
//! ( eval "$(../shared/tools/newer-lavapipe.sh target/mesa25)"; cargo run --release --example lavapipe_costs )
//! ```
//!
//! Timings on lavapipe vary by tens of percent between runs: each case is the median of 7
//! runs after a warm-up, and the loop it is compared with is timed in the same rounds.

use std::time::Instant;

use wgpu::util::DeviceExt;

const INVOCATIONS: u32 = 1 << 20;
const REPEATS: u32 = 64;
const RUNS: usize = 7;
const DISPATCHES: u32 = 2000;

/// The kernel around one case's loop body (`BODY`, which updates `acc` using `k`).
const TEMPLATE: &str = r#"
@group(0) @binding(0) var<storage, read> data: array<u32>;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;
@group(0) @binding(2) var<storage, read_write> counters: array<atomic<u32>, 64>;
@group(0) @binding(3) var<storage, read_write> scratch: array<u32>;

fn heavy(x: u32) -> u32 {
    var a = x;
    for (var i = 0u; i < 16u; i++) {
        a = a * 1103515245u + 12345u;
    }
    return a;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let g = gid.x;
    // Never met: data[1] is larger than any k (the driver cannot know it).
    let never = data[1];
    var acc = g;
    for (var k = 0u; k < 64u; k++) {
        BODY
    }
    out[g] = acc;
}
"#;

/// The cases: name and loop body.
const CASES: &[(&str, &str)] = &[
    ("loop", "acc = acc * 1664525u + k;"),
    ("uniform load", "acc = acc * 1664525u + data[k];"),
    ("varying load", "acc = acc * 1664525u + data[(g * 64u + k) & 0xfffffu];"),
    ("varying store", "acc = acc * 1664525u + k; scratch[(g * 64u + k) & 0xfffffu] = acc;"),
    ("atomic", "acc = acc * 1664525u + atomicAdd(&counters[k], 1u);"),
    ("if, never taken", "acc = acc * 1664525u + k; if k == never { acc = heavy(acc); }"),
    ("if, always taken", "acc = acc * 1664525u + k; if k != never { acc = heavy(acc); }"),
];

/// A compiled case and its bind group.
struct Case {
    name: &'static str,
    pipeline: wgpu::ComputePipeline,
    bind: wgpu::BindGroup,
}

fn main() {
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    let adapter =
        pollster::block_on(instance.request_adapter(&Default::default())).expect("a Vulkan adapter");
    let info = adapter.get_info();
    println!("{} ({}), {:?}", info.name, info.driver_info, info.device_type);
    let (device, queue) = pollster::block_on(adapter.request_device(&Default::default())).expect("a device");
    let init = |contents: &[u8]| {
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: None,
            contents,
            usage: wgpu::BufferUsages::STORAGE,
        })
    };
    let mut words: Vec<u32> = (0..INVOCATIONS).map(|i| i.wrapping_mul(2654435761)).collect();
    words[1] = 1000;
    let data = init(bytemuck::cast_slice(&words));
    let out = init(&vec![0u8; 4 * INVOCATIONS as usize]);
    let counters = init(&[0u8; 4 * 64]);
    let scratch = init(&vec![0u8; 4 * INVOCATIONS as usize]);

    let cases: Vec<Case> = CASES
        .iter()
        .map(|&(name, body)| {
            let source = TEMPLATE.replace("BODY", body);
            let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(name),
                source: wgpu::ShaderSource::Wgsl(source.into()),
            });
            let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(name),
                layout: None,
                module: &module,
                entry_point: Some("main"),
                compilation_options: Default::default(),
                cache: None,
            });
            // Bind only what the kernel uses (an automatic layout leaves the rest out).
            let used: Vec<(u32, &wgpu::Buffer)> = [(0, &data), (1, &out), (2, &counters), (3, &scratch)]
                .into_iter()
                .filter(|&(b, _)| match b {
                    2 => body.contains("atomic"),
                    3 => body.contains("scratch"),
                    _ => true,
                })
                .collect();
            let entries: Vec<wgpu::BindGroupEntry> = used
                .iter()
                .map(|&(binding, buffer)| wgpu::BindGroupEntry {
                    binding,
                    resource: buffer.as_entire_binding(),
                })
                .collect();
            let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: None,
                layout: &pipeline.get_bind_group_layout(0),
                entries: &entries,
            });
            Case { name, pipeline, bind }
        })
        .collect();

    // Runs `dispatches` dispatches of `groups` workgroups of `case` in one submission and
    // waits for them: the wall-clock seconds.
    let time = |case: &Case, groups: u32, dispatches: u32| -> f64 {
        let mut encoder = device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(&case.pipeline);
            pass.set_bind_group(0, &case.bind, &[]);
            for _ in 0..dispatches {
                pass.dispatch_workgroups(groups, 1, 1);
            }
        }
        let start = Instant::now();
        queue.submit([encoder.finish()]);
        device.poll(wgpu::PollType::Wait { submission_index: None, timeout: None }).expect("the queue");
        start.elapsed().as_secs_f64()
    };
    let groups = INVOCATIONS / 64;
    for case in &cases {
        time(case, groups, 1);
    }
    // Rounds over every case, so that a machine slowing down meets all of them alike.
    let mut seconds = vec![Vec::new(); cases.len()];
    let mut dispatch = Vec::new();
    for _ in 0..RUNS {
        for (i, case) in cases.iter().enumerate() {
            seconds[i].push(time(case, groups, 1));
        }
        let one = time(&cases[0], 1, 1);
        dispatch.push((time(&cases[0], 1, DISPATCHES) - one) / (DISPATCHES - 1) as f64);
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let base = median(&mut seconds[0].clone());
    let ops = INVOCATIONS as f64 * REPEATS as f64;
    println!("| case | kernel s (median of {RUNS}) | ns an operation an invocation, over the loop |");
    println!("|---|---|---|");
    for (case, s) in cases.iter().zip(&mut seconds) {
        let t = median(s);
        let extra = if case.name == "loop" { t / ops * 1e9 } else { (t - base) / ops * 1e9 };
        println!("| {} | {t:.4} | {extra:.3} |", case.name);
    }
    println!("| dispatch (1 workgroup) | | {:.0} µs a dispatch |", median(&mut dispatch) * 1e6);
}
