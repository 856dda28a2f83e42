//! Binary data of a glTF file: buffers (GLB chunk, external files, data URIs) and typed,
//! range-checked reads of accessors.
//!
//! The `gltf` crate checks that indices between JSON objects resolve, but not that the
//! bytes an accessor describes lie inside its buffer view and buffer. Every read here
//! checks those ranges itself (with overflow-safe arithmetic) and reports a failure with
//! the JSON path of the use, e.g. `meshes[2].primitives[0].attributes.POSITION (accessors[5])`.

use std::borrow::Cow;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

use base64::Engine as _;
use gltf::accessor::{DataType, Dimensions};
use gltf::Document;

use super::Ctx;
use crate::error::Error;

/// The bytes of every buffer of the document, in file order, with what the compression
/// extensions decoded from them. Each buffer holds at least its declared `byteLength`, except
/// a meshopt fallback buffer, which holds nothing: only views decoded from compressed data
/// may lie in it.
pub struct Buffers {
    data: Vec<Vec<u8>>,
    fallback: Vec<bool>,
    /// Buffer views decoded from EXT/KHR_meshopt_compression, by view index.
    views: HashMap<usize, Vec<u8>>,
    /// Accessors decoded from KHR_draco_mesh_compression streams, by accessor index.
    accessors: HashMap<usize, Decoded>,
}

/// An accessor's elements decoded from a compressed stream: `count` elements packed in the
/// accessor's type and component type.
pub struct Decoded {
    pub bytes: Vec<u8>,
    pub count: usize,
}

impl Buffers {
    /// Loads every buffer: the GLB binary chunk, external files (relative to the glTF file)
    /// and base64 data URIs; then decodes the meshopt-compressed views (the Draco streams
    /// are decoded over these buffers and added with [`Buffers::with_decoded`]).
    pub fn load(ctx: &Ctx, doc: &Document, mut blob: Option<Vec<u8>>) -> Result<Buffers, Error> {
        let mut data = Vec::new();
        let mut fallback = Vec::new();
        for buffer in doc.buffers() {
            let loc = format!("buffers[{}]", buffer.index());
            let is_fallback = super::meshopt::is_fallback(&buffer);
            let bytes = match buffer.source() {
                _ if is_fallback => Vec::new(),
                gltf::buffer::Source::Bin => blob.take().ok_or_else(|| {
                    ctx.err(
                        &loc,
                        "refers to the GLB binary chunk, but the file has none (or another buffer took it)",
                    )
                })?,
                gltf::buffer::Source::Uri(uri) => read_uri(ctx, uri, &loc)?.into_owned(),
            };
            if !is_fallback && bytes.len() < buffer.length() {
                return Err(ctx.err(
                    &loc,
                    format!("holds {} bytes, but its byteLength is {}", bytes.len(), buffer.length()),
                ));
            }
            data.push(bytes);
            fallback.push(is_fallback);
        }
        let mut buffers = Buffers { data, fallback, views: HashMap::new(), accessors: HashMap::new() };
        buffers.views = super::meshopt::decode_views(ctx, doc, |i| {
            buffers.data.get(i).filter(|_| !buffers.fallback[i]).map(|d| &d[..])
        })?;
        Ok(buffers)
    }

    /// These buffers with the accessors a compressed stream decoded (by accessor index):
    /// reads of those accessors take the decoded elements.
    pub fn with_decoded(self, accessors: HashMap<usize, Decoded>) -> Buffers {
        Buffers { accessors, ..self }
    }

    /// The bytes of buffer view `view` (decoded, where it was compressed), checked against
    /// its buffer. `loc` names the use.
    pub fn view<'a>(&'a self, ctx: &Ctx, view: &gltf::buffer::View, loc: &str) -> Result<&'a [u8], Error> {
        if let Some(decoded) = self.views.get(&view.index()) {
            return Ok(decoded);
        }
        let b = view.buffer().index();
        if self.fallback[b] {
            return Err(ctx.err(
                loc,
                format!(
                    "bufferViews[{}] lies in buffers[{b}], a meshopt fallback buffer without data, and is not compressed itself",
                    view.index()
                ),
            ));
        }
        let buffer = &self.data[b];
        let start = view.offset();
        match start.checked_add(view.length()).filter(|&end| end <= buffer.len()) {
            Some(end) => Ok(&buffer[start..end]),
            None => Err(ctx.err(
                loc,
                format!(
                    "bufferViews[{}] spans bytes {}..{}+{} of buffers[{}], which holds only {} bytes",
                    view.index(),
                    start,
                    start,
                    view.length(),
                    b,
                    buffer.len()
                ),
            )),
        }
    }
}

/// Reads the resource a URI names: a base64 `data:` URI, or a path relative to the glTF
/// file (percent-decoded). `loc` (e.g. `buffers[0]`) names the referring object.
pub fn read_uri<'u>(ctx: &Ctx, uri: &'u str, loc: &str) -> Result<Cow<'u, [u8]>, Error> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (meta, payload) =
            rest.split_once(',').ok_or_else(|| ctx.err(loc, "malformed data URI (no comma)"))?;
        if !meta.ends_with(";base64") {
            return Err(ctx.err(loc, "only base64 data URIs are supported"));
        }
        let bytes = base64::engine::general_purpose::STANDARD
            .decode(payload.trim())
            .map_err(|e| ctx.err(loc, format!("invalid base64 in data URI: {e}")))?;
        return Ok(Cow::Owned(bytes));
    }
    if has_scheme(uri) {
        return Err(ctx.err(
            loc,
            format!(
                "URI '{uri}' has a scheme other than data:; only relative paths and data URIs are supported"
            ),
        ));
    }
    let decoded = urlencoding::decode(uri)
        .map_err(|_| ctx.err(loc, format!("URI '{uri}' does not percent-decode to UTF-8")))?;
    let file = ctx.path.parent().unwrap_or(Path::new(".")).join(PathBuf::from(&*decoded));
    std::fs::read(&file)
        .map(Cow::Owned)
        .map_err(|e| ctx.err(loc, format!("cannot read '{}': {e}", file.display())))
}

/// True when `uri` starts with an RFC 3986 scheme (`letter *(letter/digit/+/-/.) ":"`).
/// A single letter before the colon is taken as a Windows drive, not a scheme.
fn has_scheme(uri: &str) -> bool {
    match uri.split_once(':') {
        Some((scheme, _)) => {
            scheme.len() > 1
                && scheme.starts_with(|c: char| c.is_ascii_alphabetic())
                && scheme.chars().all(|c| c.is_ascii_alphanumeric() || "+-.".contains(c))
        }
        None => false,
    }
}

/// Most elements an accessor without a buffer view (zeros plus sparse substitutions) may
/// have: nothing else bounds its count, and a huge one would exhaust memory.
const MAX_ZERO_FILLED: usize = 1 << 26;

/// An accessor's checked byte ranges.
struct Layout<'b> {
    size: usize,
    count: usize,
    dense: Option<Dense<'b>>,
    sparse: Option<Sparse<'b>>,
}

/// Interleaved or packed elements in a buffer view.
struct Dense<'b> {
    data: &'b [u8],
    offset: usize,
    stride: usize,
}

/// Sparse substitutions: `count` indices and values, each slice starting at entry 0.
struct Sparse<'b> {
    count: usize,
    indices: &'b [u8],
    index_type: DataType,
    values: &'b [u8],
}

/// Typed reads of accessors, with every byte range checked.
pub struct Reader<'a> {
    pub ctx: &'a Ctx<'a>,
    pub buffers: &'a Buffers,
}

fn type_name(d: Dimensions) -> &'static str {
    match d {
        Dimensions::Scalar => "SCALAR",
        Dimensions::Vec2 => "VEC2",
        Dimensions::Vec3 => "VEC3",
        Dimensions::Vec4 => "VEC4",
        Dimensions::Mat2 => "MAT2",
        Dimensions::Mat3 => "MAT3",
        Dimensions::Mat4 => "MAT4",
    }
}

fn component_name(t: DataType, normalized: bool) -> String {
    let name = match t {
        DataType::I8 => "BYTE",
        DataType::U8 => "UNSIGNED_BYTE",
        DataType::I16 => "SHORT",
        DataType::U16 => "UNSIGNED_SHORT",
        DataType::U32 => "UNSIGNED_INT",
        DataType::F32 => "FLOAT",
    };
    if normalized {
        format!("normalized {name}")
    } else {
        name.to_string()
    }
}

/// FLOAT, and every 8- and 16-bit type KHR_mesh_quantization allows for POSITION and
/// TEXCOORD_n: signed or unsigned, normalized or not.
pub(super) const QUANTIZED_ANY: &[(DataType, bool)] = &[
    (DataType::F32, false),
    (DataType::I8, false),
    (DataType::I8, true),
    (DataType::U8, false),
    (DataType::U8, true),
    (DataType::I16, false),
    (DataType::I16, true),
    (DataType::U16, false),
    (DataType::U16, true),
];

/// FLOAT, and the normalized signed types KHR_mesh_quantization allows for unit vectors
/// (NORMAL, TANGENT).
const QUANTIZED_UNIT: &[(DataType, bool)] =
    &[(DataType::F32, false), (DataType::I8, true), (DataType::I16, true)];

/// Reads component `k` of an element as f32, normalising integer types when asked.
fn component_f32(bytes: &[u8], t: DataType, normalized: bool, k: usize) -> f32 {
    let s = t.size();
    let b = &bytes[k * s..(k + 1) * s];
    match (t, normalized) {
        (DataType::F32, _) => f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
        (DataType::U8, true) => b[0] as f32 / 255.0,
        (DataType::U16, true) => u16::from_le_bytes([b[0], b[1]]) as f32 / 65535.0,
        (DataType::I8, true) => (b[0] as i8 as f32 / 127.0).max(-1.0),
        (DataType::I16, true) => (i16::from_le_bytes([b[0], b[1]]) as f32 / 32767.0).max(-1.0),
        (DataType::U8, false) => b[0] as f32,
        (DataType::U16, false) => u16::from_le_bytes([b[0], b[1]]) as f32,
        (DataType::I8, false) => b[0] as i8 as f32,
        (DataType::I16, false) => i16::from_le_bytes([b[0], b[1]]) as f32,
        (DataType::U32, _) => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f32,
    }
}

fn index_u32(bytes: &[u8], t: DataType) -> u32 {
    match t {
        DataType::U8 => bytes[0] as u32,
        DataType::U16 => u16::from_le_bytes([bytes[0], bytes[1]]) as u32,
        _ => u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]),
    }
}

/// `offset + (count − 1)·stride + size`, the end of the last element, or None on overflow.
fn span_end(offset: usize, count: usize, stride: usize, size: usize) -> Option<usize> {
    if count == 0 {
        return Some(offset);
    }
    (count - 1).checked_mul(stride)?.checked_add(size)?.checked_add(offset)
}

impl Reader<'_> {
    /// The number of elements of `acc`: its `count`, or the number of points of the Draco
    /// stream it was decoded from.
    pub fn count(&self, acc: &gltf::Accessor) -> usize {
        self.buffers.accessors.get(&acc.index()).map_or(acc.count(), |d| d.count)
    }

    fn err(&self, loc: &str, message: impl Into<String>) -> Error {
        self.ctx.err(loc, message)
    }

    /// Checks the accessor's type and component type against what the use allows.
    fn check_format(
        &self,
        acc: &gltf::Accessor,
        loc: &str,
        dims: Dimensions,
        allowed: &[(DataType, bool)],
    ) -> Result<(), Error> {
        if acc.dimensions() != dims {
            return Err(self.err(
                loc,
                format!("accessor type is {}, expected {}", type_name(acc.dimensions()), type_name(dims)),
            ));
        }
        let (t, n) = (acc.data_type(), acc.normalized());
        if !allowed.contains(&(t, n)) {
            let expected: Vec<String> = allowed.iter().map(|&(t, n)| component_name(t, n)).collect();
            return Err(self.err(
                loc,
                format!("component type is {}, expected {}", component_name(t, n), expected.join(" or ")),
            ));
        }
        Ok(())
    }

    /// Checks every byte range of the accessor (dense data and sparse substitutions)
    /// before anything is allocated or read.
    fn layout<'b>(&'b self, acc: &gltf::Accessor, loc: &str) -> Result<Layout<'b>, Error> {
        let size = acc.size();
        if let Some(d) = self.buffers.accessors.get(&acc.index()) {
            // Decoded from a Draco stream, packed as the accessor's elements.
            debug_assert_eq!(d.bytes.len(), d.count * size);
            let dense = Dense { data: &d.bytes, offset: 0, stride: size };
            return Ok(Layout { size, count: d.count, dense: Some(dense), sparse: None });
        }
        let count = acc.count();
        let dense = match acc.view() {
            Some(view) => {
                let data = self.buffers.view(self.ctx, &view, loc)?;
                let stride = view.stride().unwrap_or(size);
                if stride < size {
                    return Err(self.err(
                        loc,
                        format!(
                            "bufferViews[{}].byteStride {stride} is smaller than the element size {size}",
                            view.index()
                        ),
                    ));
                }
                let offset = acc.offset();
                if span_end(offset, count, stride, size).is_none_or(|end| end > data.len()) {
                    return Err(self.err(
                        loc,
                        format!(
                            "{count} elements of {size} bytes (stride {stride}) from byteOffset {offset} \
                             do not fit in bufferViews[{}], which is {} bytes long",
                            view.index(),
                            data.len()
                        ),
                    ));
                }
                Some(Dense { data, offset, stride })
            }
            None => {
                // No buffer view: the elements start as zeros, so nothing bounds the count.
                if count > MAX_ZERO_FILLED {
                    return Err(self.err(
                        loc,
                        format!(
                            "{count} elements without a bufferView (at most {MAX_ZERO_FILLED} are accepted)"
                        ),
                    ));
                }
                None
            }
        };
        let sparse = match acc.sparse() {
            None => None,
            Some(sparse) => {
                let n = sparse.count();
                let (ind, val) = (sparse.indices(), sparse.values());
                let index_type = match ind.index_type() {
                    gltf::accessor::sparse::IndexType::U8 => DataType::U8,
                    gltf::accessor::sparse::IndexType::U16 => DataType::U16,
                    gltf::accessor::sparse::IndexType::U32 => DataType::U32,
                };
                let indices = self.buffers.view(self.ctx, &ind.view(), loc)?;
                let values = self.buffers.view(self.ctx, &val.view(), loc)?;
                let fits = |data: &[u8], offset: usize, elem: usize| {
                    span_end(offset, n, elem, elem).is_some_and(|end| end <= data.len())
                };
                if !fits(indices, ind.offset(), index_type.size()) {
                    return Err(self.err(
                        loc,
                        format!(
                            "sparse.indices: {n} indices do not fit in bufferViews[{}]",
                            ind.view().index()
                        ),
                    ));
                }
                if !fits(values, val.offset(), size) {
                    return Err(self.err(
                        loc,
                        format!(
                            "sparse.values: {n} values do not fit in bufferViews[{}]",
                            val.view().index()
                        ),
                    ));
                }
                Some(Sparse {
                    count: n,
                    indices: &indices[ind.offset()..],
                    index_type,
                    values: &values[val.offset()..],
                })
            }
        };
        Ok(Layout { size, count, dense, sparse })
    }

    /// Calls `f(i, bytes)` for every element `i` of a checked accessor (dense data first, then
    /// the sparse substitutions, so a later call for the same `i` overrides an earlier one).
    fn visit(&self, layout: Layout, loc: &str, mut f: impl FnMut(usize, &[u8])) -> Result<(), Error> {
        let Layout { size, count, dense, sparse } = layout;
        match dense {
            Some(Dense { data, offset, stride }) => {
                for i in 0..count {
                    let start = offset + i * stride;
                    f(i, &data[start..start + size]);
                }
            }
            None => {
                let zeros = vec![0u8; size];
                for i in 0..count {
                    f(i, &zeros);
                }
            }
        }
        if let Some(sp) = sparse {
            let isize = sp.index_type.size();
            for k in 0..sp.count {
                let i = index_u32(&sp.indices[k * isize..], sp.index_type) as usize;
                if i >= count {
                    return Err(self.err(
                        loc,
                        format!(
                            "sparse index {i} (entry {k}) is out of range: the accessor has {count} elements"
                        ),
                    ));
                }
                f(i, &sp.values[k * size..(k + 1) * size]);
            }
        }
        Ok(())
    }

    /// Reads `acc` into a vector of `count` elements, each made by `read` from its bytes.
    /// The ranges are checked before the vector is allocated.
    fn collect<T: Copy + Default>(
        &self,
        acc: &gltf::Accessor,
        loc: &str,
        read: impl Fn(&[u8]) -> T,
    ) -> Result<Vec<T>, Error> {
        let layout = self.layout(acc, loc)?;
        let mut out = vec![T::default(); layout.count];
        self.visit(layout, loc, |i, b| out[i] = read(b))?;
        Ok(out)
    }

    /// Reads a VEC3 accessor of one of the `allowed` component types as floats, without
    /// judging its values.
    fn vec3(
        &self,
        acc: &gltf::Accessor,
        loc: &str,
        allowed: &[(DataType, bool)],
    ) -> Result<Vec<[f32; 3]>, Error> {
        self.check_format(acc, loc, Dimensions::Vec3, allowed)?;
        let (t, n) = (acc.data_type(), acc.normalized());
        self.collect(acc, loc, |b| [0, 1, 2].map(|k| component_f32(b, t, n, k)))
    }

    /// Reads NORMAL: VEC3 FLOAT, or with KHR_mesh_quantization normalized BYTE or SHORT.
    pub fn normals(&self, acc: &gltf::Accessor, loc: &str) -> Result<Vec<[f32; 3]>, Error> {
        self.vec3(acc, loc, QUANTIZED_UNIT)
    }

    /// Reads POSITION: VEC3 FLOAT, or with KHR_mesh_quantization (unsigned) BYTE or SHORT,
    /// normalized or not; every coordinate finite.
    pub fn positions(&self, acc: &gltf::Accessor, loc: &str) -> Result<Vec<[f32; 3]>, Error> {
        let out = self.vec3(acc, loc, QUANTIZED_ANY)?;
        if let Some((i, p)) = out.iter().enumerate().find(|(_, p)| !p.iter().all(|c| c.is_finite())) {
            return Err(self.err(loc, format!("position {i} is not finite: {p:?}")));
        }
        Ok(out)
    }

    /// Reads TANGENT: VEC4 FLOAT, or with KHR_mesh_quantization normalized BYTE or SHORT;
    /// w ±1. A zero or non-finite xyz is returned as it is: the caller leaves the triangles
    /// that use it without a tangent frame.
    pub fn tangents(&self, acc: &gltf::Accessor, loc: &str) -> Result<Vec<[f32; 4]>, Error> {
        self.check_format(acc, loc, Dimensions::Vec4, QUANTIZED_UNIT)?;
        let (t, n) = (acc.data_type(), acc.normalized());
        let out = self.collect(acc, loc, |b| [0, 1, 2, 3].map(|k| component_f32(b, t, n, k)))?;
        if let Some((i, t)) = out.iter().enumerate().find(|(_, t)| !(t[3] == 1.0 || t[3] == -1.0)) {
            return Err(self.err(loc, format!("tangent {i} has w = {}; it must be 1 or -1", t[3])));
        }
        Ok(out)
    }

    /// Reads TEXCOORD_n: VEC2 of FLOAT or normalized UNSIGNED_BYTE/SHORT, or with
    /// KHR_mesh_quantization any (unsigned) BYTE or SHORT; every value finite.
    pub fn texcoords(&self, acc: &gltf::Accessor, loc: &str) -> Result<Vec<[f32; 2]>, Error> {
        self.check_format(acc, loc, Dimensions::Vec2, QUANTIZED_ANY)?;
        let (t, n) = (acc.data_type(), acc.normalized());
        let out = self.collect(acc, loc, |b| [0, 1].map(|k| component_f32(b, t, n, k)))?;
        if let Some((i, uv)) = out.iter().enumerate().find(|(_, uv)| !uv.iter().all(|c| c.is_finite())) {
            return Err(self.err(loc, format!("texture coordinate {i} is not finite: {uv:?}")));
        }
        Ok(out)
    }

    /// Reads a COLOR_n accessor (VEC3 or VEC4; float, or normalised unsigned byte or short) as
    /// linear RGB; the alpha of a VEC4 is not read (cuberay has no alpha yet).
    pub fn colors(&self, acc: &gltf::Accessor, loc: &str) -> Result<Vec<[f32; 3]>, Error> {
        let dims = if acc.dimensions() == Dimensions::Vec4 { Dimensions::Vec4 } else { Dimensions::Vec3 };
        self.check_format(
            acc,
            loc,
            dims,
            &[(DataType::F32, false), (DataType::U8, true), (DataType::U16, true)],
        )?;
        let (t, n) = (acc.data_type(), acc.normalized());
        let out = self.collect(acc, loc, |b| [0, 1, 2].map(|k| component_f32(b, t, n, k)))?;
        if let Some((i, c)) =
            out.iter().enumerate().find(|(_, c)| !c.iter().all(|v| v.is_finite() && *v >= 0.0))
        {
            return Err(self.err(loc, format!("colour {i} is negative or not finite: {c:?}")));
        }
        Ok(out)
    }

    /// Reads an accessor of `dims` whose component types are among `allowed` as f32s, the
    /// components of each element in a row, every value finite (animation keyframes).
    pub fn floats(
        &self,
        acc: &gltf::Accessor,
        loc: &str,
        dims: Dimensions,
        allowed: &[(DataType, bool)],
    ) -> Result<Vec<f32>, Error> {
        self.check_format(acc, loc, dims, allowed)?;
        let (t, n) = (acc.data_type(), acc.normalized());
        let k = dims.multiplicity();
        let rows = self.collect(acc, loc, |b| {
            let mut row = [0.0f32; 4];
            for (c, v) in row.iter_mut().enumerate().take(k) {
                *v = component_f32(b, t, n, c);
            }
            row
        })?;
        let out: Vec<f32> = rows.iter().flat_map(|r| r[..k].iter().copied()).collect();
        if let Some(i) = out.iter().position(|v| !v.is_finite()) {
            return Err(self.err(loc, format!("value {} (element {}) is not finite", out[i], i / k)));
        }
        Ok(out)
    }

    /// Reads indices: SCALAR UNSIGNED_BYTE/SHORT/INT. Ranges are checked by the caller,
    /// which knows the vertex count.
    pub fn indices(&self, acc: &gltf::Accessor, loc: &str) -> Result<Vec<u32>, Error> {
        self.check_format(
            acc,
            loc,
            Dimensions::Scalar,
            &[(DataType::U8, false), (DataType::U16, false), (DataType::U32, false)],
        )?;
        let t = acc.data_type();
        self.collect(acc, loc, |b| index_u32(b, t))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn schemes() {
        assert!(has_scheme("http://example.com/a.bin"));
        assert!(has_scheme("file:///tmp/a.bin"));
        assert!(!has_scheme("a.bin"));
        assert!(!has_scheme("C:/models/a.bin"));
        assert!(!has_scheme("dir/a:b.bin"));
    }

    #[test]
    fn spans() {
        assert_eq!(span_end(4, 0, 12, 12), Some(4));
        assert_eq!(span_end(4, 3, 16, 12), Some(4 + 32 + 12));
        assert_eq!(span_end(0, usize::MAX, 16, 12), None);
    }

    #[test]
    fn normalized_components() {
        assert_eq!(component_f32(&[255], DataType::U8, true, 0), 1.0);
        assert_eq!(component_f32(&[0x80], DataType::I8, true, 0), -1.0);
        assert_eq!(component_f32(&[0xff, 0xff], DataType::U16, true, 0), 1.0);
        assert_eq!(component_f32(&[0, 0, 0x80, 0x3f], DataType::F32, false, 0), 1.0);
    }
}
