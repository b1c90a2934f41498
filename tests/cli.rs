//! The command line on bad input: a clear one-paragraph error naming file:line or the field,
//! a non-zero exit, never a panic.

mod common;

use std::process::Command;

use common::write_script;

fn refrakt(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_refrakt")).args(args).output().unwrap();
    (out.status.code().unwrap_or(-1), String::from_utf8_lossy(&out.stdout).into(), String::from_utf8_lossy(&out.stderr).into())
}

/// Renders `source` (as scene.lua) at a tiny size; returns (exit code, stderr).
fn render_script(source: &str, extra: &[&str]) -> (i32, String) {
    let (dir, path) = write_script("scene.lua", source);
    let out = dir.path().join("out");
    let mut args = vec!["render", path.to_str().unwrap(), "--out", out.to_str().unwrap(), "--size", "16x16", "--progress", "quiet"];
    args.extend_from_slice(extra);
    let (code, _, err) = refrakt(&args);
    (code, err)
}

fn assert_clean_failure(code: i32, err: &str, needles: &[&str]) {
    assert_ne!(code, 0, "must fail: {err}");
    assert!(!err.contains("panicked") && !err.contains("internal error"), "no panic: {err}");
    for n in needles {
        assert!(err.contains(n), "stderr should contain {n:?}:\n{err}");
    }
}

const HEADER: &str = "local r = require(\"refrakt\")\nlocal scene = r.scene{}\n";

#[test]
fn lua_syntax_error_names_file_and_line() {
    let (code, err) = render_script(&format!("{HEADER}local x = = 1\nreturn scene\n"), &[]);
    assert_clean_failure(code, &err, &["scene.lua:3:", "unexpected symbol"]);
}

#[test]
fn lua_runtime_error_names_file_and_line() {
    let (code, err) = render_script(&format!("{HEADER}local t = nil\nprint(t.x)\nreturn scene\n"), &[]);
    assert_clean_failure(code, &err, &["scene.lua:4:", "attempt to index"]);
}

#[test]
fn wrong_field_type_names_the_field() {
    let src = format!("{HEADER}scene:add(r.node{{ shape = r.sphere{{ radius = \"big\" }} }})\nreturn scene\n");
    let (code, err) = render_script(&src, &[]);
    assert_clean_failure(code, &err, &["scene.lua:3:", "sphere.radius must be a number > 0, got \"big\""]);
}

#[test]
fn misspelled_field_gets_a_suggestion() {
    let src = format!("{HEADER}scene:add(r.node{{ tranlsation = {{0, 1, 0}} }})\nreturn scene\n");
    let (code, err) = render_script(&src, &[]);
    assert_clean_failure(code, &err, &["scene.lua:3:", "did you mean translation?"]);
}

#[test]
fn nan_in_a_vector_is_refused() {
    let src = format!("{HEADER}scene:add(r.node{{ translation = {{0, 0/0, 0}} }})\nreturn scene\n");
    let (code, err) = render_script(&src, &[]);
    assert_clean_failure(code, &err, &["scene.lua:3:", "node.translation", "component y is nan"]);
}

#[test]
fn missing_scene_file_is_reported() {
    let (code, _, err) = refrakt(&["render", "/nonexistent/scene.lua", "--progress", "quiet"]);
    assert_clean_failure(code, &err, &["cannot read the scene script /nonexistent/scene.lua"]);
}

#[test]
fn missing_environment_image_is_reported() {
    let src = "local r = require(\"refrakt\")\nlocal scene = r.scene{\n  environment = r.environment{ image = \"sky.exr\" } }\nreturn scene\n";
    let (code, err) = render_script(src, &[]);
    assert_clean_failure(code, &err, &["scene.lua:3:", "cannot open \"sky.exr\""]);
}

#[test]
fn script_must_return_a_scene() {
    let (code, err) = render_script("local r = require(\"refrakt\")\n", &[]);
    assert_clean_failure(code, &err, &["scene.lua", "return scene"]);
}

#[test]
fn material_is_required_for_a_solid() {
    let src = format!("{HEADER}scene:add(r.node{{ name = \"ball\", shape = r.sphere{{ radius = 0.3 }} }})\nreturn scene\n");
    let (code, err) = render_script(&src, &[]);
    assert_clean_failure(code, &err, &["scene.lua:3:", "\"ball\" needs a material"]);
}

#[test]
fn volume_beyond_the_adapter_is_refused_before_allocating() {
    let src = format!("{HEADER}scene:add(r.node{{ shape = r.luneburg{{ radius = 0.5 }} }})\nreturn scene\n");
    let (code, err) = render_script(&src, &["--volume", "2048"]);
    assert_clean_failure(code, &err, &["lower the volume resolution"]);
}

/// The octree (16 bytes per cell over all levels) is the volume's largest buffer; a volume
/// whose octree outgrows what the adapter binds at once must be refused with the message, not
/// end in a GPU validation error. (On lavapipe, 128 MiB: about 205³.)
#[test]
fn volume_whose_octree_outgrows_one_binding_is_refused() {
    let ctx = refrakt::gpu::GpuContext::new(None).unwrap();
    let binding = ctx.limits.max_storage_buffer_binding_size.min(ctx.limits.max_buffer_size);
    let fits = |n: u32| refrakt::pipeline::resources::Grids::largest_binding(glam::UVec3::splat(n)) <= binding;
    let Some(n) = (64..=ctx.limits.max_texture_dimension_3d.min(2048)).find(|&n| !fits(n)) else {
        eprintln!("this adapter binds every volume its 3D textures allow; nothing to refuse here");
        return;
    };
    // A cube of side n voxels: a box-shaped volume fixed by the script.
    let src = format!(
        "local r = require(\"refrakt\")\nlocal scene = r.scene{{ volume = {{ resolution = {n}, min = {{-1, -1, -1}}, max = {{1, 1, 1}} }} }}\n\
         scene:add(r.node{{ shape = r.luneburg{{ radius = 0.5 }} }})\nreturn scene\n"
    );
    let (code, err) = render_script(&src, &[]);
    assert_clean_failure(code, &err, &["binds at once", "lower the volume resolution"]);
    assert!(!err.contains("Validation Error"), "{err}");
}

#[test]
fn bad_command_line_values_are_usage_errors() {
    let (code, _, err) = refrakt(&["render", "x.lua", "--size", "0x10"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("width and height must be from 1 to 16384"), "{err}");
    let (code, _, err) = refrakt(&["render", "x.lua", "--frames", "5..2"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("must not run backwards"), "{err}");
    for (region, says) in [("1,2,3", "is not a region like 0,0,512,288"), ("0,0,0,10", "width and height from 1")] {
        let (code, _, err) = refrakt(&["render", "x.lua", "--region", region]);
        assert_eq!(code, 2, "{err}");
        assert!(err.contains(says), "{region}: {err}");
    }
}

#[test]
fn info_names_the_adapter() {
    let (code, out, err) = refrakt(&["info"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("adapter:") && out.contains("chosen because"), "{out}");
    let (code, _, err) = refrakt(&["info", "--adapter", "no-such-gpu-anywhere"]);
    assert_clean_failure(code, &err, &["no adapter matches --adapter \"no-such-gpu-anywhere\""]);
}

/// An adapter that cannot bind what refrakt's passes bind — Mesa's GL drivers offer 16 storage
/// buffers a stage, the view binds `STORAGE_BUFFERS_PER_STAGE` — is refused by name, with the reason, when the adapters
/// are listed; it used to be chosen and fail mid-frame with "a bug in refrakt". (Where the
/// machine has no GL adapter, or one that can, this renders or names no adapter.)
#[test]
fn an_adapter_short_of_storage_buffers_is_refused_up_front() {
    let (dir, path) = write_script("scene.lua", &format!("{HEADER}return scene\n"));
    let out = dir.path().join("out");
    let args = ["render", path.to_str().unwrap(), "--out", out.to_str().unwrap(), "--size", "16x16", "--progress", "quiet"];
    let run = Command::new(env!("CARGO_BIN_EXE_refrakt")).args(args).env("WGPU_BACKEND", "gl").output().unwrap();
    let err = String::from_utf8_lossy(&run.stderr);
    if run.status.success() {
        return;
    }
    assert_clean_failure(run.status.code().unwrap_or(-1), &err, &[]);
    assert!(err.contains("no adapter refrakt can use") || err.contains("found no GPU adapter"), "{err}");
    assert!(!err.contains("a bug in refrakt"), "{err}");
    if err.contains("(Gl)") {
        let binds = format!("storage buffers per shader stage, and refrakt's view pass binds {}", refrakt::gpu::STORAGE_BUFFERS_PER_STAGE);
        assert!(err.contains(&binds), "{err}");
    }
}

#[test]
fn render_writes_whole_files_and_no_temporaries() {
    let src = format!("{HEADER}scene:add(r.node{{ shape = r.luneburg{{ radius = 0.5 }} }})\nreturn scene\n");
    let (dir, path) = write_script("lens.lua", &src);
    let out = dir.path().join("out");
    let (code, _, err) = refrakt(&["render", path.to_str().unwrap(), "--out", out.to_str().unwrap(), "--size", "24x16", "--progress", "lines"]);
    assert_eq!(code, 0, "{err}");
    let mut names: Vec<String> = std::fs::read_dir(&out).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into()).collect();
    names.sort();
    assert_eq!(names, ["lens.exr", "lens.png"]);
    let img = refrakt::output::exr::read(&out.join("lens.exr")).unwrap();
    assert_eq!((img.width, img.height), (24, 16));
    assert_eq!(img.layers[0].channels, ["R", "G", "B", "A"]);
    assert_eq!(img.layer("depth").unwrap().channels, ["Z"]);
    let png = image::open(out.join("lens.png")).unwrap();
    assert_eq!((png.width(), png.height()), (24, 16));
}

const LIT: &str = "local r = require(\"refrakt\")\nlocal scene = r.scene{ volume = { resolution = 24 } }\n\
scene:add(r.node{ shape = r.sphere{ radius = 0.3 }, material = r.glass{ ior = 1.5 } })\n\
scene:add(r.node{ name = \"floor\", translation = {0, -0.5, 0}, shape = r.plane{ size = {2, 2} }, material = r.diffuse{} })\n";

#[test]
fn negative_photon_budget_is_refused() {
    let (code, err) = render_script(&format!("{LIT}scene.photons = -5\nreturn scene\n"), &[]);
    assert_clean_failure(code, &err, &["scene.lua:5:", "scene.photons must be a whole number"]);
}

#[test]
fn zero_photons_render_without_caustics_and_say_so() {
    let src = format!("{LIT}scene:add(r.node{{ light = r.sun{{ direction = {{0, -1, 0}}, intensity = 683 }} }})\nscene.photons = 0\nreturn scene\n");
    let (code, err) = render_script(&src, &[]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("photons = 0: no caustics or light shafts"), "{err}");
}

#[test]
fn non_finite_light_intensity_is_refused() {
    for bad in ["1/0", "0/0", "-1"] {
        let src = format!("{LIT}scene:add(r.node{{ light = r.point{{ intensity = {bad} }} }})\nreturn scene\n");
        let (code, err) = render_script(&src, &[]);
        assert_clean_failure(code, &err, &["scene.lua:5:", "point.intensity must be"]);
    }
}

#[test]
fn a_light_inside_a_closed_receiver_is_pointed_out() {
    let src = format!(
        "{LIT}scene:add(r.node{{ name = \"crate\", translation = {{1, 0, 0}}, shape = r.box{{ size = {{0.5, 0.5, 0.5}} }}, material = r.diffuse{{}} }})\n\
         scene:add(r.node{{ name = \"bulb\", translation = {{1, 0, 0}}, light = r.point{{ intensity = 100 }} }})\nscene.photons = 2000\nreturn scene\n"
    );
    let (code, err) = render_script(&src, &[]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("light \"bulb\" is inside receiver \"crate\""), "{err}");
}

// Issue #16: what can be known wrong before rendering is reported before rendering, names stay
// inside --out, and count options say what they take.

/// A scene that would fail to load: an error about it means the command got that far.
const BROKEN: &str = "local x = = 1\n";

#[test]
fn out_that_is_a_file_is_refused_before_the_scene_loads() {
    let (dir, path) = write_script("scene.lua", BROKEN);
    let file = dir.path().join("taken");
    std::fs::write(&file, "not a folder").unwrap();
    for out in [file.clone(), file.join("sub")] {
        let (code, _, err) = refrakt(&["render", path.to_str().unwrap(), "--out", out.to_str().unwrap(), "--progress", "quiet"]);
        assert_clean_failure(code, &err, &["--out", "taken is a file, not a folder"]);
        assert!(!err.contains("unexpected symbol"), "checked before loading the scene: {err}");
    }
    // `watch` checks its preview's folder the same way, before the GPU starts.
    let (code, _, err) = refrakt(&["watch", path.to_str().unwrap(), "--out", file.join("p.exr").to_str().unwrap()]);
    assert_clean_failure(code, &err, &["taken is a file, not a folder"]);
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "not a folder");
}

#[test]
fn names_with_folders_empty_or_hidden_are_refused() {
    let (dir, path) = write_script("scene.lua", BROKEN);
    let out = dir.path().join("out");
    for (name, needle) in [
        ("../escape", "is not a plain file name"),
        ("a/b", "is not a plain file name"),
        ("a\\b", "is not a plain file name"),
        ("", "--name is empty"),
        (".hidden", "starts with a dot"),
    ] {
        let (code, _, err) = refrakt(&["render", path.to_str().unwrap(), "--out", out.to_str().unwrap(), "--name", name]);
        assert_clean_failure(code, &err, &[needle]);
        assert!(!err.contains("unexpected symbol"), "checked before loading the scene: {err}");
    }
    assert!(!dir.path().join("escape.exr").exists());
}

fn options(frames: Option<&str>, time: f64) -> refrakt::render::RenderOptions {
    let scene = refrakt::render::SceneOptions {
        fps: 24.0,
        eval: Default::default(),
        allow_read: vec![],
        limits: Default::default(),
        gltf: Default::default(),
        params: Default::default(),
    };
    refrakt::render::RenderOptions {
        frames: frames.map(|f| f.parse().unwrap()),
        time,
        out: "out".into(),
        name: None,
        formats: vec![refrakt::output::Format::Png],
        png: refrakt::output::png::PngOptions { exposure: 0.0, tonemap: refrakt::output::png::ToneMap::Neutral, alpha: false },
        skip_existing: false,
        progress: refrakt::progress::ProgressMode::Quiet,
        adapter: None,
        gpus: vec![],
        chunk: 1,
        scene,
        flow: Default::default(),
    }
}

fn file_name(opts: &refrakt::render::RenderOptions, frame: Option<i64>) -> String {
    let paths = refrakt::render::frame_paths(opts, "shot", frame);
    paths[0].1.file_name().unwrap().to_string_lossy().into()
}

#[test]
fn frame_numbers_are_padded_to_the_range_and_timed_stills_named_apart() {
    assert_eq!(file_name(&options(Some("1..48"), 0.0), Some(7)), "shot.0007.png");
    assert_eq!(file_name(&options(Some("9990..12000"), 0.0), Some(9990)), "shot.09990.png");
    assert_eq!(file_name(&options(Some("9990..12000"), 0.0), Some(12000)), "shot.12000.png");
    // Names of one range sort in frame order.
    let opts = options(Some("9998..10001"), 0.0);
    let names: Vec<String> = (9998..=10001).map(|k| file_name(&opts, Some(k))).collect();
    let mut sorted = names.clone();
    sorted.sort();
    assert_eq!(names, sorted);
    assert_eq!(file_name(&options(None, 0.0), None), "shot.png");
    assert_eq!(file_name(&options(None, 0.5), None), "shot.t0.5s.png");
    assert_eq!(file_name(&options(None, 1.25), None), "shot.t1.25s.png");
    assert_ne!(file_name(&options(None, 0.5), None), file_name(&options(None, 0.75), None));
}

#[test]
fn count_options_say_what_they_take() {
    let (code, _, err) = refrakt(&["render", "x.lua", "--photons", "-1"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("-1 is out of range: it must be a whole number from 0 to 1073741824"), "{err}");
    assert!(!err.contains("'-- -1'"), "no tip to pass -1 as a positional argument: {err}");
    let (code, _, err) = refrakt(&["render", "x.lua", "--size", "-5x10"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("width and height must be from 1 to 16384"), "{err}");
    assert!(!err.contains("'-- "), "{err}");
    let (code, _, err) = refrakt(&["render", "x.lua", "--samples", "1e9"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("1e9 is out of range: it must be a whole number from 1 to 256"), "{err}");
    assert!(!err.contains("invalid digit"), "{err}");
    let (code, _, err) = refrakt(&["render", "x.lua", "--volume", "big"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("\"big\" is not a whole number (from 8 to 2048)"), "{err}");
    // 1e5 is a whole number; --photons 0 is what scene.photons = 0 is (the script is missing).
    for photons in ["1e5", "0"] {
        let (code, _, err) = refrakt(&["dump", "/nonexistent/x.lua", "--photons", photons]);
        assert_eq!(code, 1, "{err}");
        assert!(err.contains("cannot read the scene script"), "{err}");
    }
}

#[test]
fn a_volume_box_inside_out_is_refused_at_its_line() {
    let src = "local r = require(\"refrakt\")\n\nlocal scene = r.scene{ volume = { resolution = 16, min = {1, -1, -1}, max = {-1, 1, 1} } }\nreturn scene\n";
    let (code, _, err) = {
        let (dir, path) = write_script("scene.lua", src);
        let r = refrakt(&["dump", path.to_str().unwrap()]);
        drop(dir);
        r
    };
    assert_clean_failure(code, &err, &["scene.lua:3:", "volume.max", "must be greater than volume.min"]);
    // Corners set one by one are checked when the frame is made, naming the last line that set one.
    let src = "local r = require(\"refrakt\")\nlocal scene = r.scene{}\nscene.volume.min = {1, 1, 1}\nscene.volume.max = {0, 2, 2}\nreturn scene\n";
    let (dir, path) = write_script("scene.lua", src);
    let (code, _, err) = refrakt(&["dump", path.to_str().unwrap()]);
    assert_clean_failure(code, &err, &["scene.lua:4:", "must be greater than volume.min"]);
    drop(dir);
}
