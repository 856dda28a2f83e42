//! EXT_meshopt_compression and KHR_meshopt_compression: buffer views stored compressed by
//! meshoptimizer's codecs (gltfpack `-c`, gltf-transform `meshopt`), decoded with
//! meshoptimizer's own decoder through the `meshopt` crate.
//!
//! A compressed view names its compressed bytes (`buffer`, `byteOffset`, `byteLength`) and
//! what they decode to: `count` elements of `byteStride` bytes, in one of three modes
//! (ATTRIBUTES, TRIANGLES, INDICES), then a filter (NONE, OCTAHEDRAL, QUATERNION,
//! EXPONENTIAL, and KHR's COLOR). The view's own buffer is usually a *fallback* buffer,
//! which holds no data (see [`super::data::Buffers`]). Every precondition of the C decoder
//! (strides, counts, the filters' strides) is checked here first, since the C code asserts
//! rather than returns on them, and the decoded size is bounded before anything is allocated.

use std::collections::HashMap;

use gltf::Document;
use serde::Deserialize;

use super::Ctx;
use crate::error::Error;

/// The extensions that compress buffer views this way (the same JSON in both).
pub const EXTENSIONS: [&str; 2] = ["EXT_meshopt_compression", "KHR_meshopt_compression"];

/// Most bytes one compressed view may decode to: a small file must not make the loader
/// allocate what it does not hold (meshoptimizer's codecs compress constant data by far
/// more than 1000:1). 1 GiB holds 2²⁶ triangles' indices, the loader's triangle limit.
const MAX_DECODED: usize = 1 << 30;

/// A compressed view's extension object, as written.
#[derive(Deserialize)]
#[serde(rename_all = "camelCase")]
struct Compressed {
    buffer: usize,
    #[serde(default)]
    byte_offset: usize,
    byte_length: usize,
    byte_stride: usize,
    count: usize,
    mode: String,
    #[serde(default = "no_filter")]
    filter: String,
}

fn no_filter() -> String {
    "NONE".into()
}

/// The compressed extension object of a buffer view, if it has one.
pub fn extension<'d>(view: &'d gltf::buffer::View<'d>) -> Option<(&'static str, &'d serde_json::Value)> {
    EXTENSIONS.iter().find_map(|&name| view.extension_value(name).map(|v| (name, v)))
}

/// Whether a buffer is a meshopt fallback buffer (no data of its own).
pub fn is_fallback(buffer: &gltf::Buffer) -> bool {
    EXTENSIONS.iter().any(|&name| {
        buffer.extension_value(name).and_then(|v| v.get("fallback")).and_then(|f| f.as_bool()) == Some(true)
    })
}

/// Decodes every compressed view of the document; `raw(i)` gives buffer `i`'s bytes (None
/// for a fallback buffer). Returns the decoded bytes by view index, each exactly the view's
/// `byteLength`.
pub fn decode_views<'b>(
    ctx: &Ctx,
    doc: &Document,
    raw: impl Fn(usize) -> Option<&'b [u8]>,
) -> Result<HashMap<usize, Vec<u8>>, Error> {
    let mut out = HashMap::new();
    for view in doc.views() {
        let Some((name, value)) = extension(&view) else { continue };
        let loc = format!("bufferViews[{}].extensions.{name}", view.index());
        let c = Compressed::deserialize(value).map_err(|e| ctx.err(&loc, format!("is malformed: {e}")))?;
        let src = compressed_bytes(ctx, &c, &loc, &raw)?;
        let size = c.count.checked_mul(c.byte_stride).filter(|&n| n <= MAX_DECODED).ok_or_else(|| {
            ctx.err(
                &loc,
                format!(
                    "{} elements of {} bytes are more than the {MAX_DECODED} bytes a view may decode to",
                    c.count, c.byte_stride
                ),
            )
        })?;
        if view.length() > size {
            return Err(ctx.err(
                &loc,
                format!(
                    "bufferViews[{}] is {} bytes long, but its {} elements of {} bytes decode to {size}",
                    view.index(),
                    view.length(),
                    c.count,
                    c.byte_stride
                ),
            ));
        }
        let mut bytes = decode(&c, src).map_err(|m| ctx.err(&loc, m))?;
        bytes.truncate(view.length());
        out.insert(view.index(), bytes);
    }
    Ok(out)
}

/// The compressed bytes a view's extension names, range-checked.
fn compressed_bytes<'b>(
    ctx: &Ctx,
    c: &Compressed,
    loc: &str,
    raw: &impl Fn(usize) -> Option<&'b [u8]>,
) -> Result<&'b [u8], Error> {
    let buffer = raw(c.buffer).ok_or_else(|| {
        ctx.err(
            loc,
            format!("names buffers[{}], which does not exist or is a fallback buffer without data", c.buffer),
        )
    })?;
    c.byte_offset
        .checked_add(c.byte_length)
        .filter(|&end| end <= buffer.len())
        .map(|end| &buffer[c.byte_offset..end])
        .ok_or_else(|| {
            ctx.err(
                loc,
                format!(
                    "bytes {}..{}+{} lie outside buffers[{}], which holds {} bytes",
                    c.byte_offset,
                    c.byte_offset,
                    c.byte_length,
                    c.buffer,
                    buffer.len()
                ),
            )
        })
}

/// Decodes one view: the codec of its mode, then its filter. The error says what was wrong
/// in words (the caller names the view).
fn decode(c: &Compressed, src: &[u8]) -> Result<Vec<u8>, String> {
    let (n, stride) = (c.count, c.byte_stride);
    let filter_ok = match c.filter.as_str() {
        "NONE" => true,
        "OCTAHEDRAL" | "COLOR" => stride == 4 || stride == 8,
        "QUATERNION" => stride == 8,
        "EXPONENTIAL" => stride % 4 == 0,
        f => return Err(format!("filter {f} is not NONE, OCTAHEDRAL, QUATERNION, EXPONENTIAL or COLOR")),
    };
    if !filter_ok {
        return Err(format!("filter {} cannot apply to elements of {stride} bytes", c.filter));
    }
    if c.mode != "ATTRIBUTES" && c.filter != "NONE" {
        return Err(format!("filter {} applies only to ATTRIBUTES, not {}", c.filter, c.mode));
    }
    // Backed by u32s, so that the filters' 16- and 32-bit accesses are aligned.
    let mut words = vec![0u32; (n * stride).div_ceil(4)];
    let dest = words.as_mut_ptr().cast::<std::ffi::c_void>();
    let rc = match c.mode.as_str() {
        "ATTRIBUTES" => {
            if stride == 0 || stride > 256 || stride % 4 != 0 {
                return Err(format!("byteStride {stride} is not a multiple of 4 from 4 to 256"));
            }
            // SAFETY: `words` holds n·stride bytes; the stride meets the decoder's asserts.
            unsafe { meshopt::ffi::meshopt_decodeVertexBuffer(dest, n, stride, src.as_ptr(), src.len()) }
        }
        "TRIANGLES" | "INDICES" => {
            if stride != 2 && stride != 4 {
                return Err(format!("byteStride {stride} of indices is not 2 or 4"));
            }
            if c.mode == "TRIANGLES" {
                if n % 3 != 0 {
                    return Err(format!("{n} indices are not whole TRIANGLES"));
                }
                // SAFETY: as above; the count is a multiple of 3 and the size 2 or 4.
                unsafe { meshopt::ffi::meshopt_decodeIndexBuffer(dest, n, stride, src.as_ptr(), src.len()) }
            } else {
                // SAFETY: as above.
                unsafe { meshopt::ffi::meshopt_decodeIndexSequence(dest, n, stride, src.as_ptr(), src.len()) }
            }
        }
        m => return Err(format!("mode {m} is not ATTRIBUTES, TRIANGLES or INDICES")),
    };
    if rc != 0 {
        return Err(format!(
            "the {} bytes of {} data do not decode to {n} elements of {stride} bytes (meshoptimizer error {rc})",
            src.len(),
            c.mode
        ));
    }
    // SAFETY: `words` holds n elements of `stride` bytes, aligned to 4, and each filter's
    // stride was checked above against what it requires.
    unsafe {
        match c.filter.as_str() {
            "OCTAHEDRAL" => meshopt::ffi::meshopt_decodeFilterOct(dest, n, stride),
            "QUATERNION" => meshopt::ffi::meshopt_decodeFilterQuat(dest, n, stride),
            "EXPONENTIAL" => meshopt::ffi::meshopt_decodeFilterExp(dest, n, stride),
            "COLOR" => meshopt::ffi::meshopt_decodeFilterColor(dest, n, stride),
            _ => {}
        }
    }
    let mut bytes: Vec<u8> = bytemuck::cast_slice(&words).to_vec();
    bytes.truncate(n * stride);
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn compressed(mode: &str, filter: &str, count: usize, stride: usize) -> Compressed {
        Compressed {
            buffer: 0,
            byte_offset: 0,
            byte_length: 0,
            byte_stride: stride,
            count,
            mode: mode.into(),
            filter: filter.into(),
        }
    }

    #[test]
    fn round_trips_through_meshoptimizer() {
        let verts: Vec<[f32; 3]> = (0..50).map(|i| [i as f32, 0.5 * i as f32, -(i as f32)]).collect();
        let enc = meshopt::encoding::encode_vertex_buffer(&verts).unwrap();
        let out = decode(&compressed("ATTRIBUTES", "NONE", 50, 12), &enc).unwrap();
        assert_eq!(out, bytemuck::cast_slice::<[f32; 3], u8>(&verts));
        let idx: Vec<u32> = vec![0, 1, 2, 2, 1, 3, 3, 1, 4];
        let enc = meshopt::encoding::encode_index_buffer(&idx, 5).unwrap();
        let out = decode(&compressed("TRIANGLES", "NONE", 9, 2), &enc).unwrap();
        let got: Vec<u16> = out.chunks_exact(2).map(|b| u16::from_le_bytes([b[0], b[1]])).collect();
        assert_eq!(got, [0, 1, 2, 2, 1, 3, 3, 1, 4]);
    }

    #[test]
    fn what_the_c_decoder_asserts_is_refused_first() {
        assert!(decode(&compressed("ATTRIBUTES", "NONE", 3, 6), &[0; 64])
            .unwrap_err()
            .contains("byteStride 6"));
        assert!(decode(&compressed("TRIANGLES", "NONE", 4, 2), &[0; 64]).unwrap_err().contains("TRIANGLES"));
        assert!(decode(&compressed("ATTRIBUTES", "QUATERNION", 3, 4), &[0; 64])
            .unwrap_err()
            .contains("QUATERNION"));
        assert!(decode(&compressed("INDICES", "OCTAHEDRAL", 3, 4), &[0; 64])
            .unwrap_err()
            .contains("only to ATTRIBUTES"));
        assert!(decode(&compressed("ATTRIBUTES", "NONE", 3, 4), &[1, 2, 3])
            .unwrap_err()
            .contains("do not decode"));
    }
}
