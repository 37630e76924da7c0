//! The binary side of a glTF document: one buffer of little-endian data, its buffer views and
//! accessors (glTF 2.0 §3.6), the base64 `data:` URI of a `.gltf` and the GLB container
//! (glTF 2.0 §4.4) of a `.glb`.
//!
//! Every buffer view starts on a 4-byte boundary (the spec asks the component size; 4 covers
//! `f32`, `u16` and `u32`), and every accessor of vertex positions or animation inputs carries
//! the exact `min`/`max` of the `f32` values written, as the spec requires.

use serde_json::{json, Value};

/// `componentType` of 32-bit floats.
const FLOAT: u32 = 5126;
/// `componentType` of unsigned 16-bit integers.
const UNSIGNED_SHORT: u32 = 5123;
/// `componentType` of unsigned 32-bit integers.
const UNSIGNED_INT: u32 = 5125;
/// `bufferView.target` of vertex attributes.
pub const ARRAY_BUFFER: u32 = 34962;
/// `bufferView.target` of vertex indices.
pub const ELEMENT_ARRAY_BUFFER: u32 = 34963;

/// The accessor `type` and its number of components.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AccessorType {
    /// One component.
    Scalar,
    /// Three components.
    Vec3,
}

impl AccessorType {
    fn name(self) -> &'static str {
        match self {
            AccessorType::Scalar => "SCALAR",
            AccessorType::Vec3 => "VEC3",
        }
    }

    fn components(self) -> usize {
        match self {
            AccessorType::Scalar => 1,
            AccessorType::Vec3 => 3,
        }
    }
}

/// A growing buffer with its views and accessors.
#[derive(Debug, Clone, Default)]
pub struct BufferBuilder {
    /// The bytes of buffer 0.
    pub bytes: Vec<u8>,
    /// `bufferViews`.
    pub views: Vec<Value>,
    /// `accessors`.
    pub accessors: Vec<Value>,
}

impl BufferBuilder {
    /// An empty buffer.
    pub fn new() -> Self {
        Self::default()
    }

    /// True when nothing was added (the document then has no buffer at all).
    pub fn is_empty(&self) -> bool {
        self.bytes.is_empty()
    }

    fn view(&mut self, data: &[u8], target: Option<u32>) -> usize {
        while self.bytes.len() % 4 != 0 {
            self.bytes.push(0);
        }
        let mut v = json!({
            "buffer": 0,
            "byteOffset": self.bytes.len(),
            "byteLength": data.len(),
        });
        if let Some(t) = target {
            v["target"] = json!(t);
        }
        self.bytes.extend_from_slice(data);
        self.views.push(v);
        self.views.len() - 1
    }

    /// `f32` data of `kind` (tightly packed) as a new view and accessor; `with_bounds` writes the
    /// per-component `min` and `max`. Returns the accessor index.
    pub fn push_f32(
        &mut self,
        values: &[f32],
        kind: AccessorType,
        target: Option<u32>,
        with_bounds: bool,
    ) -> usize {
        let n = kind.components();
        let data: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.view(&data, target);
        let mut a = json!({
            "bufferView": view,
            "componentType": FLOAT,
            "count": values.len() / n,
            "type": kind.name(),
        });
        if with_bounds {
            let (mut lo, mut hi) = (vec![f32::INFINITY; n], vec![f32::NEG_INFINITY; n]);
            for chunk in values.chunks(n) {
                for (c, v) in chunk.iter().enumerate() {
                    lo[c] = lo[c].min(*v);
                    hi[c] = hi[c].max(*v);
                }
            }
            // f32 → f64 is exact, so the JSON numbers equal the stored values.
            a["min"] = json!(lo.iter().map(|&v| f64::from(v)).collect::<Vec<_>>());
            a["max"] = json!(hi.iter().map(|&v| f64::from(v)).collect::<Vec<_>>());
        }
        self.accessors.push(a);
        self.accessors.len() - 1
    }

    /// Triangle indices (`u16` when every index fits, else `u32`) as a new view and accessor.
    pub fn push_indices(&mut self, indices: &[u32]) -> usize {
        let max = indices.iter().copied().max().unwrap_or(0);
        let (data, component): (Vec<u8>, u32) = if max < u32::from(u16::MAX) {
            (
                indices
                    .iter()
                    .flat_map(|&i| (i as u16).to_le_bytes())
                    .collect(),
                UNSIGNED_SHORT,
            )
        } else {
            (
                indices.iter().flat_map(|i| i.to_le_bytes()).collect(),
                UNSIGNED_INT,
            )
        };
        let view = self.view(&data, Some(ELEMENT_ARRAY_BUFFER));
        self.accessors.push(json!({
            "bufferView": view,
            "componentType": component,
            "count": indices.len(),
            "type": "SCALAR",
        }));
        self.accessors.len() - 1
    }
}

/// Standard base64 (RFC 4648 §4, with padding) for the embedded buffer's data URI.
pub fn base64(bytes: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let v = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(A[((v >> (18 - 6 * k)) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// The `data:` URI of a buffer embedded in a `.gltf`.
pub fn data_uri(bytes: &[u8]) -> String {
    format!("data:application/octet-stream;base64,{}", base64(bytes))
}

/// A GLB container (glTF 2.0 §4.4): the 12-byte header, the JSON chunk padded with spaces and,
/// when `bin` is not empty, the BIN chunk padded with zeros. `json` must describe buffer 0
/// without a `uri` and with `byteLength` = `bin.len()`.
pub fn glb(json: &[u8], bin: &[u8]) -> Vec<u8> {
    let pad = |n: usize| (4 - n % 4) % 4;
    let json_len = json.len() + pad(json.len());
    let bin_len = bin.len() + pad(bin.len());
    let total = 12 + 8 + json_len + if bin.is_empty() { 0 } else { 8 + bin_len };
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(&0x4654_6C67u32.to_le_bytes()); // "glTF"
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json_len as u32).to_le_bytes());
    out.extend_from_slice(&0x4E4F_534Au32.to_le_bytes()); // "JSON"
    out.extend_from_slice(json);
    out.extend(std::iter::repeat_n(b' ', pad(json.len())));
    if !bin.is_empty() {
        out.extend_from_slice(&(bin_len as u32).to_le_bytes());
        out.extend_from_slice(&0x004E_4942u32.to_le_bytes()); // "BIN\0"
        out.extend_from_slice(bin);
        out.extend(std::iter::repeat_n(0u8, pad(bin.len())));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_matches_rfc4648_examples() {
        assert_eq!(base64(b"f"), "Zg==");
        assert_eq!(base64(b"fo"), "Zm8=");
        assert_eq!(base64(b"foo"), "Zm9v");
        assert_eq!(base64(b"foobar"), "Zm9vYmFy");
    }

    #[test]
    fn views_start_on_four_byte_boundaries_and_bounds_are_per_component() {
        let mut b = BufferBuilder::new();
        b.push_indices(&[0, 1, 2]); // 6 bytes
        let a = b.push_f32(
            &[1.0, -2.0, 3.0, 0.5, 4.0, -1.0],
            AccessorType::Vec3,
            None,
            true,
        );
        assert_eq!(b.views[1]["byteOffset"], 8);
        assert_eq!(b.accessors[a]["min"], json!([0.5, -2.0, -1.0]));
        assert_eq!(b.accessors[a]["max"], json!([1.0, 4.0, 3.0]));
        assert_eq!(b.accessors[a]["count"], 2);
    }

    #[test]
    fn glb_chunks_are_padded_and_the_length_is_the_file_length() {
        let g = glb(b"{\"a\":1}", &[1, 2, 3, 4, 5]);
        assert_eq!(g.len() % 4, 0);
        assert_eq!(
            u32::from_le_bytes(g[8..12].try_into().unwrap()) as usize,
            g.len()
        );
        assert_eq!(&g[0..4], b"glTF");
        let json_len = u32::from_le_bytes(g[12..16].try_into().unwrap()) as usize;
        assert_eq!(json_len, 8);
        assert_eq!(&g[16..20], b"JSON");
        assert_eq!(&g[20 + json_len + 4..20 + json_len + 8], b"BIN\0");
    }
}
