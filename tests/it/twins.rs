//! Every struct and constant the WGSL shares with the host has one Rust twin of the same
//! name, and they agree: the composed kernels are read through naga and compared with the
//! Rust side field by field (name, offset, size, type) and constant by constant (value). A
//! WGSL constant, or a struct a binding uses, without a twin fails too, as does a twin whose
//! WGSL side is gone. No GPU is needed.

use std::any::type_name;
use std::collections::BTreeMap;
use std::mem::{offset_of, size_of};

use cuberay::arith::geometry::TIE_CAP;
use cuberay::arith::{FAR, NO_ID, SHADOW_END_REL};
use cuberay::bvh::WIDE_NODE_PRIMS;
use cuberay::coherence::flat::{GpuEntry, GpuFace, GpuOrigin, NO_ORIGIN};
use cuberay::coherence::walk::{AnyHit, SURFACE_WALK, UNBOUNDED, WALK_CHUNK};
use cuberay::gpu::shaders::{compose, Accel, Kernel, Variant};
use cuberay::layout::bvh::{
    WideNode, BVH_CHUNK, BVH_DECODE_REL, BVH_FRESH, BVH_NO_PARENT, BVH_SLACK, BVH_STACK,
};
use cuberay::layout::counters::*;
use cuberay::layout::rayquery::{RQ_COMMIT_REL, RQ_T_MAX};
use cuberay::layout::*;
use cuberay::preview::display::{
    View, ENCODE_LINEARIZE, ENCODE_NONE, ENCODE_SRGB, TONEMAP_ACES, TONEMAP_NONE, TONEMAP_PBR_NEUTRAL,
};
use cuberay::preview::session::{Tile, ACCUMULATE_WORKGROUP};

/// One field of a struct: name, offset, size and type (in WGSL's spelling).
#[derive(Debug, PartialEq)]
struct Field {
    name: String,
    offset: usize,
    size: usize,
    ty: String,
}

/// A struct's layout.
#[derive(Debug, PartialEq)]
struct Layout {
    size: usize,
    fields: Vec<Field>,
}

/// The WGSL spelling of a Rust field type: scalars, `[f32; 3]` as `vec3<f32>`, arrays and
/// structs by their last path segment.
fn wgsl_type(rust: &str) -> String {
    let short = |s: &str| s.rsplit("::").next().unwrap().to_string();
    match rust {
        "f32" | "u32" | "i32" | "f64" => rust.to_string(),
        "[f32; 2]" => "vec2<f32>".into(),
        "[f32; 3]" => "vec3<f32>".into(),
        "[f32; 4]" => "vec4<f32>".into(),
        "[f64; 3]" => "vec3<f64>".into(),
        "[f64; 4]" => "vec4<f64>".into(),
        _ if rust.starts_with('[') => {
            let inner = &rust[1..rust.len() - 1];
            let (t, n) = inner.rsplit_once("; ").expect("an array type");
            format!("array<{}, {n}>", wgsl_type(t))
        }
        _ => short(rust),
    }
}

fn field<T, F>(name: &str, offset: usize, _get: fn(&T) -> &F) -> Field {
    Field { name: name.into(), offset, size: size_of::<F>(), ty: wgsl_type(type_name::<F>()) }
}

/// The Rust twin's layout, its fields listed in WGSL order (their types come from the
/// struct itself).
macro_rules! twin {
    ($t:ident { $($f:ident),* $(,)? }) => {
        (stringify!($t), Layout {
            size: size_of::<$t>(),
            fields: vec![$(field::<$t, _>(stringify!($f), offset_of!($t, $f), |s: &$t| &s.$f)),*],
        })
    };
}

/// Every shared struct's Rust twin.
fn rust_structs() -> BTreeMap<&'static str, Layout> {
    [params_twin(), scene_record_twins(), wavefront_twins(), table_and_bvh_twins(), preview_twins()]
        .into_iter()
        .flatten()
        .collect()
}

/// The twin of `Params`, the parameters every kernel reads (`shared/layout.wgsl`).
fn params_twin() -> Vec<(&'static str, Layout)> {
    vec![twin!(Params {
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
        shadow_inline,
        spawn_rel,
        spawn_abs,
        win_x,
        win_y,
        win_w,
        own_w,
        own_h,
        bvh_node_count,
        ray_queue,
        shadow_queue,
        surface_walk,
        bvh_inline,
        env_x,
        env_texture,
        env_y,
        env_intensity,
        env_z,
        prims_per_binding,
    })]
}

/// The twins of the scene's records in `shared/layout.wgsl`: primitives, their attributes,
/// materials, lights and textures.
fn scene_record_twins() -> Vec<(&'static str, Layout)> {
    vec![
        twin!(Prim { a, b, c, kind, material, flags, attr }),
        twin!(Prim64 { a, b, c, kind, material, flags, attr, pad }),
        twin!(TriAttr { n0, n1, n2, uv01, uv2_1 }),
        twin!(TexRef { row0, texture, row1, texcoord }),
        twin!(Material {
            color,
            kd,
            mirror,
            ks,
            emission,
            shine,
            transmittance,
            ior,
            flags,
            opacity,
            metallic,
            roughness,
            transmission,
            alpha_cutoff,
            emission_factor,
            shadow_cutoff,
            normal_scale,
            clearcoat,
            clearcoat_roughness,
            clearcoat_normal_scale,
            base,
            metallic_roughness,
            emissive,
            transmission_map,
            normal,
            attenuation,
            specular,
            specular_color,
            pad0,
            clearcoat_map,
            clearcoat_roughness_map,
            clearcoat_normal,
            specular_map,
            specular_color_map
        }),
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
    ]
}

/// The twins of the wavefront's records in `shared/wavefront.wgsl`: pending rays, jobs,
/// surface walks and pass descriptions.
fn wavefront_twins() -> Vec<(&'static str, Layout)> {
    vec![
        twin!(Pending { o, kind, d, spawn, weight, from_prim }),
        twin!(Pending64 { o, kind, pad0, d, spawn, weight, from_prim }),
        twin!(WalkState { i, iend, j, jend, prim, t, b1, b2, window, t_min }),
        twin!(Job { ray, point, walking, walk }),
        twin!(Job64 { ray, point, walking, walk, pad }),
        twin!(PassDesc { src, next, shadow, retry, sample, hit, depth, pad1 }),
    ]
}

/// The twins of the tables' records in `shared/tables.wgsl` and of the BVH's wide node in
/// `shared/bvh.wgsl`.
fn table_and_bvh_twins() -> Vec<(&'static str, Layout)> {
    vec![
        twin!(GpuOrigin { n, always_start, always_count, kind }),
        twin!(GpuFace { iu0, iv0, width, height, cell_base, _pad0, _pad1, _pad2 }),
        twin!(GpuEntry { id, d_min }),
        twin!(WideNode { p, e_imask, child_base, prim_base, child_meta, q }),
    ]
}

/// The twins of the preview's records: the tile of `accumulate.wgsl` and the view of
/// `display.wgsl`.
fn preview_twins() -> Vec<(&'static str, Layout)> {
    vec![
        twin!(Tile { first_point, point_count, pad0, pad1 }),
        twin!(View { width, height, grid_w, samples, corners, encode, block, tonemap, exposure, pad1 }),
    ]
}

/// A constant's value.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Value {
    U32(u32),
    F32(f32),
}

/// Every shared constant's Rust twin.
fn rust_constants() -> BTreeMap<&'static str, Value> {
    let mut all = wavefront_constants();
    all.extend(layout_constants());
    all
}

/// The twins of the wavefront's and the walks' constants (`wavefront.wgsl`, the walks, the
/// tie rule, the tree form's stack).
fn wavefront_constants() -> BTreeMap<&'static str, Value> {
    use Value::*;
    BTreeMap::from([
        ("MAX_DEPTH", U32(MAX_DEPTH)),
        ("TREE_STACK", U32(TREE_STACK)),
        ("QUEUE_RAY0", U32(QUEUE_RAY0)),
        ("QUEUE_RAY1", U32(QUEUE_RAY1)),
        ("QUEUE_RETRY0", U32(QUEUE_RETRY0)),
        ("QUEUE_RETRY1", U32(QUEUE_RETRY1)),
        ("QUEUE_HIT", U32(QUEUE_HIT)),
        ("QUEUE_SHADOW", U32(QUEUE_SHADOW)),
        ("QUEUE_SRETRY0", U32(QUEUE_SRETRY0)),
        ("QUEUE_SRETRY1", U32(QUEUE_SRETRY1)),
        ("QUEUE_COUNT", U32(QUEUE_COUNT)),
        ("SRC_EYE", U32(SRC_EYE)),
        ("QUEUE_ARGS", U32(QUEUE_ARGS)),
        ("QUEUE_OVERFLOW", U32(QUEUE_OVERFLOW)),
        ("QUEUE_WORDS", U32(QUEUE_WORDS)),
        ("OVERFLOW_FULL", U32(OVERFLOW_FULL)),
        ("OVERFLOW_UNFINISHED", U32(OVERFLOW_UNFINISHED)),
        ("POINT_UNOWNED", U32(POINT_UNOWNED)),
        ("ACCUM_ONE", F32(ACCUM_ONE)),
        ("WALK_CHUNK", U32(WALK_CHUNK)),
        ("WALK_START", U32(WALK_START)),
        ("WALK_RESUME", U32(WALK_RESUME)),
        ("WALK_RESUME_LOST", U32(WALK_RESUME_LOST)),
        ("TIE_CAP", F32(TIE_CAP)),
        ("UNBOUNDED", U32(UNBOUNDED)),
        ("SURFACE_WALK", U32(SURFACE_WALK)),
        ("ANY_CLEAR", U32(AnyHit::Clear as u32)),
        ("ANY_BLOCKED", U32(AnyHit::Blocked as u32)),
        ("ANY_UNFINISHED", U32(AnyHit::Unfinished as u32)),
    ])
}

/// The twins of the layout's, the counters', the BVH's and the display's constants.
fn layout_constants() -> BTreeMap<&'static str, Value> {
    use Value::*;
    BTreeMap::from([
        ("WORKGROUP", U32(WORKGROUP)),
        ("KIND_SPHERE", U32(KIND_SPHERE)),
        ("KIND_TRIANGLE", U32(KIND_TRIANGLE)),
        ("KIND_CYLINDER", U32(KIND_CYLINDER)),
        ("FLAG_INSIDE_ONLY", U32(FLAG_INSIDE_ONLY)),
        ("FLAG_NORMALS", U32(FLAG_NORMALS)),
        ("FLAG_UVS", U32(FLAG_UVS)),
        ("FLAG_COLORS", U32(FLAG_COLORS)),
        ("FLAG_UV1", U32(FLAG_UV1)),
        ("FLAG_TANGENTS", U32(FLAG_TANGENTS)),
        ("FLAG_CUTOUT", U32(FLAG_CUTOUT)),
        ("FLAG_CUTOUT_SHADOW", U32(FLAG_CUTOUT_SHADOW)),
        ("MATERIAL_TINTED_TRANSMISSION", U32(MATERIAL_TINTED_TRANSMISSION)),
        ("MATERIAL_MAPS", U32(MATERIAL_MAPS)),
        ("MATERIAL_BLEND", U32(MATERIAL_BLEND)),
        ("LIGHT_POINT", U32(LIGHT_POINT)),
        ("LIGHT_SPOT", U32(LIGHT_SPOT)),
        ("LIGHT_DIRECTIONAL", U32(LIGHT_DIRECTIONAL)),
        ("WRAP_REPEAT", U32(WRAP_REPEAT)),
        ("WRAP_MIRRORED_REPEAT", U32(WRAP_MIRRORED_REPEAT)),
        ("WRAP_CLAMP_TO_EDGE", U32(WRAP_CLAMP_TO_EDGE)),
        ("TEX_BILINEAR", U32(TEX_BILINEAR)),
        ("TEX_SRGB", U32(TEX_SRGB)),
        ("AOV_DEPTH", U32(AOV_DEPTH)),
        ("AOV_NORMAL", U32(AOV_NORMAL)),
        ("AOV_ID", U32(AOV_ID)),
        ("RAY_EYE", U32(RAY_EYE)),
        ("RAY_SHADOW", U32(RAY_SHADOW)),
        ("RAY_REFLECT", U32(RAY_REFLECT)),
        ("RAY_REFRACT", U32(RAY_REFRACT)),
        ("RAY_KIND_MASK", U32(RAY_KIND_MASK)),
        ("RAY_SKIP_FROM", U32(RAY_SKIP_FROM)),
        ("RAY_DEPTH_SHIFT", U32(RAY_DEPTH_SHIFT)),
        ("SELF_HIT_SPAWNS", F32(SELF_HIT_SPAWNS)),
        ("C_RAYS", U32(C_RAYS)),
        ("C_TESTS", U32(C_TESTS)),
        ("C_EYE_HIT", U32(C_EYE_HIT)),
        ("C_SHADOW_BLOCKED", U32(C_SHADOW_BLOCKED)),
        ("C_BOUNDS", U32(C_BOUNDS)),
        ("C_SELF_HITS", U32(C_SELF_HITS)),
        ("COUNTER_COUNT", U32(COUNTER_COUNT)),
        ("LANE_NEAREST", U32(LANE_NEAREST)),
        ("LANE_SHADE", U32(LANE_SHADE)),
        ("LANE_SHADOW", U32(LANE_SHADOW)),
        ("LANE_BASE", U32(LANE_BASE)),
        ("LANE_WORDS", U32(LANE_WORDS)),
        ("LANE_SLOTS", U32(LANE_SLOTS)),
        ("FAR", F32(FAR)),
        ("NO_ID", U32(NO_ID)),
        ("SHADOW_END_REL", F32(SHADOW_END_REL)),
        ("NO_ORIGIN", U32(NO_ORIGIN)),
        ("BVH_NO_PARENT", U32(BVH_NO_PARENT)),
        ("BVH_FRESH", U32(BVH_FRESH)),
        ("BVH_STACK", U32(BVH_STACK)),
        ("BVH_CHUNK", U32(BVH_CHUNK)),
        ("WIDE_NODE_PRIMS", U32(WIDE_NODE_PRIMS)),
        ("BVH_SLACK", F32(BVH_SLACK)),
        ("BVH_DECODE_REL", F32(BVH_DECODE_REL)),
        ("RQ_COMMIT_REL", F32(RQ_COMMIT_REL)),
        ("RQ_T_MAX", F32(RQ_T_MAX)),
        ("ACCUMULATE_WORKGROUP", U32(ACCUMULATE_WORKGROUP)),
        ("ENCODE_NONE", U32(ENCODE_NONE)),
        ("ENCODE_SRGB", U32(ENCODE_SRGB)),
        ("ENCODE_LINEARIZE", U32(ENCODE_LINEARIZE)),
        ("TONEMAP_NONE", U32(TONEMAP_NONE)),
        ("TONEMAP_PBR_NEUTRAL", U32(TONEMAP_PBR_NEUTRAL)),
        ("TONEMAP_ACES", U32(TONEMAP_ACES)),
    ])
}

/// The kernels that trace rays (and so include every shared file with every effect).
fn is_trace_kernel(k: Kernel) -> bool {
    !matches!(k, Kernel::Accumulate | Kernel::Display)
}

/// Every kernel, with every effect and each set of queries (every shared file included),
/// in f32 and f64 (each layout of the structs that hold positions), through naga.
fn modules() -> Vec<(Kernel, naga::Module)> {
    Kernel::ALL
        .iter()
        .flat_map(|&k| {
            let variants: Vec<Variant> = if is_trace_kernel(k) {
                Accel::GPU
                    .into_iter()
                    .flat_map(|q| [false, true].map(|f64| Variant::full(q).with_f64(f64)))
                    .collect()
            } else {
                vec![Variant::default()]
            };
            variants.into_iter().map(move |v| (k, v))
        })
        .map(|(k, v)| {
            let src = compose(k, v).unwrap_or_else(|e| panic!("{k:?}: {e}"));
            let m = naga::front::wgsl::parse_str(&src)
                .unwrap_or_else(|e| panic!("{k:?}: {}", e.emit_to_string(&src)));
            (k, m)
        })
        .collect()
}

fn wgsl_type_of(m: &naga::Module, ty: naga::Handle<naga::Type>) -> String {
    use naga::{ScalarKind, TypeInner};
    let scalar = |s: naga::Scalar| match (s.kind, s.width) {
        (ScalarKind::Float, 4) => "f32".to_string(),
        (ScalarKind::Float, 8) => "f64".to_string(),
        (ScalarKind::Uint, 4) => "u32".to_string(),
        (ScalarKind::Sint, 4) => "i32".to_string(),
        other => format!("{other:?}"),
    };
    let t = &m.types[ty];
    match &t.inner {
        TypeInner::Scalar(s) => scalar(*s),
        TypeInner::Vector { size, scalar: s } => format!("vec{}<{}>", *size as u8, scalar(*s)),
        TypeInner::Array { base, size: naga::ArraySize::Constant(n), .. } => {
            format!("array<{}, {n}>", wgsl_type_of(m, *base))
        }
        TypeInner::Struct { .. } => t.name.clone().unwrap_or_default(),
        other => format!("{other:?}"),
    }
}

/// The layouts of the WGSL structs of `m`, by name.
fn wgsl_structs(m: &naga::Module) -> BTreeMap<String, Layout> {
    let mut layouter = naga::proc::Layouter::default();
    layouter.update(m.to_ctx()).unwrap();
    let mut out = BTreeMap::new();
    for (handle, ty) in m.types.iter() {
        let (naga::TypeInner::Struct { members, .. }, Some(name)) = (&ty.inner, &ty.name) else { continue };
        let fields = members
            .iter()
            .map(|mb| Field {
                name: mb.name.clone().unwrap_or_default(),
                offset: mb.offset as usize,
                size: layouter[mb.ty].size as usize,
                ty: wgsl_type_of(m, mb.ty),
            })
            .collect();
        out.insert(name.clone(), Layout { size: layouter[handle].size as usize, fields });
    }
    out
}

/// The values of the WGSL constants of `m`, by name.
fn wgsl_constants(m: &naga::Module) -> BTreeMap<String, Value> {
    m.constants
        .iter()
        .filter_map(|(_, c)| {
            let value = match m.global_expressions[c.init] {
                naga::Expression::Literal(naga::Literal::U32(v)) => Value::U32(v),
                naga::Expression::Literal(naga::Literal::F32(v)) => Value::F32(v),
                ref e => panic!("constant {:?} is not a u32 or f32 literal: {e:?}", c.name),
            };
            Some((c.name.clone()?, value))
        })
        .collect()
}

/// Structs the WGSL keeps to itself (never in a buffer the host writes or reads).
const WGSL_ONLY_STRUCTS: &[&str] = &[
    "Ray",
    "PrimHit",
    "Closest",
    "Stepped",
    "Surface",
    "UvSets",
    "Shading",
    "Incidence",
    "Lit",
    "Refracted",
    "Coat",
    "Fixed",
    "Walk",
    "AnyHit",
    "Occlusion",
    "ShadowRay",
    "BoxRay",
    "NodeHits",
    "Footprint",
    "BvhWalk",
    "VertexOut",
    // naga's own, for ray queries (what the driver reads, not a buffer of ours).
    "RayDesc",
    "RayIntersection",
];

#[test]
fn every_shared_struct_has_the_layout_of_its_rust_twin() {
    let rust = rust_structs();
    let mut seen = Vec::new();
    for (k, m) in modules() {
        for (name, wgsl) in wgsl_structs(&m) {
            if WGSL_ONLY_STRUCTS.contains(&name.as_str()) {
                continue;
            }
            let twin = rust
                .get(name.as_str())
                .unwrap_or_else(|| panic!("{k:?}: WGSL struct {name} has no Rust twin"));
            assert_eq!(&wgsl, twin, "{k:?}: struct {name}: WGSL (left) and Rust (right) differ");
            seen.push(name);
        }
        // Every struct a binding uses is shared.
        for (_, var) in m.global_variables.iter() {
            if var.binding.is_none() {
                continue;
            }
            let mut ty = &m.types[var.ty];
            if let naga::TypeInner::Array { base, .. } = ty.inner {
                ty = &m.types[base];
            }
            if let (naga::TypeInner::Struct { .. }, Some(name)) = (&ty.inner, &ty.name) {
                assert!(
                    rust.contains_key(name.as_str()),
                    "{k:?}: binding {:?} uses {name}, which has no Rust twin",
                    var.name
                );
            }
        }
    }
    for name in rust.keys() {
        assert!(seen.iter().any(|s| s == name), "Rust twin {name} has no WGSL struct");
    }
}

#[test]
fn every_shared_constant_has_the_value_of_its_rust_twin() {
    let rust = rust_constants();
    let mut seen = Vec::new();
    for (k, m) in modules() {
        for (name, value) in wgsl_constants(&m) {
            let twin = rust
                .get(name.as_str())
                .unwrap_or_else(|| panic!("{k:?}: WGSL constant {name} has no Rust twin"));
            assert_eq!(value, *twin, "{k:?}: constant {name}: WGSL (left) and Rust (right) differ");
            seen.push(name);
        }
    }
    for name in rust.keys() {
        assert!(seen.iter().any(|s| s == name), "Rust twin {name} has no WGSL constant");
    }
}

#[test]
fn workgroup_sizes_are_the_shared_constants() {
    for (k, m) in modules() {
        for e in &m.entry_points {
            let want = match k {
                Kernel::Accumulate => ACCUMULATE_WORKGROUP,
                Kernel::Display => continue,
                _ => WORKGROUP,
            };
            assert_eq!(e.workgroup_size, [want, 1, 1], "{k:?}: entry point {}", e.name);
        }
    }
}

/// A camera move packs only what depends on the eye (`pack_moved`): the same primitives as
/// `pack`, pointing at the same attribute entries, which `Packed::add_fixed` then writes
/// as `pack` does; the entries are where the WGSL reads them (a colour-only triangle's
/// colours in its third entry, a normal-mapped one's tangents in its second).
#[test]
fn a_move_packs_what_depends_on_the_eye_and_points_at_the_same_entries() {
    use cuberay::arith::spawn::SpawnPolicy;
    use cuberay::layout::{pack, pack_moved};
    use cuberay::scene::Primitive;
    let own = |f: &str| std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(f);
    let helmet = crate::common::shared("gltf/DamagedHelmet/DamagedHelmet.gltf");
    for path in [own("vertex_colors.gltf"), own("normal_tilt.gltf"), own("alpha_mask.gltf"), helmet] {
        let scene = cuberay::load::load(&path, &Default::default()).unwrap().scene;
        let spawn = SpawnPolicy::default();
        let full = pack(&scene, 32, 32, spawn);
        let mut moved = pack_moved(&scene, 32, 32, spawn);
        assert!(full.fixed && !moved.fixed);
        assert!(moved.tri_attrs.is_empty() && moved.materials.is_empty() && moved.texels.is_empty());
        let bits = |p: &[cuberay::layout::Prim]| bytemuck::cast_slice::<_, u8>(p).to_vec();
        assert_eq!(bits(&moved.prims), bits(&full.prims), "{}", path.display());
        moved.add_fixed(&scene);
        assert_eq!(
            bytemuck::cast_slice::<_, u8>(&moved.tri_attrs),
            bytemuck::cast_slice::<_, u8>(&full.tri_attrs)
        );
        assert_eq!(moved.texels, full.texels);
        assert_eq!(moved.materials.len(), scene.materials.len());
        for (p, packed) in scene.primitives.iter().zip(&full.prims) {
            let Primitive::Triangle(t) = p else { continue };
            let at = |k: u32| full.tri_attrs[(packed.attr + k) as usize];
            if let Some(c) = &t.color {
                assert_eq!(
                    at(2).n0[..3],
                    [c[0].x as f32, c[0].y as f32, c[0].z as f32],
                    "{}",
                    path.display()
                );
            }
            if let Some(tg) = t.tangent.as_deref() {
                assert_eq!(at(1).n1, [tg[1].x, tg[1].y, tg[1].z, tg[1].w].map(|v| v as f32));
            }
            if let Some(uv) = t.uv {
                assert_eq!(at(0).uv2_1[..2], [uv[2].x as f32, uv[2].y as f32]);
            }
        }
    }
}
