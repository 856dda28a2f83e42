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
//! (shadow walks test alpha: `ALPHA` or `BLEND`), `ENVIRONMENT` (rays leaving the scene
//! read the environment map), `VOLUME` (attenuation inside transmitting bodies), `CLEARCOAT`
//! (clear coats over materials), `F64`, `SPHERES`, `TRIANGLES` and `CYLINDERS`, `SURFACE_RAYS`
//! (rays leave surfaces: reflection, refraction and pass-through rays, shadow rays towards a
//! directional light; the BVH or ray queries take them), `BVH_SHADOWS` (shadow rays take
//! that walk too), `SURFACE_RQ` (with the tables, ray queries take them),
//! `COUNTERS` (the statistics counters), and `CUBE`, `BVH`, `BRUTE` and `RAYQUERY`,
//! of which exactly one is set: the walk `shared/query.wgsl`'s queries go over, the
//! candidate tables' of `shared/walk.wgsl`, the BVH's of `shared/bvh.wgsl`, brute force's
//! of `shared/brute.wgsl` or the platform's ray queries of `shared/rayquery.wgsl`. The table
//! walk includes the BVH walk with `SURFACE_RAYS`, or with `SURFACE_RQ` the ray queries'.
//! A module that uses ray queries (`RAY_QUERIES`) starts with `enable wgpu_ray_query;`.
//! A scene without mirrors thus gets a module with no reflection code at all, not a branch
//! that is never taken.

pub use super::variant::{Accel, Variant};
use crate::error::{Error, Result};
use crate::job::KernelForm;

/// The shader sources, by their path under `shaders/`.
const SOURCES: &[(&str, &str)] = &[
    ("nearest.wgsl", include_str!("../../shaders/nearest.wgsl")),
    ("shade.wgsl", include_str!("../../shaders/shade.wgsl")),
    ("shadow.wgsl", include_str!("../../shaders/shadow.wgsl")),
    ("resolve.wgsl", include_str!("../../shaders/resolve.wgsl")),
    ("aov.wgsl", include_str!("../../shaders/aov.wgsl")),
    ("tree.wgsl", include_str!("../../shaders/tree.wgsl")),
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
    ("shared/rayquery.wgsl", include_str!("../../shaders/shared/rayquery.wgsl")),
    ("shared/sampling.wgsl", include_str!("../../shaders/shared/sampling.wgsl")),
    ("shared/primary.wgsl", include_str!("../../shaders/shared/primary.wgsl")),
    ("shared/bilinear.wgsl", include_str!("../../shaders/shared/bilinear.wgsl")),
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
    /// The register form ([`KernelForm::Tree`]): traces each point's whole ray tree
    /// of one sample, depth first, and adds its radiance once.
    Tree,
    /// The preview's accumulation of a finished tile.
    Accumulate,
    /// The preview's display pass (vertex `vs_main`, fragment `fs_main`).
    Display,
}

impl Kernel {
    pub const ALL: [Kernel; 8] = [
        Kernel::Nearest,
        Kernel::Shade,
        Kernel::Shadow,
        Kernel::Resolve,
        Kernel::Aov,
        Kernel::Tree,
        Kernel::Accumulate,
        Kernel::Display,
    ];

    /// The wavefront kernels a render with `variant` runs (the shadow kernel only with
    /// shadows), each with the depths whose passes it serves: `nearest` twice where the
    /// tables send rays leaving surfaces to the BVH ([`Depths`]).
    pub fn wavefront(variant: Variant) -> Vec<Stage> {
        let all = |kernel| Stage { kernel, depths: Depths::All };
        let mut k = Vec::new();
        if variant.cube() && variant.surface_rays {
            k.push(Stage { kernel: Kernel::Nearest, depths: Depths::Eye });
            k.push(Stage { kernel: Kernel::Nearest, depths: Depths::Later });
        } else {
            k.push(all(Kernel::Nearest));
        }
        k.push(all(Kernel::Shade));
        if variant.effects.shadows {
            k.push(all(Kernel::Shadow));
        }
        k.push(all(Kernel::Resolve));
        k
    }

    /// The kernels a render of `variant` runs in `form` (resolved), `untabled_eye` where the
    /// tables left the eye without one: [`Kernel::wavefront`] or
    /// [`Kernel::wavefront_untabled_eye`]; in the register form the `tree` kernel, one
    /// module for every depth (in the variant of [`Depths::Untabled`] where the eye has no
    /// table), and `resolve`.
    pub fn traced(form: KernelForm, variant: Variant, untabled_eye: bool) -> Vec<Stage> {
        match (form, untabled_eye) {
            (KernelForm::Tree, _) => {
                let depths = if untabled_eye { Depths::Untabled } else { Depths::All };
                vec![
                    Stage { kernel: Kernel::Tree, depths },
                    Stage { kernel: Kernel::Resolve, depths: Depths::All },
                ]
            }
            (_, true) => Kernel::wavefront_untabled_eye(variant),
            (_, false) => Kernel::wavefront(variant),
        }
    }

    /// [`Kernel::wavefront`] for a render with the tables whose eye has none (`--accel
    /// auto` left it without): the eye's rays walk what the later depths' rays walk, so one
    /// `nearest` module, the later depths', serves every depth.
    pub fn wavefront_untabled_eye(variant: Variant) -> Vec<Stage> {
        Kernel::wavefront(variant)
            .into_iter()
            .filter(|s| s.depths != Depths::Eye)
            .map(|s| match s.depths {
                Depths::Later => Stage { depths: Depths::Untabled, ..s },
                _ => s,
            })
            .collect()
    }

    /// The kernel's name: its file stem, entry point (compute kernels) and pipeline label.
    pub fn name(self) -> &'static str {
        match self {
            Kernel::Nearest => "nearest",
            Kernel::Shade => "shade",
            Kernel::Shadow => "shadow",
            Kernel::Resolve => "resolve",
            Kernel::Aov => "aov",
            Kernel::Tree => "tree",
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
    /// the BVH or take ray queries: the module of `--accel bvh` or `rayquery`, without the
    /// table walk. On lavapipe a kernel pays for code it does not take: the table kernel's
    /// walk of these rays cost up to 37 % more than the BVH kernel's (mount_s6), and its eye
    /// walks carried the BVH loop.
    Later,
    /// Every depth, in the module of [`Depths::Later`]: the eye has no table
    /// ([`Kernel::wavefront_untabled_eye`]).
    Untabled,
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
            Depths::Later | Depths::Untabled => {
                let accel = if variant.surface_rq { Accel::RayQuery } else { Accel::Bvh };
                Variant { accel, surface_rays: true, ..variant }
            }
        }
    }

    /// Whether the stage runs the passes of depth `depth` (the eye's: 1).
    pub fn serves(self, depth: u32) -> bool {
        match self.depths {
            Depths::All => true,
            Depths::Eye => depth <= 1,
            Depths::Later => depth > 1,
            Depths::Untabled => true,
        }
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
    // WGSL wants its `enable` directives before any declaration.
    let mut out = if variant.ray_queries() { "enable wgpu_ray_query;\n".to_string() } else { String::new() };
    let mut included = Vec::new();
    let flags = Flags { variant, tree: root == Kernel::Tree.file() };
    expand(sources, root, flags, &mut out, &mut included)?;
    Ok(out)
}

/// The preprocessor's flags: the variant's, and `TREE`, set in the `tree` kernel's module
/// (the hooks of `shared/shade.wgsl` that differ between the kernel forms).
#[derive(Clone, Copy)]
struct Flags {
    variant: Variant,
    tree: bool,
}

impl Flags {
    fn get(self, name: &str) -> Option<bool> {
        match name {
            "TREE" => Some(self.tree),
            _ => self.variant.flag(name),
        }
    }
}

fn expand(
    sources: &[(&str, &str)],
    file: &str,
    flags: Flags,
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
            let on = flags.get(name).ok_or_else(|| err(n, format!("unknown flag {name}")))?;
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
                expand(sources, name, flags, out, included)?;
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
        let all = compose(Kernel::Shade, Variant::full(Accel::Cube)).unwrap();
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
        let v = Variant {
            effects: crate::scene::Effects { shadows: true, ..Default::default() },
            ..Variant::default()
        };
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
