//! EXT_meshopt_compression and KHR_meshopt_compression: bufferViews whose bytes are stored
//! compressed by meshoptimizer's codecs (what `gltfpack -c` and `gltf-transform meshopt`
//! write). Each such view names the compressed bytes (a buffer, offset and length), the
//! element `count` and `byteStride`, the codec `mode` and an optional `filter`; refrakt decodes
//! it with meshoptimizer's own decoders (the `meshopt` crate) into a buffer of its own and
//! points the view at that, so accessors read it like any other view.
//!
//! The buffer that stands in for the decoded data (marked `"fallback": true`) holds no bytes
//! when the extension is required, so [`is_fallback`] lets the buffer loader skip it.

use anyhow::{Result, anyhow};
use gltf::json;
use serde::Deserialize;
use serde_json::Value;

/// The two names of the extension; KHR_ adds the COLOR filter and version 1 of the vertex codec,
/// which the same decoders read.
const NAMES: [&str; 2] = ["EXT_meshopt_compression", "KHR_meshopt_compression"];

/// Largest decoded view refrakt makes (a view claims its decoded size; nothing is allocated for
/// a claim above this).
pub const MAX_DECODED_BYTES: u64 = 1 << 30;

/// The extension object on a bufferView (names as in the extension's JSON schema).
#[derive(Debug, Deserialize)]
#[serde(rename_all = "camelCase")]
struct Compressed {
    buffer: usize,
    #[serde(default)]
    byte_offset: u64,
    byte_length: u64,
    byte_stride: u64,
    count: u64,
    mode: Mode,
    #[serde(default)]
    filter: Filter,
}

#[derive(Clone, Copy, Debug, Deserialize, PartialEq)]
#[serde(rename_all = "UPPERCASE")]
enum Mode {
    /// Vertex attributes (the vertex codec), `byteStride` a multiple of 4 up to 256.
    Attributes,
    /// A triangle list's indices (the index codec), 2- or 4-byte indices.
    Triangles,
    /// Any other index sequence (the index sequence codec).
    Indices,
}

#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq)]
#[serde(rename_all = "UPPERCASE")]
enum Filter {
    #[default]
    None,
    /// Unit vectors in octahedral encoding (normals, tangents), 4 or 8 bytes.
    Octahedral,
    /// Unit quaternions as three components and the index of the fourth, 8 bytes.
    Quaternion,
    /// Floats as a shared exponent and a 24-bit mantissa, 4 bytes per component.
    Exponential,
    /// RGBA colors in YCoCg (KHR_meshopt_compression only), 4 or 8 bytes.
    Color,
}

/// The extension object of a buffer or bufferView, under either name.
fn extension(others: Option<&serde_json::Map<String, Value>>) -> Option<(&'static str, &Value)> {
    let others = others?;
    NAMES.iter().find_map(|n| others.get(*n).map(|v| (*n, v)))
}

/// Whether buffer `b` is the placeholder for decoded data (`"fallback": true`), which holds no
/// bytes of its own.
pub fn is_fallback(b: &json::Buffer) -> bool {
    let ext = extension(b.extensions.as_ref().map(|e| &e.others));
    ext.is_some_and(|(_, v)| v.get("fallback").and_then(Value::as_bool) == Some(true))
}

/// Decodes every compressed bufferView of `doc` into a buffer appended to `buffers`, and returns
/// the document with those views pointing at their decoded bytes.
pub fn decompress(doc: gltf::Document, buffers: &mut Vec<Vec<u8>>, file: &str) -> Result<gltf::Document> {
    let compressed = doc.as_json().buffer_views.iter().any(|v| extension(v.extensions.as_ref().map(|e| &e.others)).is_some());
    if !compressed {
        return Ok(doc);
    }
    let mut root = doc.into_json();
    for (i, view) in root.buffer_views.iter_mut().enumerate() {
        let Some((name, ext)) = extension(view.extensions.as_ref().map(|e| &e.others)) else { continue };
        let what = format!("bufferViews[{i}].extensions.{name}");
        let c = Compressed::deserialize(ext).map_err(|e| anyhow!("{file}: {what}: {e}; fix or re-export the file"))?;
        let decoded = decode_view(&c, buffers, view.byte_length.0).map_err(|m| anyhow!("{file}: {what}: {m}; the file is damaged or was written wrongly, re-export it"))?;
        view.byte_length = json::validation::USize64(decoded.len() as u64);
        view.byte_offset = None;
        view.buffer = json::Index::new(buffers.len() as u32);
        root.buffers.push(json::Buffer { byte_length: json::validation::USize64(decoded.len() as u64), name: None, uri: None, extensions: None, extras: Default::default() });
        buffers.push(decoded);
    }
    Ok(gltf::Document::from_json_without_validation(root))
}

/// The decoded bytes of one view: `count` elements of `byteStride` bytes.
fn decode_view(c: &Compressed, buffers: &[Vec<u8>], view_length: u64) -> Result<Vec<u8>, String> {
    let data = buffers.get(c.buffer).ok_or_else(|| format!("buffer {} does not exist", c.buffer))?;
    let source = c
        .byte_offset
        .checked_add(c.byte_length)
        .filter(|&end| end <= data.len() as u64)
        .map(|end| &data[c.byte_offset as usize..end as usize])
        .ok_or_else(|| format!("bytes {} + {} run past the end of buffers[{}] ({} bytes)", c.byte_offset, c.byte_length, c.buffer, data.len()))?;
    check_layout(c)?;
    let size = c.count.checked_mul(c.byte_stride).filter(|&s| s <= MAX_DECODED_BYTES).ok_or_else(|| {
        format!("{} elements of {} bytes exceed the {} MiB refrakt decodes per view", c.count, c.byte_stride, MAX_DECODED_BYTES >> 20)
    })?;
    if size != view_length {
        return Err(format!("{} elements of {} bytes make {size} bytes, but the bufferView's byteLength is {view_length}", c.count, c.byte_stride));
    }
    // Decoded into u32 words: the filters read 16- and 32-bit components in place.
    let mut words = vec![0u32; (size as usize).div_ceil(4)];
    let out: &mut [u8] = &mut bytemuck::cast_slice_mut::<u32, u8>(&mut words)[..size as usize];
    let (count, stride) = (c.count as usize, c.byte_stride as usize);
    // SAFETY: `out` holds count × stride bytes and `source` is a live slice; meshoptimizer's
    // decoders write at most that many bytes and are safe on untrusted input (they return
    // non-zero instead of reading or writing out of bounds).
    let status = unsafe {
        let (dst, src, len) = (out.as_mut_ptr().cast(), source.as_ptr(), source.len());
        match c.mode {
            Mode::Attributes => meshopt::ffi::meshopt_decodeVertexBuffer(dst, count, stride, src, len),
            Mode::Triangles => meshopt::ffi::meshopt_decodeIndexBuffer(dst, count, stride, src, len),
            Mode::Indices => meshopt::ffi::meshopt_decodeIndexSequence(dst, count, stride, src, len),
        }
    };
    if status != 0 {
        return Err(format!("the {:?} data cannot be decoded (meshoptimizer error {status})", c.mode));
    }
    // SAFETY: the filters transform count × stride bytes in place, which `out` holds; its
    // start is 4-byte aligned (a u32 buffer) and the stride was checked against the filter.
    unsafe {
        let dst = out.as_mut_ptr().cast();
        match c.filter {
            Filter::None => {}
            Filter::Octahedral => meshopt::ffi::meshopt_decodeFilterOct(dst, count, stride),
            Filter::Quaternion => meshopt::ffi::meshopt_decodeFilterQuat(dst, count, stride),
            Filter::Exponential => meshopt::ffi::meshopt_decodeFilterExp(dst, count, stride),
            Filter::Color => meshopt::ffi::meshopt_decodeFilterColor(dst, count, stride),
        }
    }
    Ok(out.to_vec())
}

/// The strides and counts each mode and filter allows (the extension's "Compression modes" and
/// "Filters"); meshoptimizer's decoders assume them.
fn check_layout(c: &Compressed) -> Result<(), String> {
    let s = c.byte_stride;
    let ok = match c.mode {
        Mode::Attributes => s > 0 && s <= 256 && s.is_multiple_of(4),
        Mode::Triangles => (s == 2 || s == 4) && c.count.is_multiple_of(3),
        Mode::Indices => s == 2 || s == 4,
    };
    if !ok {
        return Err(format!(
            "mode {:?} with byteStride {s} and count {} (ATTRIBUTES needs a stride that is a multiple of 4 up to 256; \
             TRIANGLES and INDICES 2- or 4-byte indices, TRIANGLES a multiple of 3 of them)",
            c.mode, c.count
        ));
    }
    let filter_ok = match c.filter {
        Filter::None => true,
        _ if c.mode != Mode::Attributes => false,
        Filter::Octahedral | Filter::Color => s == 4 || s == 8,
        Filter::Quaternion => s == 8,
        Filter::Exponential => s.is_multiple_of(4),
    };
    if !filter_ok {
        return Err(format!("filter {:?} does not fit mode {:?} with byteStride {s}", c.filter, c.mode));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn compressed(mode: Mode, filter: Filter, stride: u64, count: u64) -> Compressed {
        Compressed { buffer: 0, byte_offset: 0, byte_length: 0, byte_stride: stride, count, mode, filter }
    }

    #[test]
    fn layouts_the_decoders_cannot_take_are_refused() {
        assert!(check_layout(&compressed(Mode::Attributes, Filter::None, 12, 5)).is_ok());
        assert!(check_layout(&compressed(Mode::Attributes, Filter::None, 6, 5)).is_err());
        assert!(check_layout(&compressed(Mode::Triangles, Filter::None, 4, 4)).is_err());
        assert!(check_layout(&compressed(Mode::Attributes, Filter::Quaternion, 4, 4)).is_err());
        assert!(check_layout(&compressed(Mode::Indices, Filter::Exponential, 4, 4)).is_err());
    }

    #[test]
    fn octahedral_normals_decode_to_unit_vectors() {
        let normals = [[0.0f32, 0.0, 1.0, 0.0], [0.6, 0.8, 0.0, 0.0], [0.0, -1.0, 0.0, 0.0]];
        let encoded: Vec<[i8; 4]> = meshopt::encode_filter_oct(&normals, 8);
        let bytes: Vec<u8> = encoded.iter().flatten().map(|&b| b as u8).collect();
        let vertices = meshopt::encode_vertex_buffer(&encoded.iter().map(|e| e.map(|b| b as u8)).collect::<Vec<_>>()).unwrap();
        let c = Compressed { byte_length: vertices.len() as u64, ..compressed(Mode::Attributes, Filter::Octahedral, 4, 3) };
        let decoded = decode_view(&c, &[vertices], bytes.len() as u64).unwrap();
        for (n, d) in normals.iter().zip(decoded.chunks_exact(4)) {
            let v = [d[0] as i8, d[1] as i8, d[2] as i8].map(|x| x as f32 / 127.0);
            for k in 0..3 {
                assert!((v[k] - n[k]).abs() < 0.02, "{v:?} vs {n:?}");
            }
        }
    }
}
