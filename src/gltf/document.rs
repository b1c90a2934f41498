//! Reading a glTF file into a validated document: the `.glb` container (glTF 2.0 §4.4, "Binary
//! glTF Layout") or plain JSON, the crate's validation of indices and enumerations, and
//! refrakt's own checks that the crate leaves to its users: which required extensions refrakt
//! honours, the asset version, and that the nodes form trees (§3.5.1: "the node hierarchy MUST
//! be a set of disjoint strict trees").

use anyhow::{Result, anyhow, bail};
use gltf::json;
use gltf::json::validation::Validate;

/// Extensions refrakt reads in full, so a file may require them. Any other required extension
/// changes what the data means (compressed geometry, texture formats, …) and the file is refused.
pub const SUPPORTED_EXTENSIONS: &[&str] = &[
    // Its channels are read by super::pointer (a pointer to a property refrakt does not
    // animate is warned of, and the property keeps its value).
    "KHR_animation_pointer",
    "KHR_lights_punctual",
    "KHR_materials_clearcoat",
    "KHR_materials_emissive_strength",
    "KHR_materials_dispersion",
    "KHR_materials_ior",
    "KHR_materials_sheen",
    "KHR_materials_specular",
    "KHR_materials_transmission",
    "KHR_materials_variants",
    "KHR_materials_volume",
    // Quantized attributes are plain integer accessors, which the accessor reader converts.
    "KHR_mesh_quantization",
    "KHR_texture_transform",
    // Compressed bufferViews, decoded by meshoptimizer's own decoders (super::meshopt).
    "EXT_meshopt_compression",
    "KHR_meshopt_compression",
];

/// Required extensions refrakt cannot decode, with what to do about each: a tool that writes
/// the same scene without them.
pub const UNDECODABLE: &[(&str, &str)] = &[
    (
        "KHR_draco_mesh_compression",
        "its meshes are Draco-compressed, and no maintained Rust Draco decoder exists yet; decompress them first, e.g. \
         `gltf-transform copy in.glb out.glb` (glTF Transform drops Draco when copying) or re-export without Draco \
         (meshopt compression, `gltf-transform meshopt in.glb out.glb`, is read)",
    ),
    (
        "KHR_texture_basisu",
        "its textures are KTX2 / Basis Universal, which refrakt does not decode; convert them to PNG first, e.g. \
         `gltf-transform ktxdecompress in.glb out.glb`, or re-export with PNG or JPEG textures",
    ),
];

/// The chunks of a `.glb`: the JSON text and the binary buffer, if any.
pub struct Container<'a> {
    pub json: &'a [u8],
    pub bin: Option<&'a [u8]>,
}

const GLB_MAGIC: &[u8; 4] = b"glTF";
const CHUNK_JSON: u32 = 0x4E4F_534A;
const CHUNK_BIN: u32 = 0x004E_4942;

fn u32_at(bytes: &[u8], at: usize) -> Option<u32> {
    let b = bytes.get(at..at.checked_add(4)?)?;
    Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

/// Splits the file into its chunks. A file that does not start with the `.glb` magic is JSON
/// (a `.gltf`), unless its name says it is binary.
pub fn container<'a>(bytes: &'a [u8], file: &str, binary_by_name: bool) -> Result<Container<'a>> {
    if !bytes.starts_with(GLB_MAGIC) {
        if binary_by_name {
            let head: Vec<String> = bytes.iter().take(4).map(|b| format!("{b:02x}")).collect();
            bail!(
                "{file}: not a binary glTF file: it starts with bytes [{}] instead of \"glTF\" (is it a .gltf JSON file, or \
                 damaged? re-export it)",
                head.join(" ")
            );
        }
        // A UTF-8 byte order mark is allowed before JSON text by some writers.
        return Ok(Container { json: bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes), bin: None });
    }
    split_glb(bytes).map_err(|m| anyhow!("{file}: {m}; the file is truncated or damaged, re-export it"))
}

/// §4.4: a 12-byte header (magic, version, total length), then chunks of (length, type, data);
/// the first chunk is JSON, an optional second one BIN; chunks of unknown types are skipped.
fn split_glb(bytes: &[u8]) -> Result<Container<'_>, String> {
    let (Some(version), Some(length)) = (u32_at(bytes, 4), u32_at(bytes, 8)) else {
        return Err(format!("the binary glTF header needs 12 bytes, the file has {}", bytes.len()));
    };
    if version != 2 {
        return Err(format!("binary glTF version {version}; refrakt reads version 2"));
    }
    let length = length as usize;
    if length > bytes.len() {
        return Err(format!("the header says the file is {length} bytes long, but it has {}", bytes.len()));
    }
    let mut at = 12;
    let mut json = None;
    let mut bin = None;
    while at < length {
        let (Some(chunk_length), Some(kind)) = (u32_at(bytes, at), u32_at(bytes, at + 4)) else {
            return Err(format!("chunk header at byte {at} runs past the end of the file ({length} bytes)"));
        };
        let start = at + 8;
        let end = start.checked_add(chunk_length as usize).filter(|&e| e <= length).ok_or_else(|| {
            format!("the chunk at byte {at} claims {chunk_length} bytes, but only {} are left", length.saturating_sub(start))
        })?;
        let data = &bytes[start..end];
        match kind {
            CHUNK_JSON if json.is_none() && at == 12 => json = Some(data),
            CHUNK_BIN if json.is_some() && bin.is_none() => bin = Some(data),
            CHUNK_JSON | CHUNK_BIN => return Err(format!("unexpected {} chunk at byte {at}", if kind == CHUNK_JSON { "JSON" } else { "BIN" })),
            _ if json.is_none() => return Err("the first chunk must be the JSON chunk".into()),
            _ => {}
        }
        // Chunks start on 4-byte boundaries (their lengths are padded).
        at = end.next_multiple_of(4);
    }
    let json = json.ok_or("the file has no JSON chunk")?;
    Ok(Container { json, bin })
}

/// Parses and validates the JSON document.
pub fn parse(json_text: &[u8], file: &str) -> Result<gltf::Document> {
    let root: json::Root = json::deserialize::from_slice(json_text)
        .map_err(|e| anyhow!("{file}: the glTF JSON cannot be read: {e} (is the file complete? re-export it)"))?;
    check_version(&root, file)?;
    // Before validation: a required extension changes what the data means (a Draco mesh's
    // accessors have no bufferView, a KTX2 texture no source), which validation would report
    // as damage.
    check_required_extensions(&root.extensions_required, file)?;
    check_positions(&root, file)?;
    let mut errors = Vec::new();
    root.validate(&root, json::Path::new, &mut |path, error| {
        let path = path();
        // The crate refuses every required extension it does not parse itself; refrakt decides.
        if !path.as_str().starts_with("extensionsRequired") {
            errors.push(format!("{}: {}", path.as_str(), validation_text(&error)));
        }
    });
    if !errors.is_empty() {
        let more = if errors.len() > 3 { format!(" (and {} more)", errors.len() - 3) } else { String::new() };
        bail!("{file}: the glTF is invalid: {}{more}; fix or re-export the file", errors[..errors.len().min(3)].join("; "));
    }
    check_images(&root, file)?;
    check_channel_targets(&root, file)?;
    check_trees(&root, file)?;
    Ok(gltf::Document::from_json_without_validation(root))
}

/// The crate's validation looks up each POSITION accessor without checking its index (and
/// panics on a bad one), so refrakt checks those first.
fn check_positions(root: &json::Root, file: &str) -> Result<()> {
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            let position = prim.attributes.get(&json::validation::Checked::Valid(json::mesh::Semantic::Positions));
            if let Some(i) = position.filter(|i| i.value() >= root.accessors.len()) {
                bail!(
                    "{file}: the glTF is invalid: meshes[{m}].primitives[{p}].attributes[\"POSITION\"]: index out of range \
                     (accessor {} of {}); fix or re-export the file",
                    i.value(),
                    root.accessors.len()
                );
            }
        }
    }
    Ok(())
}

/// Each image names its data once — a `uri`, or a `bufferView` with its `mimeType` (glTF 2.0
/// §5.18) — which the crate's validation does not check and its image reader assumes (it
/// panics otherwise).
fn check_images(root: &json::Root, file: &str) -> Result<()> {
    for (i, image) in root.images.iter().enumerate() {
        let problem = match (&image.uri, &image.buffer_view, &image.mime_type) {
            (Some(_), Some(_), _) => Some("has both a uri and a bufferView"),
            (None, None, _) => Some("has neither a uri nor a bufferView"),
            (None, Some(_), None) => Some("has a bufferView but no mimeType"),
            _ => None,
        };
        if let Some(problem) = problem {
            bail!("{file}: the glTF is invalid: images[{i}] {problem}; fix or re-export the file");
        }
    }
    Ok(())
}

/// Each animation channel targets a node that exists and a property glTF animates — which the
/// crate's validation of animations skips and its channel reader assumes (it panics otherwise).
fn check_channel_targets(root: &json::Root, file: &str) -> Result<()> {
    for (a, animation) in root.animations.iter().enumerate() {
        for (c, channel) in animation.channels.iter().enumerate() {
            let at = format!("animations[{a}].channels[{c}].target");
            if channel.target.node.value() >= root.nodes.len() {
                bail!(
                    "{file}: the glTF is invalid: {at}.node: index out of range (node {} of {}); fix or re-export the file",
                    channel.target.node.value(),
                    root.nodes.len()
                );
            }
            if !matches!(channel.target.path, json::validation::Checked::Valid(_)) {
                bail!(
                    "{file}: the glTF is invalid: {at}.path is not one of translation, rotation, scale, weights \
                     or pointer (KHR_animation_pointer); fix or re-export the file"
                );
            }
        }
    }
    Ok(())
}

fn validation_text(e: &json::validation::Error) -> &'static str {
    use json::validation::Error::*;
    match e {
        IndexOutOfBounds => "index out of range",
        Invalid => "invalid value",
        Missing => "missing",
        Oversize => "size or offset too large",
        Unsupported => "not supported",
    }
}

fn check_version(root: &json::Root, file: &str) -> Result<()> {
    let major = root.asset.version.split('.').next().unwrap_or("");
    if major != "2" {
        bail!("{file}: asset.version is \"{}\"; refrakt reads glTF 2.x", root.asset.version);
    }
    Ok(())
}

/// §3.12: "If a required extension is not supported, the asset MUST NOT be loaded."
fn check_required_extensions(required: &[String], file: &str) -> Result<()> {
    for (extension, what_to_do) in UNDECODABLE {
        if required.iter().any(|e| e == extension) {
            bail!("{file}: the file requires the glTF extension {extension}: {what_to_do}");
        }
    }
    let unknown: Vec<&str> = required.iter().map(String::as_str).filter(|e| !SUPPORTED_EXTENSIONS.contains(e)).collect();
    if !unknown.is_empty() {
        bail!(
            "{file}: the file requires the glTF extension(s) {}, which refrakt does not support (it reads {}); export \
             without them",
            unknown.join(", "),
            SUPPORTED_EXTENSIONS.join(", ")
        );
    }
    Ok(())
}

/// Extensions used in the file that refrakt ignores, for a warning each.
pub fn ignored_extensions(doc: &gltf::Document) -> Vec<String> {
    doc.extensions_used().filter(|e| !SUPPORTED_EXTENSIONS.contains(e)).map(str::to_string).collect()
}

/// Deepest node hierarchy refrakt reads (every level is a step of recursion when the graph is
/// walked; real files stay far below it).
pub const MAX_DEPTH: usize = 1000;

/// Every node has at most one parent and no node is its own ancestor, so walking the hierarchy
/// ends; it is at most [`MAX_DEPTH`] deep; scene roots have no parent.
fn check_trees(root: &json::Root, file: &str) -> Result<()> {
    let n = root.nodes.len();
    let mut parent: Vec<Option<usize>> = vec![None; n];
    for (i, node) in root.nodes.iter().enumerate() {
        for child in node.children.iter().flatten() {
            let c = child.value();
            if let Some(p) = parent[c] {
                bail!("{file}: nodes[{c}] is a child of both nodes[{p}] and nodes[{i}]; a glTF node has one parent");
            }
            parent[c] = Some(i);
        }
    }
    // Depth of every node, each found once: walk up to a node of known depth (or a root), then
    // number the walk back down. A walk that meets itself is a cycle.
    const UNKNOWN: usize = usize::MAX;
    let mut depth = vec![UNKNOWN; n];
    let mut walked_from = vec![UNKNOWN; n];
    let mut walk = Vec::new();
    for start in 0..n {
        let mut at = start;
        while depth[at] == UNKNOWN {
            if walked_from[at] == start {
                bail!("{file}: nodes[{at}] is its own ancestor (a cycle in the node hierarchy)");
            }
            walked_from[at] = start;
            walk.push(at);
            match parent[at] {
                Some(p) => at = p,
                None => break,
            }
        }
        let mut d = if depth[at] == UNKNOWN { 0 } else { depth[at] + 1 };
        while let Some(i) = walk.pop() {
            if depth[i] == UNKNOWN {
                depth[i] = d;
                d += 1;
            }
        }
    }
    if let Some(deep) = (0..n).find(|&i| depth[i] >= MAX_DEPTH) {
        bail!("{file}: nodes[{deep}] is {} levels deep; refrakt reads hierarchies up to {MAX_DEPTH} levels", depth[deep] + 1);
    }
    for (s, scene) in root.scenes.iter().enumerate() {
        if let Some(node) = scene.nodes.iter().find(|i| parent[i.value()].is_some()) {
            bail!("{file}: scenes[{s}] lists nodes[{}] as a root, but it is another node's child", node.value());
        }
    }
    Ok(())
}
