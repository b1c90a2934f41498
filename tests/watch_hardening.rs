//! `refrakt watch` where issue #16 found it wanting: which shaders a copied binary reads, a
//! shader error at startup, the message before any frame exists, and a GPU-limit error that
//! names the size the scene asks for.

mod common;

use std::path::Path;

use common::watch::*;

/// A copy of the binary outside the source tree reads the shaders embedded in it, not the
/// files of the tree it was built in (its `render` uses the embedded ones: they must agree).
#[test]
fn a_copied_binary_uses_its_embedded_shaders() {
    let bin_dir = tempfile::tempdir().unwrap();
    let copy = bin_dir.path().join("refrakt");
    std::fs::copy(env!("CARGO_BIN_EXE_refrakt"), &copy).unwrap();
    let dir = folder_with(&[("scene.lua", &ball("0.2, 0.3, 0.4"))]);
    let (scene, out) = (dir.path().join("scene.lua"), dir.path().join("preview.exr"));
    let mut w = Watch::start_bin(&copy, &scene, &out, &["--no-progressive"], &[]);
    w.frame();
    let watching = w.seen.iter().find(|e| e["event"] == "watching").expect("a watching event").clone();
    assert!(watching["shaders"].is_null(), "no shader folder for a copied binary: {watching}");
    assert!(!w.stderr.lock().unwrap().contains("the shaders in"), "{}", w.history());
    drop(w);

    // The binary cargo built inside the tree does watch the tree's shaders (when it is there).
    let built = Path::new(env!("CARGO_BIN_EXE_refrakt"));
    if refrakt::gpu::shaders::runs_from(built, Path::new(env!("CARGO_MANIFEST_DIR"))) {
        let mut w = Watch::start(&scene, &out, &["--no-progressive"]);
        w.frame();
        let watching = w.seen.iter().find(|e| e["event"] == "watching").unwrap().clone();
        assert!(watching["shaders"].as_str().is_some_and(|d| d.ends_with("shaders")), "{watching}");
    }
}

/// A WGSL error in the edited shaders at startup is reported, and watch renders with the
/// embedded shaders until a save fixes them.
#[test]
fn a_shader_error_at_startup_falls_back_to_the_embedded_shaders() {
    let shaders = tempfile::tempdir().unwrap();
    copy_tree(&Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders"), shaders.path());
    let view = shaders.path().join("view.wgsl");
    let text = std::fs::read_to_string(&view).unwrap();
    let broken = format!("{text}\nfn broken( {{\n");
    std::fs::write(&view, &broken).unwrap();
    let dir = folder_with(&[("scene.lua", &ball("0.2, 0.3, 0.4"))]);
    let (scene, out) = (dir.path().join("scene.lua"), dir.path().join("preview.exr"));
    let mut w = Watch::start_with(&scene, &out, &["--no-progressive"], &[("REFRAKT_SHADERS", shaders.path())]);
    let error = w.error();
    let message = error["message"].as_str().unwrap();
    assert!(message.contains("shaders/view.wgsl:") && message.contains("starts with the shaders built into it"), "{message}");
    w.frame();
    assert_color(&out, [0.2, 0.3, 0.4]);
    save_by_rename(&view, &text);
    let reloaded = w.frame();
    assert_eq!(reloaded["stats"]["shader_reloads"], 1, "{reloaded}");
}

/// Before the first frame there is no last good frame to keep, and the message says so.
#[test]
fn an_error_before_any_frame_does_not_promise_a_last_good_frame() {
    let dir = folder_with(&[("scene.lua", &ball("0.2, 0.3, 0.4").replace("samples = 1", "samples = = 1"))]);
    let (scene, out) = (dir.path().join("scene.lua"), dir.path().join("preview.exr"));
    let mut w = Watch::start(&scene, &out, &["--no-progressive"]);
    w.error();
    let stderr = w.stderr_once_it_says("no frame is shown yet");
    assert!(stderr.contains("no frame is shown yet") && !stderr.contains("keeps the last good frame"), "{stderr}");
    save_by_rename(&scene, &ball("0.2, 0.3, 0.4"));
    w.frame();
    save_by_rename(&scene, &ball("0.2, 0.3, 0.4").replace("samples = 1", "samples = = 1"));
    w.error();
    let stderr = w.stderr_once_it_says("the preview keeps the last good frame");
    assert!(stderr.contains("the preview keeps the last good frame"), "{}", w.history());
}

/// A volume beyond the adapter at the script's resolution, and at half of it (the fast frame's):
/// the error names the script's size.
#[test]
fn a_gpu_limit_error_names_the_scenes_size_not_the_fast_frames() {
    let ctx = refrakt::gpu::GpuContext::new(None).unwrap();
    let binding = ctx.limits.max_storage_buffer_binding_size.min(ctx.limits.max_buffer_size);
    let fits = |n: u32| refrakt::pipeline::resources::Grids::largest_binding(glam::UVec3::splat(n)) <= binding;
    let Some(n) = (16..=1024).find(|&n| !fits(n)) else {
        eprintln!("this adapter binds every volume up to 1024³; nothing to refuse here");
        return;
    };
    let full = 2 * n;
    let src = format!(
        "local r = require(\"refrakt\")\nlocal scene = r.scene{{ camera = r.camera{{ size = {{16, 12}} }}, \
         volume = {{ resolution = {full}, min = {{-1, -1, -1}}, max = {{1, 1, 1}} }} }}\n\
         scene:add(r.node{{ shape = r.luneburg{{ radius = 0.5 }} }})\nreturn scene\n"
    );
    let dir = folder_with(&[("scene.lua", &src)]);
    let (scene, out) = (dir.path().join("scene.lua"), dir.path().join("preview.exr"));
    let mut w = Watch::start(&scene, &out, &["--fast-frame-over", "0"]);
    let message = w.error()["message"].as_str().unwrap().to_string();
    assert!(message.contains(&format!("{full}×{full}×{full}")), "names the scene's {full}³: {message}");
    assert!(!message.contains(&format!("{n}×{n}×{n}")), "not the fast frame's {n}³: {message}");
}

/// Five saves 1 ms apart, at the default debounce: one frame, of the last save (docs/live.md
/// promises one per burst). And a save that truncates the file, then writes it, is not
/// reported as the error of the empty file in between.
#[test]
fn a_burst_of_saves_is_one_frame_at_the_default_debounce() {
    let dir = folder_with(&[("scene.lua", &ball("0.2, 0.3, 0.4"))]);
    let (scene, out) = (dir.path().join("scene.lua"), dir.path().join("preview.exr"));
    let default = refrakt::watch::DEFAULT_DEBOUNCE.as_millis().to_string();
    let mut w = Watch::start(&scene, &out, &["--no-progressive", "--debounce", &default]);
    w.frame();
    // A loaded machine can stretch a 1 ms sleep past the debounce, and then the saves are no
    // longer one burst: only bursts whose writes really came within 3 ms of each other count,
    // and all but one of those (a late wake-up of the watcher's own thread) must be one frame.
    let (mut bursts, mut single) = (0, 0);
    for round in 1..=4 {
        let mut gaps = Vec::new();
        let mut last = std::time::Instant::now();
        for i in 1..=5 {
            write(&scene, &ball(&format!("0.{round}{i}, 0.5, 0.5")));
            gaps.push(last.elapsed());
            last = std::time::Instant::now();
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
        w.frame();
        let mut frames = 1;
        let deadline = std::time::Instant::now() + QUIET;
        while let Ok(event) = w.events.recv_timeout(deadline.saturating_duration_since(std::time::Instant::now())) {
            frames += (event["event"] == "frame") as u32;
            w.seen.push(event);
        }
        assert_color(&out, [round as f32 / 10.0 + 0.05, 0.5, 0.5]);
        if gaps[1..].iter().all(|g| *g < std::time::Duration::from_millis(3)) {
            bursts += 1;
            single += (frames == 1) as u32;
        }
        eprintln!("burst {round}: gaps {gaps:?}, {frames} frame(s)");
    }
    assert!(bursts == 0 || single + 1 >= bursts.max(2), "{single} of {bursts} tight bursts were one frame\n{}", w.history());
    if bursts == 0 {
        eprintln!("no burst came within 3 ms on this loaded machine; nothing to judge");
    }
    for round in 1..=3 {
        // Truncate, pause as a slow writer would (longer than the debounce), then write.
        let file = std::fs::OpenOptions::new().write(true).truncate(true).open(&scene).unwrap();
        std::thread::sleep(std::time::Duration::from_millis(30));
        std::io::Write::write_all(&mut &file, ball(&format!("0.{round}, 0.1, 0.1")).as_bytes()).unwrap();
        drop(file);
        let event = w.next();
        assert_eq!(event["event"], "frame", "no error for the half-written file\n{}", w.history());
        assert_color(&out, [round as f32 / 10.0, 0.1, 0.1]);
    }
}
