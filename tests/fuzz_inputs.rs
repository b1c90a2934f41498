//! Property tests that fuzz what a user hands refrakt besides glTF (that is `gltf_input`):
//! environment images (EXR, HDR) and OBJ meshes mutated at random, and scripts made of random
//! calls of the Lua API with random field values. Every outcome must be Ok or a message — no
//! panic, no allocation sized by a lying header — and a script's error names the script.
//! Bounded for CI (256 cases each, fixed seed; see `common::fuzz::fuzz_config` for longer runs).

mod common;

use std::path::Path;

use common::fuzz::{fuzz_config, mutate, mutation};
use proptest::prelude::*;
use refrakt::lua::{Limits, ScriptHost};
use refrakt::output::{ExrCompression, Image, Layer};
use refrakt::scene::eval::{EvalOptions, evaluate};

fn exr_bytes(compression: ExrCompression) -> Vec<u8> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sky.exr");
    let data = (0..8 * 4 * 4).map(|i| (i % 7) as f32 * 0.25).collect();
    let image = Image { width: 8, height: 4, layers: vec![Layer::new("beauty", &["R", "G", "B", "A"], data)] };
    refrakt::output::exr::write(&image, &path, compression).unwrap();
    std::fs::read(path).unwrap()
}

fn hdr_bytes() -> Vec<u8> {
    let mut bytes = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 4 +X 8\n".to_vec();
    bytes.extend((0..32u8).flat_map(|i| [i * 7, 128, 255 - i, 128]));
    bytes
}

const OBJ: &str = "# a tetrahedron in two groups\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvt 0 0\nvt 1 0\nvn 0 0 1\n\
g one\nf 1/1/1 3/2/1 2/1/1\nf 1 2 4\ng two\nf 1 4 3\nf 2 3 4\n";

/// Loads `bytes` as an environment image named `name`: any outcome but a panic.
fn load_image(dir: &Path, name: &str, bytes: &[u8]) {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    if let Ok(image) = refrakt::scene::environment::load_image(&path) {
        let caps = refrakt::scene::image_header::ENVIRONMENT;
        assert!((image.width as u64) * (image.height as u64) <= caps.max_texels());
    }
}

/// Values a script might give a field: right and wrong types, edges, NaN and infinities.
const VALUES: &[&str] = &[
    "0", "1", "-1", "0.5", "1e30", "-1e30", "0/0", "1/0", "-1/0", "2^53", "3", "256", "1 << 40", "\"x\"", "\"\"", "true", "{}",
    "{1, 2}", "{1, 2, 3}", "{0/0, 0, 0}", "{1/0, 1, 1}", "{-1, 2, 0.5}", "{1, 2, 3, 4}", "{x = 1}", "r.sphere{ radius = 0.3 }",
    "r.glass{}", "function() end", "\"studio\"", "\"sky.exr\"", "\"mesh.obj\"", "{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}",
];

/// Constructors of the API and the fields each takes (plus a misspelt one).
const CALLS: &[(&str, &[&str])] = &[
    ("sphere", &["radius", "boundary"]),
    ("box", &["size", "boundary"]),
    ("luneburg", &["radius", "boundary"]),
    ("slab", &["size", "ior", "gradient", "boundary"]),
    ("plane", &["size"]),
    ("mesh", &["file", "vertices", "triangles", "boundary"]),
    ("glass", &["ior", "absorption", "color", "distance", "scattering", "g"]),
    ("diffuse", &["color"]),
    ("point", &["color", "intensity", "power"]),
    ("spot", &["color", "intensity", "angle", "blend", "target"]),
    ("sun", &["color", "intensity", "direction", "angular_diameter"]),
    ("rect", &["color", "intensity", "size", "target"]),
    ("camera", &["position", "target", "rotation", "up", "fov", "size"]),
    ("environment", &["color", "image", "preset", "intensity", "rotation", "visible"]),
    ("fog", &["density", "color", "scattering", "absorption", "g"]),
    ("node", &["name", "translation", "rotation", "scale", "visible", "colour"]),
];

/// One statement: a constructor call with some fields, added to the scene as what it is.
fn statement() -> impl Strategy<Value = String> {
    (0..CALLS.len(), proptest::collection::vec((any::<usize>(), any::<usize>()), 0..4), 0..4usize).prop_map(|(c, fields, role)| {
        let (name, known) = CALLS[c];
        let body: Vec<String> = fields.iter().map(|&(f, v)| format!("{} = {}", known[f % known.len()], VALUES[v % VALUES.len()])).collect();
        let call = format!("r.{name}{{ {} }}", body.join(", "));
        match (name, role) {
            ("camera", _) => format!("scene.camera = {call}"),
            ("environment", _) => format!("scene.environment = {call}"),
            ("fog", _) => format!("scene.fog = {call}"),
            ("node", _) => format!("scene:add({call})"),
            ("glass" | "diffuse", _) => format!("scene:add(r.node{{ shape = r.sphere{{ radius = 0.2 }}, material = {call} }})"),
            ("point" | "spot" | "sun" | "rect", _) => format!("scene:add(r.node{{ translation = {{0, 1, 0}}, light = {call} }})"),
            (_, 0) => format!("scene:add(r.node{{ shape = {call} }})"),
            _ => format!("scene:add(r.node{{ shape = {call}, material = r.glass{{}} }})"),
        }
    })
}

proptest! {
    #![proptest_config(fuzz_config())]

    #[test]
    fn mutated_exr_environments_never_panic(ms in proptest::collection::vec(mutation(), 1..6), zip in any::<bool>()) {
        let dir = tempfile::tempdir().unwrap();
        let base = exr_bytes(if zip { ExrCompression::Small } else { ExrCompression::Fast });
        load_image(dir.path(), "m.exr", &mutate(base, &ms));
    }

    #[test]
    fn mutated_hdr_environments_never_panic(ms in proptest::collection::vec(mutation(), 1..6)) {
        let dir = tempfile::tempdir().unwrap();
        load_image(dir.path(), "m.hdr", &mutate(hdr_bytes(), &ms));
    }

    #[test]
    fn mutated_obj_meshes_never_panic(ms in proptest::collection::vec(mutation(), 1..8)) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.obj");
        std::fs::write(&path, mutate(OBJ.as_bytes().to_vec(), &ms)).unwrap();
        if let Ok(mesh) = refrakt::scene::obj::load(&path) {
            prop_assert!(!mesh.triangles.is_empty());
        }
    }

    #[test]
    fn random_lua_api_calls_load_or_name_the_script(statements in proptest::collection::vec(statement(), 1..6)) {
        let dir = tempfile::tempdir().unwrap();
        let source = format!(
            "local r = require(\"refrakt\")\nlocal scene = r.scene{{ volume = {{ resolution = 16 }} }}\n{}\nreturn scene\n",
            statements.join("\n")
        );
        let path = dir.path().join("scene.lua");
        std::fs::write(&path, &source).unwrap();
        std::fs::write(dir.path().join("mesh.obj"), OBJ).unwrap();
        let limits = Limits { time_budget: std::time::Duration::from_secs(20), memory_bytes: 256 << 20 };
        // Errors of the script (its calls, their fields) name scene.lua:line; evaluating what
        // it built may fail with any message, but must not panic.
        match ScriptHost::load(&path, &[], &limits) {
            Ok(host) => {
                if let Err(e) = host.update(0.0) {
                    let message = format!("{e:#}");
                    prop_assert!(message.contains("scene.lua"), "{message}\n{source}");
                }
                let scene = host.scene().borrow();
                let _ = evaluate(&scene, 0.0, &EvalOptions { size: Some((8, 6)), ..Default::default() });
            }
            Err(e) => {
                let message = format!("{e:#}");
                prop_assert!(message.contains("scene.lua:"), "the error names the script's line: {message}\n{source}");
                prop_assert!(!message.contains("stack traceback"), "{message}");
            }
        }
    }
}
