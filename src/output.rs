//! Images and writing them: PNG for display, OpenEXR (and Radiance HDR) for linear radiance,
//! OpenEXR for auxiliary outputs (AOVs).
//!
//! - **PNG**: each value is multiplied by the image's exposure (2^`--exposure`), tone mapped
//!   by its [`Tonemap`] (by default PBR Neutral for glTF, none for NFF), clamped to [0, 1] and
//!   encoded by its [`Transfer`], 8 bits per channel, RGB: the sRGB transfer function for
//!   linear radiance (glTF), or as they are for display values (NFF, whose colours and light
//!   intensities were chosen for a [0, 1] frame buffer: so the SPD renders look like their
//!   reference images). EXR and HDR files keep the linear radiance as rendered.
//! - **EXR**: linear f32 values as rendered: RGB for radiance, RGBA for AOVs (A = 1 where
//!   the pixel's ray hit something, 0 where it missed; see [`Aov`] for the values),
//!   ZIP-compressed scan lines written in order, so that equal images give equal files
//!   ([`encode_exr`], which the partial images of [`crate::part`] use too).
//! - **HDR** (Radiance RGBE): linear values as rendered, RGB, 8-bit mantissas with a shared
//!   exponent (about 1% precision); no AOVs.
//!
//! The format is chosen by the file extension (`.png`, `.exr`, `.hdr`, any case);
//! [`OutputFormat::from_path`] rejects anything else, so a command can check it before
//! rendering. Files are written atomically: into a temporary file in the target's
//! directory, which is renamed over the target only once complete, so a failed or
//! interrupted write never leaves a half-written image.

use std::io::{BufWriter, Write};
use std::path::Path;

use image::{ImageBuffer, ImageFormat, Rgb};

use crate::error::Error;
pub use crate::scene::{Tonemap, Transfer};

/// An image of linear f32 values, row-major from the top-left pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    /// RGBA per pixel. Radiance images keep A = 1.
    pub pixels: Vec<[f32; 4]>,
    /// True for AOVs, whose alpha says hit (1) or miss (0) and is written to EXR.
    pub has_alpha: bool,
    /// How a PNG (or the preview's window) encodes the values.
    pub transfer: Transfer,
    /// What a PNG (or the window) multiplies the values by first: 2^`--exposure`
    /// ([`exposure_scale`]).
    pub exposure: f32,
    /// How a PNG (or the window) brings values beyond 1 into range, before the transfer.
    pub tonemap: Tonemap,
}

impl Image {
    pub fn new(width: u32, height: u32, has_alpha: bool) -> Image {
        Image {
            width,
            height,
            pixels: vec![[0.0, 0.0, 0.0, 1.0]; (width * height) as usize],
            has_alpha,
            transfer: Transfer::Srgb,
            exposure: 1.0,
            tonemap: Tonemap::None,
        }
    }

    pub fn get(&self, x: u32, y: u32) -> [f32; 4] {
        self.pixels[(y * self.width + x) as usize]
    }

    /// True when every value is finite.
    pub fn is_finite(&self) -> bool {
        self.pixels.iter().all(|p| p.iter().all(|v| v.is_finite()))
    }
}

/// Auxiliary outputs (`--aov`), taken from the eye ray through each pixel centre.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Aov {
    /// Distance from the eye ray's origin to the first hit, in scene units, in R, G and B.
    /// Miss: 0 (no hit is at distance 0).
    Depth,
    /// World-space unit shading normal at the first hit, turned to face the eye ray
    /// (x, y, z in R, G, B). Miss: (0, 0, 0).
    Normal,
    /// Object id (index of the primitive in the scene) of the first hit, in R, G and B
    /// (exact up to 2²⁴). Miss: −1.
    Id,
}

/// The image file formats `-o` accepts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OutputFormat {
    Png,
    Exr,
    /// Radiance RGBE (.hdr): linear radiance, 8-bit mantissas with a shared exponent.
    Hdr,
}

impl OutputFormat {
    /// The format named by `path`'s extension.
    pub fn from_path(path: &Path) -> Result<OutputFormat, Error> {
        let ext = path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase());
        match ext.as_deref() {
            Some("png") => Ok(OutputFormat::Png),
            Some("exr") => Ok(OutputFormat::Exr),
            Some("hdr") => Ok(OutputFormat::Hdr),
            _ => Err(Error::UnknownImageFormat { path: path.to_owned() }),
        }
    }
}

/// What `--exposure EV` multiplies the values by: 2^EV.
pub fn exposure_scale(ev: f64) -> f32 {
    ev.exp2() as f32
}

/// The sRGB transfer function (linear [0, 1] to encoded [0, 1]).
pub fn linear_to_srgb(c: f64) -> f64 {
    if c <= 0.0031308 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// The documented PNG mapping of one value: clamp to [0, 1], encode by `transfer`, round.
pub fn png_value(v: f32, transfer: Transfer) -> u8 {
    let c = if v.is_nan() { 0.0 } else { (v as f64).clamp(0.0, 1.0) };
    let e = match transfer {
        Transfer::Srgb => linear_to_srgb(c),
        Transfer::Display => c,
    };
    (e * 255.0).round() as u8
}

/// The 8-bit pixel a PNG holds for linear value `p` of `img`: times the exposure, tone
/// mapped, clamped to [0, 1] and encoded by the transfer (the preview's `display.wgsl`
/// likewise).
pub fn display_rgb8(p: [f32; 4], img: &Image) -> [u8; 3] {
    let c = img.tonemap.apply([p[0] * img.exposure, p[1] * img.exposure, p[2] * img.exposure]);
    c.map(|v| png_value(v, img.transfer))
}

/// The 8-bit image a PNG would hold ([`display_rgb8`]).
pub fn to_rgb8(img: &Image) -> ImageBuffer<Rgb<u8>, Vec<u8>> {
    ImageBuffer::from_fn(img.width, img.height, |x, y| Rgb(display_rgb8(img.get(x, y), img)))
}

/// Writes `img` to `path` in the format its extension names, atomically.
pub fn write(img: &Image, path: &Path) -> Result<(), Error> {
    let format = OutputFormat::from_path(path)?;
    if img.has_alpha && format != OutputFormat::Exr {
        return Err(Error::AovNeedsExr { path: path.to_owned() });
    }
    write_atomically(path, |w| match format {
        OutputFormat::Png => to_rgb8(img)
            .write_to(w, ImageFormat::Png)
            .map_err(|source| Error::Encode { path: path.to_owned(), source }),
        OutputFormat::Exr => encode_exr(w, img, (0, 0), (img.width, img.height), None)
            .map_err(|e| Error::Options(format!("{}: cannot encode the image: {e}", path.display()))),
        OutputFormat::Hdr => to_rgb32f(img)
            .write_to(w, ImageFormat::Hdr)
            .map_err(|source| Error::Encode { path: path.to_owned(), source }),
    })
}

/// The linear values an .hdr file holds: RGBE stores no negative or NaN value, so those
/// become 0 (a render makes neither; an image read from elsewhere might).
pub fn to_rgb32f(img: &Image) -> image::Rgb32FImage {
    let f = |v: f32| if v > 0.0 { v } else { 0.0 };
    ImageBuffer::from_fn(img.width, img.height, |x, y| {
        let p = img.get(x, y);
        Rgb([f(p[0]), f(p[1]), f(p[2])])
    })
}

/// Encodes `img` as OpenEXR: f32 RGB (RGBA for AOVs), ZIP-compressed scan lines in
/// increasing order, so that equal pixels give equal files (the compression runs in
/// parallel, but the chunks are written sorted). Its data window starts at `position` of a
/// display window `display` pixels wide and high; `attribute`, if any, goes into the header
/// beside `software` = `cuberay` (one at most: the exr crate keeps them in a hash map, whose
/// order would vary between runs).
pub fn encode_exr(
    w: &mut (impl Write + std::io::Seek),
    img: &Image,
    position: (u32, u32),
    display: (u32, u32),
    attribute: Option<(exr::meta::attribute::Text, exr::meta::attribute::AttributeValue)>,
) -> exr::error::UnitResult {
    use exr::prelude as x;
    use x::traits::WritableImage;
    let mut layer_attributes = x::LayerAttributes {
        layer_position: x::Vec2(position.0 as i32, position.1 as i32),
        software_name: Some(x::Text::from("cuberay")),
        ..Default::default()
    };
    layer_attributes.other.extend(attribute);
    let mut image_attributes =
        x::ImageAttributes::new(x::IntegerBounds::from_dimensions((display.0 as usize, display.1 as usize)));
    image_attributes.pixel_aspect = 1.0;
    let size = (img.width as usize, img.height as usize);
    let at = |p: x::Vec2<usize>| img.pixels[p.y() * img.width as usize + p.x()];
    if img.has_alpha {
        let channels = x::SpecificChannels::rgba(|p: x::Vec2<usize>| {
            let v = at(p);
            (v[0], v[1], v[2], v[3])
        });
        let layer = x::Layer::new(size, layer_attributes, x::Encoding::SMALL_LOSSLESS, channels);
        x::Image::new(image_attributes, layer).write().to_buffered(w)
    } else {
        let channels = x::SpecificChannels::rgb(|p: x::Vec2<usize>| {
            let v = at(p);
            (v[0], v[1], v[2])
        });
        let layer = x::Layer::new(size, layer_attributes, x::Encoding::SMALL_LOSSLESS, channels);
        x::Image::new(image_attributes, layer).write().to_buffered(w)
    }
}

/// Writes an 8-bit RGB image (row-major, 3 bytes a pixel, e.g. a heat map) as a PNG,
/// atomically.
pub fn write_rgb8(width: u32, height: u32, rgb: Vec<u8>, path: &Path) -> Result<(), Error> {
    let buf: ImageBuffer<Rgb<u8>, Vec<u8>> =
        ImageBuffer::from_raw(width, height, rgb).expect("3 bytes per pixel of a width x height image");
    write_atomically(path, |w| {
        buf.write_to(w, ImageFormat::Png).map_err(|source| Error::Encode { path: path.to_owned(), source })
    })
}

/// Runs `encode` into a temporary file beside `path` and renames it to `path` on success
/// (on failure or a stop asked for, the temporary file is removed and `path` is untouched).
pub fn write_atomically(
    path: &Path,
    encode: impl FnOnce(&mut BufWriter<&std::fs::File>) -> Result<(), Error>,
) -> Result<(), Error> {
    let io = |source| Error::Io { path: path.to_owned(), source };
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let mut builder = tempfile::Builder::new();
    builder.prefix(".cuberay-").suffix(".tmp");
    // Created as any new file would be (0666 less the umask), not tempfile's private 0600:
    // the file is renamed into place as the output.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    let tmp = builder.tempfile_in(dir).map_err(|e| Error::Io {
        path: dir.to_owned(),
        source: std::io::Error::new(
            e.kind(),
            if dir.is_dir() { "cannot create a file in this folder" } else { "no such folder" },
        ),
    })?;
    {
        let mut w = BufWriter::new(tmp.as_file());
        encode(&mut w)?;
        w.flush().map_err(io)?;
    }
    tmp.as_file().sync_all().map_err(io)?;
    // A stop asked for while the file was written: nothing is left behind (dropping `tmp` on
    // any error above removes the temporary file).
    crate::interrupt::check()?;
    tmp.persist(path).map_err(|e| io(e.error))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats_by_extension() {
        assert_eq!(OutputFormat::from_path(Path::new("a/b.PNG")).unwrap(), OutputFormat::Png);
        assert_eq!(OutputFormat::from_path(Path::new("b.exr")).unwrap(), OutputFormat::Exr);
        assert_eq!(OutputFormat::from_path(Path::new("b.HDR")).unwrap(), OutputFormat::Hdr);
        assert!(OutputFormat::from_path(Path::new("b.jpg")).is_err());
        assert!(OutputFormat::from_path(Path::new("b")).is_err());
    }

    #[test]
    fn png_applies_exposure_then_the_tone_mapping_then_the_transfer() {
        let mut img = Image::new(1, 1, false);
        img.transfer = Transfer::Display;
        img.pixels[0] = [0.25, 0.5, 4.0, 1.0];
        assert_eq!(display_rgb8(img.pixels[0], &img), [64, 128, 255]);
        img.exposure = 2.0;
        assert_eq!(display_rgb8(img.pixels[0], &img), [128, 255, 255]);
        // PBR Neutral keeps a colour below 0.76 but for its offset (0.04 where every
        // channel is at least 0.08), and brings a bright one below 1.
        img.exposure = 1.0;
        img.tonemap = Tonemap::PbrNeutral;
        img.pixels[0] = [0.3, 0.5, 0.7, 1.0];
        assert_eq!(display_rgb8(img.pixels[0], &img), png_values([0.26, 0.46, 0.66]));
        img.pixels[0] = [10.0, 10.0, 10.0, 1.0];
        let bright = display_rgb8(img.pixels[0], &img);
        assert!(bright[0] < 255 && bright[0] > 240, "{bright:?}");
        // ACES maps black to black and a bright grey below white.
        img.tonemap = Tonemap::Aces;
        img.pixels[0] = [0.0, 0.0, 0.0, 1.0];
        assert_eq!(display_rgb8(img.pixels[0], &img), [0, 0, 0]);
        img.pixels[0] = [1.0, 1.0, 1.0, 1.0];
        let grey = display_rgb8(img.pixels[0], &img);
        assert!(grey.iter().all(|&g| g > 150 && g < 255), "{grey:?}");
    }

    fn png_values(c: [f32; 3]) -> [u8; 3] {
        c.map(|v| png_value(v, Transfer::Display))
    }

    #[test]
    fn png_mapping_clamps_and_encodes() {
        for t in [Transfer::Srgb, Transfer::Display] {
            assert_eq!(png_value(-1.0, t), 0);
            assert_eq!(png_value(0.0, t), 0);
            assert_eq!(png_value(1.0, t), 255);
            assert_eq!(png_value(7.0, t), 255);
            assert_eq!(png_value(f32::NAN, t), 0);
        }
        assert_eq!(png_value(0.5, Transfer::Srgb), 188);
        assert_eq!(png_value(0.5, Transfer::Display), 128);
    }

    /// An output gets the permissions any new file gets (the umask's), not a temporary
    /// file's private ones.
    #[cfg(unix)]
    #[test]
    fn outputs_get_the_permissions_of_a_new_file() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let (ours, plain) = (dir.path().join("ours.txt"), dir.path().join("plain.txt"));
        write_atomically(&ours, |w| {
            w.write_all(b"x").map_err(|e| Error::Io { path: ours.clone(), source: e })
        })
        .unwrap();
        std::fs::write(&plain, b"x").unwrap();
        let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode(&ours), mode(&plain));
    }

    #[test]
    fn equal_images_give_equal_exr_files() {
        // Big enough for many compressed chunks, which are compressed in parallel.
        let mut img = Image::new(300, 200, false);
        for (i, p) in img.pixels.iter_mut().enumerate() {
            *p = [(i % 7) as f32 * 0.1, (i % 300) as f32 / 300.0, ((i * 31) % 97) as f32, 1.0];
        }
        let dir = tempfile::tempdir().unwrap();
        let files: Vec<Vec<u8>> = (0..4)
            .map(|k| {
                let p = dir.path().join(format!("x{k}.exr"));
                write(&img, &p).unwrap();
                std::fs::read(&p).unwrap()
            })
            .collect();
        assert!(files.windows(2).all(|w| w[0] == w[1]), "the EXR bytes vary between writes");
        let back = image::open(dir.path().join("x0.exr")).unwrap().into_rgb32f();
        assert_eq!(back.get_pixel(17, 3).0, [img.get(17, 3)[0], img.get(17, 3)[1], img.get(17, 3)[2]]);
    }

    /// An .hdr file holds linear radiance above 1 to RGBE's precision (8-bit mantissas under
    /// an exponent shared by the pixel: each channel within 1% of the pixel's largest),
    /// negative and NaN values as 0, and refuses an AOV.
    #[test]
    fn hdr_holds_linear_radiance() {
        let dir = tempfile::tempdir().unwrap();
        let mut img = Image::new(4, 3, false);
        img.pixels[5] = [0.25, 37.5, 0.003, 1.0];
        img.pixels[6] = [-1.0, f32::NAN, 1.0, 1.0];
        let hdr = dir.path().join("x.hdr");
        write(&img, &hdr).unwrap();
        let back = image::open(&hdr).unwrap().into_rgb32f();
        assert_eq!(back.dimensions(), (4, 3));
        for (got, want) in back.get_pixel(1, 1).0.iter().zip([0.25f32, 37.5, 0.003]) {
            assert!((got - want).abs() <= 0.01 * 37.5, "{got} for {want}");
        }
        assert!((back.get_pixel(1, 1).0[1] - 37.5).abs() / 37.5 < 0.01);
        assert_eq!(back.get_pixel(2, 1).0[..2], [0.0, 0.0]);
        assert!((back.get_pixel(2, 1).0[2] - 1.0).abs() < 0.01);
        let aov = Image::new(2, 2, true);
        assert!(matches!(write(&aov, &dir.path().join("a.hdr")), Err(Error::AovNeedsExr { .. })));
    }

    #[test]
    fn writes_png_and_exr_and_leaves_no_temporary_file() {
        let dir = tempfile::tempdir().unwrap();
        let mut img = Image::new(3, 2, false);
        img.pixels[4] = [0.25, 2.0, 0.0, 1.0];
        let png = dir.path().join("x.png");
        let exr = dir.path().join("x.exr");
        write(&img, &png).unwrap();
        write(&img, &exr).unwrap();
        let back = image::open(&exr).unwrap().into_rgb32f();
        assert_eq!(back.get_pixel(1, 1).0, [0.25, 2.0, 0.0]);
        let back = image::open(&png).unwrap().into_rgb8();
        assert_eq!(back.get_pixel(1, 1).0, [png_value(0.25, Transfer::Srgb), 255, 0]);
        // Display values are stored as they are.
        img.transfer = Transfer::Display;
        write(&img, &png).unwrap();
        assert_eq!(image::open(&png).unwrap().into_rgb8().get_pixel(1, 1).0, [64, 255, 0]);
        let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(names.len(), 2, "{names:?}");
        // An AOV cannot go to a PNG, and nothing is written.
        let aov = Image::new(1, 1, true);
        let p = dir.path().join("aov.png");
        assert!(write(&aov, &p).is_err());
        assert!(!p.exists());
    }
}
