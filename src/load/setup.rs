//! What a loaded scene gets beyond its file, from the command line: another camera
//! (`--look-from`, `--look-at`, `--up`, `--fov`) and the environment (`--env`,
//! `--env-rotate`, `--env-intensity`, `--env-lights`), read from `.hdr` and `.exr` maps.

use std::path::{Path, PathBuf};

use glam::DVec3;

use super::{Loaded, SceneFormat};
use crate::error::Error;
use crate::scene::environment::{self, Environment, DEFAULT_LIGHTS, MAX_LIGHTS, MAX_WIDTH};
use crate::scene::{LightSource, ViewOverride};

/// Which environment surrounds the scene (`--env`).
#[derive(Clone, Debug, Default, PartialEq)]
pub enum EnvChoice {
    /// The built-in studio for a glTF scene without lights, else none.
    #[default]
    Auto,
    /// None: the file's background (and for a file without lights, the default headlight).
    None,
    /// The built-in studio environment ([`environment::studio`]).
    Studio,
    /// An equirectangular map read from an `.hdr` or `.exr` file.
    File(PathBuf),
}

/// The command line's additions to a loaded scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Setup {
    pub view: ViewOverride,
    pub env: EnvChoice,
    /// `--env-rotate`: degrees about the up axis.
    pub env_rotate: f64,
    /// `--env-intensity`: what the map's radiance is multiplied by.
    pub env_intensity: f64,
    /// `--env-lights`: how many directional lights stand in for the map (0: none).
    pub env_lights: u32,
}

impl Default for Setup {
    fn default() -> Setup {
        Setup {
            view: ViewOverride::default(),
            env: EnvChoice::Auto,
            env_rotate: 0.0,
            env_intensity: 1.0,
            env_lights: DEFAULT_LIGHTS,
        }
    }
}

impl Setup {
    /// Checks the numbers; the error names the flag.
    pub fn validate(&self) -> Result<(), Error> {
        let bad = |m: String| Err(Error::Options(m));
        for (flag, v) in
            [("--look-from", self.view.from), ("--look-at", self.view.at), ("--up", self.view.up)]
        {
            if v.is_some_and(|v| !v.is_finite()) {
                return bad(format!("{flag} {} is not three finite numbers", v.unwrap()));
            }
        }
        if self.view.up.is_some_and(|u| u.length_squared() == 0.0) {
            return bad("--up is the zero vector".into());
        }
        if let Some(f) = self.view.fov_degrees {
            if !(f.is_finite() && f > 0.0 && f < 180.0) {
                return bad(format!("--fov {f} is not between 0 and 180 degrees"));
            }
        }
        if !self.env_rotate.is_finite() {
            return bad(format!("--env-rotate {} is not a finite number of degrees", self.env_rotate));
        }
        if !(self.env_intensity.is_finite() && self.env_intensity >= 0.0) {
            return bad(format!(
                "--env-intensity {} is not a finite number of at least 0",
                self.env_intensity
            ));
        }
        if self.env_lights > MAX_LIGHTS {
            return bad(format!(
                "--env-lights {} is more than the {MAX_LIGHTS} cuberay takes",
                self.env_lights
            ));
        }
        Ok(())
    }
}

/// The map's centre column for a world whose up is `up`: +X made orthogonal to it (+Y where
/// up is along X), so that a glTF scene (up +Y) sees +X there, as the Sample Viewer does.
fn front_for(up: DVec3) -> DVec3 {
    let x = if up.x.abs() > 0.9 { DVec3::Y } else { DVec3::X };
    (x - up * x.dot(up)).normalize()
}

/// Applies `setup` to `loaded` (a scene from `path`): the camera, then the environment, and
/// a warning where the default changed what the file alone gives.
pub fn apply(loaded: &mut Loaded, path: &Path, setup: &Setup) -> Result<(), Error> {
    setup.validate()?;
    let scene = &mut loaded.scene;
    let camera = scene.camera.overridden(&setup.view, scene.up)?;
    let moved = camera.eye != scene.camera.eye;
    scene.camera = camera;
    let headlight = scene.lights.iter().any(|l| l.source == LightSource::Default);
    let choice = match &setup.env {
        EnvChoice::Auto if loaded.format == SceneFormat::Gltf && headlight => EnvChoice::Studio,
        EnvChoice::Auto => EnvChoice::None,
        c => c.clone(),
    };
    let env = match &choice {
        EnvChoice::None | EnvChoice::Auto => None,
        EnvChoice::Studio => Some(environment::studio(scene.up, front_for(scene.up))),
        EnvChoice::File(p) => Some(read_environment(p, scene.up, front_for(scene.up))?),
    };
    let env = env.map(|e| Environment { intensity: setup.env_intensity, ..e.rotated(setup.env_rotate) });
    let lit_by_env = env.is_some();
    // The lights that are not the file's follow what the scene is now: the environment's,
    // or the default headlight at the camera's eye, wherever the camera moved.
    scene.set_environment(env, setup.env_lights);
    if headlight && (lit_by_env || moved) {
        // The loader's warning about the headlight no longer holds.
        loaded.warnings.retain(|w| !w.contains("headlight"));
        if !lit_by_env {
            loaded.warnings.push(format!(
                "the file has no light: added a white headlight at the eye {} (intensity 1)",
                scene.camera.eye
            ));
        } else if setup.env == EnvChoice::Auto {
            loaded.warnings.push(
                "the scene has no light: lit by the built-in studio environment (--env none gives the default \
                 headlight instead)"
                    .into(),
            );
        }
    }
    scene.validate().map_err(|e| Error::Invalid { path: path.to_owned(), message: e.into_message() })?;
    Ok(())
}

/// Reads an equirectangular `.hdr` or `.exr` map around `up`, centred on `front`.
pub fn read_environment(path: &Path, up: DVec3, front: DVec3) -> Result<Environment, Error> {
    let bytes = std::fs::read(path).map_err(|source| Error::Io { path: path.to_owned(), source })?;
    environment_from_bytes(&bytes, path, up, front)
}

/// [`read_environment`] of a file's bytes (for the fuzz target): the format by its content,
/// an EXR's header checked first ([`check_exr_header`]), a decoder kept within
/// [`MAX_WIDTH`] and a gigabyte, then [`Environment::from_rgb`]'s checks. Errors name `path`.
pub fn environment_from_bytes(
    bytes: &[u8],
    path: &Path,
    up: DVec3,
    front: DVec3,
) -> Result<Environment, Error> {
    let invalid = |message: String| Error::Invalid { path: path.to_owned(), message };
    let mut reader = image::ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| invalid(format!("cannot read the environment map: {e}")))?;
    match reader.format() {
        Some(image::ImageFormat::Hdr) => {}
        Some(image::ImageFormat::OpenExr) => check_exr_header(bytes).map_err(invalid)?,
        Some(f) => {
            return Err(invalid(format!(
                "an environment map is an equirectangular .hdr or .exr image, not {f:?}"
            )))
        }
        None => return Err(invalid("not an .hdr or .exr image".into())),
    }
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_WIDTH);
    limits.max_image_height = Some(MAX_WIDTH / 2 + 1);
    limits.max_alloc = Some(1 << 30);
    reader.limits(limits);
    let img = reader.decode().map_err(|e| invalid(format!("cannot decode the environment map: {e}")))?;
    let rgb = img.into_rgb32f();
    let (w, h) = rgb.dimensions();
    let name = path.file_name().map_or_else(|| path.display().to_string(), |n| n.to_string_lossy().into());
    Environment::from_rgb(&name, w, h, rgb.as_raw(), up, front)
        .map_err(|e| invalid(e.into_message().trim_start_matches("invalid scene: ").to_string()))
}

/// The most bytes one compressed block of an EXR map may unpack to (64 MiB: 32 lines of a
/// map `MAX_WIDTH` wide with four f32 channels take 8 MiB).
const MAX_EXR_BLOCK_BYTES: usize = 1 << 26;

/// Refuses an EXR whose header asks the decoder for more than a map could need, before it
/// allocates anything by it: the `exr` crate sizes a block's buffers by the header's data
/// window, tile size and channels, beyond what `image::Limits` bounds (a fuzzed file of a
/// kilobyte asked for 48 GiB, docs/fuzzing.md).
fn check_exr_header(bytes: &[u8]) -> Result<(), String> {
    let meta = exr::meta::MetaData::read_from_buffered(std::io::Cursor::new(bytes), false)
        .map_err(|e| format!("cannot read the environment map's EXR header: {e}"))?;
    for h in &meta.headers {
        let (w, ht) = (h.layer_size.width(), h.layer_size.height());
        if h.deep {
            return Err("an environment map holds flat pixels, not deep data".into());
        }
        if w > MAX_WIDTH as usize || ht > MAX_WIDTH as usize / 2 + 1 {
            return Err(format!("its {w}x{ht} pixels are more than an environment map's {MAX_WIDTH} a row"));
        }
        if h.channels.list.len() > 16 {
            return Err(format!("its {} channels are more than an RGB(A) map has", h.channels.list.len()));
        }
        // A block's bytes: its tile's pixels, or its scan lines', times the pixel's bytes.
        let block = h.max_block_byte_size();
        if block > MAX_EXR_BLOCK_BYTES {
            return Err(format!(
                "a block of it unpacks to {block} bytes, more than a map's {MAX_EXR_BLOCK_BYTES}"
            ));
        }
    }
    Ok(())
}
