//! How the renderer uses the device: kernels compiled once per effect set, an uncounted
//! render equal to the counted one, memory that stays flat over a long render, a lost
//! device, the first dispatch timed apart from the kernel time.

use crate::common::renderer;
use cuberay::gpu::GpuRenderer;
use cuberay::job::RenderOptions;
use cuberay::output::Aov;
use cuberay::sampling::Sampling;

use super::{hidden, showcase};

#[test]
fn kernels_are_compiled_once_per_effect_set() {
    let r = GpuRenderer::new().unwrap_or_else(|e| panic!("{e}"));
    let scene = showcase();
    // The tables, whatever `auto` would choose for so small an image.
    let opts = RenderOptions { accel: cuberay::job::Accel::Cube, ..RenderOptions::new(8, 6) };
    r.render(&scene, &opts, &hidden()).unwrap();
    r.render(&scene, &opts, &hidden()).unwrap();
    // The wavefront's kernels: nearest for the eye's depth and for the later ones (whose
    // rays walk the BVH), shade, shadow (the showcase has shadows), resolve.
    assert_eq!(r.compiled_kernels(), 5);
    // The AOV pass traces eye rays only: a module (and tables) without effects.
    r.render_aov(&scene, &opts, Aov::Id, &hidden()).unwrap();
    r.render_aov(&scene, &opts, Aov::Depth, &hidden()).unwrap();
    assert_eq!(r.compiled_kernels(), 6);
    // Depth 1 needs neither reflection nor refraction: other modules of the kernels that
    // trace, one nearest for its one depth (`resolve` traces nothing: one module of it
    // serves every variant).
    let shallow = RenderOptions { max_depth: 1, ..opts.clone() };
    r.render(&scene, &shallow, &hidden()).unwrap();
    assert_eq!(r.compiled_kernels(), 9);
}

#[test]
fn an_uncounted_render_is_the_counted_one_without_its_counts() {
    // The showcase has mirrors, glass and shadows: every kind of ray, every counter.
    let scene = showcase();
    let counted = RenderOptions { sampling: Sampling::Corners, ..RenderOptions::new(24, 18) };
    let uncounted = RenderOptions { count: false, ..counted.clone() };
    let a = renderer().render(&scene, &counted, &hidden()).unwrap();
    let b = renderer().render(&scene, &uncounted, &hidden()).unwrap();
    assert_eq!(a.image.pixels, b.image.pixels, "counting changed the image");
    let (ca, cb) = (a.stats.counters, b.stats.counters);
    assert!(ca.rays.iter().all(|&r| r > 0), "a counted render counts every kind of ray: {ca:?}");
    assert!(ca.tests.iter().all(|t| t.total() > 0), "and tests for each: {ca:?}");
    assert_eq!(cb, cuberay::stats::Counters::default(), "an uncounted render counts nothing");
    // And says so, rather than reporting zeros.
    assert!(a.stats.counted && !b.stats.counted);
    assert!(b.stats.to_text().contains("not counted") && !b.stats.to_text().contains("per ray"));
}

/// A long render's memory does not grow with its length: `cuberay render` is sampled while
/// it traces tetra_s6 by brute force (256² or, where that ends within 3 s, a bigger image:
/// dozens of kernel passes over many tiles), and its resident memory over the last tenth of the run stays within 15% of the second tenth.
/// (With the kernel parameters in a uniform buffer, lavapipe compiled a kernel variant per
/// tile and kept them all: this render grew from 110 to 210 MB.) A small render of the same
/// kernel first compiles it, so that the one-time compilation (lavapipe compiles at the first
/// dispatch, and caches on disk) is not mistaken for growth.
#[test]
fn a_long_render_keeps_its_memory_flat() {
    let dir = tempfile::tempdir().unwrap();
    let render = |size: &str| {
        let mut c = crate::common::cuberay();
        c.args(["render", "--accel", "brute", "--width", size, "--height", size, "-o"])
            .arg(dir.path().join("long.png"))
            .arg(crate::common::shared("spd/nff/tetra_s6.nff"))
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null());
        c
    };
    assert!(render("8").status().unwrap().success(), "the warm-up render failed");
    // Sampled every 100 ms, the render must last at least 3 s to be judged: a faster machine
    // (or a faster kernel) renders a bigger image rather than passing on too few samples.
    let sample = |size: &str| {
        let mut child = render(size).spawn().unwrap();
        let status = format!("/proc/{}/status", child.id());
        let mut rss_kib = Vec::new();
        while child.try_wait().unwrap().is_none() {
            if let Some(kib) = std::fs::read_to_string(&status).ok().and_then(|s| {
                s.lines().find(|l| l.starts_with("VmRSS:"))?.split_whitespace().nth(1)?.parse::<u64>().ok()
            }) {
                rss_kib.push(kib);
            }
            std::thread::sleep(std::time::Duration::from_millis(100));
        }
        assert!(child.wait().unwrap().success(), "the {size}² render failed");
        rss_kib
    };
    let mut rss_kib = Vec::new();
    for size in ["256", "384", "576", "864"] {
        rss_kib = sample(size);
        if rss_kib.len() >= 30 {
            break;
        }
        eprintln!("a {size}² render took only {} samples of 100 ms: rendering a bigger one", rss_kib.len());
    }
    let n = rss_kib.len();
    assert!(n >= 30, "the render took only {n} samples of 100 ms: too short to judge; make it longer");
    let mean = |a: usize, b: usize| rss_kib[a..b].iter().sum::<u64>() as f64 / (b - a) as f64;
    let (second, last) = (mean(n / 10, 2 * n / 10), mean(9 * n / 10, n));
    eprintln!(
        "resident memory: second tenth {:.0} MiB, last tenth {:.0} MiB ({n} samples)",
        second / 1024.0,
        last / 1024.0
    );
    assert!(last <= 1.15 * second, "memory grew from {:.0} to {:.0} MiB", second / 1024.0, last / 1024.0);
}

/// A device that is gone ends a render with an error that says so: no hang, no panic.
#[test]
fn a_lost_device_ends_the_render_with_an_error() {
    let r = GpuRenderer::new().unwrap_or_else(|e| panic!("{e}"));
    r.ctx.device.destroy();
    let e = r.render(&showcase(), &RenderOptions::new(16, 12), &hidden()).err().expect("an error");
    eprintln!("{e}");
    assert!(matches!(e, cuberay::Error::Gpu(_)), "{e:?}");
}

/// Compilation at first dispatch is timed apart from the kernel time: the first render of a
/// kernel warms it up once (a dispatch over no points), later renders in the process do not;
/// both report the longest submission.
#[test]
fn the_first_dispatch_is_timed_apart_from_the_kernel_time() {
    let r = GpuRenderer::new().unwrap_or_else(|e| panic!("{e}"));
    let opts = RenderOptions::new(16, 12);
    let first = r.render(&showcase(), &opts, &hidden()).unwrap().stats.time;
    let second = r.render(&showcase(), &opts, &hidden()).unwrap().stats.time;
    eprintln!("first {first:?}\nsecond {second:?}");
    assert!(first.compile_s.is_some_and(|c| c > 0.0), "{first:?}");
    assert_eq!(second.compile_s, Some(0.0));
    for t in [&first, &second] {
        let longest = t.longest_submit_s.expect("longest submission");
        assert!(longest > 0.0 && longest <= t.trace_s, "{t:?}");
    }
}
