//! The platform's ray queries and the register form of the kernels give the bytes of brute
//! force's wavefront: `--accel rayquery` (every ray) and `cube` with `--surface-walk
//! rayquery` (the rays leaving surfaces), and the tables with the BVH in `--kernel-form
//! tree` (in f32 and f64; the hard cases and maps scenes in f32), with the same ray counts, on the SPD
//! databases at size 1, DamagedHelmet under the studio environment (whose sixteen directional
//! lights send every shadow ray to the ray queries), every scene in `scenes/hard/`, and the
//! project's maps scenes (alpha mask and blend included).
//!
//! They need an adapter with ray queries: a GPU with ray tracing, or Mesa's lavapipe from 24.1
//! on, which also has no loop limit, so that it runs the tree form. On Debian 12, whose Mesa
//! 22.3 has neither, `bash .ci/setup` unpacks bookworm-backports' Mesa into
//! `target/lavapipe-rq` beside the system's (`.ci/lavapipe-rq.sh`). Each test here
//! runs its renders in a child process of this test binary (the ignored tests of `child`)
//! whose Vulkan loader that file's variables point at that lavapipe; elsewhere the child uses
//! the system's driver. A child that finds no ray queries fails, saying how to get them.

use std::path::{Path, PathBuf};

use cuberay::gpu::GpuRenderer;
use cuberay::job::{Accel, KernelForm, Precision, RenderOptions, SurfaceWalk};
use cuberay::load;
use cuberay::scene::Scene;

use crate::common::{first_difference, hard, save_failure, shared};

/// Runs the ignored test `child::NAME` in a process with the ray-query lavapipe's variables
/// (`target/lavapipe-rq/env`, or the file `$CUBERAY_RQ_ENV` names), and fails with its
/// output unless it ran and passed.
fn in_ray_query_process(name: &str) {
    let (env, vars) = ray_query_driver();
    let mut c = std::process::Command::new(std::env::current_exe().expect("the test binary"));
    c.args([&format!("rayquery::child::{name}"), "--exact", "--ignored", "--nocapture", "--test-threads=1"]);
    c.envs(vars);
    let out = c.output().expect("the test binary runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    let tail = |s: &str| {
        s.lines().rev().take(40).collect::<Vec<_>>().into_iter().rev().collect::<Vec<_>>().join("\n")
    };
    assert!(
        out.status.success() && stdout.contains("test result: ok. 1 passed"),
        "child::{name} (driver variables from {}{}) did not pass:\n{}\n{}",
        env.display(),
        if env.exists() { "" } else { ": absent, the system's driver" },
        tail(&stdout),
        tail(&stderr)
    );
}

/// The file of the ray-query lavapipe's variables (`target/lavapipe-rq/env`, or the file
/// `$CUBERAY_RQ_ENV` names) and its variables (none where it is absent: the system's driver).
pub fn ray_query_driver() -> (PathBuf, Vec<(String, String)>) {
    let env = std::env::var_os("CUBERAY_RQ_ENV")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("target/lavapipe-rq/env"));
    let text = std::fs::read_to_string(&env).unwrap_or_default();
    let vars = text.lines().filter_map(|l| l.split_once('=')).map(|(k, v)| (k.into(), v.into())).collect();
    (env, vars)
}

/// This process's adapter, which must have ray queries.
fn rq_renderer() -> GpuRenderer {
    let r = GpuRenderer::new().unwrap_or_else(|e| panic!("{e}"));
    assert!(
        r.ctx.ray_queries,
        "{} ({}) has no ray queries: these tests need a GPU with ray tracing or Mesa's lavapipe from 24.1 on; \
         on Debian 12, `bash .ci/setup` unpacks bookworm-backports' into target/lavapipe-rq",
        r.ctx.info.name,
        r.ctx.info.driver_info
    );
    r
}

/// A scene file with the default set-up (a glTF model without lights gets the studio).
fn scene(path: &Path) -> Scene {
    let mut loaded =
        load::load(path, &Default::default()).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    load::apply_setup(&mut loaded, path, &Default::default())
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    loaded.scene
}

/// Renders `scene` at `size`² by brute force in the wavefront form, with ray queries (every
/// ray, and in f32 the rays leaving surfaces under the tables) and with the tables and the
/// BVH in the tree form, in f32 and f64, and returns every difference: a pixel's bits, a ray
/// count, or the form or walk a render says it took. (The BVH and the tables give brute
/// force's bytes in the wavefront form in `gpu::accels::accels_match_brute_force` and its
/// kin, on the system's driver; the tree form's one loop is the same whatever the
/// accelerator, and `matrix` renders it with each in every command. Each further
/// accelerator here would cost a cold compile of its kernels on CI's first run.)
fn differences(r: &GpuRenderer, name: &str, scene: &Scene, size: u32, tree_f64: bool) -> Vec<String> {
    use KernelForm::{Tree, Wavefront};
    let mut found = Vec::new();
    for precision in [Precision::F32, Precision::F64] {
        let render = |accel, surface, form| {
            let opts = RenderOptions { accel, surface, precision, form, ..RenderOptions::new(size, size) };
            r.render(scene, &opts, &indicatif::ProgressBar::hidden())
                .unwrap_or_else(|e| panic!("{name}: {e}"))
        };
        let brute = render(Accel::Brute, SurfaceWalk::Bvh, Wavefront);
        let mut others = vec![("rayquery", Accel::RayQuery, SurfaceWalk::Bvh, Wavefront)];
        if precision == Precision::F32 || tree_f64 {
            others.push(("cube with the BVH", Accel::Cube, SurfaceWalk::Bvh, Tree));
        }
        if precision == Precision::F32 {
            others.push(("cube with ray queries", Accel::Cube, SurfaceWalk::RayQuery, Wavefront));
        }
        for (label, accel, surface, form) in others {
            let a = render(accel, surface, form);
            let what = format!("{name} {}, {label}, {} form", precision.name(), form.name());
            if a.stats.settings.kernel_form.as_deref() != Some(form.name()) {
                found.push(format!("{what}: the kernels say {:?}", a.stats.settings.kernel_form));
            }
            let expect_surface = (accel == Accel::Cube && a.stats.rays.reflect + a.stats.rays.refract > 0)
                .then(|| surface.name().to_string());
            if accel == Accel::Cube
                && expect_surface.is_some()
                && a.stats.settings.surface_walk != expect_surface
            {
                found.push(format!("{what}: rays leaving surfaces took {:?}", a.stats.settings.surface_walk));
            }
            let (ra, rb) = (a.stats.rays, brute.stats.rays);
            let counts = |s: &cuberay::stats::RayStats| {
                (s.eye, s.eye_hit, s.reflect, s.refract, s.shadow, s.shadow_blocked)
            };
            if counts(&ra) != counts(&rb) {
                found.push(format!(
                    "{what}: ray counts (eye, hits, reflect, refract, shadow, blocked) {:?}, brute force {:?}",
                    counts(&ra),
                    counts(&rb)
                ));
            }
            if let Some((x, y, p, q)) = first_difference(&a.image, &brute.image) {
                let files = save_failure(&what, &[(label, &a.image), ("brute", &brute.image)], None);
                found.push(format!("{what}: pixel ({x}, {y}) {p:?}, brute force {q:?}; images: {files}"));
            }
        }
    }
    found
}

/// Fails listing every difference of every scene in `scenes` (the tree form in f64 too
/// where `tree_f64`: its f64 kernels are large, and each compiles cold in seconds on CI).
fn assert_identical(scenes: &[(String, Scene)], size: u32, tree_f64: bool) {
    let r = rq_renderer();
    let mut found = Vec::new();
    for (name, s) in scenes {
        let d = differences(&r, name, s, size, tree_f64);
        eprintln!("{name}: {}", if d.is_empty() { "identical" } else { "DIFFERS" });
        found.extend(d);
    }
    assert!(found.is_empty(), "{} differences:\n{}", found.len(), found.join("\n"));
}

/// The files of `dir` with extension `ext` (sorted).
fn files(dir: &Path, ext: &[&str]) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("a folder entry").path())
        .filter(|p| p.extension().and_then(|e| e.to_str()).is_some_and(|e| ext.contains(&e)))
        .collect();
    v.sort();
    v
}

fn named(paths: impl IntoIterator<Item = PathBuf>) -> Vec<(String, Scene)> {
    paths.into_iter().map(|p| (p.file_name().unwrap().to_string_lossy().into_owned(), scene(&p))).collect()
}

#[test]
fn spd_size_1_is_brute_force_with_ray_queries() {
    in_ray_query_process("spd");
}

#[test]
fn the_helmet_in_the_studio_is_brute_force_with_ray_queries() {
    in_ray_query_process("helmet");
}

#[test]
fn the_hard_cases_are_brute_force_with_ray_queries() {
    in_ray_query_process("hard");
}

#[test]
fn the_maps_scenes_are_brute_force_with_ray_queries() {
    in_ray_query_process("maps");
}

/// `--accel rayquery` on an adapter without ray queries (this process's: on Debian 12 the
/// system's Mesa 22.3) is refused naming the adapter and what would provide them; with them,
/// it renders. Either way `cube` renders.
#[test]
fn rayquery_is_refused_clearly_where_the_adapter_has_none() {
    let r = crate::common::renderer();
    let s = scene(&hard("parallel_mirrors.nff"));
    let opts = |accel, surface| RenderOptions { accel, surface, ..RenderOptions::new(16, 16) };
    for (accel, surface, flag) in [
        (Accel::RayQuery, SurfaceWalk::Auto, "--accel rayquery"),
        (Accel::Cube, SurfaceWalk::RayQuery, "--surface-walk rayquery"),
    ] {
        let got = r.render(&s, &opts(accel, surface), &indicatif::ProgressBar::hidden());
        match (&got, r.ctx.ray_queries) {
            (Err(e), false) => {
                let e = e.to_string();
                assert!(e.contains(flag) && e.contains(&r.ctx.info.name) && e.contains("24.1"), "{e}");
            }
            (Ok(_), true) => {}
            (got, has) => panic!("{flag} on an adapter with ray queries {has}: {:?}", got.as_ref().err()),
        }
    }
    let cube =
        r.render(&s, &opts(Accel::Cube, SurfaceWalk::Auto), &indicatif::ProgressBar::hidden()).unwrap();
    let walked = cube.stats.settings.surface_walk.as_deref();
    assert!(walked == Some("bvh") || (r.ctx.ray_queries && walked == Some("rayquery")), "{walked:?}");
}

/// `--kernel-form tree` on a driver that ends long loops (this process's: on Debian 12 the
/// system's Mesa 22.3) is refused naming the adapter, the limit and what to use instead, and
/// `auto` takes the wavefront there; on a driver without the limit both forms render, to
/// the same bytes.
#[test]
fn the_tree_form_is_refused_clearly_where_the_driver_limits_loops() {
    let r = crate::common::renderer();
    let s = scene(&hard("parallel_mirrors.nff"));
    let render = |form| {
        let opts = RenderOptions { form, ..RenderOptions::new(16, 16) };
        r.render(&s, &opts, &indicatif::ProgressBar::hidden())
    };
    let auto = render(KernelForm::Auto).unwrap();
    let tree = render(KernelForm::Tree);
    if cuberay::gpu::choose::loop_limited(&r.caps) {
        let e = tree.err().expect("the tree form is refused").to_string();
        assert!(
            e.contains("--kernel-form tree") && e.contains(&r.ctx.info.name) && e.contains("65535"),
            "{e}"
        );
        assert_eq!(auto.stats.settings.kernel_form.as_deref(), Some("wavefront"));
    } else {
        let tree = tree.unwrap();
        let wavefront = render(KernelForm::Wavefront).unwrap();
        assert_eq!(tree.stats.settings.kernel_form.as_deref(), Some("tree"));
        assert!(first_difference(&tree.image, &wavefront.image).is_none(), "the forms' images differ");
    }
}

/// The renders, each in a process whose adapter has ray queries (see the module doc); ignored
/// on their own.
mod child {
    use super::*;

    #[test]
    #[ignore = "run by rayquery::spd_size_1_is_brute_force_with_ray_queries with a lavapipe that has ray queries"]
    fn spd() {
        let dbs = [
            "balls", "gears", "jacks", "lattice", "mount", "rings", "shells", "sombrero", "teapot", "tetra",
            "tree",
        ];
        assert_identical(&named(dbs.map(|db| shared(&format!("spd/nff/{db}_s1.nff")))), 128, true);
    }

    #[test]
    #[ignore = "run by rayquery::the_helmet_in_the_studio_is_brute_force_with_ray_queries"]
    fn helmet() {
        let scenes = named([shared("gltf/DamagedHelmet/DamagedHelmet.gltf")]);
        assert!(scenes[0].1.environment.is_some(), "the helmet gets the studio environment");
        assert_identical(&scenes, 32, true);
    }

    #[test]
    #[ignore = "run by rayquery::the_hard_cases_are_brute_force_with_ray_queries"]
    fn hard() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/hard");
        let scenes = named(files(&dir, &["nff", "gltf"]));
        assert!(scenes.len() >= 20, "{} hard cases", scenes.len());
        assert_identical(&scenes, 32, false);
    }

    #[test]
    #[ignore = "run by rayquery::the_maps_scenes_are_brute_force_with_ray_queries"]
    fn maps() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
        let mut paths = files(&dir, &["gltf"]);
        paths.push(dir.join("showcase.nff"));
        let mut scenes = named(paths);
        // The masked checker blended instead (as
        // gpu::closed_forms::alpha_blend_lets_one_minus_alpha_through): pass-through rays, and
        // shadow rays that test its alpha.
        let mut blended = scene(&dir.join("alpha_mask.gltf"));
        blended.materials[0].alpha = cuberay::scene::Alpha::Blend;
        blended.materials[0].opacity = 0.6;
        scenes.push(("alpha_mask.gltf blended".into(), blended));
        let blend = scenes.iter().any(|(_, s)| s.effects().blend);
        let alpha = scenes.iter().any(|(_, s)| s.effects().alpha);
        assert!(blend && alpha, "the maps scenes hold a blend and an alpha mask");
        assert_identical(&scenes, 40, false);
    }
}
