//! The converged reference a sweep is measured against, and its cache file: the CPU's f64
//! render, its eye rays' object ids and distances, rendered once per scene file, size and
//! reference settings and kept beside the sweep's output (`reference-HASH.bin`: a magic
//! line, then each image's size, flags and f32 pixels). A file that does not read back
//! whole, at the expected size and finite, is rendered again.

use std::io::{Read, Write};
use std::path::{Path, PathBuf};

use indicatif::ProgressBar;
use sha2::{Digest, Sha256};

use super::Settings;
use crate::error::{Error, Result};
use crate::output::{Aov, Image, Transfer};
use crate::scene::Scene;

/// The converged reference: the CPU's f64 render at many samples and full depth, and its
/// eye rays' object ids and distances through the pixel centres.
#[derive(Clone, Debug)]
pub struct Reference {
    pub image: Image,
    pub id: Image,
    pub depth: Image,
    /// Seconds it took to render (0 when read from the cache).
    pub seconds: f64,
    pub cache: PathBuf,
    pub cached: bool,
}

/// The first line of a reference cache file.
const CACHE_MAGIC: &[u8] = b"cuberay accuracy reference 2\n";

/// The cache file of the reference of the scene whose file holds `scene_bytes`, for
/// `settings`, in `dir`: named by a hash of the bytes, the reference's options and the
/// cuberay version.
pub fn reference_cache(dir: &Path, scene_bytes: &[u8], settings: &Settings) -> PathBuf {
    let o = settings.reference_options();
    let mut h = Sha256::new();
    h.update(scene_bytes);
    h.update(format!(
        "{} {} {} {} {} {}",
        o.width,
        o.height,
        o.spp,
        o.max_depth,
        o.seed,
        env!("CARGO_PKG_VERSION")
    ));
    let key: String = h.finalize().iter().take(8).map(|b| format!("{b:02x}")).collect();
    dir.join(format!("reference-{key}.bin"))
}

fn write_images(path: &Path, images: [&Image; 3]) -> Result<()> {
    crate::output::write_atomically(path, |w| {
        let io = |source| Error::Io { path: path.to_owned(), source };
        w.write_all(CACHE_MAGIC).map_err(io)?;
        for img in images {
            w.write_all(&img.width.to_le_bytes()).map_err(io)?;
            w.write_all(&img.height.to_le_bytes()).map_err(io)?;
            w.write_all(&[img.has_alpha as u8, (img.transfer == Transfer::Display) as u8]).map_err(io)?;
            w.write_all(bytemuck::cast_slice(&img.pixels)).map_err(io)?;
        }
        Ok(())
    })
}

fn read_images(path: &Path, size: (u32, u32)) -> Option<[Image; 3]> {
    let mut bytes = Vec::new();
    std::fs::File::open(path).ok()?.read_to_end(&mut bytes).ok()?;
    let mut r = bytes.strip_prefix(CACHE_MAGIC)?;
    let mut take = |n: usize| -> Option<&[u8]> {
        let (a, b) = r.split_at_checked(n)?;
        r = b;
        Some(a)
    };
    let mut one = || -> Option<Image> {
        let w = u32::from_le_bytes(take(4)?.try_into().ok()?);
        let h = u32::from_le_bytes(take(4)?.try_into().ok()?);
        let flags = take(2)?;
        let alpha = flags[0] != 0;
        let transfer = if flags[1] != 0 { Transfer::Display } else { Transfer::Srgb };
        if (w, h) != size {
            return None;
        }
        let px = take(w as usize * h as usize * 16)?;
        let mut img = Image::new(w, h, alpha);
        img.pixels = bytemuck::pod_collect_to_vec(px);
        img.transfer = transfer;
        img.pixels.iter().all(|p| p.iter().all(|v| v.is_finite())).then_some(img)
    };
    Some([one()?, one()?, one()?])
}

/// The reference of `scene` for `settings`: read from `cache` when it holds it, else
/// rendered on the CPU (f64) and written there.
pub fn reference(
    scene: &Scene,
    settings: &Settings,
    cache: &Path,
    progress: &ProgressBar,
) -> Result<Reference> {
    let opts = settings.reference_options();
    if let Some([image, id, depth]) = read_images(cache, (opts.width, opts.height)) {
        return Ok(Reference { image, id, depth, seconds: 0.0, cache: cache.to_owned(), cached: true });
    }
    let start = std::time::Instant::now();
    let image = crate::reference::render(scene, &opts, progress)?.image;
    let aov = |a| crate::reference::render_aov(scene, &opts, a, &ProgressBar::hidden()).map(|r| r.image);
    let (id, depth) = (aov(Aov::Id)?, aov(Aov::Depth)?);
    write_images(cache, [&image, &id, &depth])?;
    let seconds = start.elapsed().as_secs_f64();
    Ok(Reference { image, id, depth, seconds, cache: cache.to_owned(), cached: false })
}
