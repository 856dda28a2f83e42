//! The composed WGSL modules, checked with naga (no GPU needed): every effect variant
//! validates, code paths a scene does not call for are absent from its module, and every
//! WGSL struct shared with the host has the layout of its Rust twin.

use cuberay::gpu::layout::twins;
use cuberay::gpu::shader::{compose, Variant};
use cuberay::load;
use naga::valid::{Capabilities, ValidationFlags, Validator};

fn module(v: Variant) -> naga::Module {
    let src = compose(v).unwrap_or_else(|e| panic!("{v:?}: {e}"));
    naga::front::wgsl::parse_str(&src).unwrap_or_else(|e| panic!("{v:?}: {}", e.emit_to_string(&src)))
}

fn has_function(m: &naga::Module, name: &str) -> bool {
    m.functions.iter().any(|(_, f)| f.name.as_deref() == Some(name))
}

#[test]
fn every_variant_validates() {
    for v in Variant::all() {
        let m = module(v);
        Validator::new(ValidationFlags::all(), Capabilities::default())
            .validate(&m)
            .unwrap_or_else(|e| panic!("{v:?}: {e:?}"));
        for entry in ["render", "aov"] {
            assert!(m.entry_points.iter().any(|e| e.name == entry), "{v:?}: no entry point {entry}");
        }
    }
}

#[test]
fn variant_functions_follow_the_flags() {
    for v in Variant::all() {
        let m = module(v);
        assert_eq!(has_function(&m, "reflect_dir"), v.reflection, "{v:?}");
        assert_eq!(has_function(&m, "refract_dir"), v.refraction, "{v:?}");
        assert_eq!(has_function(&m, "sample_texture"), v.textures, "{v:?}");
        assert_eq!(has_function(&m, "occluded"), v.shadows, "{v:?}");
    }
}

fn scene(src: &str) -> cuberay::scene::Scene {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("s.nff");
    std::fs::write(&p, src).unwrap();
    load::load(&p, &Default::default()).unwrap().scene
}

const VIEW: &str = "v\nfrom 0 0 5\nat 0 0 0\nup 0 1 0\nangle 40\nhither 0.01\nresolution 8 8\n";

fn binds(m: &naga::Module, binding: u32) -> bool {
    m.global_variables.iter().any(|(_, v)| v.binding.as_ref().is_some_and(|b| b.binding == binding))
}

/// `--accel cube` kernels walk the tables and contain no brute-force loop; `--accel brute`
/// kernels contain no table code and bind no table buffer.
#[test]
fn cube_and_brute_kernels_contain_only_their_own_queries() {
    for v in Variant::all() {
        let m = module(v);
        let cube = ["cube_walk_nearest", "cube_cell_range", "cube_face_cell", "cube_origin"];
        for f in cube {
            assert_eq!(has_function(&m, f), v.cube, "{v:?}: {f}");
        }
        assert_eq!(has_function(&m, "cube_walk_any"), v.cube && v.shadows, "{v:?}");
        assert!(!has_function(&m, "brute_nearest") || !v.cube, "{v:?}: brute loop in a cube kernel");
        assert_eq!(has_function(&m, "brute_nearest"), !v.cube, "{v:?}");
        assert_eq!(has_function(&m, "brute_any"), !v.cube && v.shadows, "{v:?}");
        assert_eq!(has_function(&m, "brute_range"), !v.cube, "{v:?}");
        for binding in 11..=19 {
            assert_eq!(binds(&m, binding), v.cube, "{v:?}: binding {binding}");
        }
        // No loop runs over primitive ids in a cube kernel: the only loops over primitives
        // are the candidate walks and group members.
        let src = compose(v).unwrap();
        assert_eq!(src.contains("; id < end; id++"), !v.cube, "{v:?}");
        assert!(!src.contains("< params.prim_count; id++"), "{v:?}: an unbounded loop");
    }
}

#[test]
fn a_scene_without_mirrors_or_glass_has_no_such_code() {
    // Matte only: no reflection, no refraction.
    let matte = scene(&format!("{VIEW}l 3 3 3\nf 1 0 0 1 0 1 0 1\ns 0 0 0 1\n"));
    for cube in [false, true] {
        let v = Variant::for_effects(matte.effects(), 5).with_cube(cube);
        let m = module(v);
        assert!(!has_function(&m, "reflect_dir") && !has_function(&m, "refract_dir"), "{v:?}");
        assert!(has_function(&m, "occluded"), "the light casts shadows");
    }
    // A mirror but no glass: reflection without refraction.
    let mirror = scene(&format!("{VIEW}l 3 3 3\nf 1 1 1 0.2 0.8 10 0 1\ns 0 0 0 1\n"));
    for cube in [false, true] {
        let m = module(Variant::for_effects(mirror.effects(), 5).with_cube(cube));
        assert!(has_function(&m, "reflect_dir") && !has_function(&m, "refract_dir"));
    }
    // Glass: both; depth 1 needs neither.
    let glass = scene(&format!("{VIEW}l 3 3 3\nf 1 1 1 0 0.1 10 0.9 1.5\ns 0 0 0 1\n"));
    let m = module(Variant::for_effects(glass.effects(), 5));
    assert!(has_function(&m, "reflect_dir") && has_function(&m, "refract_dir"));
    let m = module(Variant::for_effects(glass.effects(), 1));
    assert!(!has_function(&m, "reflect_dir") && !has_function(&m, "refract_dir"));
}

#[test]
fn wgsl_structs_match_their_rust_twins() {
    let m = module(Variant::all()[63]);
    let mut layouter = naga::proc::Layouter::default();
    layouter.update(m.to_ctx()).unwrap();
    let shared: Vec<String> = twins().iter().map(|t| t.name.to_string()).collect();
    for twin in twins() {
        let (handle, ty) = m
            .types
            .iter()
            .find(|(_, t)| t.name.as_deref() == Some(twin.name))
            .unwrap_or_else(|| panic!("no WGSL struct {}", twin.name));
        let naga::TypeInner::Struct { members, .. } = &ty.inner else {
            panic!("{} is not a struct", twin.name)
        };
        assert_eq!(layouter[handle].size as usize, twin.size, "size of {}", twin.name);
        let wgsl: Vec<(String, usize)> =
            members.iter().map(|mb| (mb.name.clone().unwrap_or_default(), mb.offset as usize)).collect();
        let rust: Vec<(String, usize)> = twin.members.iter().map(|(n, o)| (n.to_string(), *o)).collect();
        assert_eq!(wgsl, rust, "members of {}", twin.name);
    }
    // Every struct a binding uses has a twin.
    for (_, var) in m.global_variables.iter() {
        if var.binding.is_none() {
            continue;
        }
        let mut ty = &m.types[var.ty];
        if let naga::TypeInner::Array { base, .. } = ty.inner {
            ty = &m.types[base];
        }
        if let (naga::TypeInner::Struct { .. }, Some(name)) = (&ty.inner, &ty.name) {
            assert!(shared.contains(name), "binding {:?} uses {name}, which has no Rust twin", var.name);
        }
    }
}
