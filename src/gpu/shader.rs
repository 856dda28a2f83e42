//! Composing the WGSL kernels per effect set.
//!
//! The kernels live in `shaders/` (one file per stage plus shared includes) and are
//! embedded in the binary. A tiny line-based preprocessor composes one module per
//! [`Variant`]: `#include "file.wgsl"` pastes a file (once), and `#if NAME` / `#else` /
//! `#endif` (nestable) keep or drop lines by the variant's flags `SHADOWS`, `REFLECTION`,
//! `REFRACTION`, `TEXTURES` and `EMISSION`, and `CUBE`, which picks the ray queries: the
//! candidate-table walk of `cube.wgsl` or the brute force of `brute.wgsl` (never both). A
//! scene without mirrors thus gets a module with no reflection code at all, not a branch
//! that is never taken.

use crate::error::{Error, Result};
use crate::scene::Effects;

/// The shader sources, by the name `#include` uses.
const SOURCES: &[(&str, &str)] = &[
    ("trace.wgsl", include_str!("../../shaders/trace.wgsl")),
    ("common.wgsl", include_str!("../../shaders/common.wgsl")),
    ("geometry.wgsl", include_str!("../../shaders/geometry.wgsl")),
    ("brute.wgsl", include_str!("../../shaders/brute.wgsl")),
    ("cube.wgsl", include_str!("../../shaders/cube.wgsl")),
    ("sampling.wgsl", include_str!("../../shaders/sampling.wgsl")),
    ("texture.wgsl", include_str!("../../shaders/texture.wgsl")),
    ("shade.wgsl", include_str!("../../shaders/shade.wgsl")),
];

/// The file every module starts from.
pub const ROOT: &str = "trace.wgsl";

/// The code paths one compiled module contains.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub struct Variant {
    pub shadows: bool,
    pub reflection: bool,
    pub refraction: bool,
    pub textures: bool,
    pub emission: bool,
    /// Trace the direction-cube tables (`--accel cube`) rather than every primitive.
    pub cube: bool,
}

impl Variant {
    /// The variant for a scene's effects rendered with `max_depth` (below 2 no secondary
    /// ray is ever spawned, so neither reflection nor refraction code is needed).
    pub fn for_effects(e: Effects, max_depth: u32) -> Variant {
        let secondary = max_depth >= 2;
        Variant {
            shadows: e.shadows,
            reflection: e.reflection && secondary,
            refraction: e.refraction && secondary,
            textures: e.textures,
            emission: e.emission,
            cube: false,
        }
    }

    /// The same effects traced with the tables (`true`) or by brute force.
    pub fn with_cube(self, cube: bool) -> Variant {
        Variant { cube, ..self }
    }

    /// Every one of the 64 variants; the last has every flag set.
    pub fn all() -> Vec<Variant> {
        (0..64u32)
            .map(|b| Variant {
                shadows: b & 1 != 0,
                reflection: b & 2 != 0,
                refraction: b & 4 != 0,
                textures: b & 8 != 0,
                emission: b & 16 != 0,
                cube: b & 32 != 0,
            })
            .collect()
    }

    fn flag(&self, name: &str) -> Option<bool> {
        Some(match name {
            "SHADOWS" => self.shadows,
            "REFLECTION" => self.reflection,
            "REFRACTION" => self.refraction,
            "TEXTURES" => self.textures,
            "EMISSION" => self.emission,
            "CUBE" => self.cube,
            _ => return None,
        })
    }
}

/// The WGSL source of `variant`.
pub fn compose(variant: Variant) -> Result<String> {
    compose_from(SOURCES, ROOT, variant)
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
        let all = compose(Variant::all()[63]).unwrap();
        let none = compose(Variant::default()).unwrap();
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
