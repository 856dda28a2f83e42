//! Partial renders and merging them: the EXR file a `--tile` or `--crop` render writes, and
//! `cuberay merge`, which assembles such parts into the whole image and its statistics.
//!
//! A part is an OpenEXR file whose data window is the part's [`Region`] and whose display
//! window is the whole image, so other EXR tools place it correctly. Its header carries one
//! text attribute, `cuberay`, holding a JSON [`PartInfo`]: which scene (the file's name,
//! length and SHA-256), the render's settings (window included), the effects, the raw
//! counters and the times. The pixels are the f32 values the renderer produced, unchanged.
//!
//! [`merge`] refuses parts of different scenes or settings, overlapping parts and parts that
//! leave a pixel uncovered, naming the part; it sums the counters (each grid point is
//! counted by exactly one part, see [`crate::job::GridRegion`]), so the merged statistics
//! equal those of a single render, and the merged pixels are those a single render gives.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use crate::error::Error;
use crate::output::{self, Image};
use crate::region::Region;
use crate::scene::Effects;
use crate::stats::{Counters, Settings, Stats, Times};

/// The value of [`PartInfo::format`]: the layout of the attribute, versioned.
pub const PART_FORMAT: &str = "cuberay-part/1";

/// The EXR header attribute that holds the [`PartInfo`] JSON.
pub const PART_ATTRIBUTE: &str = "cuberay";

/// Which scene a part shows: the file as given on the command line, its length and digest,
/// and what selects within it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SceneId {
    /// The path as given (for messages; parts rendered on different machines may name the
    /// same file differently, so only the digest is compared).
    pub name: String,
    pub bytes: u64,
    /// SHA-256 of the file's bytes, hex.
    pub sha256: String,
    /// glTF: `--camera`.
    pub camera: Option<usize>,
    /// `--frames`: the frame and its time in seconds.
    pub frame: Option<u32>,
    pub time_s: Option<f64>,
}

impl SceneId {
    /// The identity of scene file `name` with contents `bytes`.
    pub fn of(name: &str, bytes: &[u8], camera: Option<usize>) -> SceneId {
        let digest = Sha256::digest(bytes);
        let sha256 = digest.iter().map(|b| format!("{b:02x}")).collect();
        SceneId { name: name.into(), bytes: bytes.len() as u64, sha256, camera, frame: None, time_s: None }
    }

    /// Whether both name the same scene content, camera and frame.
    fn same_as(&self, o: &SceneId) -> bool {
        self.sha256 == o.sha256
            && self.bytes == o.bytes
            && self.camera == o.camera
            && self.frame == o.frame
            && self.time_s == o.time_s
    }

    fn describe(&self) -> String {
        let short = self.sha256.get(..12).unwrap_or(&self.sha256);
        let mut s = format!("{} ({} bytes, sha256 {short}…)", self.name, self.bytes);
        if let Some(c) = self.camera {
            s += &format!(", camera {c}");
        }
        if let Some(f) = self.frame {
            s += &format!(", frame {f}");
        }
        s
    }
}

/// Everything a part records besides its pixels.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PartInfo {
    pub format: String,
    /// What rendered it: the cuberay version and the backend (the GPU adapter and driver,
    /// or the CPU reference). Parts of different renderers are not merged: their pixels
    /// could differ in the last bits, and the merged image would match no single render.
    pub renderer: String,
    pub scene: SceneId,
    /// The render's settings; `settings.window` is the part's pixels.
    pub settings: Settings,
    /// `--aov`: which auxiliary output (`depth`, `normal`, `id`), else none.
    pub aov: Option<String>,
    pub effects: Vec<String>,
    /// The raw counters of the grid points the part owns.
    pub counters: Counters,
    pub time: Times,
}

impl PartInfo {
    /// The record of a windowed render with statistics `stats`, by `backend` (the GPU
    /// adapter and driver, or `cpu`). The render must have counted its rays
    /// ([`crate::job::RenderOptions::count`]): `merge` adds the parts' counts up.
    pub fn new(scene: SceneId, stats: &Stats, aov: Option<String>, backend: &str) -> PartInfo {
        debug_assert!(stats.counted, "a part's render must count its rays");
        PartInfo {
            format: PART_FORMAT.into(),
            renderer: format!("cuberay {} on {backend}", env!("CARGO_PKG_VERSION")),
            scene,
            settings: stats.settings.clone(),
            aov,
            effects: stats.effects.iter().map(|e| e.to_string()).collect(),
            counters: stats.counters,
            time: stats.time.clone(),
        }
    }

    fn region(&self) -> Region {
        let [w, h] = self.settings.size;
        self.settings.window.unwrap_or(Region::full(w, h))
    }
}

/// JSON with every non-ASCII character escaped (`\uXXXX`), as EXR text attributes hold
/// bytes, not UTF-8.
fn ascii_json(value: &impl Serialize) -> String {
    let json = serde_json::to_string(value).expect("part records always serialise");
    let mut out = String::with_capacity(json.len());
    for c in json.chars() {
        if c.is_ascii() {
            out.push(c);
        } else {
            let mut units = [0u16; 2];
            for u in c.encode_utf16(&mut units) {
                out += &format!("\\u{u:04x}");
            }
        }
    }
    out
}

/// Writes `image` (the window's pixels) as a partial EXR with `info`, atomically.
pub fn write_part(image: &Image, info: &PartInfo, path: &Path) -> Result<(), Error> {
    use exr::meta::attribute::{AttributeValue, Text};
    let win = info.region();
    if (image.width, image.height) != (win.width(), win.height()) {
        return Err(Error::Options(format!(
            "internal: a {}x{} image for the window {win}",
            image.width, image.height
        )));
    }
    let [full_w, full_h] = info.settings.size;
    let text = Text::new_or_none(ascii_json(info)).expect("ASCII JSON is valid EXR text");
    let attribute = Some((Text::from(PART_ATTRIBUTE), AttributeValue::Text(text)));
    output::write_atomically(path, |w| {
        output::encode_exr(w, image, (win.x0, win.y0), (full_w, full_h), attribute)
            .map_err(|e| Error::Part { path: path.to_owned(), message: format!("cannot encode: {e}") })
    })
}

/// A part read back: its record and its pixels.
pub struct Part {
    pub path: PathBuf,
    pub info: PartInfo,
    pub image: Image,
}

/// The most pixels a part holds (as RGBA f32, 1 GiB): `cuberay render` refuses a larger
/// `--tile` or `--crop` to an EXR, and [`read_part`] a larger file before it allocates its
/// pixels. Render larger images in more parts.
pub const MAX_PART_PIXELS: u64 = 1 << 26;

/// Reads a partial EXR written by [`write_part`].
pub fn read_part(path: &Path) -> Result<Part, Error> {
    if !path.exists() {
        return Err(part_error(path, "no such file".into()));
    }
    check_part_size(path)?;
    let file = read_rgba(path)?;
    let info = part_record(path, &file.layer)?;
    check_placement(path, &info, &file)?;
    let win = info.region();
    let mut image = Image::new(win.width(), win.height(), info.aov.is_some());
    image.transfer = info.settings.transfer;
    image.tonemap = info.settings.tonemap;
    image.exposure = output::exposure_scale(info.settings.exposure);
    image.pixels = file.pixels;
    if !image.is_finite() {
        return Err(part_error(path, "it holds a non-finite value".into()));
    }
    Ok(Part { path: path.to_owned(), info, image })
}

/// The [`Error::Part`] that says what is wrong with the part at `path`.
fn part_error(path: &Path, message: String) -> Error {
    Error::Part { path: path.to_owned(), message }
}

/// Ok when no layer in the header of the EXR at `path` is larger than a part cuberay
/// writes (32768 a side, [`MAX_PART_PIXELS`] in all); the error names the size. Reads the
/// header only, so that a small file cannot make the reader allocate pixels for a huge data
/// window.
fn check_part_size(path: &Path) -> Result<(), Error> {
    let meta = exr::prelude::MetaData::read_from_file(path, false)
        .map_err(|e| part_error(path, format!("not a readable RGB EXR file: {e}")))?;
    let too_large = |h: &&exr::meta::header::Header| {
        let (w, ht) = (h.layer_size.width(), h.layer_size.height());
        w > 32768 || ht > 32768 || (w as u64) * (ht as u64) > MAX_PART_PIXELS
    };
    if let Some(h) = meta.headers.iter().find(too_large) {
        return Err(part_error(
            path,
            format!(
                "its {}x{} pixels are more than any cuberay part holds (at most {MAX_PART_PIXELS} pixels, \
                 32768 a side)",
                h.layer_size.width(),
                h.layer_size.height()
            ),
        ));
    }
    Ok(())
}

/// The parts of an RGB(A) EXR file that [`read_part`] checks and keeps.
struct RgbaFile {
    /// The image's attributes: the display window.
    image: exr::meta::header::ImageAttributes,
    /// The first valid layer's attributes: its position and the `cuberay` record.
    layer: exr::meta::header::LayerAttributes,
    /// The layer's size in pixels.
    size: exr::prelude::Vec2<usize>,
    /// The layer's pixels in row order, RGBA (A is 1 where the file has none).
    pixels: Vec<[f32; 4]>,
}

/// The first valid layer of the EXR at `path`, with its R, G, B and (optional) A channels
/// and all attributes, or the error that it is not a readable RGB EXR file.
fn read_rgba(path: &Path) -> Result<RgbaFile, Error> {
    use exr::prelude as x;
    use x::traits::*;
    let read = x::read()
        .no_deep_data()
        .largest_resolution_level()
        .specific_channels()
        .required("R")
        .required("G")
        .required("B")
        .optional("A", 1.0f32)
        .collect_pixels(
            |size: x::Vec2<usize>, _| (size.width(), vec![[0.0f32; 4]; size.area()]),
            |(w, px): &mut (usize, Vec<[f32; 4]>), p: x::Vec2<usize>, (r, g, b, a): (f32, f32, f32, f32)| {
                px[p.y() * *w + p.x()] = [r, g, b, a]
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .map_err(|e| part_error(path, format!("not a readable RGB EXR file: {e}")))?;
    let layer = read.layer_data;
    Ok(RgbaFile {
        image: read.attributes,
        layer: layer.attributes,
        size: layer.size,
        pixels: layer.channel_data.pixels.1,
    })
}

/// The [`PartInfo`] in the `cuberay` attribute of `layer`, once it is known to be in
/// [`PART_FORMAT`], to name a non-empty window of its image and to carry a SHA-256 scene
/// digest; the error says which of these fails first.
fn part_record(path: &Path, layer: &exr::meta::header::LayerAttributes) -> Result<PartInfo, Error> {
    use exr::prelude as x;
    let bad = |m: String| part_error(path, m);
    let text = match layer.other.get(&x::Text::from(PART_ATTRIBUTE)) {
        Some(x::AttributeValue::Text(t)) => t.to_string(),
        _ => {
            return Err(bad(format!(
                "not a cuberay part (its header has no `{PART_ATTRIBUTE}` attribute): render parts with --tile or --crop to .exr"
            )))
        }
    };
    let info: PartInfo = serde_json::from_str(&text)
        .map_err(|e| bad(format!("its `{PART_ATTRIBUTE}` record is malformed: {e}")))?;
    if info.format != PART_FORMAT {
        return Err(bad(format!(
            "its record is in format {:?}; this cuberay reads {PART_FORMAT:?}",
            info.format
        )));
    }
    let [full_w, full_h] = info.settings.size;
    let win = info.region();
    if full_w == 0
        || full_h == 0
        || win.x0 >= win.x1
        || win.y0 >= win.y1
        || win.x1 > full_w
        || win.y1 > full_h
    {
        return Err(bad(format!(
            "its record names the window {},{},{},{}, which is not a non-empty part of its {full_w}x{full_h} image",
            win.x0, win.y0, win.x1, win.y1
        )));
    }
    if info.scene.sha256.len() != 64 || !info.scene.sha256.bytes().all(|b| b.is_ascii_hexdigit()) {
        return Err(bad("its record's scene digest is not a SHA-256".into()));
    }
    Ok(info)
}

/// Ok when `file`'s display window is the whole image `info` names and its pixels fill
/// exactly the window `info` names; the error says which does not.
fn check_placement(path: &Path, info: &PartInfo, file: &RgbaFile) -> Result<(), Error> {
    let bad = |m: String| part_error(path, m);
    let [full_w, full_h] = info.settings.size;
    let win = info.region();
    let display = file.image.display_window;
    if (display.position.x(), display.position.y(), display.size.width(), display.size.height())
        != (0, 0, full_w as usize, full_h as usize)
    {
        return Err(bad(format!(
            "its display window ({}x{} at {}, {}) is not the {full_w}x{full_h} image its record names",
            display.size.width(),
            display.size.height(),
            display.position.x(),
            display.position.y()
        )));
    }
    let pos = file.layer.layer_position;
    let (w, h) = (file.size.width(), file.size.height());
    if (pos.x(), pos.y()) != (win.x0 as i32, win.y0 as i32)
        || (w, h) != (win.width() as usize, win.height() as usize)
    {
        return Err(bad(format!(
            "its pixels ({w}x{h} at {}, {}) do not fill the window its record names ({win})",
            pos.x(),
            pos.y()
        )));
    }
    Ok(())
}

/// The merged image and statistics of `parts`.
pub struct Merged {
    pub image: Image,
    pub stats: Stats,
}

/// The settings of two parts that must agree, as JSON: all but the window.
fn comparable(s: &Settings) -> serde_json::Map<String, serde_json::Value> {
    let mut v = match serde_json::to_value(s).expect("settings serialise") {
        serde_json::Value::Object(m) => m,
        _ => unreachable!("settings serialise to an object"),
    };
    v.remove("window");
    v
}

/// The `&'static` name of a known effect.
fn effect_name(name: &str) -> Option<&'static str> {
    Effects::ALL.names().into_iter().find(|n| *n == name)
}

/// Assembles `parts` (at least one) into the whole image: checks that they come from one
/// scene and one set of settings and cover every pixel exactly once, and adds up their
/// counters and times.
pub fn merge(parts: &[Part]) -> Result<Merged, Error> {
    let Some(first) = parts.first() else {
        return Err(Error::Options("merge needs at least one part".into()));
    };
    let reference = comparable(&first.info.settings);
    for p in &parts[1..] {
        check_same_render(first, &reference, p)?;
    }
    check_disjoint(parts)?;
    let [w, h] = first.info.settings.size;
    check_covered(parts, w, h)?;
    let (image, counters, time) = assemble(parts, w, h);
    let effects = first
        .info
        .effects
        .iter()
        .map(|e| {
            effect_name(e).ok_or_else(|| part_error(&first.path, format!("it names an unknown effect {e:?}")))
        })
        .collect::<Result<Vec<_>, _>>()?;
    let settings = Settings { window: None, ..first.info.settings.clone() };
    Ok(Merged { image, stats: Stats::new(settings, effects, &counters, time) })
}

/// Ok when `p` shows the scene of `first`, was rendered by the same renderer, holds the
/// same image or AOV and was rendered with the same settings (`reference`, those of
/// `first` as [`comparable`] gives them); the error, about `p`, says the first difference.
fn check_same_render(
    first: &Part,
    reference: &serde_json::Map<String, serde_json::Value>,
    p: &Part,
) -> Result<(), Error> {
    let bad = |m: String| part_error(&p.path, m);
    let first_name = first.path.display().to_string();
    if !p.info.scene.same_as(&first.info.scene) {
        return Err(bad(format!(
            "it shows {}, but {} shows {}",
            p.info.scene.describe(),
            first_name,
            first.info.scene.describe()
        )));
    }
    if p.info.renderer != first.info.renderer {
        return Err(bad(format!(
            "it was rendered by {}, but {} by {}",
            p.info.renderer, first_name, first.info.renderer
        )));
    }
    if p.info.aov != first.info.aov {
        let what = |a: &Option<String>| match a {
            Some(a) => format!("the {a} AOV"),
            None => "the image".to_string(),
        };
        return Err(bad(format!(
            "it holds {}, but {} holds {}",
            what(&p.info.aov),
            first_name,
            what(&first.info.aov)
        )));
    }
    let theirs = comparable(&p.info.settings);
    if theirs != *reference {
        let differ: Vec<String> = reference
            .iter()
            .filter(|(k, v)| theirs.get(*k) != Some(*v))
            .map(|(k, v)| {
                format!("{k} {} (against {v} in {first_name})", theirs.get(k).cloned().unwrap_or_default())
            })
            .collect();
        return Err(bad(format!("it was rendered with other settings: {}", differ.join(", "))));
    }
    Ok(())
}

/// Ok when no two of `parts` are the same file or overlap; the error is about the later
/// part of the first such pair.
fn check_disjoint(parts: &[Part]) -> Result<(), Error> {
    for (i, a) in parts.iter().enumerate() {
        for b in &parts[i + 1..] {
            if a.path == b.path {
                return Err(part_error(&b.path, "it is named twice".into()));
            }
            let (wa, wb) = (a.info.region(), b.info.region());
            if wa.overlaps(&wb) {
                return Err(part_error(
                    &b.path,
                    format!(
                        "its pixels ({wb}) overlap those of {} ({wa}); each pixel must come from one part",
                        a.path.display()
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// Ok when `parts` (which do not overlap) cover all of the `w`×`h` image; the error names
/// the first pixel none of them holds.
fn check_covered(parts: &[Part], w: u32, h: u32) -> Result<(), Error> {
    let covered: u64 = parts.iter().map(|p| p.info.region().pixels()).sum();
    if covered != w as u64 * h as u64 {
        let (x, y) = first_gap(parts.iter().map(|p| p.info.region()).collect(), w, h);
        return Err(Error::Options(format!(
            "the {} parts cover {covered} of the {w}x{h} image's {} pixels: pixel ({x}, {y}) is in none of them",
            parts.len(),
            w as u64 * h as u64,
        )));
    }
    Ok(())
}

/// The `w`×`h` image with each of `parts` (which tile it) copied into its window, in the
/// first part's transfer, tone mapping and exposure, and the sums of the parts' counters
/// and times.
fn assemble(parts: &[Part], w: u32, h: u32) -> (Image, Counters, Times) {
    let first = &parts[0];
    let mut image = Image::new(w, h, first.image.has_alpha);
    image.transfer = first.image.transfer;
    image.tonemap = first.image.tonemap;
    image.exposure = first.image.exposure;
    let mut counters = Counters::default();
    let mut time = Times::default();
    for p in parts {
        let win = p.info.region();
        for y in 0..win.height() {
            let src = &p.image.pixels[(y * win.width()) as usize..((y + 1) * win.width()) as usize];
            let at = ((win.y0 + y) * w + win.x0) as usize;
            image.pixels[at..at + src.len()].copy_from_slice(src);
        }
        counters += p.info.counters;
        time = add_times(time, &p.info.time);
    }
    (image, counters, time)
}

/// The first pixel, in row order, that none of `windows` (which do not overlap and lie in
/// the `w`×`h` image, but cover less than it) holds: per row, the windows' column ranges
/// sorted, and the first hole between them.
fn first_gap(mut windows: Vec<Region>, w: u32, h: u32) -> (u32, u32) {
    windows.sort_by_key(|win| win.x0);
    for y in 0..h {
        let mut x = 0;
        for win in windows.iter().filter(|win| (win.y0..win.y1).contains(&y)) {
            if win.x0 > x {
                return (x, y);
            }
            x = x.max(win.x1);
        }
        if x < w {
            return (x, y);
        }
    }
    (0, 0)
}

/// The times of work done in parts: what it cost in all (the longest submission: the
/// longest of any part).
fn add_times(a: Times, b: &Times) -> Times {
    let sum = |x: Option<f64>, y: Option<f64>| match (x, y) {
        (None, None) => None,
        (x, y) => Some(x.unwrap_or(0.0) + y.unwrap_or(0.0)),
    };
    Times {
        preprocess_s: a.preprocess_s + b.preprocess_s,
        trace_s: a.trace_s + b.trace_s,
        gpu_s: sum(a.gpu_s, b.gpu_s),
        gpu_kernel_s: crate::stats::KernelTimes {
            nearest: sum(a.gpu_kernel_s.nearest, b.gpu_kernel_s.nearest),
            shade: sum(a.gpu_kernel_s.shade, b.gpu_kernel_s.shade),
            shadow: sum(a.gpu_kernel_s.shadow, b.gpu_kernel_s.shadow),
            resolve: sum(a.gpu_kernel_s.resolve, b.gpu_kernel_s.resolve),
            aov: sum(a.gpu_kernel_s.aov, b.gpu_kernel_s.aov),
            tree: sum(a.gpu_kernel_s.tree, b.gpu_kernel_s.tree),
        },
        gpu_depth_s: match (&a.gpu_depth_s, &b.gpu_depth_s) {
            (Some(x), Some(y)) => {
                let mut all = x.clone();
                for d in y {
                    match all.iter_mut().find(|e| e.depth == d.depth) {
                        Some(e) => {
                            e.nearest += d.nearest;
                            e.shade += d.shade;
                            e.shadow += d.shadow;
                            e.all += d.all;
                        }
                        None => all.push(*d),
                    }
                }
                all.sort_by_key(|e| e.depth);
                Some(all)
            }
            (x, y) => x.clone().or_else(|| y.clone()),
        },
        compile_s: sum(a.compile_s, b.compile_s),
        longest_dispatch_s: match (a.longest_dispatch_s, b.longest_dispatch_s) {
            (Some(x), Some(y)) => Some(x.max(y)),
            (x, y) => x.or(y),
        },
        longest_submit_s: match (a.longest_submit_s, b.longest_submit_s) {
            (Some(x), Some(y)) => Some(x.max(y)),
            (x, y) => x.or(y),
        },
        tiles_run_again: match (a.tiles_run_again, b.tiles_run_again) {
            (Some(x), Some(y)) => Some(x + y),
            (x, y) => x.or(y),
        },
        phases: a.phases + b.phases,
    }
}
