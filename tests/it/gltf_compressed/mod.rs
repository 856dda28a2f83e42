//! glTF as the optimizers write it. Every file that gltfpack (defaults, `-c`, `-cc`, `-mi`,
//! `-kn`) and gltf-transform (`optimize`, `draco`, `meshopt`, `quantize`, `webp`) write from
//! the eleven sample models loads, renders on the GPU within FLIP 0.02 of the uncompressed
//! original (the original's camera, the same size and samples), and agrees with the CPU
//! reference within FLIP 0.01. The files are written here, on first use, by the npm tools
//! `.ci/setup` installs under `target/npm`, into the tests' scratch folder; a test fails,
//! saying how to install them, when they are missing.
//!
//! The images are 64² (16 samples a pixel against the original, 4 against the CPU), to
//! keep the suite fast on lavapipe; the same
//! tests at 256², as docs/scenes.md reports them, are
//! `CUBERAY_COMPRESSED_SIZE=256 cargo test --release --test it gltf_compressed -- --nocapture`.
//! `bad` holds the malformed streams, which need neither the tools nor the models.

mod bad;

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::{Arc, Mutex, OnceLock};

use cuberay::compare::compare;
use cuberay::job::RenderOptions;
use cuberay::load::{self, Loaded};
use cuberay::output::Image;
use cuberay::reference;
use cuberay::scene::Camera;
use indicatif::ProgressBar;

use crate::common::renderer;

/// The versions `.ci/setup` installs; the generated files are kept per version.
pub const GLTFPACK: &str = "1.3.0";
pub const GLTF_TRANSFORM: &str = "4.5.1";

/// The folder of the npm tools' commands (`target/npm/node_modules/.bin`, or
/// `$CUBERAY_NPM_BIN`). Panics, saying how to install them, when gltfpack is not there.
pub fn npm_bin() -> PathBuf {
    let dir = std::env::var_os("CUBERAY_NPM_BIN")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("target/npm/node_modules/.bin"));
    for tool in ["gltfpack", "gltf-transform"] {
        assert!(
            dir.join(tool).exists(),
            "{tool} is missing from {}: run `bash .ci/setup`, which installs gltfpack@{GLTFPACK} and \
             @gltf-transform/cli@{GLTF_TRANSFORM} there (or set CUBERAY_NPM_BIN)",
            dir.display()
        );
    }
    dir
}

/// The image size: 64, or `$CUBERAY_COMPRESSED_SIZE` (256 for the documented measurement).
fn size() -> u32 {
    std::env::var("CUBERAY_COMPRESSED_SIZE").ok().and_then(|s| s.parse().ok()).unwrap_or(64)
}

/// Samples a pixel of the renders compared with the original: 16, so that both are near
/// their converged images. At 4, texture aliasing alone (a texel more or less under a
/// sample, from UVs quantized to 12 bits) put ToyCar's velvet 0.02 to 0.04 apart, which
/// no decoding error did.
const SPP_AGAINST_ORIGINAL: u32 = 16;

/// Runs one of the npm tools, failing the test with its output when it fails.
pub fn run_tool(tool: &str, args: &[&std::ffi::OsStr]) {
    // The tools' `#!/usr/bin/env node` takes npm's Node.js where `.ci/setup` installed one
    // beside them (the system's is older than gltf-transform needs, as Debian 12's).
    let bin = npm_bin();
    let path = std::env::join_paths(
        std::iter::once(bin.clone())
            .chain(std::env::split_paths(&std::env::var_os("PATH").unwrap_or_default())),
    )
    .expect("PATH joins");
    let out =
        Command::new(bin.join(tool)).args(args).env("PATH", path).output().expect("the npm tool starts");
    assert!(
        out.status.success(),
        "{tool} {args:?} failed: {}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The file `variant` writes from the sample model `model` (a path under the shared glTF
/// folder), written on first use into the tests' scratch folder. Two variants are the
/// lossless twins of lossy ones: `webp-png` is the `webp` file with its textures decoded by
/// gltf-transform (libwebp) and written as PNG, `optimize-uncompressed` is `optimize`
/// without its meshopt compression and quantization.
fn generated(model: &str, variant: &str) -> PathBuf {
    let src = crate::common::shared(&format!("gltf/{model}"));
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("compressed-gltfpack{GLTFPACK}-gltf-transform{GLTF_TRANSFORM}"));
    std::fs::create_dir_all(&dir).unwrap();
    let stem = Path::new(model).file_stem().unwrap().to_str().unwrap();
    let out = dir.join(format!("{stem}.{variant}.glb"));
    if out.is_file() {
        return out;
    }
    // Written beside, then renamed: a test never sees half a file.
    let part = dir.join(format!("{stem}.{variant}.part.glb"));
    let (i, o) = (src.as_os_str(), part.as_os_str());
    match (variant, variant.strip_prefix("gltfpack")) {
        (_, Some("")) => run_tool("gltfpack", &["-i".as_ref(), i, "-o".as_ref(), o]),
        (_, Some(flag)) => run_tool("gltfpack", &["-i".as_ref(), i, "-o".as_ref(), o, flag.as_ref()]),
        ("webp-png", _) => {
            run_tool("gltf-transform", &["png".as_ref(), generated(model, "webp").as_os_str(), o])
        }
        ("optimize-uncompressed", _) => {
            run_tool("gltf-transform", &["optimize".as_ref(), i, o, "--compress".as_ref(), "false".as_ref()])
        }
        _ => run_tool("gltf-transform", &[variant.as_ref(), i, o]),
    }
    std::fs::rename(&part, &out).unwrap();
    out
}

/// The files whose tool loses more than FLIP 0.02 of the original by design, with the bound
/// they are held to against it (a little over what was measured, at 64² and 256²), and the
/// lossless twin they must match, which shows the loss is the tool's and not the decoding's:
/// WebP at gltf-transform's default quality on ToyCar's metallic-roughness and clearcoat maps
/// and on the lamp's textures (measured 0.036 and 0.024 at 64², 0.034 and 0.011 at 256²;
/// against the PNGs libwebp decodes, 0.0000), and `optimize`'s simplification of ToyCar
/// from 108936 to 80928 triangles (0.040 and 0.036; against `optimize` without compression
/// 0.015 and 0.014, what quantizing alone costs ToyCar's mirror-like paint in every
/// quantized file, held to 0.02 as they are).
const LOSSY: &[(&str, &str, f64, &str, f64)] = &[
    ("ToyCar/ToyCar.gltf", "webp", 0.04, "webp-png", 0.01),
    ("ToyCar/ToyCar.gltf", "optimize", 0.045, "optimize-uncompressed", 0.02),
    ("LightsPunctualLamp/LightsPunctualLamp.gltf", "webp", 0.03, "webp-png", 0.01),
];

/// A scene set up as `cuberay render` sets it up (the studio environment where the file
/// has no light), looking through `camera` when given.
fn setup(path: &Path, camera: Option<&Camera>) -> Loaded {
    let mut loaded = load::load(path, &Default::default()).unwrap_or_else(|e| panic!("{e}"));
    if let Some(c) = camera {
        loaded.scene.camera = c.clone();
    }
    load::apply_setup(&mut loaded, path, &Default::default()).unwrap_or_else(|e| panic!("{e}"));
    loaded
}

/// The renders compared with the CPU's: 4 samples a pixel, as the GPU's other tests.
fn options() -> RenderOptions {
    RenderOptions { spp: 4, ..RenderOptions::new(size(), size()) }
}

/// The renders compared with the original's.
fn converged() -> RenderOptions {
    RenderOptions { spp: SPP_AGAINST_ORIGINAL, ..options() }
}

/// An original model's camera, its number of primitives, and its render on the GPU (not the
/// scene itself: eleven of them, textures and all, would stay in memory for the whole run).
type Original = Arc<(Camera, usize, Image)>;

/// The original model loaded and rendered on the GPU, once per model for all its variants.
fn original(model: &str) -> Original {
    static CACHE: OnceLock<Mutex<HashMap<String, Arc<OnceLock<Original>>>>> = OnceLock::new();
    let cell = CACHE.get_or_init(Default::default).lock().unwrap().entry(model.into()).or_default().clone();
    cell.get_or_init(|| {
        let loaded = setup(&crate::common::shared(&format!("gltf/{model}")), None);
        let image = renderer().render(&loaded.scene, &converged(), &ProgressBar::hidden()).unwrap().image;
        Arc::new((loaded.scene.camera, loaded.scene.primitives.len(), image))
    })
    .clone()
}

/// FLIP mean of `b` against `a`; over `limit`, the test fails and leaves both images.
fn flip_within(name: &str, labels: [&str; 2], a: &Image, b: &Image, limit: f64) -> f64 {
    let (cmp, heat) = compare(a, b, 2.0 / 255.0);
    if cmp.flip_mean > limit {
        let n = size();
        let files = crate::common::save_failure(name, &[(labels[0], a), (labels[1], b)], Some((&heat, n, n)));
        panic!(
            "{name}: FLIP mean {} of {} against {} > {limit}; images: {files}",
            cmp.flip_mean, labels[1], labels[0]
        );
    }
    cmp.flip_mean
}

/// One generated file against its original and against the CPU.
fn variant_matches_the_original(model: &str, variant: &str) {
    let path = generated(model, variant);
    let orig = original(model);
    let loaded = setup(&path, Some(&orig.0));
    let name = format!("{model} {variant}");
    let render = |opts: &RenderOptions| {
        let r = renderer().render(&loaded.scene, opts, &ProgressBar::hidden());
        let image = r.unwrap_or_else(|e| panic!("{name}: {e}")).image;
        assert!(image.is_finite(), "{name}: a non-finite pixel");
        image
    };
    let image = render(&converged());
    let lossy = LOSSY.iter().find(|l| l.0 == model && l.1 == variant);
    let vs_original =
        flip_within(&name, ["original", "compressed"], &orig.2, &image, lossy.map_or(0.02, |l| l.2));
    if let Some(&(.., twin, bound)) = lossy {
        let twin_scene = setup(&generated(model, twin), Some(&orig.0)).scene;
        let twin_image = renderer().render(&twin_scene, &converged(), &ProgressBar::hidden()).unwrap().image;
        let flip = flip_within(&name, [twin, "compressed"], &twin_image, &image, bound);
        eprintln!("compressed: {model} {variant}: FLIP {flip:.4} against {twin}, its lossless twin");
    }
    let (opts, gpu) = (options(), render(&options()));
    let cpu = reference::render(&loaded.scene, &opts, &ProgressBar::hidden()).unwrap();
    let vs_cpu = flip_within(&name, ["cpu", "gpu"], &cpu.image, &gpu, 0.01);
    let bytes = std::fs::metadata(&path).unwrap().len();
    eprintln!(
        "compressed: {model} {variant} ({bytes} bytes, {} triangles against {}): FLIP {vs_original:.4} against \
         the original ({SPP_AGAINST_ORIGINAL} spp), {vs_cpu:.4} GPU against CPU (4 spp), {}²",
        loaded.scene.primitives.len(),
        orig.1,
        size()
    );
}

/// One test per model and variant: `variants!(module: "Model/Model.gltf")`.
macro_rules! variants {
    ($module:ident: $model:literal) => {
        mod $module {
            fn case(variant: &str) {
                super::variant_matches_the_original($model, variant)
            }
            #[test]
            fn gltfpack() {
                case("gltfpack")
            }
            #[test]
            fn gltfpack_c() {
                case("gltfpack-c")
            }
            #[test]
            fn gltfpack_cc() {
                case("gltfpack-cc")
            }
            #[test]
            fn gltfpack_mi() {
                case("gltfpack-mi")
            }
            #[test]
            fn gltfpack_kn() {
                case("gltfpack-kn")
            }
            #[test]
            fn optimize() {
                case("optimize")
            }
            #[test]
            fn draco() {
                case("draco")
            }
            #[test]
            fn meshopt() {
                case("meshopt")
            }
            #[test]
            fn quantize() {
                case("quantize")
            }
            #[test]
            fn webp() {
                case("webp")
            }
        }
    };
}

variants!(avocado: "Avocado/Avocado.gltf");
variants!(box_: "Box/Box.gltf");
variants!(box_textured: "BoxTextured/BoxTextured.gltf");
variants!(cameras: "Cameras/Cameras.gltf");
variants!(cornell_box: "CornellBox/CornellBox.glb");
variants!(damaged_helmet: "DamagedHelmet/DamagedHelmet.gltf");
variants!(flight_helmet: "FlightHelmet/FlightHelmet.gltf");
variants!(lights_punctual_lamp: "LightsPunctualLamp/LightsPunctualLamp.gltf");
variants!(metal_rough_spheres: "MetalRoughSpheresNoTextures/MetalRoughSpheresNoTextures.gltf");
variants!(suzanne: "Suzanne/Suzanne.gltf");
variants!(toy_car: "ToyCar/ToyCar.gltf");

/// EXT_mesh_gpu_instancing: sixteen copies of Suzanne on a grid, written as sixteen nodes,
/// and gltfpack `-mi`'s one instanced node of them, give the same triangles and image; the
/// bytes the expansion costs against one mesh and sixteen transforms are printed
/// (docs/scenes.md).
#[test]
fn instances_expand_into_the_triangles_of_separate_nodes() {
    let src = crate::common::shared("gltf/Suzanne/Suzanne.gltf");
    let dir = tempfile::tempdir().unwrap();
    let mut doc: serde_json::Value = serde_json::from_slice(&std::fs::read(&src).unwrap()).unwrap();
    // Beside the files it names (gltfpack reads only relative URIs).
    for list in ["buffers", "images"] {
        for item in doc[list].as_array().into_iter().flatten() {
            let uri = item["uri"].as_str().unwrap();
            std::fs::copy(src.parent().unwrap().join(uri), dir.path().join(uri)).unwrap();
        }
    }
    let nodes: Vec<serde_json::Value> = (0..16)
        .map(|k| serde_json::json!({"mesh": 0, "translation": [2.5 * (k % 4) as f64, 2.5 * (k / 4) as f64, 0.0]}))
        .collect();
    doc["nodes"] = nodes.into();
    doc["scenes"] = serde_json::json!([{"nodes": (0..16).collect::<Vec<_>>()}]);
    let separate = dir.path().join("separate.gltf");
    std::fs::write(&separate, serde_json::to_vec(&doc).unwrap()).unwrap();
    let instanced = dir.path().join("instanced.glb");
    run_tool(
        "gltfpack",
        &["-i".as_ref(), separate.as_os_str(), "-o".as_ref(), instanced.as_os_str(), "-mi".as_ref()],
    );
    let json = bad::glb_json(&std::fs::read(&instanced).unwrap());
    assert!(
        json["extensionsUsed"].to_string().contains("EXT_mesh_gpu_instancing"),
        "gltfpack -mi did not instance"
    );

    let a = setup(&separate, None);
    let b = setup(&instanced, Some(&a.scene.camera));
    let one = load::load(&src, &Default::default()).unwrap().scene.primitives.len();
    assert_eq!(a.scene.primitives.len(), 16 * one);
    assert_eq!(b.scene.primitives.len(), a.scene.primitives.len());
    let opts = converged();
    let ga = renderer().render(&a.scene, &opts, &ProgressBar::hidden()).unwrap();
    let gb = renderer().render(&b.scene, &opts, &ProgressBar::hidden()).unwrap();
    let flip = flip_within("instanced Suzanne", ["separate", "instanced"], &ga.image, &gb.image, 0.02);

    // What the expansion costs: every instance's triangles, in the scene and packed for the
    // GPU, against one mesh's and a 3×4 f32 transform per instance.
    let scene_bytes = |n: usize| n * std::mem::size_of::<cuberay::scene::Primitive>();
    let packed = cuberay::layout::pack(&b.scene, opts.width, opts.height, opts.spawn);
    let gpu_bytes = std::mem::size_of_val(&packed.prims[..]) + std::mem::size_of_val(&packed.tri_attrs[..]);
    let n = b.scene.primitives.len();
    eprintln!(
        "instancing: 16 instances of {one} triangles, FLIP {flip:.4}: scene {} bytes expanded against {} for one mesh \
         and 16 transforms; packed for the GPU {gpu_bytes} bytes against {}",
        scene_bytes(n),
        scene_bytes(one) + 16 * 48,
        gpu_bytes / 16 + 16 * 48
    );
}
