//! The library's one error type. Every fallible function of `cuberay` returns [`Error`]: a
//! variant per kind of failure, each saying what was wrong and where (the file, and the line
//! or JSON path in it), in words a user can act on. Only the binary turns it into `anyhow`
//! context and an exit code.
//!
//! A variant that wraps a lower-level error keeps it as its `source` and does not repeat it in
//! its own message, so that a printed chain (`{:#}`) names each cause once.

use std::path::PathBuf;

/// What went wrong.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be read or written.
    #[error("{}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// NFF syntax or value error. `line` is 1-based; `token` is the offending token, if any.
    #[error("{}:{line}: {message}{}", path.display(), token.as_ref().map(|t| format!(" (at token '{t}')")).unwrap_or_default())]
    Nff { path: PathBuf, line: usize, token: Option<String>, message: String },
    /// glTF error. `location` is a JSON path such as `meshes[2].primitives[0].attributes.POSITION`.
    #[error("{}: {location}: {message}", path.display())]
    Gltf { path: PathBuf, location: String, message: String },
    /// A scene file parsed but its scene cannot be rendered (no geometry, a bad camera...).
    #[error("{}: {message}", path.display())]
    Invalid { path: PathBuf, message: String },
    /// A scene file whose extension names no format cuberay reads.
    #[error("{}: unknown scene format (expected a .nff, .gltf or .glb file)", path.display())]
    UnknownSceneFormat { path: PathBuf },
    /// A scene (read from a file or built in code) breaks an invariant of the scene model.
    #[error("invalid scene: {0}")]
    Scene(String),
    /// Render options that cannot be rendered (an empty image, `--spp 0`...).
    #[error("{0}")]
    Options(String),
    /// A stored tables file (`render --tables`) that cannot be read or was built for
    /// another render.
    #[error("{}: {message}", path.display())]
    Tables { path: PathBuf, message: String },
    /// A partial image (`cuberay merge`) that cannot be read or does not fit the others.
    #[error("{}: {message}", path.display())]
    Part { path: PathBuf, message: String },
    /// An output file name whose extension names no format cuberay writes.
    #[error("{}: unknown image format (expected a .png, .exr or .hdr file name)", path.display())]
    UnknownImageFormat { path: PathBuf },
    /// An auxiliary output (depth, normal, id) asked for in a format that cannot hold it.
    #[error("{}: auxiliary outputs (--aov) hold linear values and need an .exr file", path.display())]
    AovNeedsExr { path: PathBuf },
    /// The image encoder failed.
    #[error("{}: cannot encode the image", path.display())]
    Encode {
        path: PathBuf,
        #[source]
        source: image::ImageError,
    },
    /// The candidate tables need more than one storage binding holds, even at the coarsest
    /// resolution the build tries.
    #[error("the candidate tables need {bytes} bytes in one buffer, over wgpu's {limit}-byte binding limit, even at the coarsest resolution the build tries")]
    TablesTooLarge { bytes: usize, limit: usize },
    /// Built tables break an invariant the walkers rely on (a bug in the builder).
    #[error("the candidate tables are inconsistent: {0}")]
    TablesInvalid(String),
    /// No GPU adapter at all (or none matching `WGPU_ADAPTER_NAME`).
    #[error(
        "no GPU adapter found{filter}. On Debian or Ubuntu install Mesa's software Vulkan driver \
         (lavapipe) with `sudo apt-get install mesa-vulkan-drivers`, or run `bash .ci/setup` in \
         the cuberay repository; or render on the CPU with `--backend cpu`"
    )]
    NoAdapter { filter: String },
    /// The adapter refused to open a device.
    #[error("the GPU adapter '{adapter}' refused to open a device")]
    Device {
        adapter: String,
        #[source]
        source: wgpu::RequestDeviceError,
    },
    /// A bug in `shaders/` found while composing a kernel, with its file and line.
    #[error("shaders/{file}:{line}: {message}")]
    Shader { file: String, line: usize, message: String },
    /// The GPU failed during a render (a lost device, a queue overflow too wide to split).
    #[error("the GPU failed: {0}")]
    Gpu(String),
    /// A call into wgpu failed (`what`: waiting for the queue, mapping a buffer for a
    /// readback); wgpu's own error is the source.
    #[error("the GPU failed while {what}")]
    GpuCall {
        what: &'static str,
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// The preview found no display to open its window on.
    #[error(
        "cannot open a window ({0}): the preview needs a display (X11 or Wayland). To render \
         without one use `cuberay render SCENE -o image.png` (--spp N renders the samples of N \
         preview frames)"
    )]
    NoDisplay(String),
    /// The window system failed.
    #[error("the window system failed: {0}")]
    Window(String),
    /// A signal (`signal`, its number) asked to stop; nothing was written.
    #[error("interrupted by signal {signal}; nothing was written")]
    Interrupted { signal: i32 },
}

impl Error {
    /// The bare message of a [`Error::Scene`] (for a loader to place it in its file), or the
    /// whole message of any other error.
    pub fn into_message(self) -> String {
        match self {
            Error::Scene(m) => m,
            e => e.to_string(),
        }
    }
}

/// `Result` with the library's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// A [`Error::Scene`] placed inside a part of the scene (`light 2`, `primitive 17`...);
    /// other errors unchanged.
    pub fn within(self, part: impl std::fmt::Display) -> Error {
        match self {
            Error::Scene(m) => Error::Scene(format!("{part}: {m}")),
            e => e,
        }
    }
}
