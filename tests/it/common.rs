//! Helpers shared by the integration tests: where the scenes are, the binary under test,
//! the one GPU renderer, and what a failed comparison leaves behind.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use cuberay::gpu::GpuRenderer;

/// The third-party scenes folder (`../shared/scenes` beside the repository, or
/// `$CUBERAY_SHARED_SCENES`). Panics with a plain message when it is missing: tests that
/// need these scenes must not pass silently without them.
pub fn shared_scenes() -> PathBuf {
    if let Ok(dir) = std::env::var("CUBERAY_SHARED_SCENES") {
        let p = PathBuf::from(dir);
        assert!(p.is_dir(), "CUBERAY_SHARED_SCENES={} is not a directory", p.display());
        return p;
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for dir in root.ancestors() {
        let candidate = dir.join("shared").join("scenes");
        if candidate.is_dir() && dir != root {
            return candidate;
        }
    }
    panic!(
        "the shared scenes folder is missing: expected ../shared/scenes beside {} (or set \
         CUBERAY_SHARED_SCENES). These tests read the SPD databases and glTF sample models from it.",
        root.display()
    );
}

/// A file under the shared scenes folder, which must exist.
pub fn shared(rel: &str) -> PathBuf {
    let p = shared_scenes().join(rel);
    assert!(p.exists(), "missing shared scene file {}", p.display());
    p
}

/// A file of the project's own hard-case scenes (`scenes/hard/`).
pub fn hard(file: &str) -> PathBuf {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/hard").join(file);
    assert!(p.exists(), "missing hard-case scene {}", p.display());
    p
}

/// The GPU renderer every test shares (one device; a test that needs its own makes it).
/// Without a Vulkan adapter it fails, saying how to install one.
pub fn renderer() -> &'static GpuRenderer {
    static R: OnceLock<GpuRenderer> = OnceLock::new();
    R.get_or_init(|| GpuRenderer::new().unwrap_or_else(|e| panic!("{e}")))
}

/// The cuberay binary built for these tests.
pub fn cuberay() -> std::process::Command {
    std::process::Command::new(env!("CARGO_BIN_EXE_cuberay"))
}

/// Writes the images of a failed comparison (`name.LABEL.png` for each image, and the FLIP
/// heat map when given) into the tests' scratch folder and returns where they went, for the
/// failure message.
pub fn save_failure(
    name: &str,
    images: &[(&str, &cuberay::output::Image)],
    flip: Option<(&[u8], u32, u32)>,
) -> String {
    let safe: String =
        name.chars().map(|c| if c.is_ascii_alphanumeric() || c == '_' { c } else { '-' }).collect();
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("failures");
    std::fs::create_dir_all(&dir).expect("the failure folder");
    let mut written = Vec::new();
    for (label, image) in images {
        let p = dir.join(format!("{safe}.{label}.png"));
        // AOV images are linear data: save them as EXR.
        let p = if image.has_alpha { p.with_extension("exr") } else { p };
        cuberay::output::write(image, &p).expect("a failure image");
        written.push(p);
    }
    if let Some((rgb, w, h)) = flip {
        let p = dir.join(format!("{safe}.flip.png"));
        cuberay::output::write_rgb8(w, h, rgb.to_vec(), &p).expect("the FLIP map");
        written.push(p);
    }
    written.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", ")
}

/// The first pixel (x, y) where two images differ in any bit, with both values.
pub fn first_difference(
    a: &cuberay::output::Image,
    b: &cuberay::output::Image,
) -> Option<(u32, u32, [f32; 4], [f32; 4])> {
    let i = a.pixels.iter().zip(&b.pixels).position(|(p, q)| p.map(f32::to_bits) != q.map(f32::to_bits))?;
    Some((i as u32 % a.width, i as u32 / a.width, a.pixels[i], b.pixels[i]))
}

/// One test per case, in a module of the cases' name: a failure names its case and hides no
/// other. `cases!(module: function { test_name => (arguments...), ... })`.
#[macro_export]
macro_rules! cases {
    ($module:ident: $case:path { $($name:ident => ($($arg:expr),* $(,)?)),* $(,)? }) => {
        mod $module {
            $(
                #[test]
                fn $name() {
                    $case($($arg),*)
                }
            )*
        }
    };
}

/// One test per SPD database: `spd_cases!(module: function => [balls, gears, ...])` calls
/// `function("balls")` in the test `module::balls`, and so on.
#[macro_export]
macro_rules! spd_cases {
    ($module:ident: $case:path => [$($db:ident),* $(,)?]) => {
        mod $module {
            $(
                #[test]
                fn $db() {
                    $case(stringify!($db))
                }
            )*
        }
    };
}
