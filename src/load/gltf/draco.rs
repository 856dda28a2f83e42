//! KHR_draco_mesh_compression: primitives whose indices and attributes are one Draco stream
//! in a buffer view (gltf-transform `draco`), decoded with draco-oxide, a pure-Rust port of
//! Google's Draco decoder (docs/scenes.md says why that one).
//!
//! The primitive's accessors keep their JSON (type, component type, normalized), but their
//! data comes from the stream: its faces become the indices accessor's elements and each
//! attribute the extension names (by the stream's unique id) becomes that attribute's
//! accessor's elements, one per decoded point. The decoded point count replaces the
//! accessors' `count`: Google's decoder and draco-oxide may split a non-manifold vertex
//! differently (on DamagedHelmet 14412 points against 14440, with the same triangles), so
//! the file's count is the encoder's and not a contract. Every decoded accessor is
//! checked against its JSON before the loader reads it like any other
//! ([`super::data::Reader`]).

use std::collections::HashMap;

use draco_oxide_core::attribute::{Attribute, ComponentDataType};
use gltf::accessor::{DataType, Dimensions};
use gltf::Document;
use serde::Deserialize;

use super::data::{Buffers, Decoded};
use super::Ctx;
use crate::error::Error;

pub const EXTENSION: &str = "KHR_draco_mesh_compression";

/// The extension object of a primitive, as written.
#[derive(Deserialize)]
#[serde(rename_all = "camelCase")]
struct Compressed {
    buffer_view: usize,
    attributes: HashMap<String, u64>,
}

/// Decodes the Draco stream of every primitive that has one, returning the decoded data of
/// their accessors by accessor index.
pub fn decode_primitives(
    ctx: &Ctx,
    doc: &Document,
    buffers: &Buffers,
) -> Result<HashMap<usize, Decoded>, Error> {
    let mut out = HashMap::new();
    for mesh in doc.meshes() {
        for prim in mesh.primitives() {
            let Some(value) = prim.extension_value(EXTENSION) else { continue };
            let loc = format!("meshes[{}].primitives[{}].extensions.{EXTENSION}", mesh.index(), prim.index());
            let c =
                Compressed::deserialize(value).map_err(|e| ctx.err(&loc, format!("is malformed: {e}")))?;
            let view = doc.views().nth(c.buffer_view).ok_or_else(|| {
                ctx.err(&loc, format!("names bufferViews[{}], which does not exist", c.buffer_view))
            })?;
            let stream = buffers.view(ctx, &view, &loc)?;
            let vloc = format!("{loc} (bufferViews[{}])", c.buffer_view);
            // draco-oxide is young: whatever it might panic on is this file's error, not a crash.
            let decoded =
                std::panic::catch_unwind(|| draco_oxide_decoder::decode_mesh(stream)).map_err(|_| {
                    ctx.err(&vloc, "the Draco decoder failed on this stream (a malformed stream)")
                })?;
            let mesh_data = decoded
                .map_err(|e| ctx.err(&vloc, format!("is not a Draco mesh this decoder reads: {e}")))?;
            let points = mesh_data.attributes.first().map_or(0, Attribute::len);
            let Some(indices) = prim.indices() else {
                return Err(ctx.err(&loc, "the primitive has no indices accessor for the stream's faces"));
            };
            let iloc = format!("{loc}: indices (accessors[{}])", indices.index());
            out.insert(indices.index(), faces(ctx, &iloc, &indices, &mesh_data.faces, points)?);
            for (semantic, acc) in prim.attributes() {
                let name = semantic.to_string();
                let Some(&uid) = c.attributes.get(&name) else { continue };
                let aloc = format!("{loc}.attributes.{name} (accessors[{}])", acc.index());
                let att =
                    mesh_data.attributes.iter().find(|a| a.get_id().as_usize() as u64 == uid).ok_or_else(
                        || ctx.err(&aloc, format!("the stream has no attribute of unique id {uid}")),
                    )?;
                if att.len() != points {
                    return Err(ctx.err(
                        &aloc,
                        format!("the stream gives {} values of it for {points} points", att.len()),
                    ));
                }
                out.insert(acc.index(), attribute(ctx, &aloc, &acc, att)?);
            }
        }
    }
    Ok(out)
}

/// The stream's faces as the indices accessor's elements (its component type).
fn faces<P: Copy + Into<usize>>(
    ctx: &Ctx,
    loc: &str,
    acc: &gltf::Accessor,
    faces: &[[P; 3]],
    points: usize,
) -> Result<Decoded, Error> {
    let t = acc.data_type();
    if acc.dimensions() != Dimensions::Scalar || !matches!(t, DataType::U8 | DataType::U16 | DataType::U32) {
        return Err(ctx.err(loc, "is not a SCALAR of UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT"));
    }
    let limit = match t {
        DataType::U8 => u8::MAX as usize,
        DataType::U16 => u16::MAX as usize,
        _ => u32::MAX as usize,
    };
    let mut bytes = Vec::with_capacity(faces.len() * 3 * t.size());
    for (k, &i) in faces.iter().flatten().enumerate() {
        let i: usize = i.into();
        if i >= points || i > limit {
            return Err(ctx.err(
                loc,
                format!("decoded index {i} (element {k}) is out of range: the stream has {points} points"),
            ));
        }
        bytes.extend_from_slice(&(i as u32).to_le_bytes()[..t.size()]);
    }
    Ok(Decoded { bytes, count: faces.len() * 3 })
}

/// The glTF component type of a decoded attribute's components.
fn component(t: ComponentDataType) -> Option<DataType> {
    Some(match t {
        ComponentDataType::F32 => DataType::F32,
        ComponentDataType::U8 => DataType::U8,
        ComponentDataType::I8 => DataType::I8,
        ComponentDataType::U16 => DataType::U16,
        ComponentDataType::I16 => DataType::I16,
        ComponentDataType::U32 => DataType::U32,
        _ => return None,
    })
}

/// A decoded attribute as its accessor's elements, one per point, in the accessor's
/// component type (which must be the stream's).
fn attribute(ctx: &Ctx, loc: &str, acc: &gltf::Accessor, att: &Attribute) -> Result<Decoded, Error> {
    let t = component(att.get_component_type()).filter(|&t| t == acc.data_type());
    let k = acc.dimensions().multiplicity();
    let Some(t) = t.filter(|_| att.get_num_components() == k) else {
        return Err(ctx.err(
            loc,
            format!(
                "the stream decodes it to {} components of {:?}, but the accessor holds {k} of {:?}",
                att.get_num_components(),
                att.get_component_type(),
                acc.data_type()
            ),
        ));
    };
    let size = k * t.size();
    let values = att.get_data_as_bytes();
    let map = att.point_map_as_slice();
    let mut bytes = Vec::with_capacity(att.len() * size);
    for p in 0..att.len() {
        let v: usize = map.map_or(p, |m| m[p].into());
        let Some(value) = values.get(v * size..(v + 1) * size) else {
            return Err(ctx.err(loc, format!("point {p} names value {v}, which the stream does not hold")));
        };
        bytes.extend_from_slice(value);
    }
    Ok(Decoded { bytes, count: att.len() })
}
