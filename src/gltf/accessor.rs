//! Typed reads of accessors (glTF 2.0 §3.6.2), with every offset, stride and count checked
//! against the bytes that exist, so a file that lies about its sizes gets an error naming the
//! accessor, never an out-of-bounds read or an allocation sized by a claim.

use anyhow::{Result, anyhow, bail};
use gltf::json;
use gltf::json::accessor::{ComponentType, Type};

/// Components (floats) an accessor with no bufferView (all zeros, §3.6.2.3, or filled by sparse
/// values) may have: there are no bytes to check its count against, so it is capped (64 MiB).
const MAX_VALUES_WITHOUT_DATA: u64 = 1 << 24;

/// An accessor's elements as floats, `components` per element.
pub struct Floats {
    pub components: usize,
    pub values: Vec<f32>,
}

impl Floats {
    pub fn len(&self) -> usize {
        self.values.len() / self.components.max(1)
    }

    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }
}

/// Reads accessors of one document.
pub struct Accessors<'a> {
    pub root: &'a json::Root,
    pub buffers: &'a [Vec<u8>],
    pub file: &'a str,
}

fn component_size(c: ComponentType) -> u64 {
    match c {
        ComponentType::I8 | ComponentType::U8 => 1,
        ComponentType::I16 | ComponentType::U16 => 2,
        ComponentType::U32 | ComponentType::F32 => 4,
    }
}

/// Rows and columns: matrices are stored column by column.
fn shape(t: Type) -> (u64, u64) {
    match t {
        Type::Scalar => (1, 1),
        Type::Vec2 => (2, 1),
        Type::Vec3 => (3, 1),
        Type::Vec4 => (4, 1),
        Type::Mat2 => (2, 2),
        Type::Mat3 => (3, 3),
        Type::Mat4 => (4, 4),
    }
}

/// §3.6.2.4: each column of a matrix starts on a 4-byte boundary (which pads MAT2 of bytes and
/// MAT3 of bytes or shorts).
fn column_stride(t: Type, c: ComponentType) -> u64 {
    let (rows, cols) = shape(t);
    let packed = rows * component_size(c);
    if cols == 1 { packed } else { packed.next_multiple_of(4) }
}

fn element_size(t: Type, c: ComponentType) -> u64 {
    let (rows, cols) = shape(t);
    if cols == 1 { rows * component_size(c) } else { cols * column_stride(t, c) }
}

/// One component as a float; normalized integers map to [0, 1] or [−1, 1] (§3.11, "Animations",
/// and §3.6.2.1: signed values are max(c / (2ⁿ⁻¹ − 1), −1)).
fn decode(bytes: &[u8], c: ComponentType, normalized: bool) -> f32 {
    let b = |i: usize| bytes[i];
    match (c, normalized) {
        (ComponentType::F32, _) => f32::from_le_bytes([b(0), b(1), b(2), b(3)]),
        (ComponentType::U32, _) => u32::from_le_bytes([b(0), b(1), b(2), b(3)]) as f32,
        (ComponentType::I8, false) => b(0) as i8 as f32,
        (ComponentType::I8, true) => (b(0) as i8 as f32 / 127.0).max(-1.0),
        (ComponentType::U8, false) => b(0) as f32,
        (ComponentType::U8, true) => b(0) as f32 / 255.0,
        (ComponentType::I16, false) => i16::from_le_bytes([b(0), b(1)]) as f32,
        (ComponentType::I16, true) => (i16::from_le_bytes([b(0), b(1)]) as f32 / 32767.0).max(-1.0),
        (ComponentType::U16, false) => u16::from_le_bytes([b(0), b(1)]) as f32,
        (ComponentType::U16, true) => u16::from_le_bytes([b(0), b(1)]) as f32 / 65535.0,
    }
}

/// An unsigned integer component (indices, joints).
fn decode_uint(bytes: &[u8], c: ComponentType) -> Option<u32> {
    match c {
        ComponentType::U8 => Some(bytes[0] as u32),
        ComponentType::U16 => Some(u16::from_le_bytes([bytes[0], bytes[1]]) as u32),
        ComponentType::U32 => Some(u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]])),
        _ => None,
    }
}

/// The bytes of a run of elements inside a buffer, and the distance between elements.
struct Run<'b> {
    bytes: &'b [u8],
    stride: usize,
}

/// Which elements to find: `count` elements of `size` bytes, from byte `offset` of bufferView
/// `view`, either at the view's byteStride or tightly `packed` (sparse data, §3.6.2.3).
struct Span {
    view: usize,
    offset: u64,
    count: u64,
    size: u64,
    packed: bool,
}

impl<'a> Accessors<'a> {
    fn accessor(&self, index: usize, what: &str) -> Result<&'a json::Accessor> {
        self.root.accessors.get(index).ok_or_else(|| anyhow!("{}: {what}: accessors[{index}] does not exist", self.file))
    }

    fn err(&self, index: usize, what: &str, msg: impl std::fmt::Display) -> anyhow::Error {
        anyhow!("{}: {what} (accessors[{index}]): {msg}; the file is damaged or was written wrongly, re-export it", self.file)
    }

    /// The bytes of a span of elements, checked against their bufferView and the view against
    /// its buffer.
    fn run(&self, index: usize, what: &str, span: Span) -> Result<Run<'a>> {
        let Span { view, offset, count, size, packed } = span;
        let v = self.root.buffer_views.get(view).ok_or_else(|| self.err(index, what, format!("bufferViews[{view}] does not exist")))?;
        let data = &self.buffers[v.buffer.value()];
        let view_start = v.byte_offset.map_or(0, |o| o.0);
        let view_len = v.byte_length.0;
        view_start.checked_add(view_len).filter(|&e| e <= data.len() as u64).ok_or_else(|| {
            self.err(index, what, format!("bufferViews[{view}] (bytes {view_start} + {view_len}) runs past the end of buffers[{}] ({} bytes)", v.buffer.value(), data.len()))
        })?;
        let stride = match v.byte_stride {
            Some(s) if !packed => s.0 as u64,
            _ => size,
        };
        if stride < size {
            return Err(self.err(index, what, format!("byteStride {stride} is smaller than an element ({size} bytes)")));
        }
        let needed = if count == 0 { Some(0) } else { (count - 1).checked_mul(stride).and_then(|x| x.checked_add(size)) };
        let needed = needed.ok_or_else(|| self.err(index, what, format!("count {count} is too large")))?;
        offset.checked_add(needed).filter(|&e| e <= view_len).ok_or_else(|| {
            self.err(index, what, format!("{count} elements of {size} bytes from byte {offset} need {needed} bytes, but bufferViews[{view}] has {view_len}"))
        })?;
        // Both checks above bound this range inside the buffer.
        let start = (view_start + offset) as usize;
        Ok(Run { bytes: &data[start..start + needed as usize], stride: stride as usize })
    }

    fn kinds(&self, a: &json::Accessor, index: usize, what: &str) -> Result<(Type, ComponentType)> {
        match (&a.type_, &a.component_type) {
            (json::validation::Checked::Valid(t), json::validation::Checked::Valid(c)) => Ok((*t, c.0)),
            _ => Err(self.err(index, what, "unknown type or componentType")),
        }
    }

    /// Every element of accessor `index` as floats (sparse substitution applied).
    pub fn floats(&self, index: usize, what: &str) -> Result<Floats> {
        let a = self.accessor(index, what)?;
        let (t, c) = self.kinds(a, index, what)?;
        let (rows, cols) = shape(t);
        let components = (rows * cols) as usize;
        let count = a.count.0;
        let col_stride = column_stride(t, c);
        let size = element_size(t, c);
        let read_element = |bytes: &[u8], out: &mut Vec<f32>| {
            for col in 0..cols {
                for row in 0..rows {
                    let at = (col * col_stride + row * component_size(c)) as usize;
                    out.push(decode(&bytes[at..], c, a.normalized));
                }
            }
        };
        let mut values = match a.buffer_view {
            Some(view) => {
                let run = self.run(index, what, Span { view: view.value(), offset: a.byte_offset.map_or(0, |o| o.0), count, size, packed: false })?;
                let mut out = Vec::with_capacity(count as usize * components);
                for i in 0..count as usize {
                    read_element(&run.bytes[i * run.stride..], &mut out);
                }
                out
            }
            None if count.saturating_mul(components as u64) <= MAX_VALUES_WITHOUT_DATA => vec![0.0; count as usize * components],
            None => return Err(self.err(index, what, format!("count {count} with no bufferView (more than refrakt reads without data)"))),
        };
        if let Some(sparse) = &a.sparse {
            let n = sparse.count.0;
            let ic = match &sparse.indices.component_type {
                json::validation::Checked::Valid(ic) => ic.0,
                _ => return Err(self.err(index, what, "sparse indices of unknown componentType")),
            };
            let isize = component_size(ic);
            let idx = Span { view: sparse.indices.buffer_view.value(), offset: sparse.indices.byte_offset.0, count: n, size: isize, packed: true };
            let idx = self.run(index, what, idx)?;
            let vals = Span { view: sparse.values.buffer_view.value(), offset: sparse.values.byte_offset.0, count: n, size, packed: true };
            let vals = self.run(index, what, vals)?;
            for k in 0..n as usize {
                let target = decode_uint(&idx.bytes[k * isize as usize..], ic)
                    .ok_or_else(|| self.err(index, what, "sparse indices must be unsigned integers"))?;
                if target as u64 >= count {
                    return Err(self.err(index, what, format!("sparse index {target} is not below count {count}")));
                }
                let mut element = Vec::with_capacity(components);
                read_element(&vals.bytes[k * size as usize..], &mut element);
                values[target as usize * components..][..components].copy_from_slice(&element);
            }
        }
        Ok(Floats { components, values })
    }

    /// Floats with an expected number of components per element (e.g. 3 for positions).
    pub fn floats_of(&self, index: usize, what: &str, components: usize) -> Result<Floats> {
        let f = self.floats(index, what)?;
        if f.components != components {
            bail!("{}: {what} (accessors[{index}]) has {} components per element; {components} are expected", self.file, f.components);
        }
        Ok(f)
    }

    /// Unsigned integers (indices, joint numbers), `components` per element, from U8/U16/U32
    /// accessors as §3.7.2.1 requires of indices and §3.7.3.3 of JOINTS_n.
    pub fn uints(&self, index: usize, what: &str, components: usize) -> Result<Vec<u32>> {
        let a = self.accessor(index, what)?;
        let (t, c) = self.kinds(a, index, what)?;
        let (rows, cols) = shape(t);
        if cols != 1 || rows as usize != components || decode_uint(&[0; 4], c).is_none() || a.normalized {
            bail!(
                "{}: {what} (accessors[{index}]) must be {components}-component unsigned integers (it is {t:?} of {c:?}{})",
                self.file,
                if a.normalized { ", normalized" } else { "" }
            );
        }
        if a.sparse.is_some() {
            // Sparse integer data is rare enough to convert through floats (exact below 2²⁴).
            return Ok(self.floats(index, what)?.values.iter().map(|&x| x as u32).collect());
        }
        let Some(view) = a.buffer_view else {
            bail!("{}: {what} (accessors[{index}]) has no bufferView, so it holds no data", self.file);
        };
        let size = element_size(t, c);
        let span = Span { view: view.value(), offset: a.byte_offset.map_or(0, |o| o.0), count: a.count.0, size, packed: false };
        let run = self.run(index, what, span)?;
        let cs = component_size(c) as usize;
        let mut out = Vec::with_capacity(a.count.0 as usize * components);
        for i in 0..a.count.0 as usize {
            for k in 0..components {
                out.extend(decode_uint(&run.bytes[i * run.stride + k * cs..], c));
            }
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matrix_columns_are_padded_to_four_bytes() {
        assert_eq!(element_size(Type::Mat4, ComponentType::F32), 64);
        assert_eq!(element_size(Type::Mat2, ComponentType::U8), 8);
        assert_eq!(element_size(Type::Mat3, ComponentType::I16), 24);
        assert_eq!(element_size(Type::Vec3, ComponentType::U16), 6);
    }

    #[test]
    fn normalized_integers_map_to_unit_ranges() {
        assert_eq!(decode(&[255], ComponentType::U8, true), 1.0);
        assert_eq!(decode(&[0x80], ComponentType::I8, true), -1.0);
        assert_eq!(decode(&[0xff, 0x7f], ComponentType::I16, true), 1.0);
        assert_eq!(decode(&[7], ComponentType::U8, false), 7.0);
    }
}
