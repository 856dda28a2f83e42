//! The glTF extensions the loader knows, and what it does with each: reads it, approximates
//! it on the Whitted model, ignores it, or refuses the file.
//!
//! One table ([`KNOWN`]) decides both the loader's answer to `extensionsRequired` and what
//! `cuberay info` lists. An extension the table does not know is ignored when the file only
//! uses it and refused when the file requires it, as the glTF specification asks.

use std::path::Path;

use serde::Serialize;

/// What the loader does with an extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Status {
    /// Read as the extension specifies.
    Read,
    /// Read, and mapped onto the Whitted model with a documented approximation.
    Approximated,
    /// Not read: the file renders without it (with a warning).
    Ignored,
    /// The file cannot be rendered without it, and the loader refuses it.
    Refused,
}

impl Status {
    pub fn name(self) -> &'static str {
        match self {
            Status::Read => "read",
            Status::Approximated => "approximated",
            Status::Ignored => "ignored",
            Status::Refused => "refused",
        }
    }
}

/// How an extension known to the loader is handled.
struct Known {
    name: &'static str,
    status: Status,
    /// How, in a few words (for `info` and the warnings).
    how: &'static str,
}

/// The rewrite that makes a file with KHR_texture_basisu textures readable.
pub const BASISU_REWRITE: &str = "npx @gltf-transform/cli ktxdecompress in.glb out.glb";

const KNOWN: &[Known] = &[
    Known { name: "KHR_lights_punctual", status: Status::Read, how: "point, spot and directional lights" },
    Known {
        name: "KHR_materials_transmission",
        status: Status::Approximated,
        how: "a Whitted refracted ray weighted by the transmission (no roughness)",
    },
    Known { name: "KHR_materials_ior", status: Status::Read, how: "the index of refraction" },
    Known { name: "KHR_materials_emissive_strength", status: Status::Read, how: "scales the emission" },
    Known { name: "KHR_texture_transform", status: Status::Read, how: "offset, rotation, scale and texCoord" },
    Known {
        name: "KHR_mesh_quantization",
        status: Status::Read,
        how: "integer and normalized attributes, dequantized by their node transforms",
    },
    Known {
        name: "EXT_meshopt_compression",
        status: Status::Read,
        how: "buffer views decoded with meshoptimizer (fallback buffers need no data)",
    },
    Known {
        name: "KHR_meshopt_compression",
        status: Status::Read,
        how: "buffer views decoded with meshoptimizer (fallback buffers need no data)",
    },
    Known {
        name: "KHR_draco_mesh_compression",
        status: Status::Read,
        how: "primitives decoded with draco-oxide",
    },
    Known {
        name: "EXT_mesh_gpu_instancing",
        status: Status::Read,
        how: "each instance expanded into its own triangles",
    },
    Known { name: "EXT_texture_webp", status: Status::Read, how: "WebP images decoded" },
    Known {
        name: "KHR_texture_basisu",
        status: Status::Refused,
        how: "no Basis Universal transcoder is built in; where a texture has a PNG or JPEG source too, that is used",
    },
    Known {
        name: "KHR_materials_clearcoat",
        status: Status::Approximated,
        how: "a mirror layer weighted by Schlick's Fresnel at IOR 1.5 over the base, with its textures and normal map; one reflected ray, about the coat's normal; no highlight of its own",
    },
    Known { name: "KHR_materials_sheen", status: Status::Ignored, how: "no sheen lobe" },
    Known {
        name: "KHR_materials_specular",
        status: Status::Approximated,
        how: "the dielectric F0 scaled and tinted, with its textures; the Phong highlight stays white",
    },
    Known {
        name: "KHR_materials_volume",
        status: Status::Read,
        how: "Beer–Lambert attenuation along the refracted path's real length; thickness only marks a body",
    },
    Known {
        name: "KHR_materials_unlit",
        status: Status::Approximated,
        how: "the base colour (factor × texture) emitted as is, unlit; vertex colours are not applied to it",
    },
];

fn known(name: &str) -> Option<&'static Known> {
    KNOWN.iter().find(|k| k.name == name)
}

/// Whether the loader can render a file that requires `name`.
pub fn can_require(name: &str) -> bool {
    known(name).is_some_and(|k| matches!(k.status, Status::Read | Status::Approximated))
}

/// What the loader does with extension `name` in a file that uses it (`required`: names it
/// in `extensionsRequired`).
pub fn status(name: &str, required: bool) -> Status {
    match known(name) {
        Some(k) if k.status == Status::Ignored && required => Status::Refused,
        Some(k) if k.status == Status::Refused && !required => Status::Ignored,
        Some(k) => k.status,
        None if required => Status::Refused,
        None => Status::Ignored,
    }
}

/// The error message for a required extension the loader cannot render.
pub fn refusal(name: &str) -> String {
    let readable: Vec<&str> = KNOWN.iter().filter(|k| can_require(k.name)).map(|k| k.name).collect();
    let why = match name {
        "KHR_texture_basisu" => format!(
            "; no Basis Universal transcoder is built in: rewrite the textures as PNG with `{BASISU_REWRITE}`"
        ),
        _ => String::new(),
    };
    format!(
        "the file requires extension {name}, which this loader does not support{why} (it reads {})",
        readable.join(", ")
    )
}

/// The warning for an extension the file uses (not requires) and the loader ignores.
pub fn ignored_warning(name: &str) -> String {
    match known(name) {
        Some(k) => format!("extension {name} is ignored: {}", k.how),
        None => format!("extension {name} is not supported; ignored"),
    }
}

/// One extension of a file, as `cuberay info` lists it.
#[derive(Clone, Debug, Serialize)]
pub struct ExtensionInfo {
    pub name: String,
    /// Whether the file names it in `extensionsRequired`.
    pub required: bool,
    pub status: Status,
    /// How the loader handles it.
    pub how: String,
}

/// The extensions a glTF document uses (`extensionsUsed`, plus any required one it forgot
/// to list there), with what the loader does with each.
pub fn list(used: &[String], required: &[String]) -> Vec<ExtensionInfo> {
    let mut names: Vec<&String> = used.iter().collect();
    names.extend(required.iter().filter(|r| !used.contains(r)));
    names
        .into_iter()
        .map(|name| {
            let is_required = required.contains(name);
            ExtensionInfo {
                name: name.clone(),
                required: is_required,
                status: status(name, is_required),
                how: known(name).map_or("not known to this loader", |k| k.how).to_string(),
            }
        })
        .collect()
}

/// The extensions of the glTF file at `path`, read from its JSON alone (empty for a file
/// that is not glTF or whose JSON does not parse: loading it says why).
pub fn of_file(path: &Path) -> Vec<ExtensionInfo> {
    let gltf = matches!(path.extension().and_then(|e| e.to_str()), Some("gltf" | "glb"));
    let Some(bytes) = gltf.then(|| std::fs::read(path).ok()).flatten() else { return Vec::new() };
    let Ok(parsed) = gltf::Gltf::from_slice_without_validation(&bytes) else { return Vec::new() };
    let json = parsed.document.as_json();
    list(&json.extensions_used, &json.extensions_required)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn required_and_optional_extensions() {
        assert_eq!(status("KHR_mesh_quantization", true), Status::Read);
        assert_eq!(status("KHR_materials_transmission", false), Status::Approximated);
        assert_eq!(status("KHR_materials_clearcoat", true), Status::Approximated);
        assert_eq!(status("KHR_materials_volume", true), Status::Read);
        assert_eq!(status("KHR_materials_sheen", false), Status::Ignored);
        assert_eq!(status("KHR_materials_sheen", true), Status::Refused);
        assert_eq!(status("KHR_texture_basisu", true), Status::Refused);
        assert_eq!(status("KHR_texture_basisu", false), Status::Ignored);
        assert_eq!(status("EXT_unknown", false), Status::Ignored);
        assert_eq!(status("EXT_unknown", true), Status::Refused);
        assert!(refusal("KHR_texture_basisu").contains(BASISU_REWRITE));
        let readable = refusal("EXT_unknown").split_once("(it reads ").unwrap().1.to_string();
        assert!(readable.contains("KHR_draco_mesh_compression") && !readable.contains("EXT_unknown"));
        assert!(
            !readable.contains("KHR_texture_basisu")
                && !readable.contains("sheen")
                && readable.contains("clearcoat")
        );
        let l = list(&["A".into()], &["B".into()]);
        assert_eq!((l[0].required, l[1].required, l[1].status), (false, true, Status::Refused));
    }
}
