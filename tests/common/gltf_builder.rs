//! Writes small glTF files for tests: JSON built with serde_json, binary data appended to one
//! buffer, saved as a .glb, a .gltf with a data: URI, or a .gltf with an external .bin.

use std::f32::consts::FRAC_1_SQRT_2;
use std::path::{Path, PathBuf};

use base64::Engine;
use serde_json::{Value, json};

pub struct GltfBuilder {
    pub json: Value,
    pub bin: Vec<u8>,
}

impl Default for GltfBuilder {
    fn default() -> Self {
        Self::new()
    }
}

impl GltfBuilder {
    pub fn new() -> Self {
        Self { json: json!({ "asset": { "version": "2.0", "generator": "refrakt tests" } }), bin: Vec::new() }
    }

    /// Appends `value` to the top-level array `key`; returns its index.
    pub fn push(&mut self, key: &str, value: Value) -> usize {
        let list = self.json.as_object_mut().unwrap().entry(key).or_insert_with(|| json!([]));
        let list = list.as_array_mut().unwrap();
        list.push(value);
        list.len() - 1
    }

    /// A bufferView over `bytes` (4-byte aligned in the buffer).
    pub fn view(&mut self, bytes: &[u8]) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        self.push("bufferViews", json!({ "buffer": 0, "byteOffset": offset, "byteLength": bytes.len() }))
    }

    /// A float accessor of `kind` ("SCALAR", "VEC3", "VEC4", "MAT4", …) over `values`.
    pub fn floats(&mut self, values: &[f32], kind: &str) -> usize {
        let n = match kind {
            "SCALAR" => 1,
            "VEC2" => 2,
            "VEC3" => 3,
            "VEC4" => 4,
            "MAT4" => 16,
            _ => panic!("{kind}"),
        };
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.view(&bytes);
        let mut a = json!({ "bufferView": view, "componentType": 5126, "count": values.len() / n, "type": kind });
        if kind == "SCALAR" || kind == "VEC3" {
            // Animation inputs and POSITION need min and max (§3.6.2.5).
            let cols = |f: fn(f32, f32) -> f32, init: f32| -> Vec<f32> {
                (0..n).map(|c| values.iter().skip(c).step_by(n).copied().fold(init, f)).collect()
            };
            a["min"] = json!(cols(f32::min, f32::INFINITY));
            a["max"] = json!(cols(f32::max, f32::NEG_INFINITY));
        }
        self.push("accessors", a)
    }

    /// An unsigned integer accessor (component type 5121 u8, 5123 u16 or 5125 u32).
    pub fn uints(&mut self, values: &[u32], kind: &str, component_type: u32) -> usize {
        let n = if kind == "VEC4" { 4 } else { 1 };
        let bytes: Vec<u8> = match component_type {
            5121 => values.iter().map(|&v| v as u8).collect(),
            5123 => values.iter().flat_map(|&v| (v as u16).to_le_bytes()).collect(),
            _ => values.iter().flat_map(|v| v.to_le_bytes()).collect(),
        };
        let view = self.view(&bytes);
        self.push("accessors", json!({ "bufferView": view, "componentType": component_type, "count": values.len() / n, "type": kind }))
    }

    /// A triangle mesh (one primitive) from positions and triangles; returns the mesh index.
    pub fn mesh(&mut self, positions: &[[f32; 3]], triangles: &[[u32; 3]], material: Option<usize>) -> usize {
        let p: Vec<f32> = positions.iter().flatten().copied().collect();
        let i: Vec<u32> = triangles.iter().flatten().copied().collect();
        let pos = self.floats(&p, "VEC3");
        let idx = self.uints(&i, "SCALAR", 5125);
        let mut prim = json!({ "attributes": { "POSITION": pos }, "indices": idx });
        if let Some(m) = material {
            prim["material"] = json!(m);
        }
        self.push("meshes", json!({ "primitives": [prim] }))
    }

    /// One scene with these root nodes (and the file's default scene is the first one).
    pub fn scene(&mut self, name: &str, roots: &[usize]) -> usize {
        let s = self.push("scenes", json!({ "name": name, "nodes": roots }));
        if self.json.get("scene").is_none() {
            self.json["scene"] = json!(0);
        }
        s
    }

    /// Marks an extension used (and required, if asked).
    pub fn uses(&mut self, ext: &str, required: bool) {
        self.push("extensionsUsed", json!(ext));
        if required {
            self.push("extensionsRequired", json!(ext));
        }
    }

    fn with_buffer(&self, uri: Option<String>) -> Value {
        let mut j = self.json.clone();
        if !self.bin.is_empty() {
            let mut b = json!({ "byteLength": self.bin.len() });
            if let Some(u) = uri {
                b["uri"] = json!(u);
            }
            j["buffers"] = json!([b]);
        }
        j
    }

    /// The binary container: header, JSON chunk (space padded), BIN chunk (zero padded).
    pub fn glb_bytes(&self) -> Vec<u8> {
        glb(&serde_json::to_vec(&self.with_buffer(None)).unwrap(), &self.bin)
    }

    pub fn write_glb(&self, path: &Path) -> PathBuf {
        std::fs::write(path, self.glb_bytes()).unwrap();
        path.to_path_buf()
    }

    /// A .gltf with the buffer inline as a base64 data: URI.
    pub fn write_embedded(&self, path: &Path) -> PathBuf {
        let uri = format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(&self.bin));
        std::fs::write(path, serde_json::to_vec_pretty(&self.with_buffer(Some(uri))).unwrap()).unwrap();
        path.to_path_buf()
    }

    /// A .gltf next to an external `bin_name`.
    pub fn write_external(&self, path: &Path, bin_name: &str) -> PathBuf {
        std::fs::write(path.with_file_name(bin_name), &self.bin).unwrap();
        std::fs::write(path, serde_json::to_vec_pretty(&self.with_buffer(Some(bin_name.to_string()))).unwrap()).unwrap();
        path.to_path_buf()
    }
}

/// A file of one glass tetrahedron, node "Drop" in scene "S", of `material` (the `extensions`
/// it names declared used): what a test of one material setting needs. Returns the builder,
/// the material's index and the scene's.
pub fn tetrahedron_of(material: Value, extensions: &[&str]) -> (GltfBuilder, usize, usize) {
    let mut g = GltfBuilder::new();
    for ext in extensions {
        g.uses(ext, false);
    }
    let material = g.push("materials", material);
    let mesh = g.mesh(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], &[[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], Some(material));
    let node = g.push("nodes", json!({ "name": "Drop", "mesh": mesh }));
    let scene = g.scene("S", &[node]);
    (g, material, scene)
}

/// The frame at time 0 of the .glb `g` writes to `path`, or the import's or evaluation's error.
pub fn frame_of_glb(g: &GltfBuilder, path: &Path) -> anyhow::Result<refrakt::frame::FrameDesc> {
    let source = refrakt::render::GltfScene::load(&g.write_glb(path), &[], &Default::default())?;
    refrakt::scene::eval::evaluate(&source.scene, 0.0, &Default::default())
}

/// A .glb from its JSON text and binary chunk (glTF 2.0 §4.4).
pub fn glb(json: &[u8], bin: &[u8]) -> Vec<u8> {
    let pad = |v: &[u8], with: u8| {
        let mut v = v.to_vec();
        while !v.len().is_multiple_of(4) {
            v.push(with);
        }
        v
    };
    let (json, bin) = (pad(json, b' '), pad(bin, 0));
    let total = 12 + 8 + json.len() + if bin.is_empty() { 0 } else { 8 + bin.len() };
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    if !bin.is_empty() {
        out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&bin);
    }
    out
}

/// A small file that uses most of what refrakt reads: a glass tetrahedron with a morph target
/// and KHR materials, a skinned and animated bar, a textured floor, lights, a camera, every
/// interpolation, sparse accessors and refrakt extras. The fuzz test mutates it.
pub fn sample_scene() -> GltfBuilder {
    let mut g = GltfBuilder::new();
    for ext in ["KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_volume", "KHR_lights_punctual"] {
        g.uses(ext, false);
    }
    let glass = g.push("materials", json!({ "name": "Glass", "pbrMetallicRoughness": { "metallicFactor": 0.0, "roughnessFactor": 0.0 }, "extensions": {
        "KHR_materials_transmission": { "transmissionFactor": 1.0 }, "KHR_materials_ior": { "ior": 1.45 },
        "KHR_materials_volume": { "thicknessFactor": 0.5, "attenuationColor": [0.9, 0.8, 0.7], "attenuationDistance": 0.5 } },
        "extras": { "refrakt": { "boundary": 2.0 } } }));
    let floor_mat = g.push("materials", json!({ "name": "Floor", "pbrMetallicRoughness": { "baseColorFactor": [0.8, 0.7, 0.6, 1.0], "baseColorTexture": { "index": 0 } } }));
    // A 2×2 PNG texture in the binary chunk.
    let mut png = Vec::new();
    let img = image::RgbaImage::from_raw(2, 2, vec![255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 255, 255, 255, 255]).unwrap();
    image::DynamicImage::ImageRgba8(img).write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png).unwrap();
    let png_view = g.view(&png);
    g.push("images", json!({ "bufferView": png_view, "mimeType": "image/png" }));
    g.push("samplers", json!({ "wrapS": 10497, "wrapT": 10497 }));
    g.push("textures", json!({ "source": 0, "sampler": 0 }));

    let tetra = [[0.0f32, 0.0, 0.0], [0.3, 0.0, 0.0], [0.0, 0.3, 0.0], [0.0, 0.0, 0.3]];
    let tp: Vec<f32> = tetra.iter().flatten().copied().collect();
    let pos = g.floats(&tp, "VEC3");
    let idx = g.uints(&[0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3], "SCALAR", 5123);
    // A sparse morph target: only vertex 3 moves.
    let sparse_idx = g.view(&3u16.to_le_bytes());
    let sparse_val = g.view(&[0.0f32, 0.1, 0.1].iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<_>>());
    let target = g.push("accessors", json!({ "componentType": 5126, "count": 4, "type": "VEC3", "min": [0.0, 0.0, 0.0], "max": [0.0, 0.1, 0.1],
        "sparse": { "count": 1, "indices": { "bufferView": sparse_idx, "componentType": 5123 }, "values": { "bufferView": sparse_val } } }));
    let gem = g.push("meshes", json!({ "name": "Gem", "primitives": [{ "attributes": { "POSITION": pos }, "indices": idx, "material": glass, "targets": [{ "POSITION": target }] }], "weights": [0.5] }));

    let floor_p = g.floats(&[-2.0, 0.0, -2.0, 2.0, 0.0, -2.0, 2.0, 0.0, 2.0, -2.0, 0.0, 2.0], "VEC3");
    let floor_uv = g.floats(&[0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0, 1.0], "VEC2");
    let floor_i = g.uints(&[0, 2, 1, 0, 3, 2], "SCALAR", 5121);
    let floor = g.push("meshes", json!({ "name": "Floor", "primitives": [{ "attributes": { "POSITION": floor_p, "TEXCOORD_0": floor_uv }, "indices": floor_i, "material": floor_mat }] }));

    let bar_p = g.floats(&[0.1, 0.0, 0.0, 0.1, 1.0, 0.0, 0.1, 2.0, 0.1, -0.1, 1.5, 0.0], "VEC3");
    let bar_j = g.uints(&[0, 0, 0, 0, 0, 1, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0], "VEC4", 5121);
    let bar_w = g.floats(&[1.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.3, 0.7, 0.0, 0.0], "VEC4");
    let bar_i = g.uints(&[0, 1, 2, 0, 2, 3, 0, 3, 1, 1, 3, 2], "SCALAR", 5125);
    let bar = g.push("meshes", json!({ "name": "Bar", "primitives": [{ "attributes": { "POSITION": bar_p, "JOINTS_0": bar_j, "WEIGHTS_0": bar_w }, "indices": bar_i, "material": glass }] }));
    let ibm: Vec<f32> = [[1.0f32, 0., 0., 0., 0., 1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1.], [1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1., 0., 0., -1., 0., 1.]].concat();
    let ibm = g.floats(&ibm, "MAT4");

    g.json["extensions"] = json!({ "KHR_lights_punctual": { "lights": [
        { "type": "spot", "intensity": 500.0, "color": [1.0, 0.9, 0.8], "spot": { "innerConeAngle": 0.3, "outerConeAngle": 0.5 } },
        { "type": "directional", "intensity": 2.0 } ] } });
    g.push("cameras", json!({ "type": "perspective", "perspective": { "yfov": 0.7, "aspectRatio": 1.5, "znear": 0.05 } }));

    let gem_node = g.push("nodes", json!({ "name": "Gem", "mesh": gem, "translation": [0.0, 0.5, 0.0] }));
    let floor_node = g.push("nodes", json!({ "name": "Floor", "mesh": floor }));
    let tip = g.push("nodes", json!({ "name": "Tip", "translation": [0.0, 1.0, 0.0] }));
    let root = g.push("nodes", json!({ "name": "Root", "children": [tip] }));
    let bar_node = g.push("nodes", json!({ "name": "Bar", "mesh": bar, "skin": 0 }));
    let rig = g.push("nodes", json!({ "name": "Rig", "translation": [1.0, 0.0, 0.0], "scale": [0.5, 0.5, 0.5], "children": [root, bar_node] }));
    let lens = g.push("nodes", json!({ "name": "Lens", "translation": [-1.0, 0.5, 0.0], "extras": { "refrakt": { "field": "luneburg", "radius": 0.3 } } }));
    let spot = g.push("nodes", json!({ "name": "Spot", "translation": [0.0, 3.0, 0.0], "rotation": [-FRAC_1_SQRT_2, 0.0, 0.0, FRAC_1_SQRT_2],
                                       "extensions": { "KHR_lights_punctual": { "light": 0 } } }));
    let sun = g.push("nodes", json!({ "name": "Sun", "rotation": [-0.38268343, 0.0, 0.0, 0.9238795], "extensions": { "KHR_lights_punctual": { "light": 1 } } }));
    let cam = g.push("nodes", json!({ "name": "Camera", "camera": 0, "translation": [0.0, 1.0, 4.0] }));
    g.push("skins", json!({ "joints": [root, tip], "inverseBindMatrices": ibm }));

    let times = g.floats(&[0.0, 0.5, 1.0], "SCALAR");
    let gem_t = g.floats(&[0.0, 0.5, 0.0, 0.0, 0.7, 0.0, 0.0, 0.5, 0.0], "VEC3");
    let tip_r = g.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.38268343, 0.9238795, 0.0, 0.0, FRAC_1_SQRT_2, FRAC_1_SQRT_2], "VEC4");
    let weights = g.floats(&[0.0, 1.0, 0.25], "SCALAR");
    g.push("animations", json!({ "name": "Play", "samplers": [
        { "input": times, "output": gem_t, "interpolation": "LINEAR" },
        { "input": times, "output": tip_r, "interpolation": "LINEAR" },
        { "input": times, "output": weights, "interpolation": "STEP" } ],
        "channels": [
        { "sampler": 0, "target": { "node": gem_node, "path": "translation" } },
        { "sampler": 1, "target": { "node": tip, "path": "rotation" } },
        { "sampler": 2, "target": { "node": gem_node, "path": "weights" } } ] }));
    let bob = cubic_out_keys(&mut g);
    g.push("animations", json!({ "name": "Bob", "samplers": [
        { "input": times, "output": bob, "interpolation": "CUBICSPLINE" } ],
        "channels": [ { "sampler": 0, "target": { "node": cam, "path": "translation" } } ] }));
    let s = g.push("scenes", json!({ "name": "Sample", "nodes": [gem_node, floor_node, rig, lens, spot, sun, cam],
        "extras": { "refrakt": { "photons": 5000, "samples": 1, "volume": { "resolution": 24, "margin": 0.05 },
                                 "environment": { "color": [0.2, 0.3, 0.4], "intensity": 1.0, "visible": true } } } }));
    g.json["scene"] = json!(s);
    g
}

/// CUBICSPLINE keyframes (in-tangent, value, out-tangent) × 3 for a translation.
fn cubic_out_keys(g: &mut GltfBuilder) -> usize {
    let keys: Vec<f32> = [[0.0f32, 0.0, 0.0], [0.0, 1.0, 4.0], [0.0, 0.5, 0.0], [0.0, 0.0, 0.0], [0.0, 1.2, 4.0], [0.0, 0.0, 0.0], [0.0, -0.5, 0.0], [0.0, 1.0, 4.0], [0.0, 0.0, 0.0]]
        .concat();
    g.floats(&keys, "VEC3")
}
