//! Composing the WGSL kernels per effect set and accelerator.
//!
//! The kernels live in `shaders/`: one file per kernel (the wavefront's `nearest.wgsl`,
//! `shade.wgsl`, `shadow.wgsl` and `resolve.wgsl`, `aov.wgsl`, and the preview's
//! `accumulate.wgsl` and `display.wgsl`), the kernel, its pipeline and its label sharing one
//! name, and the code they share in `shaders/shared/` (the kernels that trace include
//! `shared/trace.wgsl`, which brings the variant's one accelerator). All are embedded in the
//! binary. A tiny line-based preprocessor composes one module per [`Kernel`] and
//! [`Variant`]: `#include "shared/file.wgsl"` pastes a file (once), and `#if NAME` / `#else` /
//! `#endif` (nestable) keep or drop lines by the variant's flags `SHADOWS`, `REFLECTION`,
//! `REFRACTION`, `TEXTURES`, `EMISSION`, `VERTEX_COLORS`, `MAPS`, `NORMAL_MAPS`, `ALPHA`
//! (every walk tests alpha on masked materials), `BLEND` (pass-through rays) and `CUTOUTS`
//! (shadow walks test alpha: `ALPHA` or `BLEND`), `F64`, `SPHERES`, `TRIANGLES` and
//! `CYLINDERS`, `SURFACE_RAYS` (rays leave surfaces: reflection, refraction and
//! pass-through rays, shadow rays towards a directional light; the BVH takes them),
//! `COUNTERS` (the statistics counters), and `TABLES`, `BVH` and `BRUTE`, of which exactly one
//! is set: the walk `shared/query.wgsl`'s queries go over, the candidate tables' of
//! `shared/walk.wgsl`, the BVH's of `shared/bvh.wgsl` or brute force's of
//! `shared/brute.wgsl`. The table walk includes the BVH walk with `SURFACE_RAYS`. A scene
//! without mirrors thus gets a module with no reflection code at all, not a branch that is
//! never taken.

use crate::error::{Error, Result};
use crate::scene::{Effects, Shapes};

/// The shader sources, by their path under `shaders/`.
const SOURCES: &[(&str, &str)] = &[
    ("nearest.wgsl", include_str!("../../shaders/nearest.wgsl")),
    ("shade.wgsl", include_str!("../../shaders/shade.wgsl")),
    ("shadow.wgsl", include_str!("../../shaders/shadow.wgsl")),
    ("resolve.wgsl", include_str!("../../shaders/resolve.wgsl")),
    ("aov.wgsl", include_str!("../../shaders/aov.wgsl")),
    ("accumulate.wgsl", include_str!("../../shaders/accumulate.wgsl")),
    ("display.wgsl", include_str!("../../shaders/display.wgsl")),
    ("shared/layout.wgsl", include_str!("../../shaders/shared/layout.wgsl")),
    ("shared/wavefront.wgsl", include_str!("../../shaders/shared/wavefront.wgsl")),
    ("shared/counters.wgsl", include_str!("../../shaders/shared/counters.wgsl")),
    ("shared/geometry.wgsl", include_str!("../../shaders/shared/geometry.wgsl")),
    ("shared/intersect.wgsl", include_str!("../../shaders/shared/intersect.wgsl")),
    ("shared/closest.wgsl", include_str!("../../shaders/shared/closest.wgsl")),
    ("shared/brute.wgsl", include_str!("../../shaders/shared/brute.wgsl")),
    ("shared/tables.wgsl", include_str!("../../shaders/shared/tables.wgsl")),
    ("shared/walk.wgsl", include_str!("../../shaders/shared/walk.wgsl")),
    ("shared/bvh.wgsl", include_str!("../../shaders/shared/bvh.wgsl")),
    ("shared/sampling.wgsl", include_str!("../../shaders/shared/sampling.wgsl")),
    ("shared/texture.wgsl", include_str!("../../shaders/shared/texture.wgsl")),
    ("shared/environment.wgsl", include_str!("../../shaders/shared/environment.wgsl")),
    ("shared/tonemap.wgsl", include_str!("../../shaders/shared/tonemap.wgsl")),
    ("shared/shade.wgsl", include_str!("../../shaders/shared/shade.wgsl")),
    ("shared/trace.wgsl", include_str!("../../shaders/shared/trace.wgsl")),
    ("shared/query.wgsl", include_str!("../../shaders/shared/query.wgsl")),
];

/// A kernel: its file `shaders/NAME.wgsl`, its entry point(s) and its pipeline share the name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Kernel {
    /// Traces a queue of rays (or a tile's eye rays, which it makes: see `gpu::schedule`) for
    /// their nearest hits and queues the hits.
    Nearest,
    /// Shades a queue of hits: their light, their shadow rays and the rays they spawn.
    Shade,
    /// Traces a queue of shadow rays (variants with shadows).
    Shadow,
    /// The tile's radiance, summed in fixed point, as f32 colours.
    Resolve,
    /// Writes depth, normal or object id from the eye ray through each pixel centre.
    Aov,
    /// The preview's accumulation of a finished tile.
    Accumulate,
    /// The preview's display pass (vertex `vs_main`, fragment `fs_main`).
    Display,
}

impl Kernel {
    pub const ALL: [Kernel; 7] = [
        Kernel::Nearest,
        Kernel::Shade,
        Kernel::Shadow,
        Kernel::Resolve,
        Kernel::Aov,
        Kernel::Accumulate,
        Kernel::Display,
    ];

    /// The wavefront kernels a render with `variant` runs (the shadow kernel only with
    /// shadows), each with the depths whose passes it serves: `nearest` twice where the
    /// tables send rays leaving surfaces to the BVH ([`Depths`]).
    pub fn wavefront(variant: Variant) -> Vec<Stage> {
        let all = |kernel| Stage { kernel, depths: Depths::All };
        let mut k = Vec::new();
        if variant.tables() && variant.surface_rays {
            k.push(Stage { kernel: Kernel::Nearest, depths: Depths::Eye });
            k.push(Stage { kernel: Kernel::Nearest, depths: Depths::Later });
        } else {
            k.push(all(Kernel::Nearest));
        }
        k.push(all(Kernel::Shade));
        if variant.shadows {
            k.push(all(Kernel::Shadow));
        }
        k.push(all(Kernel::Resolve));
        k
    }

    /// The kernel's name: its file stem, entry point (compute kernels) and pipeline label.
    pub fn name(self) -> &'static str {
        match self {
            Kernel::Nearest => "nearest",
            Kernel::Shade => "shade",
            Kernel::Shadow => "shadow",
            Kernel::Resolve => "resolve",
            Kernel::Aov => "aov",
            Kernel::Accumulate => "accumulate",
            Kernel::Display => "display",
        }
    }

    /// The variant `kernel` is compiled in for a render of `variant`: `resolve` traces
    /// nothing, so one module of it serves every variant.
    pub fn variant_of(self, variant: Variant) -> Variant {
        match self {
            Kernel::Resolve => Variant::default(),
            _ => variant,
        }
    }

    /// The kernel's file under `shaders/`.
    pub fn file(self) -> String {
        format!("{}.wgsl", self.name())
    }
}

/// The depths of the ray trees whose passes a wavefront kernel's module serves.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Depths {
    /// Every depth: the render's variant.
    All,
    /// The eye's depth only: the eye rays walk the eye's table, and the module holds no BVH
    /// walk for rays leaving surfaces.
    Eye,
    /// The depths past the eye's, whose rays leave surfaces and (with `--accel cube`) walk
    /// the BVH: the module of `--accel bvh`, without the table walk. On lavapipe a kernel
    /// pays for code it does not take: the table kernel's walk of these rays cost up to 37 %
    /// more than the BVH kernel's (mount_s6), and its eye walks carried the BVH loop.
    Later,
}

/// A wavefront kernel and the depths it serves ([`Kernel::wavefront`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Stage {
    pub kernel: Kernel,
    pub depths: Depths,
}

impl Stage {
    /// The variant the stage's module is compiled in for a render of `variant`.
    pub fn variant(self, variant: Variant) -> Variant {
        match self.depths {
            Depths::All => self.kernel.variant_of(variant),
            Depths::Eye => variant.with_surface_rays(false),
            Depths::Later => Variant { queries: Queries::Bvh, surface_rays: true, ..variant },
        }
    }

    /// Whether the stage runs the passes of depth `depth` (the eye's: 1).
    pub fn serves(self, depth: u32) -> bool {
        match self.depths {
            Depths::All => true,
            Depths::Eye => depth <= 1,
            Depths::Later => depth > 1,
        }
    }
}

/// Which queries a kernel traces rays with.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum Queries {
    /// The direction-cube candidate tables (`--accel cube`, the default).
    #[default]
    Tables,
    /// Every primitive for every ray (`--accel brute`).
    Brute,
    /// The bounding volume hierarchy (`--accel bvh`), the baseline the tables are timed against.
    Bvh,
}

impl Queries {
    pub const ALL: [Queries; 3] = [Queries::Tables, Queries::Bvh, Queries::Brute];

    /// The `--accel` name.
    pub fn name(self) -> &'static str {
        match self {
            Queries::Tables => "cube",
            Queries::Bvh => "bvh",
            Queries::Brute => "brute",
        }
    }
}

/// The code paths one compiled module contains.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub struct Variant {
    pub shadows: bool,
    pub reflection: bool,
    pub refraction: bool,
    pub textures: bool,
    pub emission: bool,
    /// Triangles carry vertex colours that multiply the base colour (`VERTEX_COLORS`).
    pub vertex_colors: bool,
    /// Materials evaluate metallic-roughness, emissive and transmission maps per hit (`MAPS`).
    pub maps: bool,
    /// Materials bend shading normals with normal maps (`NORMAL_MAPS`).
    pub normal_maps: bool,
    /// Every walk tests alpha at hits of masked materials (`ALPHA`).
    pub alpha: bool,
    /// Hits of blended materials spawn pass-through rays, and shadow walks test alpha at
    /// them (`BLEND`).
    pub blend: bool,
    /// Rays that leave the scene look up the environment map (`ENVIRONMENT`).
    pub environment: bool,
    /// The ray queries: the candidate tables, the BVH or brute force.
    pub queries: Queries,
    /// Intersection tests and hit points in f64 (`--precision f64`; `SHADER_F64`).
    pub f64: bool,
    /// The kinds of primitive whose intersection and surface code the module holds (default:
    /// all). On lavapipe a kernel pays for the branches it does not take, so a scene of
    /// triangles alone traces faster without the sphere and cylinder tests in its loops.
    pub shapes: Shapes,
    /// Whether rays leave surfaces (`SURFACE_RAYS`), so that the table kernels hold the walk
    /// of the BVH that takes such rays. [`Variant::for_effects`] assumes so
    /// wherever reflection or shadows may spawn them; a render narrows it to what its tables
    /// trace (`GpuRenderer::for_scene`): a scene whose shadow rays all leave point lights and
    /// that has no mirror or glass traces none, and its kernels would otherwise run a BVH loop
    /// for every eye and shadow ray on lavapipe, where a loop no invocation enters still
    /// runs once.
    pub surface_rays: bool,
    /// Whether shadow rays may walk the BVH (`BVH_SHADOWS`): with the tables, the rays of
    /// directional lights, which have no table. A render narrows it to scenes with such a
    /// light (`GpuRenderer::for_scene`): on lavapipe (Mesa 22.3) the `shade` kernel ran the
    /// BVH's shadow walk once for every light of every hit where no shadow ray took it, 10 %
    /// of the eye's `shade` time on balls_s4 and gears_s4.
    pub bvh_shadows: bool,
    /// Whether the kernels count rays and tests into the statistics counters (`COUNTERS`).
    /// On lavapipe counting costs a kernel 5–22 % of its time (a private array indexed per
    /// lane at every test, workgroup atomics at the end), so a render counts only when asked
    /// to (`RenderOptions::count`); uncounted, its counts are zero.
    pub counters: bool,
}

impl Variant {
    /// The variant for a scene's effects rendered with `max_depth` (below 2 no secondary
    /// ray is ever spawned, so neither reflection nor refraction code is needed).
    pub fn for_effects(e: Effects, max_depth: u32) -> Variant {
        let secondary = max_depth >= 2;
        let reflection = e.reflection && secondary;
        Variant {
            shadows: e.shadows,
            reflection,
            refraction: e.refraction && secondary,
            textures: e.textures,
            emission: e.emission,
            vertex_colors: e.vertex_colors,
            maps: e.maps,
            normal_maps: e.normal_maps,
            alpha: e.alpha,
            blend: e.blend,
            environment: e.environment,
            queries: Queries::Tables,
            f64: false,
            shapes: Shapes::ALL,
            surface_rays: reflection || e.shadows || (e.blend && secondary),
            bvh_shadows: e.shadows,
            counters: true,
        }
    }

    /// The same effects for a scene of `shapes` only.
    pub fn with_shapes(self, shapes: Shapes) -> Variant {
        Variant { shapes, ..self }
    }

    /// The same effects where rays leave surfaces only if `surface_rays` (and the effects
    /// may spawn them).
    pub fn with_surface_rays(self, surface_rays: bool) -> Variant {
        Variant { surface_rays: self.surface_rays && surface_rays, ..self }
    }

    /// The same effects where shadow rays walk the BVH only if `bvh_shadows` (and the effects
    /// say they may).
    pub fn with_bvh_shadows(self, bvh_shadows: bool) -> Variant {
        Variant { bvh_shadows: self.bvh_shadows && bvh_shadows, ..self }
    }

    /// The same effects, counted (`true`) or not.
    pub fn with_counters(self, counters: bool) -> Variant {
        Variant { counters, ..self }
    }

    /// The same effects with intersections in f64 (`true`) or f32.
    pub fn with_f64(self, f64: bool) -> Variant {
        Variant { f64, ..self }
    }

    /// The same effects traced with `queries`.
    pub fn with_queries(self, queries: Queries) -> Variant {
        Variant { queries, ..self }
    }

    /// Whether the kernels walk the candidate tables.
    pub fn tables(&self) -> bool {
        self.queries == Queries::Tables
    }

    /// The effects the kernels simulate (what their tables must serve).
    pub fn effects(&self) -> Effects {
        Effects {
            shadows: self.shadows,
            reflection: self.reflection,
            refraction: self.refraction,
            textures: self.textures,
            emission: self.emission,
            vertex_colors: self.vertex_colors,
            maps: self.maps,
            normal_maps: self.normal_maps,
            alpha: self.alpha,
            blend: self.blend,
            environment: self.environment,
        }
    }

    /// The variants the tests compile: the 32 effect sets for each of [`Queries::ALL`], in f32
    /// and in f64, with every kind of primitive (192, the effect sets in the order of their
    /// bits, the last of each 32 with every effect), then every other set of kinds (none
    /// included: a scene may hold no primitive) with every effect (42), then shadows without
    /// rays leaving surfaces (lights with tables, no mirror), with and without textures and
    /// emission (12), then every effect uncounted (6), then maps, normal maps, mask and
    /// blend each without the others, mirrors lit by point lights alone and an environment
    /// alone (36), so that
    /// each `#if` is compiled both ways. Vertex colours, maps, normal maps, alpha and blend are off in the 32 effect sets
    /// and on in the rest (each further effect is compiled on and off against a
    /// representative rest, not in the full product).
    pub fn all() -> Vec<Variant> {
        let effects = [false, true].into_iter().flat_map(|f64| {
            Queries::ALL.into_iter().flat_map(move |queries| {
                (0..32u32).map(move |b| Variant {
                    shadows: b & 1 != 0,
                    reflection: b & 2 != 0,
                    refraction: b & 4 != 0,
                    textures: b & 8 != 0,
                    emission: b & 16 != 0,
                    vertex_colors: false,
                    maps: false,
                    normal_maps: false,
                    alpha: false,
                    blend: false,
                    environment: false,
                    queries,
                    f64,
                    shapes: Shapes::ALL,
                    surface_rays: b & 3 != 0,
                    bvh_shadows: b & 1 != 0,
                    counters: true,
                })
            })
        });
        let shapes = [false, true].into_iter().flat_map(|f64| {
            Queries::ALL.into_iter().flat_map(move |queries| {
                (0..7u32).map(move |b| {
                    let shapes = Shapes { spheres: b & 1 != 0, triangles: b & 2 != 0, cylinders: b & 4 != 0 };
                    Variant { f64, shapes, ..Variant::full(queries) }
                })
            })
        });
        let point_lit = [false, true].into_iter().flat_map(|f64| {
            Queries::ALL.into_iter().flat_map(move |queries| {
                [false, true].map(move |more| Variant {
                    shadows: true,
                    textures: more,
                    emission: more,
                    vertex_colors: more,
                    maps: more,
                    normal_maps: more,
                    alpha: more,
                    blend: more,
                    queries,
                    f64,
                    shapes: Shapes::ALL,
                    counters: true,
                    ..Variant::default()
                })
            })
        });
        let uncounted = [false, true].into_iter().flat_map(|f64| {
            Queries::ALL
                .into_iter()
                .map(move |queries| Variant { f64, ..Variant::full(queries) }.with_counters(false))
        });
        // The map effects apart: maps, normal maps, a mask alone, a blend alone (which needs
        // no texture), so that none leans on another's code.
        let apart = [false, true].into_iter().flat_map(|f64| {
            Queries::ALL.into_iter().flat_map(move |queries| {
                let base = Variant { shadows: true, reflection: true, queries, f64, ..Variant::default() };
                [
                    Variant { textures: true, maps: true, ..base },
                    Variant { textures: true, normal_maps: true, ..base },
                    Variant { textures: true, alpha: true, ..base },
                    Variant { blend: true, surface_rays: true, ..base },
                    Variant { surface_rays: true, bvh_shadows: false, ..base },
                    Variant { environment: true, ..base },
                ]
            })
        });
        effects.chain(shapes).chain(point_lit).chain(uncounted).chain(apart).collect()
    }

    /// Every effect with `queries`.
    pub fn full(queries: Queries) -> Variant {
        Variant { queries, ..Variant::for_effects(Effects::ALL, crate::layout::MAX_DEPTH) }
    }

    fn flag(&self, name: &str) -> Option<bool> {
        Some(match name {
            "SHADOWS" => self.shadows,
            "REFLECTION" => self.reflection,
            "REFRACTION" => self.refraction,
            "TEXTURES" => self.textures,
            "EMISSION" => self.emission,
            "VERTEX_COLORS" => self.vertex_colors,
            "MAPS" => self.maps,
            "NORMAL_MAPS" => self.normal_maps,
            "ALPHA" => self.alpha,
            "BLEND" => self.blend,
            "ENVIRONMENT" => self.environment,
            // Shadow walks test alpha: masked or blended materials.
            "CUTOUTS" => self.alpha || self.blend,
            "F64" => self.f64,
            "SPHERES" => self.shapes.spheres,
            "TRIANGLES" => self.shapes.triangles,
            "CYLINDERS" => self.shapes.cylinders,
            // Rays leave surfaces: reflection and refraction rays, and shadow rays towards
            // directional lights (which have no table).
            "SURFACE_RAYS" => self.surface_rays,
            // Shadow rays walk the BVH: all of them with the BVH, with the tables those
            // towards directional lights.
            "BVH_SHADOWS" => match self.queries {
                Queries::Bvh => true,
                Queries::Tables => self.surface_rays && self.bvh_shadows,
                Queries::Brute => false,
            },
            "COUNTERS" => self.counters,
            "TABLES" => self.queries == Queries::Tables,
            "BVH" => self.queries == Queries::Bvh,
            "BRUTE" => self.queries == Queries::Brute,
            _ => return None,
        })
    }
}

/// The WGSL source of `kernel` for `variant`.
pub fn compose(kernel: Kernel, variant: Variant) -> Result<String> {
    compose_from(SOURCES, &kernel.file(), variant)
}

/// The WGSL of a module whose root file is `root` (text, not a kernel of `shaders/`),
/// composed with the shared files it includes for `variant`: for tests that run the
/// kernels' shared functions on their own inputs.
pub fn compose_root(root: &str, variant: Variant) -> Result<String> {
    let mut sources = SOURCES.to_vec();
    sources.push(("<root>", root));
    compose_from(&sources, "<root>", variant)
}

/// Composes `root` from `sources` (name, text).
fn compose_from(sources: &[(&str, &str)], root: &str, variant: Variant) -> Result<String> {
    let mut out = String::new();
    let mut included = Vec::new();
    expand(sources, root, variant, &mut out, &mut included)?;
    Ok(out)
}

fn expand(
    sources: &[(&str, &str)],
    file: &str,
    variant: Variant,
    out: &mut String,
    included: &mut Vec<String>,
) -> Result<()> {
    if included.iter().any(|f| f == file) {
        return Ok(());
    }
    included.push(file.to_string());
    let err = |line: usize, message: String| Error::Shader { file: file.to_string(), line, message };
    let src = sources
        .iter()
        .find(|(n, _)| *n == file)
        .map(|(_, s)| *s)
        .ok_or_else(|| err(0, format!("no shader file named {file}")))?;
    // Each open #if: (this branch is kept, the enclosing lines are kept, seen #else).
    let mut stack: Vec<(bool, bool, bool)> = Vec::new();
    let active = |stack: &[(bool, bool, bool)]| stack.last().is_none_or(|&(on, outer, _)| on && outer);
    for (n, line) in src.lines().enumerate() {
        let n = n + 1;
        let t = line.trim();
        if let Some(name) = t.strip_prefix("#if ") {
            let name = name.trim();
            let on = variant.flag(name).ok_or_else(|| err(n, format!("unknown flag {name}")))?;
            let outer = active(&stack);
            stack.push((on, outer, false));
        } else if t == "#else" {
            let top = stack.last_mut().ok_or_else(|| err(n, "#else without #if".into()))?;
            if top.2 {
                return Err(err(n, "second #else".into()));
            }
            *top = (!top.0, top.1, true);
        } else if t == "#endif" {
            stack.pop().ok_or_else(|| err(n, "#endif without #if".into()))?;
        } else if let Some(rest) = t.strip_prefix("#include ") {
            if active(&stack) {
                let name = rest.trim().trim_matches('"');
                expand(sources, name, variant, out, included)?;
            }
        } else if t.starts_with('#') {
            return Err(err(n, format!("unknown directive {t}")));
        } else if active(&stack) {
            out.push_str(line);
            out.push('\n');
        }
    }
    if !stack.is_empty() {
        return Err(err(src.lines().count(), "#if without #endif".into()));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flags_select_lines() {
        let all = compose(Kernel::Shade, Variant::full(Queries::Tables)).unwrap();
        let none = compose(Kernel::Shade, Variant::default()).unwrap();
        assert!(all.contains("fn reflect_dir") && all.contains("fn refract_dir"));
        assert!(!none.contains("fn reflect_dir") && !none.contains("fn refract_dir"));
        assert!(!none.contains("#"), "a directive leaked into the module");
    }

    #[test]
    fn nesting_else_and_includes() {
        let src = [
            ("a", "top\n#if SHADOWS\ns\n#if TEXTURES\nst\n#else\ns-no-t\n#endif\n#else\nno-s\n#endif\n#include \"b\"\n#include \"b\""),
            ("b", "bee"),
        ];
        let v = Variant { shadows: true, ..Variant::default() };
        assert_eq!(compose_from(&src, "a", v).unwrap(), "top\ns\ns-no-t\nbee\n");
        assert_eq!(compose_from(&src, "a", Variant::default()).unwrap(), "top\nno-s\nbee\n");
    }

    #[test]
    fn malformed_sources_are_errors_with_file_and_line() {
        let v = Variant::default();
        let e = compose_from(&[("a", "x\n#if NOPE\n#endif")], "a", v).unwrap_err();
        let Error::Shader { file, line, .. } = &e else { panic!("{e:?}") };
        assert_eq!((file.as_str(), *line), ("a", 2));
        assert!(e.to_string().contains("unknown flag NOPE"));
        assert!(compose_from(&[("a", "#if SHADOWS\n")], "a", v).is_err());
        assert!(compose_from(&[("a", "#endif\n")], "a", v).is_err());
        assert!(compose_from(&[("a", "#if SHADOWS\n#else\n#else\n#endif")], "a", v).is_err());
        assert!(compose_from(&[("a", "#include \"missing\"")], "a", v).is_err());
        assert!(compose_from(&[("a", "#define X")], "a", v).is_err());
    }
}
