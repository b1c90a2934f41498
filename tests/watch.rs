//! `refrakt watch`, driven as a user drives it: the real binary with `--progress json`, a tiny
//! scene in a temporary folder, edits saved to disk the ways editors save them. Waits are for
//! events (with generous timeouts for a loaded CI machine on lavapipe), and "nothing happens" is
//! checked over the debounce time plus a margin. Speed is never asserted.
//!
//! Also, in-process: a frame that reuses the volume and photons of the frame before is the same,
//! byte for byte, as a frame rendered from scratch, and only what changed is redone.

mod common;

use std::path::Path;
use std::time::Duration;

use serde_json::Value;

use common::watch::*;
use common::{frame_from_lua, renderer};
use refrakt::output::Image;

#[test]
fn each_save_renders_once_and_shows_the_edit() {
    let dir = folder_with(&[("scene.lua", &ball("0.2, 0.3, 0.4"))]);
    let (scene, out) = (dir.path().join("scene.lua"), dir.path().join("preview.exr"));
    let mut w = Watch::start(&scene, &out, &["--no-progressive"]);
    let first = w.frame();
    assert_eq!(first["quality"], "final");
    assert_eq!(first["files"][0], out.to_str().unwrap());
    assert_color(&out, [0.2, 0.3, 0.4]);
    w.quiet("nothing was edited");

    write(&scene, &ball("0.9, 0.1, 0.1"));
    w.frame();
    w.quiet("one write is one render");
    assert_color(&out, [0.9, 0.1, 0.1]);

    save_by_rename(&scene, &ball("0.1, 0.8, 0.1"));
    w.frame();
    w.quiet("a save by rename is one render");
    assert_color(&out, [0.1, 0.8, 0.1]);

    // A burst of writes, the last one winning: one render, of the last.
    for i in 1..=10 {
        write(&scene, &ball(&format!("0.{i:02}, 0.5, 0.5")));
    }
    w.frame();
    w.quiet("a burst of writes is one render");
    assert_color(&out, [0.1, 0.5, 0.5]);
}

#[test]
fn an_error_keeps_the_last_good_frame_until_it_is_fixed() {
    let dir = folder_with(&[("scene.lua", &ball("0.2, 0.3, 0.4"))]);
    let (scene, out) = (dir.path().join("scene.lua"), dir.path().join("preview.exr"));
    let mut w = Watch::start(&scene, &out, &["--no-progressive"]);
    w.frame();
    let good = std::fs::read(&out).unwrap();

    // A syntax error on line 6, which the message must name.
    save_by_rename(&scene, &ball("0.9, 0.1, 0.1").replace("samples = 1", "samples = = 1"));
    let error = w.error();
    let message = error["message"].as_str().unwrap();
    assert!(message.contains("scene.lua:6:"), "the message names file:line: {message}");
    w.quiet("an error renders nothing");
    assert_eq!(std::fs::read(&out).unwrap(), good, "the preview keeps the last good frame");

    // A runtime error too (a field of the wrong type), then the fix.
    save_by_rename(&scene, &ball("0.9, 0.1, 0.1").replace("radius = 0.4", "radius = \"big\""));
    let message = w.error()["message"].as_str().unwrap().to_string();
    assert!(message.contains("scene.lua:8:") && message.contains("radius"), "{message}");
    assert_eq!(std::fs::read(&out).unwrap(), good);

    save_by_rename(&scene, &ball("0.9, 0.1, 0.1"));
    w.frame();
    assert_color(&out, [0.9, 0.1, 0.1]);
}

/// The scene reads a module, an OBJ mesh and an environment image; each is watched, and a file
/// beside them that it does not read is not.
#[test]
fn modules_and_assets_are_watched_other_files_are_not() {
    let scene_src = r#"local r = require("refrakt")
local look = require("lib.look")
local scene = r.scene{
  camera = r.camera{ position = {0, 0, 3}, target = {0, 0, 0}, fov = 35, size = {32, 24} },
  environment = r.environment{ image = "sky.exr", intensity = look.intensity },
  volume = { resolution = 20 },
  samples = 1,
}
scene:add(r.node{ name = "gem", scale = 0.5, shape = r.mesh{ file = "gem.obj" }, material = r.glass{ ior = 1.5 } })
return scene
"#;
    let gem = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";
    let dir = folder_with(&[("scene.lua", scene_src), ("lib/look.lua", "return { intensity = 1.0 }\n"), ("gem.obj", gem), ("notes.txt", "")]);
    let sky = dir.path().join("sky.exr");
    let write_sky = |rgb: [f32; 3]| {
        let data = (0..8 * 4).flat_map(|_| [rgb[0], rgb[1], rgb[2], 1.0]).collect();
        let image = Image { width: 8, height: 4, layers: vec![refrakt::output::Layer::new("beauty", &["R", "G", "B", "A"], data)] };
        refrakt::output::write(&image, refrakt::output::Format::Exr, &sky, &Default::default()).unwrap();
    };
    write_sky([0.25, 0.5, 0.75]);
    let (scene, out) = (dir.path().join("scene.lua"), dir.path().join("preview.exr"));
    let mut w = Watch::start(&scene, &out, &["--no-progressive"]);
    let first = w.frame();
    assert_color(&out, [0.25, 0.5, 0.75]);
    let watched = w.watched();
    for name in ["scene.lua", "look.lua", "gem.obj", "sky.exr"] {
        assert!(watched.iter().any(|f| f.ends_with(name)), "{name} is watched: {watched:?}");
    }
    assert!(!watched.iter().any(|f| f.ends_with("notes.txt")), "{watched:?}");

    save_by_rename(&dir.path().join("lib/look.lua"), "return { intensity = 2.0 }\n");
    w.frame();
    assert_color(&out, [0.5, 1.0, 1.5]);

    write_sky([0.1, 0.2, 0.3]);
    w.frame();
    assert_color(&out, [0.2, 0.4, 0.6]);

    let voxelized = |e: &Value| e["stats"]["meshes_voxelized"].as_u64().unwrap();
    let before = voxelized(&first);
    write(&dir.path().join("gem.obj"), &gem.replace("v 0 0 1", "v 0 0 0.5"));
    let frame = w.frame();
    assert!(voxelized(&frame) > before, "the edited mesh is voxelized again: {frame}");

    write(&dir.path().join("notes.txt"), "an unrelated edit");
    std::fs::write(dir.path().join("other.lua"), "return 1").unwrap();
    w.quiet("files the scene does not read are not watched");
}

#[test]
fn a_missing_asset_is_reported_and_rendered_once_it_appears() {
    let scene_src = r#"local r = require("refrakt")
local scene = r.scene{ camera = r.camera{ size = {32, 24} }, volume = { resolution = 20 }, samples = 1 }
scene:add(r.node{ name = "gem", shape = r.mesh{ file = "gem.obj" }, material = r.glass{ ior = 1.5 } })
return scene
"#;
    let dir = folder_with(&[("scene.lua", scene_src)]);
    let (scene, out) = (dir.path().join("scene.lua"), dir.path().join("preview.exr"));
    let mut w = Watch::start(&scene, &out, &["--no-progressive"]);
    let message = w.error()["message"].as_str().unwrap().to_string();
    assert!(message.contains("scene.lua:3:") && message.contains("gem.obj"), "{message}");
    assert!(!out.exists());
    write(&dir.path().join("gem.obj"), "v 0 0 0\nv 0.5 0 0\nv 0 0.5 0\nv 0 0 0.5\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n");
    w.frame();
    assert!(out.exists());
}

/// A camera move neither voxelizes nor traces photons again (the volume and the light in it do
/// not depend on the view); the image still moves with the camera.
#[test]
fn a_camera_move_reuses_the_volume_and_the_photons() {
    let lit = |camera_x: &str| {
        format!(
            r#"local r = require("refrakt")
local scene = r.scene{{
  camera = r.camera{{ position = {{{camera_x}, 1, 3}}, target = {{0, 0, 0}}, fov = 35, size = {{32, 24}} }},
  environment = r.environment{{ color = {{0.1, 0.1, 0.1}} }},
  volume = {{ resolution = 20 }},
  photons = 2000,
  samples = 2,
}}
scene:add(r.node{{ name = "ball", shape = r.sphere{{ radius = 0.3 }}, material = r.glass{{ ior = 1.5 }} }})
scene:add(r.node{{ name = "floor", translation = {{0, -0.4, 0}}, shape = r.plane{{ size = {{2, 2}} }},
                  material = r.diffuse{{ color = {{0.8, 0.8, 0.8}} }} }})
scene:add(r.node{{ name = "sun", light = r.sun{{ direction = {{0, -1, 0}}, intensity = 2000 }} }})
return scene
"#
        )
    };
    let dir = folder_with(&[("scene.lua", &lit("0"))]);
    let (scene, out) = (dir.path().join("scene.lua"), dir.path().join("preview.exr"));
    // Progressive, with the fast frame always shown: the fast frame of a camera move keeps the
    // full volume.
    let mut w = Watch::start(&scene, &out, &["--fast-frame-over", "0"]);
    let before = w.final_frame();
    let first_image = std::fs::read(&out).unwrap();
    save_by_rename(&scene, &lit("0.5"));
    let fast = w.frame();
    assert_eq!(fast["quality"], "preview", "samples = 2: a 1-sample frame comes first");
    let after = w.final_frame();
    let stat = |e: &Value, k: &str| e["stats"][k].as_u64().unwrap();
    for e in [&fast, &after] {
        assert_eq!(stat(e, "volume_builds"), stat(&before, "volume_builds"), "no voxelization for a camera move: {e}");
        assert_eq!(stat(e, "photon_traces"), stat(&before, "photon_traces"), "no photons for a camera move: {e}");
        assert_eq!(e["stats"]["reused"]["volume"], true);
        assert_eq!(e["stats"]["reused"]["photons"], true);
    }
    assert!(stat(&before, "photon_traces") >= 1, "the scene traces photons: {before}");
    assert_ne!(std::fs::read(&out).unwrap(), first_image, "the view moved");

    // Moving the light traces photons again, on the same volume.
    save_by_rename(&scene, &lit("0.5").replace("direction = {0, -1, 0}", "direction = {0.3, -1, 0}"));
    let relit = w.final_frame();
    assert_eq!(stat(&relit, "volume_builds"), stat(&before, "volume_builds"));
    assert!(stat(&relit, "photon_traces") > stat(&before, "photon_traces"));
}

#[test]
fn a_shader_error_keeps_the_old_pipelines() {
    let shaders = tempfile::tempdir().unwrap();
    let source = Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
    copy_tree(&source, shaders.path());
    let dir = folder_with(&[("scene.lua", &ball("0.2, 0.3, 0.4"))]);
    let (scene, out) = (dir.path().join("scene.lua"), dir.path().join("preview.exr"));
    let mut w = Watch::start_with(&scene, &out, &["--no-progressive"], &[("REFRAKT_SHADERS", shaders.path())]);
    w.frame();
    let good = std::fs::read(&out).unwrap();
    let view = shaders.path().join("view.wgsl");
    let text = std::fs::read_to_string(&view).unwrap();
    let broken = format!("{text}\nfn broken( {{\n");
    let line = broken.lines().position(|l| l.starts_with("fn broken")).unwrap() + 1;
    save_by_rename(&view, &broken);
    let message = w.error()["message"].as_str().unwrap().to_string();
    assert!(message.contains(&format!("shaders/view.wgsl:{line}")), "the error names the shader's file:line {line}: {message}");
    assert_eq!(std::fs::read(&out).unwrap(), good);

    // The old pipelines still render a scene edit.
    save_by_rename(&scene, &ball("0.9, 0.1, 0.1"));
    w.frame();
    assert_color(&out, [0.9, 0.1, 0.1]);

    save_by_rename(&view, &text);
    let reloaded = w.frame();
    assert_eq!(reloaded["stats"]["shader_reloads"], 1, "{reloaded}");
}

#[test]
fn a_loop_renders_the_range_round_and_round() {
    let animated = ball("0.2, 0.3, 0.4").replace("return scene", "function update(scene, t)\n  scene.environment = r.environment{ color = {t, 0, 0} }\nend\nreturn scene");
    let dir = folder_with(&[("scene.lua", &animated)]);
    let (scene, out) = (dir.path().join("scene.lua"), dir.path().join("preview.exr"));
    let mut w = Watch::start(&scene, &out, &["--frames", "1..3", "--loop", "--fps", "10"]);
    let frames: Vec<Value> = (0..5).map(|_| w.frame()).collect();
    let numbers: Vec<i64> = frames.iter().map(|e| e["frame"].as_i64().unwrap()).collect();
    assert_eq!(numbers, [1, 2, 3, 1, 2], "{frames:?}");
    assert_eq!(frames[1]["time"], 0.2);
    assert_eq!((frames[2]["done"].as_u64(), frames[2]["total"].as_u64()), (Some(3), Some(3)));
    assert!(frames.iter().all(|e| e["quality"] == "final"));
}

#[test]
fn frame_k_is_the_scene_at_k_over_fps() {
    let animated = ball("0.2, 0.3, 0.4").replace("return scene", "function update(scene, t)\n  scene.environment = r.environment{ color = {t, 0, 0} }\nend\nreturn scene");
    let dir = folder_with(&[("scene.lua", &animated)]);
    let (scene, out) = (dir.path().join("scene.lua"), dir.path().join("preview.exr"));
    let mut w = Watch::start(&scene, &out, &["--frame", "12", "--fps", "24"]);
    let e = w.final_frame();
    assert_eq!((e["frame"].as_i64(), e["time"].as_f64()), (Some(12), Some(0.5)));
    assert_color(&out, [0.5, 0.0, 0.0]);
}

#[cfg(unix)]
#[test]
fn sigterm_stops_cleanly_leaving_no_temporary_files() {
    let dir = folder_with(&[("scene.lua", &ball("0.2, 0.3, 0.4"))]);
    let (scene, out) = (dir.path().join("scene.lua"), dir.path().join("preview.exr"));
    let mut w = Watch::start(&scene, &out, &[]);
    w.final_frame();
    // Stop it while it takes an edit (it may be debouncing, rendering or writing by now).
    save_by_rename(&scene, &ball("0.9, 0.1, 0.1"));
    std::thread::sleep(Duration::from_millis(DEBOUNCE_MS));
    assert_eq!(w.terminate(), 130, "{}", w.history());
    assert_eq!(temporaries(dir.path()), Vec::<String>::new());
    refrakt::output::exr::read(&out).expect("the preview is a whole file");
    // The output ends with a done event (read to the end of the pipe).
    while let Ok(event) = w.events.recv_timeout(PATIENCE) {
        w.seen.push(event);
    }
    assert_eq!(w.seen.last().unwrap()["event"], "done", "{}", w.history());
}

/// Bit patterns of every layer, so that even NaNs compare.
fn bits(image: &Image) -> Vec<Vec<u32>> {
    image.layers.iter().map(|l| l.data.iter().map(|v| v.to_bits()).collect()).collect()
}

/// A glass ball over a floor under the sun, with caustics, seen from `camera`.
fn lit_scene(camera: &str, sun: &str, ior: &str) -> String {
    format!(
        r#"local r = require("refrakt")
local scene = r.scene{{
  camera = r.camera{{ position = {{{camera}}}, target = {{0, 0, 0}}, fov = 35, size = {{40, 30}} }},
  environment = r.environment{{ color = {{0.1, 0.1, 0.1}} }},
  volume = {{ resolution = 24 }},
  photons = 3000,
  samples = 1,
}}
scene:add(r.node{{ name = "ball", shape = r.sphere{{ radius = 0.3 }}, material = r.glass{{ ior = {ior}, absorption = {{0.5, 0.2, 0}} }} }})
scene:add(r.node{{ name = "gem", translation = {{0.4, 0, 0}}, shape = r.icosphere{{ radius = 0.15, subdivisions = 1 }},
                  material = r.glass{{ ior = 1.4 }} }})
scene:add(r.node{{ name = "floor", translation = {{0, -0.4, 0}}, shape = r.plane{{ size = {{2, 2}} }},
                  material = r.diffuse{{ color = {{0.8, 0.8, 0.8}} }} }})
scene:add(r.node{{ name = "sun", light = r.sun{{ direction = {{{sun}}}, intensity = 2000 }} }})
return scene
"#
    )
}

#[test]
fn a_frame_from_cached_stages_equals_a_full_render_byte_for_byte() {
    // Two evaluations of the scene, as two loads of an edited script give: nothing shared.
    let a = frame_from_lua(&lit_scene("0, 1, 3", "0, -1, 0", "1.5"));
    let b = frame_from_lua(&lit_scene("0.6, 0.8, 3", "0, -1, 0", "1.5"));
    let mut r = renderer();
    let image_a = r.frame(&a).unwrap();
    let cached = r.frame(&b).unwrap();
    assert_eq!((r.counters.volume_builds, r.counters.photon_traces), (1, 1), "{:?}", r.counters);
    assert_eq!((r.counters.volumes_reused, r.counters.photons_reused), (1, 1), "{:?}", r.counters);
    let full = renderer().frame(&b).unwrap();
    assert!(bits(&cached) == bits(&full), "a frame that reuses the volume and photons is the full render");
    assert!(bits(&image_a) != bits(&cached), "the camera moved, so the image did");
    assert!(r.photon_stats().is_some(), "the reused photons' statistics stand");
}

#[test]
fn only_what_changed_is_redone() {
    let mut r = renderer();
    let base = frame_from_lua(&lit_scene("0, 1, 3", "0, -1, 0", "1.5"));
    r.frame(&base).unwrap();
    let counts = |r: &refrakt::pipeline::Renderer| (r.counters.volume_builds, r.counters.photon_traces, r.counters.meshes_voxelized);
    assert_eq!(counts(&r), (1, 1, 1));

    // The light moves: photons again, on the same volume. (Each frame shares what is unchanged
    // with the one before, as `refrakt watch` does after a reload.)
    let mut relit = frame_from_lua(&lit_scene("0, 1, 3", "0.2, -1, 0", "1.5"));
    relit.share_unchanged(&base);
    let cached = r.frame(&relit).unwrap();
    assert_eq!(counts(&r), (1, 2, 1));
    assert!(bits(&cached) == bits(&renderer().frame(&relit).unwrap()), "same as from scratch");

    // A new photon budget: photons again, nothing recompiled.
    let mut more = relit.clone();
    more.photons = 6000;
    r.frame(&more).unwrap();
    assert_eq!(counts(&r), (1, 3, 1));
    assert_eq!(r.counters.shader_reloads, 0);

    // A render setting the photons depend on.
    r.settings.caustic_filter = refrakt::pipeline::caustics::CausticFilter::Fixed { radius: 2 };
    r.frame(&more).unwrap();
    assert_eq!(counts(&r), (1, 4, 1));

    // The ball's index: the volume again (the unchanged mesh shared from the last frame keeps
    // its solid), and photons through it.
    let mut glass = frame_from_lua(&lit_scene("0, 1, 3", "0.2, -1, 0", "1.6"));
    glass.photons = 6000;
    glass.share_unchanged(&more);
    r.frame(&glass).unwrap();
    assert_eq!(counts(&r), (2, 5, 1), "{:?}", r.counters);
    assert_eq!(r.counters.meshes_reused, 1);

    // New pipelines: nothing of the old ones' results is reused.
    r.reload_shaders().unwrap();
    r.frame(&glass).unwrap();
    assert_eq!(counts(&r).0, 3);
    assert_eq!(counts(&r).1, 6);
    assert_eq!(r.counters.shader_reloads, 1);

    // With reuse off (benchmarks), every stage runs.
    r.settings.reuse_unchanged = false;
    r.frame(&glass).unwrap();
    assert_eq!(counts(&r).0, 4);
}


/// The fast frame comes first only while full frames are slow: after the first frame (always
/// preceded by a fast one), a full frame that took less than `--fast-frame-over` comes alone.
#[test]
fn a_fast_frame_comes_first_only_while_full_frames_are_slow() {
    let two_samples = |env: &str| ball(env).replace("samples = 1", "samples = 2");
    let dir = folder_with(&[("scene.lua", &two_samples("0.2, 0.3, 0.4"))]);
    let (scene, out) = (dir.path().join("scene.lua"), dir.path().join("preview.exr"));
    // Every full frame counts as quick: an hour.
    let mut w = Watch::start(&scene, &out, &["--fast-frame-over", "3600000"]);
    assert_eq!(w.frame()["quality"], "preview", "the first frame has no full frame to go by");
    // (Until a full frame is done, every frame is a fast one first: a late event of the scene's
    // creation, on a loaded machine, may start a second before it.)
    w.final_frame();
    save_by_rename(&scene, &two_samples("0.9, 0.3, 0.4"));
    assert_eq!(w.frame()["quality"], "final", "a quick full frame comes without a fast one: {}", w.history());
    // And with every full frame counting as slow (0 ms), each edit gets its fast frame.
    drop(w);
    let mut w = Watch::start(&scene, &out, &["--fast-frame-over", "0"]);
    w.final_frame();
    save_by_rename(&scene, &two_samples("0.2, 0.9, 0.4"));
    assert_eq!(w.frame()["quality"], "preview", "{}", w.history());
    assert_eq!(w.frame()["quality"], "final");
}

/// An EXR preview holds the beauty pass (quickest to read back and write), or every layer with
/// `--layers all`.
#[test]
fn the_preview_holds_the_layers_asked_for() {
    let dir = folder_with(&[("scene.lua", &ball("0.2, 0.3, 0.4"))]);
    let scene = dir.path().join("scene.lua");
    let layers = |extra: &[&str], name: &str| {
        let out = dir.path().join(name);
        let mut w = Watch::start(&scene, &out, extra);
        w.final_frame();
        let image = refrakt::output::exr::read(&out).unwrap();
        image.layers.iter().map(|l| l.name.clone()).collect::<Vec<_>>()
    };
    assert_eq!(layers(&[], "beauty.exr"), ["beauty"]);
    assert_eq!(layers(&["--layers", "all"], "all.exr"), ["beauty", "caustic", "depth", "direct", "indirect", "volume"]);
}

/// A glTF scene whose buffer file is missing is reported, and renders once the file appears:
/// the buffers and images a failed import looked for are watched like a script's assets.
#[test]
fn a_gltf_scene_renders_once_its_missing_buffer_appears() {
    let dir = tempfile::tempdir().unwrap();
    let (scene, out) = (dir.path().join("scene.gltf"), dir.path().join("preview.exr"));
    let sample = common::gltf_builder::sample_scene();
    sample.write_external(&scene, "scene.bin");
    let bin = std::fs::read(dir.path().join("scene.bin")).unwrap();
    std::fs::remove_file(dir.path().join("scene.bin")).unwrap();
    let mut w = Watch::start(&scene, &out, &["--no-progressive", "--size", "32x24", "--volume", "20", "--samples", "1"]);
    let message = w.error()["message"].as_str().unwrap().to_string();
    assert!(message.contains("scene.bin"), "{message}");
    assert!(!out.exists());
    std::fs::write(dir.path().join("scene.bin"), bin).unwrap();
    w.frame();
    assert!(out.exists());
}
