//! glTF 2.0 loader: `.gltf` (external or data-URI buffers) and `.glb`.
//!
//! The `gltf` crate parses the JSON and checks that references between objects resolve;
//! everything it does not check is checked here, before any byte is read: buffer sizes,
//! accessor and buffer-view ranges, component types, counts, index values, and the
//! finiteness of positions and transforms. Errors name the file and the JSON path of the
//! offending use, e.g. `meshes[2].primitives[0].attributes.POSITION (accessors[5])`.
//!
//! What is loaded:
//! - the default scene (or scene 0, or every root node when the file has no scene), with
//!   the full node hierarchy (matrix or TRS; normals by the inverse transpose; a mirroring
//!   transform flips the winding); every node that instances a mesh gets its own triangles;
//! - TRIANGLES, TRIANGLE_STRIP and TRIANGLE_FAN primitives, indexed or not (POINTS and
//!   LINES are skipped with a warning); normals from NORMAL, UVs from the TEXCOORD set of
//!   the material's base colour texture; degenerate triangles are dropped with a count;
//! - cameras: the first camera node in traversal order, or the N-th with
//!   [`LoadOptions::camera`]; without one, a camera framing the scene (with a warning);
//! - with [`LoadOptions::time`], the nodes' translation, rotation and scale animation
//!   channels sampled at that time (`animation`), cameras and lights as well as meshes;
//! - KHR_lights_punctual point, spot and directional lights; without any light, the
//!   documented default headlight ([`Light::default_for`], with a warning);
//! - metallic-roughness materials with KHR_materials_transmission, KHR_materials_ior and
//!   KHR_materials_emissive_strength, mapped as [`crate::scene`] documents; the base colour
//!   texture's KHR_texture_transform is applied to the UVs of the triangles that use it;
//! - glTF as the optimizers write it: quantized attributes (KHR_mesh_quantization),
//!   meshopt-compressed buffer views (`meshopt`), Draco-compressed primitives (`draco`),
//!   instanced meshes (`instancing`) and WebP images; [`extensions`] lists what is done with
//!   every extension.
//!
//! glTF has no ambient light or background colour: both are black.

use std::collections::BTreeSet;
use std::path::Path;

use glam::DVec3;
use gltf::Document;

use super::{LoadOptions, Loaded};
use crate::error::Error;
use crate::scene::{Camera, Light, Scene, Transfer};

mod animation;
mod data;
mod draco;
pub mod extensions;
mod geometry;
mod instancing;
mod layers;
mod materials;
mod meshopt;
mod view;

/// The file being loaded, for error messages.
pub(crate) struct Ctx<'a> {
    pub path: &'a Path,
}

impl Ctx<'_> {
    /// An error at `location` (a JSON path) in the file.
    pub fn err(&self, location: impl Into<String>, message: impl Into<String>) -> Error {
        Error::Gltf { path: self.path.to_owned(), location: location.into(), message: message.into() }
    }

    fn invalid(&self, message: impl Into<String>) -> Error {
        Error::Invalid { path: self.path.to_owned(), message: message.into() }
    }
}

/// Parses the JSON (and GLB container), rejects unsupported required extensions, then
/// runs the `gltf` crate's validation.
fn parse(ctx: &Ctx, bytes: &[u8]) -> Result<gltf::Gltf, Error> {
    if bytes.starts_with(b"glTF") {
        // The gltf crate subtracts the header size from the declared length unchecked.
        let declared = bytes.get(8..12).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize);
        match declared {
            Some(n) if (12..=bytes.len()).contains(&n) => {}
            Some(n) => {
                return Err(ctx.err(
                    "GLB header",
                    format!("declares {n} bytes, but the file has {} (truncated or corrupt)", bytes.len()),
                ))
            }
            None => return Err(ctx.err("GLB header", "truncated: fewer than 12 bytes")),
        }
    }
    let gltf::Gltf { document, blob } =
        gltf::Gltf::from_slice_without_validation(bytes).map_err(|e| match e {
            gltf::Error::Deserialize(e) => ctx.err("JSON", format!("{e}")),
            gltf::Error::Binary(e) => ctx.err("GLB", glb_message(&e)),
            e => ctx.err("file", format!("{e}")),
        })?;
    for (i, ext) in document.extensions_required().enumerate() {
        if !extensions::can_require(ext) {
            return Err(ctx.err(format!("extensionsRequired[{i}]"), extensions::refusal(ext)));
        }
    }
    let mut json = document.into_json();
    check_what_validation_indexes(ctx, &json)?;
    texture_sources(ctx, &mut json)?;
    let errors = validate(ctx, &json)?;
    if let Some((path, first)) = errors.first() {
        let more = match errors.len() {
            1 => String::new(),
            n => format!(" (and {} more problems)", n - 1),
        };
        return Err(ctx.err(path.to_string(), format!("{first}{more}")));
    }
    let document = Document::from_json_without_validation(json);
    Ok(gltf::Gltf { document, blob })
}

/// The `gltf` crate's validation of the JSON, less what it reports wrongly here: a required
/// extension the crate does not know (this loader checked them: [`extensions`]), and an
/// accessor without a bufferView, which glTF allows (its elements are zeros; a Draco
/// primitive's accessors have none, their data being in the stream).
fn validate(
    ctx: &Ctx,
    json: &gltf::json::Root,
) -> Result<Vec<(gltf::json::Path, gltf::json::validation::Error)>, Error> {
    use gltf::json::validation::{Error as E, Validate};
    let mut errors = Vec::new();
    // The crate's validation indexes some references before checking them (a bad POSITION
    // accessor: `check_what_validation_indexes`): whatever else it might panic on is
    // contained here and reported as this file's error, not a crash.
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        json.validate(json, gltf::json::Path::new, &mut |path, error| errors.push((path(), error)))
    }))
    .map_err(|_| ctx.err("file", "the glTF validation failed on this file (a malformed reference)"))?;
    errors.retain(|(path, error)| {
        let p = path.as_str();
        let checked_here = match error {
            E::Unsupported => p.starts_with("extensionsRequired["),
            E::Missing => p.starts_with("accessors[") && p.ends_with("].bufferView"),
            _ => false,
        };
        !checked_here
    });
    Ok(errors)
}

/// The references the `gltf` crate's validation follows before checking them: gltf-json
/// 1.4's `primitive_validate_hook` indexes `accessors` with a primitive's POSITION
/// unchecked, so a file naming an accessor that does not exist panicked inside
/// `Document::from_json` (found by mutating sample files). The upstream fix is a
/// `root.accessors.get(i)` there, reporting `Error::IndexOutOfBounds`.
fn check_what_validation_indexes(ctx: &Ctx, json: &gltf::json::Root) -> Result<(), Error> {
    let accessors = json.accessors.len();
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            let position = gltf::json::validation::Checked::Valid(gltf::Semantic::Positions);
            if let Some(index) = prim.attributes.get(&position) {
                if index.value() >= accessors {
                    return Err(ctx.err(
                        format!("meshes[{m}].primitives[{p}].attributes.POSITION"),
                        format!(
                            "names accessors[{}], but the file has {accessors} accessor{}",
                            index.value(),
                            if accessors == 1 { "" } else { "s" }
                        ),
                    ));
                }
            }
        }
    }
    Ok(())
}

/// Points each texture at the image it is read from: EXT_texture_webp's source where the
/// texture has one (its `source`, if any, is a fallback for viewers without WebP). A texture
/// with no source but a KHR_texture_basisu one cannot be read, and is refused by name.
fn texture_sources(ctx: &Ctx, json: &mut gltf::json::Root) -> Result<(), Error> {
    for (i, texture) in json.textures.iter_mut().enumerate() {
        let ext = |name: &str| texture.extensions.as_ref().and_then(|e| e.others.get(name)).cloned();
        let loc = format!("textures[{i}]");
        if let Some(webp) = ext("EXT_texture_webp") {
            let source = webp.get("source").and_then(|s| s.as_u64()).filter(|&s| s < u32::MAX as u64);
            let source = source.ok_or_else(|| {
                ctx.err(format!("{loc}.extensions.EXT_texture_webp"), "has no source image index")
            })?;
            texture.source = gltf::json::Index::new(source as u32);
        } else if texture.source.value() == u32::MAX as usize && ext("KHR_texture_basisu").is_some() {
            return Err(ctx.err(loc, extensions::refusal("KHR_texture_basisu")));
        }
    }
    Ok(())
}

/// A GLB container error in words.
fn glb_message(e: &gltf::binary::Error) -> String {
    use gltf::binary::Error as E;
    match e {
        E::Io(e) => format!("truncated: {e}"),
        E::Version(v) => format!("version {v} is not supported (expected 2)"),
        E::Magic(m) => format!("bad magic {m:?}"),
        E::Length { length, length_read } => {
            format!("the header declares {length} bytes of chunks, but only {length_read} follow (truncated)")
        }
        E::ChunkLength { ty, length, length_read } => {
            format!("the {ty:?} chunk declares {length} bytes, but only {length_read} follow (truncated)")
        }
        E::ChunkType(ty) => format!("unexpected {ty:?} chunk (the JSON chunk must come first, then BIN)"),
        E::UnknownChunkType(t) => format!("unknown chunk type {:?}", String::from_utf8_lossy(t)),
    }
}

/// The glTF materials (None: the default material) of the surface primitives the scene
/// instances.
fn used_materials(doc: &Document, hierarchy: &geometry::Hierarchy) -> BTreeSet<Option<usize>> {
    use gltf::mesh::Mode;
    let meshes: Vec<gltf::Mesh> = doc.meshes().collect();
    let mut used = BTreeSet::new();
    for placed in &hierarchy.meshes {
        for prim in meshes[placed.item].primitives() {
            let surface = matches!(prim.mode(), Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan);
            if surface && prim.get(&gltf::Semantic::Positions).is_some() {
                used.insert(prim.material().index());
            }
        }
    }
    used
}

/// Every buffer of `doc` (with `blob`, a GLB's binary chunk), the meshopt views and the
/// Draco streams decoded.
fn buffers(ctx: &Ctx, doc: &Document, blob: Option<Vec<u8>>) -> Result<data::Buffers, Error> {
    let buffers = data::Buffers::load(ctx, doc, blob)?;
    let decoded = draco::decode_primitives(ctx, doc, &buffers)?;
    Ok(buffers.with_decoded(decoded))
}

/// Loads a .gltf or .glb file into a validated scene.
pub fn load(path: &Path, options: &LoadOptions) -> Result<Loaded, Error> {
    let ctx = Ctx { path };
    let bytes = std::fs::read(path).map_err(|source| Error::Io { path: path.to_owned(), source })?;
    let gltf::Gltf { document: doc, blob } = parse(&ctx, &bytes)?;
    drop(bytes);
    let mut warnings = Vec::new();
    for ext in doc.extensions_used() {
        if extensions::status(ext, false) == extensions::Status::Ignored {
            warnings.push(extensions::ignored_warning(ext));
        }
    }

    let buffers = buffers(&ctx, &doc, blob)?;
    let reader = data::Reader { ctx: &ctx, buffers: &buffers };
    let pose = match options.time {
        None => animation::Pose::default(),
        Some(_) if !animation::has_animations(&doc) => {
            return Err(ctx.invalid("the file has no animations to sample frames of (--frames)"))
        }
        Some(t) => animation::pose_at(&reader, &doc, t, &mut warnings)?,
    };
    let hierarchy = instancing::expand(&reader, &doc, geometry::walk(&ctx, &doc, &pose)?)?;
    let mut table = materials::build(&ctx, &doc, &buffers, &used_materials(&doc, &hierarchy), &mut warnings)?;
    let primitives = geometry::triangles(&reader, &doc, &hierarchy, &table, &mut warnings)?;
    materials::widen_bounds_for_missing_uvs(&mut table.materials, &primitives);
    if primitives.is_empty() {
        return Err(ctx.invalid(format!(
            "the scene has no triangles to render ({} mesh nodes in it)",
            hierarchy.meshes.len()
        )));
    }

    let bounds = primitives.iter().fold(crate::scene::Aabb::EMPTY, |b, p| b.union(&p.bounds()));
    // A camera node gives no look-at point: the one along its view nearest the scene's
    // centre (one unit ahead where that lies behind it), for `--look-from` and `info`.
    let aimed = |mut camera: Camera| {
        let centre = bounds.center();
        let ahead = (centre - camera.eye).dot(camera.forward);
        if centre.is_finite() {
            camera.target = camera.eye + camera.forward * if ahead > 0.0 { ahead } else { 1.0 };
        }
        camera
    };
    let camera = match options.camera {
        Some(n) => match hierarchy.cameras.get(n) {
            Some(placed) => aimed(view::camera(&ctx, &doc, placed)?),
            None => {
                return Err(ctx.invalid(format!(
                    "camera {n} was asked for, but the scene has {} camera nodes{}",
                    hierarchy.cameras.len(),
                    match hierarchy.cameras.len() {
                        0 => String::new(),
                        k => format!(" (valid: 0 to {})", k - 1),
                    }
                )))
            }
        },
        None => match hierarchy.cameras.first() {
            Some(placed) => aimed(view::camera(&ctx, &doc, placed)?),
            None => {
                let cam = view::framing_camera(&bounds).map_err(|e| ctx.invalid(e.into_message()))?;
                let d = view::AUTO_CAMERA_DIRECTION;
                warnings.push(format!(
                    "the scene has no camera: using a {}° perspective camera framing its bounds from direction ({}, {}, {})",
                    view::AUTO_CAMERA_FOV_DEGREES,
                    d.x,
                    d.y,
                    d.z
                ));
                cam
            }
        },
    };

    let mut lights = hierarchy
        .lights
        .iter()
        .map(|placed| view::light(&ctx, &doc, placed))
        .collect::<Result<Vec<_>, _>>()?;
    if lights.is_empty() {
        lights.push(Light::default_for(&camera));
        warnings.push("the scene has no light: added the default white headlight at the camera".into());
    }

    let scene = Scene {
        camera,
        lights,
        ambient: DVec3::ZERO,
        background: DVec3::ZERO,
        materials: table.materials,
        textures: table.textures,
        primitives,
        resolution: None,
        up: DVec3::Y,
        environment: None,
        transfer: Transfer::Srgb,
    };
    scene.validate().map_err(|e| ctx.invalid(format!("internal check failed: {}", e.into_message())))?;
    Ok(Loaded { scene, warnings, format: crate::load::SceneFormat::Gltf })
}
