//! EXT_mesh_gpu_instancing (gltfpack `-mi`, gltf-transform `instance`): a node that draws
//! its mesh many times, once per element of its TRANSLATION, ROTATION and SCALE accessors.
//!
//! cuberay's scene holds world-space triangles, so each instance is expanded into a mesh
//! placement of its own (the node's world matrix times the instance's T·R·S), exactly as if
//! the file had one node per instance. docs/scenes.md gives what that costs in memory.

use glam::{DMat4, DQuat, DVec3};
use gltf::accessor::{DataType, Dimensions};
use gltf::Document;

use super::data::Reader;
use super::geometry::{Hierarchy, Placed};
use crate::error::Error;

pub const EXTENSION: &str = "EXT_mesh_gpu_instancing";

/// Most instances a file may expand to: each is a placement of its mesh, and the triangle
/// limit is checked only once they are placed.
pub const MAX_INSTANCES: usize = 1 << 20;

/// FLOAT and every 8- and 16-bit type, as KHR_mesh_quantization allows for positions.
const FLOATS: &[(DataType, bool)] = super::data::QUANTIZED_ANY;
const ROTATIONS: &[(DataType, bool)] = &[(DataType::F32, false), (DataType::I8, true), (DataType::I16, true)];

/// `hierarchy` with every mesh placement whose node has the extension replaced by one
/// placement per instance, in instance order.
pub fn expand(reader: &Reader, doc: &Document, mut hierarchy: Hierarchy) -> Result<Hierarchy, Error> {
    let nodes: Vec<gltf::Node> = doc.nodes().collect();
    if !nodes.iter().any(|n| n.extension_value(EXTENSION).is_some()) {
        return Ok(hierarchy);
    }
    let mut out = Vec::with_capacity(hierarchy.meshes.len());
    let mut made = 0;
    for placed in std::mem::take(&mut hierarchy.meshes) {
        let node = &nodes[placed.node];
        let Some(ext) = node.extension_value(EXTENSION) else {
            out.push(placed);
            continue;
        };
        let loc = format!("nodes[{}].extensions.{EXTENSION}", placed.node);
        let transforms = instances(reader, doc, ext, &loc)?;
        made += transforms.len();
        if made > MAX_INSTANCES {
            return Err(reader.ctx.err(loc, format!("the file has more than {MAX_INSTANCES} instances")));
        }
        out.extend(transforms.into_iter().map(|m| Placed { world: placed.world * m, ..placed }));
    }
    hierarchy.meshes = out;
    Ok(hierarchy)
}

/// The T·R·S matrix of every instance of one node's extension object.
fn instances(
    reader: &Reader,
    doc: &Document,
    ext: &serde_json::Value,
    loc: &str,
) -> Result<Vec<DMat4>, Error> {
    let ctx = reader.ctx;
    let attributes = ext
        .get("attributes")
        .and_then(|a| a.as_object())
        .ok_or_else(|| ctx.err(loc, "has no attributes object (TRANSLATION, ROTATION, SCALE)"))?;
    let mut count = None;
    let mut read = |name: &str,
                    dims: Dimensions,
                    allowed: &[(DataType, bool)]|
     -> Result<Option<Vec<f32>>, Error> {
        let Some(index) = attributes.get(name) else { return Ok(None) };
        let aloc = format!("{loc}.attributes.{name}");
        let acc = index
            .as_u64()
            .and_then(|i| doc.accessors().nth(i as usize))
            .ok_or_else(|| ctx.err(&aloc, format!("{index} names no accessor of the file")))?;
        let aloc = format!("{aloc} (accessors[{}])", acc.index());
        let n = reader.count(&acc);
        if count.is_some_and(|c| c != n) {
            return Err(
                ctx.err(aloc, format!("has {n} elements, but the other attributes {}", count.unwrap_or(0)))
            );
        }
        if n > MAX_INSTANCES {
            return Err(ctx.err(aloc, format!("{n} instances are more than the {MAX_INSTANCES} accepted")));
        }
        count = Some(n);
        reader.floats(&acc, &aloc, dims, allowed).map(Some)
    };
    let t = read("TRANSLATION", Dimensions::Vec3, FLOATS)?;
    let r = read("ROTATION", Dimensions::Vec4, ROTATIONS)?;
    let s = read("SCALE", Dimensions::Vec3, FLOATS)?;
    let Some(n) = count else {
        return Err(ctx.err(loc, "has none of TRANSLATION, ROTATION and SCALE"));
    };
    let v3 = |a: &Option<Vec<f32>>, i: usize, default: DVec3| {
        a.as_ref().map_or(default, |a| DVec3::new(a[3 * i] as f64, a[3 * i + 1] as f64, a[3 * i + 2] as f64))
    };
    (0..n)
        .map(|i| {
            let q = r.as_ref().map_or(DQuat::IDENTITY, |r| {
                DQuat::from_xyzw(
                    r[4 * i] as f64,
                    r[4 * i + 1] as f64,
                    r[4 * i + 2] as f64,
                    r[4 * i + 3] as f64,
                )
            });
            let len = q.length();
            if len == 0.0 {
                return Err(ctx.err(
                    format!("{loc}.attributes.ROTATION"),
                    format!("instance {i} is a zero quaternion"),
                ));
            }
            Ok(DMat4::from_scale_rotation_translation(v3(&s, i, DVec3::ONE), q / len, v3(&t, i, DVec3::ZERO)))
        })
        .collect()
}
