//! The composed WGSL modules, checked with naga (no GPU needed): every kernel in every
//! effect variant validates, and code paths a scene does not call for are absent from its
//! module. (The twins of the shared structs and constants are checked in `twins.rs`.)

use cuberay::gpu::shaders::{compose, Accel, Kernel, Variant};
use cuberay::job::{KernelForm, RenderOptions};
use cuberay::load;
use cuberay::scene::Shapes;
use naga::valid::{Capabilities, ValidationFlags, Validator};

fn module_of(k: Kernel, v: Variant) -> naga::Module {
    let src = compose(k, v).unwrap_or_else(|e| panic!("{k:?} {v:?}: {e}"));
    naga::front::wgsl::parse_str(&src).unwrap_or_else(|e| panic!("{k:?} {v:?}: {}", e.emit_to_string(&src)))
}

/// The modules of the kernels that trace and shade a render of variant `v` in either form
/// (`nearest`, `shade` and, with shadows, `shadow`; `tree`).
struct Wavefront(Vec<naga::Module>);

fn module(v: Variant) -> Wavefront {
    Wavefront(
        Kernel::wavefront(v)
            .into_iter()
            .chain(Kernel::traced(KernelForm::Tree, v, false))
            .filter(|s| s.kernel != Kernel::Resolve)
            .map(|s| module_of(s.kernel, s.variant(v)))
            .collect(),
    )
}

/// Whether any type of `m` is (or holds) a 64-bit float.
fn has_f64(m: &Wavefront) -> bool {
    let f64 = |s: naga::Scalar| s.kind == naga::ScalarKind::Float && s.width == 8;
    m.0.iter().flat_map(|m| m.types.iter()).any(|(_, t)| match t.inner {
        naga::TypeInner::Scalar(s) | naga::TypeInner::Vector { scalar: s, .. } => f64(s),
        _ => false,
    })
}

fn defines(m: &naga::Module, name: &str) -> bool {
    m.functions.iter().any(|(_, f)| f.name.as_deref() == Some(name))
}

/// Whether any of the kernels defines function `name`.
fn has_function(m: &Wavefront, name: &str) -> bool {
    m.0.iter().any(|m| defines(m, name))
}

#[test]
fn every_kernel_and_variant_validates() {
    for v in Variant::all() {
        // A render runs the shadow kernel only with shadows.
        let wavefront = Kernel::wavefront(v);
        assert_eq!(wavefront.iter().any(|s| s.kernel == Kernel::Shadow), v.effects.shadows, "{v:?}");
        // Each depth's passes have one `nearest`.
        for depth in 1..=3 {
            let n = wavefront.iter().filter(|s| s.kernel == Kernel::Nearest && s.serves(depth)).count();
            assert_eq!(n, 1, "{v:?}: depth {depth}");
        }
        let stages = wavefront.into_iter().map(|s| (s.kernel, s.variant(v)));
        for (k, v) in stages.chain([(Kernel::Aov, v), (Kernel::Tree, v)]) {
            let m = module_of(k, v);
            let mut caps = Capabilities::default();
            caps.set(Capabilities::FLOAT64, v.f64);
            caps.set(Capabilities::RAY_QUERY, v.ray_queries());
            Validator::new(ValidationFlags::all(), caps)
                .validate(&m)
                .unwrap_or_else(|e| panic!("{k:?} {v:?}: {e:?}"));
            // The kernel's file, entry point and pipeline share its name.
            let names: Vec<&str> = m.entry_points.iter().map(|e| e.name.as_str()).collect();
            assert_eq!(names, [k.name()], "{k:?} {v:?}");
        }
    }
    let accumulate = module_of(Kernel::Accumulate, Variant::default());
    let display = module_of(Kernel::Display, Variant::default());
    for (k, m) in [(Kernel::Accumulate, &accumulate), (Kernel::Display, &display)] {
        Validator::new(ValidationFlags::all(), Capabilities::default())
            .validate(m)
            .unwrap_or_else(|e| panic!("{k:?}: {e:?}"));
    }
    assert_eq!(accumulate.entry_points.iter().map(|e| e.name.as_str()).collect::<Vec<_>>(), ["accumulate"]);
    assert_eq!(
        display.entry_points.iter().map(|e| e.name.as_str()).collect::<Vec<_>>(),
        ["vs_main", "fs_main"]
    );
}

#[test]
fn variant_functions_follow_the_flags() {
    for v in Variant::all() {
        // `nearest` only traces: the shading is `shade`'s, over hits only.
        let nearest = module_of(Kernel::Nearest, v);
        for f in [
            "shade_hit",
            "shade_local",
            "light_term",
            "reflect_dir",
            "refract_dir",
            "whitted",
            "mapped_normal",
        ] {
            assert!(!defines(&nearest, f), "{v:?}: nearest defines {f}");
        }
        // A walk samples textures only to test alpha.
        assert_eq!(
            defines(&nearest, "sample_texture"),
            (v.effects.alpha || v.effects.blend) && v.effects.textures,
            "{v:?}"
        );
        assert!(defines(&module_of(Kernel::Shade, v), "shade_hit"), "{v:?}");
        let m = module(v);
        assert_eq!(has_function(&m, "reflect_dir"), v.effects.reflection, "{v:?}");
        assert_eq!(has_function(&m, "refract_dir"), v.effects.refraction, "{v:?}");
        assert_eq!(has_function(&m, "sample_texture"), v.effects.textures, "{v:?}");
        assert_eq!(has_function(&m, "whitted"), v.effects.maps, "{v:?}");
        assert_eq!(has_function(&m, "mapped_normal"), v.effects.normal_maps, "{v:?}");
        assert_eq!(has_function(&m, "alpha_passes"), v.effects.alpha || v.effects.blend, "{v:?}");
        assert_eq!(has_f64(&m), v.f64, "{v:?}: f64 only in the f64 variant");
        assert_eq!(has_function(&m, "occluded_short"), v.effects.shadows, "{v:?}");
        assert_eq!(has_function(&m, "trace_shadow"), v.effects.shadows, "{v:?}");
        // Intersection code only for the kinds of primitive the scene holds.
        assert_eq!(has_function(&m, "intersect_sphere"), v.shapes.spheres, "{v:?}");
        assert_eq!(has_function(&m, "intersect_triangle"), v.shapes.triangles, "{v:?}");
        assert_eq!(has_function(&m, "intersect_cylinder"), v.shapes.cylinders, "{v:?}");
        assert_eq!(has_function(&m, "cone_normal"), v.shapes.cylinders, "{v:?}");
    }
}

fn scene(src: &str) -> cuberay::scene::Scene {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("s.nff");
    std::fs::write(&p, src).unwrap();
    load::load(&p, &Default::default()).unwrap().scene
}

const VIEW: &str = "v\nfrom 0 0 5\nat 0 0 0\nup 0 1 0\nangle 40\nhither 0.01\nresolution 8 8\n";

fn binds(m: &Wavefront, binding: u32) -> bool {
    m.0.iter()
        .flat_map(|m| m.global_variables.iter())
        .any(|(_, v)| v.binding.as_ref().is_some_and(|b| b.binding == binding))
}

/// Each kernel contains its own queries only: `--accel cube` kernels walk the tables (and,
/// where rays leave surfaces, the BVH or ray queries for them), `--accel bvh` kernels the
/// BVH, `--accel brute` kernels loop over every primitive, `--accel rayquery` kernels take
/// ray queries, and none contains or binds other code or buffers.
#[test]
fn each_kernel_contains_only_its_own_queries() {
    for v in Variant::all() {
        let m = module(v);
        let cube = v.accel == Accel::Cube;
        let bvh = v.accel == Accel::Bvh;
        let brute = v.accel == Accel::Brute;
        let table_fns = ["cell_walk", "cube_cell_range", "walk_from"];
        for f in table_fns {
            assert_eq!(has_function(&m, f), cube, "{v:?}: {f}");
        }
        // One copy of the queries, over whichever walk the variant holds.
        for f in ["closest", "closest_step", "walk_nearest", "walk_chunk"] {
            assert!(has_function(&m, f), "{v:?}: {f}");
        }
        for f in ["occluded_short", "occluded_step", "walk_inline", "walk_of_shadow"] {
            assert_eq!(has_function(&m, f), v.effects.shadows, "{v:?}: {f}");
        }

        assert_eq!(has_function(&m, "walk_any"), v.effects.shadows, "{v:?}");
        let walks_bvh = bvh || (cube && v.surface_rays && !v.surface_rq);
        let queries_rays = v.accel == Accel::RayQuery || (cube && v.surface_rays && v.surface_rq);
        assert_eq!(v.ray_queries(), queries_rays, "{v:?}");
        assert_eq!(has_function(&m, "rq_nearest"), queries_rays, "{v:?}");
        assert_eq!(has_function(&m, "rq_any"), queries_rays && v.effects.shadows, "{v:?}");
        assert_eq!(binds(&m, 25), queries_rays, "{v:?}: binding 25");
        assert_eq!(has_function(&m, "bvh_nearest"), walks_bvh, "{v:?}");
        assert_eq!(has_function(&m, "node_hits"), walks_bvh, "{v:?}");
        assert_eq!(has_function(&m, "bvh_any"), walks_bvh && v.effects.shadows, "{v:?}");
        assert_eq!(has_function(&m, "bvh_walk"), walks_bvh, "{v:?}");
        // Every accelerator traces the one shadow ray, and only where there are shadows.
        assert_eq!(has_function(&m, "shadow_ray"), v.effects.shadows, "{v:?}");
        for binding in 11..=15 {
            assert_eq!(binds(&m, binding), cube, "{v:?}: binding {binding}");
        }
        for binding in 20..=21 {
            assert_eq!(binds(&m, binding), walks_bvh, "{v:?}: binding {binding}");
        }
        // Only brute force loops over primitive ids; the table and BVH kernels loop over
        // candidate walks, group members and leaves.
        for s in Kernel::wavefront(v) {
            let (k, sv) = (s.kernel, s.variant(v));
            let src = compose(k, sv).unwrap();
            let traces = k != Kernel::Resolve;
            assert_eq!(src.contains("; id < end; id++"), brute && traces, "{v:?} {k:?}");
            assert!(!src.contains("< params.prim_count; id++"), "{v:?} {k:?}: an unbounded loop");
        }
    }
}

#[test]
fn a_scene_without_mirrors_or_glass_has_no_such_code() {
    // Matte only: no reflection, no refraction.
    let matte = scene(&format!("{VIEW}l 3 3 3\nf 1 0 0 1 0 1 0 1\ns 0 0 0 1\n"));
    for q in Accel::GPU {
        let v = Variant::for_effects(matte.effects(), 5).with_accel(q);
        let m = module(v);
        assert!(!has_function(&m, "reflect_dir") && !has_function(&m, "refract_dir"), "{v:?}");
        assert!(has_function(&m, "occluded_short"), "the light casts shadows");
    }
    // A mirror but no glass: reflection without refraction.
    let mirror = scene(&format!("{VIEW}l 3 3 3\nf 1 1 1 0.2 0.8 10 0 1\ns 0 0 0 1\n"));
    for q in Accel::GPU {
        let m = module(Variant::for_effects(mirror.effects(), 5).with_accel(q));
        assert!(has_function(&m, "reflect_dir") && !has_function(&m, "refract_dir"));
    }
    // Glass: both; depth 1 needs neither.
    let glass = scene(&format!("{VIEW}l 3 3 3\nf 1 1 1 0 0.1 10 0.9 1.5\ns 0 0 0 1\n"));
    let m = module(Variant::for_effects(glass.effects(), 5));
    assert!(has_function(&m, "reflect_dir") && has_function(&m, "refract_dir"));
    let m = module(Variant::for_effects(glass.effects(), 1));
    assert!(!has_function(&m, "reflect_dir") && !has_function(&m, "refract_dir"));
}

/// The table kernels walk the BVH for rays leaving surfaces only where a render spawns them:
/// not for a matte scene lit by point lights (whose shadow rays leave the lights' tables),
/// but with a mirror, with glass, or with a directional light (which has no table).
#[test]
fn a_scene_whose_rays_all_leave_the_eye_or_a_light_has_no_bvh_walk() {
    let opts = RenderOptions::new(8, 8);
    let matte = scene(&format!("{VIEW}l 3 3 3\nf 1 0 0 1 0 1 0 1\ns 0 0 0 1\n"));
    let mirror = scene(&format!("{VIEW}l 3 3 3\nf 1 1 1 0.2 0.8 10 0 1\ns 0 0 0 1\n"));
    let glass = scene(&format!("{VIEW}l 3 3 3\nf 1 1 1 0 0.1 10 0.9 1.5\ns 0 0 0 1\n"));
    let mut sun = matte.clone();
    sun.lights[0].kind = cuberay::scene::LightKind::Directional;
    sun.lights[0].direction = glam::DVec3::new(0.0, -1.0, 0.0);
    let shallow = RenderOptions { max_depth: 1, ..opts.clone() };
    for (name, s, o, surface) in [
        ("matte", &matte, &opts, false),
        ("mirror", &mirror, &opts, true),
        ("glass", &glass, &opts, true),
        ("mirror at depth 1", &mirror, &shallow, false),
        ("directional light", &sun, &opts, true),
    ] {
        let v = cuberay::gpu::prepare::variant_for(s, o, cuberay::gpu::Purpose::Render).unwrap();
        assert_eq!(v.surface_rays, surface, "{name}");
        assert!(v.cube() && v.effects.shadows, "{name}: {v:?}");
        let m = module(v);
        assert_eq!(has_function(&m, "bvh_nearest"), surface, "{name}");
        assert_eq!(has_function(&m, "bvh_any"), surface, "{name}");
        assert!(has_function(&m, "walk_any") && has_function(&m, "cell_walk"), "{name}");
    }
}

/// A scene's module holds the intersection code of the kinds of primitive it has, and no
/// other (on lavapipe a kernel pays for the branches it never takes).
#[test]
fn a_scene_compiles_the_intersections_of_its_kinds_only() {
    let cases = [
        ("s 0 0 0 1\n", [true, false, false]),
        ("p 3\n0 0 0\n1 0 0\n0 1 0\n", [false, true, false]),
        ("c\n0 0 0 1\n0 1 0 0.5\ns 0 2 0 1\n", [true, false, true]),
        ("c\n0 0 0 1\n0 1 0 0.5\ns 0 2 0 1\np 3\n0 0 0\n1 0 0\n0 1 0\n", [true, true, true]),
    ];
    for (prims, [spheres, triangles, cylinders]) in cases {
        let s = scene(&format!("{VIEW}l 3 3 3\nf 1 0 0 1 0 1 0 1\n{prims}"));
        let shapes = s.shapes();
        assert_eq!(
            (shapes.spheres, shapes.triangles, shapes.cylinders),
            (spheres, triangles, cylinders),
            "{prims}"
        );
        assert!(Shapes::ALL.contains(shapes) && shapes.contains(shapes), "{prims}");
        let triangles_only = Shapes { spheres: false, triangles: true, cylinders: false };
        assert_eq!(triangles_only.contains(shapes), !spheres && !cylinders, "{prims}");
        for q in Accel::GPU {
            let m = module(Variant::for_effects(s.effects(), 5).with_accel(q).with_shapes(shapes));
            assert_eq!(has_function(&m, "intersect_sphere"), spheres, "{prims}");
            assert_eq!(has_function(&m, "intersect_triangle"), triangles, "{prims}");
            assert_eq!(has_function(&m, "intersect_cylinder"), cylinders, "{prims}");
        }
    }
}

/// With the tables, the kernels that trace shadow rays (`shade`, `shadow`) hold the BVH's
/// shadow walk only where a directional light's shadow rays, which have no table, take it:
/// on lavapipe (Mesa 22.3) a kernel runs the code of a loop no invocation enters once.
#[test]
fn only_directional_lights_walk_shadows_in_the_bvh() {
    let mut seen = [0; 2];
    for v in Variant::all().into_iter().filter(|v| v.cube() && v.effects.shadows && v.surface_rays) {
        for s in
            Kernel::wavefront(v).into_iter().filter(|s| matches!(s.kernel, Kernel::Shade | Kernel::Shadow))
        {
            let m = Wavefront(vec![module_of(s.kernel, s.variant(v))]);
            let walk = if v.surface_rq { "rq_any" } else { "bvh_any" };
            assert_eq!(has_function(&m, walk), v.bvh_shadows, "{v:?} {:?}", s.kernel);
            seen[v.bvh_shadows as usize] += 1;
        }
    }
    assert!(seen[0] > 0 && seen[1] > 0, "{seen:?}");
}

/// Where the tables send rays leaving surfaces to the BVH, the eye's depth runs a `nearest`
/// without the BVH walk and the later depths one without the table walk; without rays
/// leaving surfaces, one `nearest` serves every depth.
#[test]
fn each_depth_runs_a_nearest_with_its_own_walk_only() {
    for v in Variant::all().into_iter().filter(|v| v.cube()) {
        let nearest: Vec<_> =
            Kernel::wavefront(v).into_iter().filter(|s| s.kernel == Kernel::Nearest).collect();
        if !v.surface_rays {
            assert_eq!(nearest.len(), 1, "{v:?}");
            continue;
        }
        let of = |depth: u32| {
            let s = nearest.iter().find(|s| s.serves(depth)).unwrap();
            Wavefront(vec![module_of(s.kernel, s.variant(v))])
        };
        let (eye, later) = (of(1), of(2));
        let (walk, binding) = if v.surface_rq { ("rq_nearest", 25) } else { ("bvh_nearest", 20) };
        assert!(has_function(&eye, "cell_walk") && !has_function(&eye, walk), "{v:?}");
        assert!(has_function(&later, walk) && !has_function(&later, "cell_walk"), "{v:?}");
        assert!(
            !binds(&later, 14) && binds(&later, binding) && binds(&eye, 14) && !binds(&eye, binding),
            "{v:?}"
        );
    }
}
