//! `refrakt render --gpus`: one renderer per adapter, chunks of the range taken in turn, each
//! frame rendered and written once, the same files as one renderer writes; `--adapter` by
//! index. Without a GPU, lavapipe named twice (`--gpus 0,0`) stands in for two adapters.

use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;

/// A tiny animated lens (no photons: quick on lavapipe; the frames still differ over time).
/// 16 samples a pixel make its 24 frames take seconds on lavapipe, well past the spread in the
/// two renderers' start-up (opening the adapter, compiling the pipelines): with one sample the
/// frames took under a second, and the renderer that started first now and then took every
/// chunk before the other was ready, which the queue rightly allows.
const SCENE: &str = r#"local r = require("refrakt")
local scene = r.scene{
  camera = r.camera{ position = {0, 0, 3}, target = {0, 0, 0}, fov = 35, size = {32, 18} },
  volume = { resolution = 16 },
  photons = 0,
  samples = 16,
}
local lens = r.node{ shape = r.luneburg{ radius = 0.5 } }
scene:add(lens)
function update(scene, t)
  lens.translation = {0.4 * math.sin(3 * t), 0, 0}
end
return scene
"#;

fn refrakt(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_refrakt")).args(args).output().unwrap();
    (out.status.success(), String::from_utf8_lossy(&out.stdout).into_owned(), String::from_utf8_lossy(&out.stderr).into_owned())
}

fn files(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .map(|p| (p.file_name().unwrap().to_string_lossy().into_owned(), std::fs::read(&p).unwrap()))
        .collect()
}

#[test]
fn two_renderers_take_chunks_in_turn_and_write_each_frame_once() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("lens.lua");
    std::fs::write(&scene, SCENE).unwrap();
    let (one, two) = (dir.path().join("one"), dir.path().join("two"));
    let s = scene.to_str().unwrap();
    let (ok, _, err) = refrakt(&["render", s, "--frames", "0..23", "--out", one.to_str().unwrap(), "--format", "png", "--progress", "quiet"]);
    assert!(ok, "{err}");
    let (ok, out, err) = refrakt(&[
        "render", s, "--frames", "0..23", "--out", two.to_str().unwrap(), "--format", "png", "--progress", "json", "--gpus", "0,0",
        "--chunk", "2",
    ]);
    assert!(ok, "{err}");
    // frame -> the renderers that wrote it.
    let mut writers: BTreeMap<i64, Vec<u64>> = BTreeMap::new();
    for line in out.lines() {
        let event: serde_json::Value = serde_json::from_str(line).unwrap();
        if event["event"] == "frame" {
            let gpu = event["gpu"].as_u64().expect("frame events of --gpus name the renderer");
            writers.entry(event["frame"].as_i64().unwrap()).or_default().push(gpu);
        }
    }
    assert_eq!(writers.keys().copied().collect::<Vec<_>>(), (0..=23).collect::<Vec<_>>(), "every frame written");
    assert!(writers.values().all(|w| w.len() == 1), "each frame written once: {writers:?}");
    // Chunks of two consecutive frames stay on one renderer; both renderers took some.
    for k in (0..24).step_by(2) {
        assert_eq!(writers[&k], writers[&(k + 1)], "frames {k} and {} are one chunk: {writers:?}", k + 1);
    }
    let used: std::collections::BTreeSet<u64> = writers.values().flatten().copied().collect();
    assert_eq!(used, [0, 1].into(), "both renderers took chunks: {writers:?}");
    assert_eq!(files(&one), files(&two), "the same files as one renderer writes, byte for byte");
}

#[test]
fn adapters_are_chosen_by_index_and_bad_indices_are_refused() {
    let (ok, out, err) = refrakt(&["info", "--adapter", "0"]);
    assert!(ok, "{err}");
    assert!(out.contains("adapter 0 of"), "chosen by index: {out}");
    let (ok, _, err) = refrakt(&["info", "--adapter", "57"]);
    assert!(!ok && err.contains("usable adapters: 0:") && !err.contains("panicked"), "{err}");
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("lens.lua");
    std::fs::write(&scene, SCENE).unwrap();
    let (ok, _, err) = refrakt(&["render", scene.to_str().unwrap(), "--frames", "0..1", "--gpus", "0,9"]);
    assert!(!ok && err.contains("\"9\" is not the index of a usable adapter"), "{err}");
    let (ok, _, err) = refrakt(&["render", scene.to_str().unwrap(), "--gpus", "0"]);
    assert!(!ok && err.contains("--frames"), "--gpus needs a frame range: {err}");
}
