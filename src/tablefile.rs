//! Candidate tables on disk: `cuberay tables` builds a render's tables once and writes them,
//! and `cuberay render --tables FILE` reads them instead of building, so that the tasks of
//! a split render (`--tile`) share one build.
//!
//! The file holds what the GPU renderer uploads: the flat tables ([`FlatTables`]). It starts
//! with a magic line and a JSON header (format version, the **key**, the scalars and the
//! array lengths), followed by each array's bytes as the GPU takes them (little-endian,
//! `#[repr(C)]`). The renderer recomputes the bounds on their walks from the tables and
//! checks every index against the scene ([`FlatTables::check_scene`]) before upload.
//!
//! The key ([`key`]) names everything the tables depend on, as the renderer sees it: the
//! scene as packed for the GPU (primitives, materials, lights, camera, in f32 around the
//! eye: the frame the tables are conservative in), the build parameters (image size,
//! effects, spawn offset, budgets) and the cuberay binary that built them (a changed
//! builder or kernel may need other tables). Reading with another key is refused: tables
//! built for another scene, pose or settings would not be conservative for it.

use std::io::{BufWriter, Read, Write};
use std::path::Path;

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use crate::coherence::{BuildParams, FlatTables, GpuEntry, GpuFace, GpuOrigin};
use crate::error::Error;
use crate::scene::Scene;

/// The first line of a tables file.
const MAGIC: &[u8] = b"cuberay tables\n";

/// The layout version; a file of another version is refused.
const VERSION: u32 = 3;

/// The SHA-256 of the running cuberay binary (its version where it cannot be read): stored
/// tables are valid for the builder and kernels that made them.
fn build_id() -> &'static str {
    static ID: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    ID.get_or_init(|| match std::env::current_exe().and_then(std::fs::read) {
        Ok(bytes) => Sha256::digest(&bytes).iter().map(|b| format!("{b:02x}")).collect(),
        Err(_) => format!("version {}", env!("CARGO_PKG_VERSION")),
    })
}

/// The key of the tables built with `params` for `scene`: a SHA-256 of the binary's build
/// id, the scene packed for the GPU at the params' image size and spawn offset, and the
/// params themselves.
pub fn key(scene: &Scene, params: &BuildParams) -> String {
    let (w, h) = params.image.unwrap_or_else(|| scene.camera.default_resolution());
    let packed = crate::layout::pack(scene, w, h, params.spawn);
    let mut hash = Sha256::new();
    let mut part = |bytes: &[u8]| {
        hash.update((bytes.len() as u64).to_le_bytes());
        hash.update(bytes);
    };
    part(build_id().as_bytes());
    part(bytemuck::cast_slice(&packed.prims));
    part(bytemuck::cast_slice(&packed.tri_attrs));
    part(bytemuck::cast_slice(&packed.materials));
    part(bytemuck::cast_slice(&packed.lights));
    part(bytemuck::bytes_of(&packed.params));
    part(format!("{params:?}").as_bytes());
    hash.finalize().iter().map(|b| format!("{b:02x}")).collect()
}

/// Tables read from a file: the flat tables the GPU renderer uploads.
#[derive(Clone, Debug)]
pub struct StoredTables {
    pub flat: FlatTables,
}

#[derive(Serialize, Deserialize)]
struct Header {
    version: u32,
    key: String,
    /// The scene as the caller named it (for messages).
    scene: String,
    eye_origin: u32,
    fallback_origin: u32,
    /// Element counts of the arrays that follow, in the order written.
    origins: usize,
    faces: usize,
    cell_start: usize,
    entries: usize,
    light_origin: usize,
}

/// Writes `flat` with `key` to `path`, atomically (`scene` names the scene in messages).
pub fn write(path: &Path, key: &str, scene: &str, flat: &FlatTables) -> Result<(), Error> {
    let header = Header {
        version: VERSION,
        key: key.into(),
        scene: scene.into(),
        eye_origin: flat.eye_origin,
        fallback_origin: flat.fallback_origin,
        origins: flat.origins.len(),
        faces: flat.faces.len(),
        cell_start: flat.cell_start.len(),
        entries: flat.entries.len(),
        light_origin: flat.light_origin.len(),
    };
    let json = serde_json::to_vec(&header).expect("the header serialises");
    let io = |source| Error::Io { path: path.to_owned(), source };
    crate::output::write_atomically(path, |w: &mut BufWriter<&std::fs::File>| {
        w.write_all(MAGIC).map_err(io)?;
        w.write_all(&(json.len() as u64).to_le_bytes()).map_err(io)?;
        w.write_all(&json).map_err(io)?;
        let arrays: [&[u8]; 5] = [
            bytemuck::cast_slice(&flat.origins),
            bytemuck::cast_slice(&flat.faces),
            bytemuck::cast_slice(&flat.cell_start),
            bytemuck::cast_slice(&flat.entries),
            bytemuck::cast_slice(&flat.light_origin),
        ];
        for a in arrays {
            w.write_all(a).map_err(io)?;
        }
        Ok(())
    })
}

/// Reads the tables in `path`, refusing a file whose key is not `key`.
pub fn read(path: &Path, key: &str) -> Result<StoredTables, Error> {
    let bad = |m: String| Error::Tables { path: path.to_owned(), message: m };
    let bytes = std::fs::read(path).map_err(|source| Error::Io { path: path.to_owned(), source })?;
    let mut r: &[u8] = &bytes;
    let mut magic = [0u8; MAGIC.len()];
    if r.read_exact(&mut magic).is_err() || magic != MAGIC {
        return Err(bad("not a cuberay tables file (write one with `cuberay tables`)".into()));
    }
    let mut len = [0u8; 8];
    r.read_exact(&mut len).map_err(|_| bad("it ends inside its header".into()))?;
    let len = u64::from_le_bytes(len) as usize;
    if len > r.len() {
        return Err(bad("it ends inside its header".into()));
    }
    let (json, mut rest) = r.split_at(len);
    let h: Header = serde_json::from_slice(json).map_err(|e| bad(format!("its header is malformed: {e}")))?;
    if h.version != VERSION {
        return Err(bad(format!(
            "it is in format version {}; this cuberay reads version {VERSION}",
            h.version
        )));
    }
    if h.key != key {
        return Err(bad(format!(
            "it holds the tables of another scene or other settings (it was built for {}, and \
             tables are conservative only for the scene, pose, camera, image size and effects \
             they were built for, by the same cuberay binary): rebuild it with `cuberay tables` \
             and the render's options",
            h.scene
        )));
    }
    fn take<T: bytemuck::Pod>(rest: &mut &[u8], count: usize, what: &str) -> Result<Vec<T>, String> {
        let n = count.checked_mul(std::mem::size_of::<T>()).ok_or(format!("{what}: impossible length"))?;
        if n > rest.len() {
            return Err(format!("it ends inside its {what} ({count} expected)"));
        }
        let (a, b) = rest.split_at(n);
        *rest = b;
        Ok(bytemuck::pod_collect_to_vec(a))
    }
    let t = |e: String| bad(e);
    let origins: Vec<GpuOrigin> = take(&mut rest, h.origins, "origins").map_err(t)?;
    let faces: Vec<GpuFace> = take(&mut rest, h.faces, "faces").map_err(t)?;
    let cell_start: Vec<u32> = take(&mut rest, h.cell_start, "cell starts").map_err(t)?;
    let entries: Vec<GpuEntry> = take(&mut rest, h.entries, "entries").map_err(t)?;
    let light_origin: Vec<u32> = take(&mut rest, h.light_origin, "light origins").map_err(t)?;
    if !rest.is_empty() {
        return Err(bad(format!("{} bytes follow its last array", rest.len())));
    }
    let flat = FlatTables {
        origins,
        faces,
        cell_start,
        entries,
        light_origin,
        eye_origin: h.eye_origin,
        fallback_origin: h.fallback_origin,
    };
    Ok(StoredTables { flat })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::coherence;
    use crate::scene::Scene;

    /// Mirror spheres on a floor, lit by one light.
    fn scene() -> Scene {
        let mut nff = String::from(
            "v\nfrom 0 -6 2\nat 0 0 0\nup 0 0 1\nangle 40\nhither 1\nresolution 32 24\n\
             l 3 -3 5\nf 0.8 0.6 0.4 0.7 0.3 10 0 1\np 4 -4 -4 -0.4 4 -4 -0.4 4 4 -0.4 -4 4 -0.4\n",
        );
        for i in 0..12 {
            nff += &format!("s {} {} {} 0.3\n", (i % 4) as f64 - 1.5, (i / 4) as f64, 0.3 * (i % 3) as f64);
        }
        crate::load::nff::parse(&nff, Path::new("mirrors.nff")).unwrap().scene
    }

    #[test]
    fn tables_come_back_as_they_were_written() {
        let s = scene();
        let params = BuildParams { image: Some((32, 24)), ..BuildParams::default() };
        let t = coherence::build(&s, &params).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.tables");
        let k = key(&s, &params);
        write(&path, &k, "scene", &t.flat).unwrap();
        let back = read(&path, &k).unwrap();
        let (a, b) = (&t.flat, &back.flat);
        assert_eq!(a.origins, b.origins);
        assert_eq!(a.faces, b.faces);
        assert_eq!(a.cell_start, b.cell_start);
        assert_eq!(bytemuck::cast_slice::<_, u8>(&a.entries), bytemuck::cast_slice::<_, u8>(&b.entries));
        assert_eq!(a.light_origin, b.light_origin);
        assert_eq!((a.eye_origin, a.fallback_origin), (b.eye_origin, b.fallback_origin));
        back.flat.check_scene(s.primitives.len(), s.lights.len()).unwrap();
        // The key changes with the image size and with the scene, by as little as one
        // sphere's radius; another key, a truncated file and a foreign file are refused.
        let other = key(&s, &BuildParams { image: Some((33, 24)), ..params.clone() });
        assert_ne!(other, k);
        assert_ne!(key(&s, &BuildParams { eye_n: Some(16), ..params.clone() }), k);
        let mut moved = s.clone();
        if let crate::scene::Primitive::Sphere(sp) = &mut moved.primitives[3] {
            sp.radius *= 1.001;
        }
        assert_ne!(key(&moved, &params), k);
        assert_eq!(key(&s, &params), k, "the key is a function of the scene and params");
        assert!(read(&path, &other).unwrap_err().to_string().contains("another scene or other settings"));
        let bytes = std::fs::read(&path).unwrap();
        std::fs::write(&path, &bytes[..bytes.len() - 3]).unwrap();
        assert!(read(&path, &k).unwrap_err().to_string().contains("ends inside"));
        std::fs::write(&path, b"P6 something else").unwrap();
        assert!(read(&path, &k).unwrap_err().to_string().contains("not a cuberay tables file"));
    }
}
