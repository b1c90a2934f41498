//! Images whose headers lie: an environment `.exr`/`.hdr` or a glTF texture that declares more
//! texels than refrakt reads, or more than the file holds, is refused with one message naming
//! the file and the script line — before any pixel memory is allocated (the commands run under
//! a 512 MiB address-space limit, where the 640 GB or 2 GB a decoder would ask for fails).

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::gltf_builder::sample_scene;
use refrakt::output::{ExrCompression, Image, Layer};
use serde_json::json;

/// `refrakt dump FILE` (no GPU needed) under a 512 MiB address-space limit: (exit code, stderr).
fn dump_limited(path: &Path) -> (i32, String) {
    let out = Command::new("sh")
        .arg("-c")
        .arg("ulimit -v 524288 && exec \"$0\" dump \"$1\"")
        .arg(env!("CARGO_BIN_EXE_refrakt"))
        .arg(path)
        .output()
        .unwrap();
    (out.status.code().unwrap_or(-1), String::from_utf8_lossy(&out.stderr).into())
}

fn assert_refused(path: &Path, needles: &[&str]) {
    let (code, err) = dump_limited(path);
    assert_eq!(code, 1, "must fail cleanly: {err}");
    assert!(!err.contains("panicked") && !err.contains("internal error") && !err.contains("memory allocation"), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "one paragraph: {err}");
    for n in needles {
        assert!(err.contains(n), "stderr should contain {n:?}:\n{err}");
    }
}

/// A scene whose environment is `image`, next to it in `dir`.
fn scene_with_environment(dir: &Path, image: &str) -> PathBuf {
    let path = dir.join("scene.lua");
    let src = format!(
        "local r = require(\"refrakt\")\nlocal scene = r.scene{{}}\nscene.environment = r.environment{{ image = \"{image}\" }}\nreturn scene\n"
    );
    std::fs::write(&path, src).unwrap();
    path
}

/// An 8×4 EXR (uncompressed) whose `dataWindow` is then rewritten to (0, 0)–(`w`−1, `h`−1).
fn exr_claiming(w: i32, h: i32) -> Vec<u8> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("small.exr");
    let image = Image { width: 8, height: 4, layers: vec![Layer::new("beauty", &["R", "G", "B", "A"], vec![0.5; 8 * 4 * 4])] };
    refrakt::output::exr::write(&image, &path, ExrCompression::Fast).unwrap();
    let mut bytes = std::fs::read(&path).unwrap();
    let key = b"dataWindow\0box2i\0";
    let at = bytes.windows(key.len()).position(|w| w == key).expect("a dataWindow attribute") + key.len() + 4;
    for (i, v) in [0, 0, w - 1, h - 1].into_iter().enumerate() {
        bytes[at + 4 * i..at + 4 * i + 4].copy_from_slice(&v.to_le_bytes());
    }
    bytes
}

#[test]
fn an_exr_claiming_200000_squared_texels_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("sky.exr"), exr_claiming(200_000, 200_000)).unwrap();
    let scene = scene_with_environment(dir.path(), "sky.exr");
    assert_refused(&scene, &["scene.lua:3:", "sky.exr", "declares 200000×200000 texels", "at most 16384 a side", "downscale"]);
}

#[test]
fn a_short_exr_claiming_16k_is_refused_as_truncated() {
    let dir = tempfile::tempdir().unwrap();
    let bytes = exr_claiming(16384, 8192);
    assert!(bytes.len() < 2000, "a few hundred bytes: {}", bytes.len());
    std::fs::write(dir.path().join("sky.exr"), bytes).unwrap();
    let scene = scene_with_environment(dir.path(), "sky.exr");
    assert_refused(&scene, &["scene.lua:3:", "sky.exr", "too short for the pixels its header declares", "truncated"]);
}

#[test]
fn hdr_headers_are_checked_too() {
    let dir = tempfile::tempdir().unwrap();
    let header = |w: u64, h: u64| format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n").into_bytes();
    std::fs::write(dir.path().join("huge.hdr"), [header(200_000, 200_000), vec![1, 2, 3, 4]].concat()).unwrap();
    assert_refused(&scene_with_environment(dir.path(), "huge.hdr"), &["scene.lua:3:", "huge.hdr", "declares 200000×200000 texels"]);
    std::fs::write(dir.path().join("short.hdr"), [header(16384, 8192), vec![1, 2, 3, 4]].concat()).unwrap();
    assert_refused(&scene_with_environment(dir.path(), "short.hdr"), &["scene.lua:3:", "short.hdr", "too short"]);
    // A whole small image still loads.
    let mut pixels = header(4, 2);
    pixels.extend(std::iter::repeat_n([128u8, 128, 128, 128], 8).flatten());
    std::fs::write(dir.path().join("ok.hdr"), pixels).unwrap();
    let (code, err) = dump_limited(&scene_with_environment(dir.path(), "ok.hdr"));
    assert_eq!(code, 0, "{err}");
}

/// A JPEG whose frame header (SOF0) claims `w`×`h` (JPEG has no checksum to fix up).
fn jpeg_claiming(w: u16, h: u16) -> Vec<u8> {
    let img = image::RgbImage::from_pixel(8, 8, image::Rgb([200, 100, 50]));
    let mut bytes = Vec::new();
    image::DynamicImage::ImageRgb8(img).write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Jpeg).unwrap();
    let sof = bytes.windows(2).position(|m| m == [0xFF, 0xC0]).expect("a baseline JPEG");
    bytes[sof + 5..sof + 7].copy_from_slice(&h.to_be_bytes());
    bytes[sof + 7..sof + 9].copy_from_slice(&w.to_be_bytes());
    bytes
}

#[test]
fn a_gltf_texture_claiming_more_than_8192_a_side_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("big.jpg"), jpeg_claiming(60000, 60000)).unwrap();
    let mut g = sample_scene();
    g.json["images"][0] = json!({ "uri": "big.jpg" });
    let path = g.write_glb(&dir.path().join("textured.glb"));
    assert_refused(&path, &["textured.glb", "images[0]", "declares 60000×60000 texels", "at most 8192 a side"]);
}
