//! Every file reader cuberay exposes to a user's files, driven from bytes: the fuzz targets
//! (`fuzz/fuzz_targets/`, cargo-fuzz on nightly) call [`run`], and so does the regression
//! test that replays what the campaigns found (`tests/it/fuzz.rs`, stable), so that both go
//! through the same code. A reader may refuse its input (an `Err`); it must never panic,
//! hang or allocate what the file does not hold, and what it accepts must not put a NaN or
//! an Inf into the buffers the GPU would get.
//!
//! Each input is written to a file in a scratch folder of its own thread, as a user's file
//! would be, and read through the public API: the scene loaders (`load::load`), the part
//! EXR reader of `cuberay merge`, and the tables file reader of `render --tables` with the
//! checks that precede an upload.

use std::io::Write;
use std::path::{Path, PathBuf};

use cuberay::job::RenderOptions;
use cuberay::load::{self, LoadOptions};

/// Which reader an input is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reader {
    /// An NFF file.
    Nff,
    /// A `.gltf` file, in a folder holding the buffer and image its seeds name
    /// (`data.bin`, `texture.png`), so that mutated references reach real files.
    Gltf,
    /// A `.glb` file.
    Glb,
    /// A `.glb` file as the glTF optimizers write it: quantized attributes, meshopt- and
    /// Draco-compressed geometry, instancing, WebP images (its seeds say which).
    Compressed,
    /// A part EXR, as `cuberay merge` reads it.
    PartExr,
    /// A tables file whose JSON header is given the key of the tables of [`tables_scene`]
    /// (when it parses), so that the reader goes past the key check to the arrays and the
    /// index checks that precede an upload.
    Tables,
    /// An environment map (`--env`): an equirectangular `.hdr` or `.exr`, and the lights
    /// median cut makes of it.
    Env,
}

impl Reader {
    pub const ALL: [Reader; 7] = [
        Reader::Nff,
        Reader::Gltf,
        Reader::Glb,
        Reader::Compressed,
        Reader::PartExr,
        Reader::Tables,
        Reader::Env,
    ];

    /// The target's name (its folder under `fuzz/seeds` and `fuzz/regressions`).
    pub fn name(self) -> &'static str {
        match self {
            Reader::Nff => "nff",
            Reader::Gltf => "gltf",
            Reader::Glb => "glb",
            Reader::Compressed => "compressed",
            Reader::PartExr => "part_exr",
            Reader::Tables => "tables",
            Reader::Env => "env",
        }
    }

    fn file_name(self) -> &'static str {
        match self {
            Reader::Nff => "scene.nff",
            Reader::Gltf => "scene.gltf",
            Reader::Glb | Reader::Compressed => "scene.glb",
            Reader::PartExr => "part.exr",
            Reader::Tables => "scene.tables",
            Reader::Env => "map.hdr",
        }
    }
}

/// The repository's root (the fuzz crate lives in its `fuzz/` folder).
fn repo() -> &'static Path {
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR"));
    if cfg!(fuzzing) {
        manifest.parent().expect("fuzz/ has a parent")
    } else {
        manifest
    }
}

/// The folder with the files a `.gltf` input may name beside it.
fn gltf_files() -> PathBuf {
    repo().join("fuzz/seeds/gltf-files")
}

/// A folder of this thread's own, removed when the thread ends.
struct Scratch(PathBuf);

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

thread_local! {
    static SCRATCH: Scratch = {
        let dir = std::env::temp_dir().join(format!(
            "cuberay-fuzz-{}-{:?}",
            std::process::id(),
            std::thread::current().id()
        ));
        std::fs::create_dir_all(&dir).expect("a scratch folder");
        for name in ["data.bin", "texture.png"] {
            std::fs::copy(gltf_files().join(name), dir.join(name)).expect("the glTF seed files");
        }
        Scratch(dir)
    };
}

/// Reads `bytes` with `reader`: `Ok` when the reader accepted the input (and what it gave
/// passed the checks below), `Err` with the reader's message when it refused it. Panics
/// only where cuberay is wrong: a reader's panic, or a NaN or Inf in accepted input.
pub fn run(reader: Reader, bytes: &[u8]) -> Result<(), String> {
    let path = SCRATCH.with(|dir| dir.0.join(reader.file_name()));
    let bytes = match reader {
        Reader::Tables => rekeyed(bytes),
        _ => bytes.to_vec(),
    };
    std::fs::File::create(&path).and_then(|mut f| f.write_all(&bytes)).expect("the scratch file");
    match reader {
        Reader::Nff | Reader::Gltf | Reader::Glb | Reader::Compressed => scene(&path),
        Reader::PartExr => part(&path),
        Reader::Tables => tables(&path),
        Reader::Env => env(&path),
    }
}

/// A scene file: loaded, checked as the GPU backend checks it, and packed for the GPU.
fn scene(path: &Path) -> Result<(), String> {
    let loaded = load::load(path, &LoadOptions::default()).map_err(|e| e.to_string())?;
    let scene = loaded.scene;
    let (width, height) = (16, 12);
    let opts = RenderOptions::new(width, height);
    cuberay::gpu::check(&scene, &opts).map_err(|e| e.to_string())?;
    let packed = cuberay::layout::pack(&scene, width, height, opts.spawn);
    assert!(
        packed
            .params
            .cam_forward
            .iter()
            .chain(&packed.params.cam_right)
            .chain(&packed.params.cam_up)
            .all(|x| x.is_finite()),
        "a non-finite camera reached the packed scene of {}",
        path.display()
    );
    for p in &packed.prims {
        assert!(
            p.a.iter().chain(&p.b).chain(&p.c).all(|x| x.is_finite()),
            "a non-finite coordinate reached the packed scene of {}",
            path.display()
        );
    }
    for t in &packed.tri_attrs {
        assert!(
            [t.n0, t.n1, t.n2, t.uv01, t.uv2_1].iter().flatten().all(|x| x.is_finite()),
            "a non-finite normal or texture coordinate reached the packed scene of {}",
            path.display()
        );
    }
    for m in &packed.materials {
        assert!(
            m.color.iter().chain(&m.mirror).chain(&m.emission).all(|x| x.is_finite())
                && m.emission_factor.iter().all(|x| x.is_finite())
                && [m.kd, m.ks, m.shine, m.transmittance, m.ior, m.opacity, m.metallic, m.roughness]
                    .iter()
                    .chain(&[m.transmission, m.alpha_cutoff, m.shadow_cutoff, m.normal_scale])
                    .all(|x| x.is_finite()),
            "a non-finite material value reached the packed scene of {}",
            path.display()
        );
    }
    for l in &packed.lights {
        assert!(
            l.position.iter().chain(&l.direction).chain(&l.radiance).all(|x| x.is_finite())
                && [l.range, l.cos_outer, l.span].iter().all(|x| x.is_finite()),
            "a non-finite light value reached the packed scene of {}",
            path.display()
        );
    }
    Ok(())
}

/// An environment map, read as `--env` reads it (the format by its content, whatever the
/// name), with its lights: every texel and every light finite.
fn env(path: &Path) -> Result<(), String> {
    let e = load::setup::read_environment(path, glam::DVec3::Y, glam::DVec3::X).map_err(|e| e.to_string())?;
    let probe = e.radiance(glam::DVec3::new(0.3, 0.8, -0.5));
    assert!(probe.is_finite(), "a non-finite radiance from the map {}", path.display());
    for l in e.lights(16) {
        assert!(
            l.color.is_finite() && l.direction.is_finite() && l.color.min_element() >= 0.0,
            "a non-finite or negative light from the map {}",
            path.display()
        );
    }
    Ok(())
}

/// A part EXR, read as `cuberay merge` reads it, then merged alone (which a part that
/// does not cover its whole image makes `merge` refuse: not the reader's refusal).
fn part(path: &Path) -> Result<(), String> {
    let part = cuberay::part::read_part(path).map_err(|e| e.to_string())?;
    let _ = cuberay::part::merge(&[part]);
    Ok(())
}

/// The scene and render options the tables inputs are keyed for: `scenes/hard/
/// parallel_mirrors.nff` at 8×8, whose tables are a few hundred bytes (its seeds are
/// `cuberay tables scenes/hard/parallel_mirrors.nff --width 8 --height 8`).
pub fn tables_scene() -> (cuberay::scene::Scene, RenderOptions) {
    let path = repo().join("scenes/hard/parallel_mirrors.nff");
    let scene = load::load(&path, &LoadOptions::default()).expect("the tables' scene loads").scene;
    (scene, RenderOptions::new(8, 8))
}

fn tables_key() -> &'static str {
    static KEY: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    KEY.get_or_init(|| {
        let (scene, opts) = tables_scene();
        let params = cuberay::gpu::prepare::build_params(&scene, &opts, cuberay::gpu::Purpose::Render)
            .expect("the scene resolves")
            .expect("the scene has tables");
        cuberay::tablefile::key(&scene, &params)
    })
}

/// `bytes` with the key of its JSON header replaced by [`tables_key`], when the header
/// parses as a JSON object; else as it is.
fn rekeyed(bytes: &[u8]) -> Vec<u8> {
    const MAGIC: &[u8] = b"cuberay tables\n";
    let Some(rest) = bytes.strip_prefix(MAGIC) else { return bytes.to_vec() };
    let Some(len) = rest.get(..8).map(|b| u64::from_le_bytes(b.try_into().unwrap())) else {
        return bytes.to_vec();
    };
    let Some(json) = usize::try_from(len).ok().and_then(|n| rest.get(8..8usize.checked_add(n)?)) else {
        return bytes.to_vec();
    };
    let Ok(serde_json::Value::Object(mut header)) = serde_json::from_slice(json) else {
        return bytes.to_vec();
    };
    header.insert("key".into(), serde_json::Value::String(tables_key().into()));
    let json_out = serde_json::to_vec(&header).expect("a JSON object serialises");
    let mut out = MAGIC.to_vec();
    out.extend((json_out.len() as u64).to_le_bytes());
    out.extend(json_out);
    out.extend(&rest[8 + json.len()..]);
    out
}

/// A tables file, read with the key of [`tables_scene`]'s tables and checked as the GPU
/// renderer checks stored tables before it uploads them.
fn tables(path: &Path) -> Result<(), String> {
    let (scene, opts) = tables_scene();
    let stored = cuberay::tablefile::read(path, tables_key()).map_err(|e| e.to_string())?;
    cuberay::gpu::prepare::check_stored(&scene, &opts, &stored).map_err(|e| e.to_string())
}
