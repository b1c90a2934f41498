//! Animation through the command line: `update(scene, t)` drives the frames, frame k of a range
//! is exactly the still at t = k / fps, and an error in `update` stops the render at its frame
//! with the frames before it kept.

mod common;

use std::path::Path;
use std::process::Command;

use common::write_script;

/// A glass ball that bobs and a slab lens that turns, both set from t alone.
const ANIMATED: &str = r#"local r = require("refrakt")
local scene = r.scene{
  camera = r.camera{ position = {0, 0.2, 2.5}, target = {0, 0, 0}, fov = 35, size = {24, 16} },
  environment = r.environment{ preset = "checker" },
  volume = { resolution = 24, min = {-0.8, -0.8, -0.8}, max = {0.8, 0.8, 0.8} },
  samples = 1,
}
local lens = scene:add(r.node{ name = "lens", translation = {-0.35, 0, 0},
                               shape = r.slab{ size = {0.3, 0.5, 0.3}, ior = 1.3, gradient = 1.0 } })
local ball = scene:add(r.node{ name = "ball", translation = {0.35, 0, 0}, shape = r.sphere{ radius = 0.2 },
                               material = r.glass{ ior = 1.5 } })
function update(scene, t)
  lens.rotation = r.axis_angle({0, 1, 0}, 90 * t)
  ball.translation = {0.35, 0.2 * math.sin(2 * math.pi * t), 0}
  FAIL_AT
end
return scene
"#;

/// Runs refrakt; returns (exit code, stderr and stdout together).
fn refrakt(args: &[&str]) -> (i32, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_refrakt")).args(args).output().unwrap();
    let text = format!("{}{}", String::from_utf8_lossy(&out.stderr), String::from_utf8_lossy(&out.stdout));
    (out.status.code().unwrap_or(-1), text)
}

fn render(scene: &Path, out: &Path, extra: &[&str]) -> (i32, String) {
    let mut args = vec!["render", scene.to_str().unwrap(), "--out", out.to_str().unwrap(), "--progress", "json"];
    args.extend_from_slice(extra);
    refrakt(&args)
}

fn files(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into()).collect();
    names.sort();
    names
}

#[test]
fn frame_k_equals_the_still_at_k_over_fps() {
    let (dir, scene) = write_script("anim.lua", &ANIMATED.replace("FAIL_AT", ""));
    let seq = dir.path().join("seq");
    let (code, err) = render(&scene, &seq, &["--frames", "0..3", "--fps", "10"]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(
        files(&seq),
        ["anim.0000.exr", "anim.0000.png", "anim.0001.exr", "anim.0001.png", "anim.0002.exr", "anim.0002.png", "anim.0003.exr", "anim.0003.png"]
    );
    let still = dir.path().join("still");
    let (code, err) = render(&scene, &still, &["--time", "0.2"]);
    assert_eq!(code, 0, "{err}");
    for ext in ["exr", "png"] {
        let frame = std::fs::read(seq.join(format!("anim.0002.{ext}"))).unwrap();
        let alone = std::fs::read(still.join(format!("anim.t0.2s.{ext}"))).unwrap();
        assert!(frame == alone, "frame 2 of the sequence and the still at t = 0.2 s differ ({ext})");
    }
    // The animation moves: consecutive frames differ, so the comparison above means something.
    let f1 = std::fs::read(seq.join("anim.0001.exr")).unwrap();
    let f2 = std::fs::read(seq.join("anim.0002.exr")).unwrap();
    assert!(f1 != f2, "frames 1 and 2 should differ");
}

#[test]
fn an_update_error_stops_at_its_frame_and_keeps_the_earlier_ones() {
    let source = ANIMATED.replace("FAIL_AT", "if t > 0.15 then error(\"the rig broke\") end");
    let (dir, scene) = write_script("anim.lua", &source);
    let out = dir.path().join("out");
    let (code, err) = render(&scene, &out, &["--frames", "0..4", "--fps", "10", "--format", "png"]);
    assert_ne!(code, 0, "{err}");
    assert!(!err.contains("panicked") && !err.contains("internal error"), "{err}");
    // One paragraph: the frame, its time, the script line, and how to go on.
    assert!(err.contains("error: frame 2 (t = 0.2000 s): "), "{err}");
    assert!(err.contains("anim.lua:15: the rig broke"), "{err}");
    assert!(err.contains("frames 0 to 1 are written") && err.contains("--skip-existing"), "{err}");
    // The JSON progress event names the frame too (the Blender add-on reads it).
    assert!(err.contains("\"event\":\"error\"") && err.contains("\"frame\":2"), "{err}");
    assert_eq!(files(&out), ["anim.0000.png", "anim.0001.png"]);
}

#[test]
fn time_and_frames_do_not_mix() {
    let (code, err) = refrakt(&["render", "x.lua", "--frames", "1..4", "--time", "2"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("cannot be used with"), "{err}");
}

/// Progress follows the frames: a frame's JSON event is printed as soon as its file is written,
/// not at the render loop's next pause (the Blender add-on's progress bar reads these). The
/// third frame's `update` spins for 1.5 s and then prints (to stderr, merged here with stdout):
/// frame 1, long written by then, must have been reported before that line.
#[test]
fn each_frame_is_reported_when_its_file_is_written() {
    let slow = ANIMATED.replace(
        "FAIL_AT",
        "if t > 0.1 then local t0 = os.clock() while os.clock() - t0 < 1.5 do end print(\"update 3 done\") end",
    );
    let (dir, scene) = write_script("scene.lua", &slow);
    let out = dir.path().join("out");
    let command = format!(
        "exec \"$0\" render \"$1\" --out \"$2\" --progress json --frames 1..3 --format exr 2>&1"
    );
    let run = Command::new("sh").arg("-c").arg(command).arg(env!("CARGO_BIN_EXE_refrakt")).arg(&scene).arg(&out).output().unwrap();
    let text = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success(), "{text}");
    let position = |needle: &str| text.find(needle).unwrap_or_else(|| panic!("no {needle:?} in:\n{text}"));
    assert!(
        position("\"frame\":1,") < position("update 3 done"),
        "frame 1 was reported only after the third frame's update:\n{text}"
    );
}

/// A small glowing ball crossing an orthographic view at 12 m/s, frame 1 at 24 fps: it travels
/// L = 12 · shutter / 24 m while the shutter is open.
fn moving_ball(shutter: f32) -> String {
    format!(
        r#"local r = require("refrakt")
local scene = r.scene{{
  camera = r.camera{{ position = {{0, 0, 2}}, target = {{0, 0, 0}}, orthographic = 0.5, size = {{64, 16}} }},
  environment = r.environment{{ color = {{0, 0, 0}} }},
  photons = 0, samples = 64, volume = {{ resolution = 16 }}, shutter = {shutter},
}}
local ball = scene:add(r.node{{ shape = r.sphere{{ radius = 0.1 }},
                                material = r.diffuse{{ color = {{0, 0, 0}}, emission = {{1, 1, 1}}, emission_strength = 1 }} }})
function update(scene, t)
  ball.translation = {{12 * t, 0, 0}}
end
return scene
"#
    )
}

/// The beauty's red channel of frame 1, and its total, centroid and variance along x (pixels).
fn light_along_x(dir: &Path, shutter: f32) -> (f64, f64, f64) {
    let (_keep, scene) = write_script("ball.lua", &moving_ball(shutter));
    let out = dir.join(format!("shutter{shutter}"));
    let (code, err) = render(&scene, &out, &["--frames", "1..1", "--format", "exr"]);
    assert_eq!(code, 0, "{err}");
    let image = refrakt::output::exr::read(&out.join("ball.0001.exr")).unwrap();
    let beauty = &image.layers[0];
    let c = beauty.channels.len();
    let w = image.width as usize;
    let weights: Vec<(f64, f64)> = beauty.data.chunks(c).enumerate().map(|(i, p)| ((i % w) as f64 + 0.5, p[0] as f64)).collect();
    let total: f64 = weights.iter().map(|(_, v)| v).sum();
    let centroid = weights.iter().map(|(x, v)| x * v).sum::<f64>() / total;
    let variance = weights.iter().map(|(x, v)| (x - centroid).powi(2) * v).sum::<f64>() / total;
    (total, centroid, variance)
}

/// Motion blur (`scene.shutter`): a moving object is smeared over exactly its travel while the
/// shutter is open, centred on where it is at the frame's time, with the same light. Rendered at
/// 8 instants, the midpoints of equal parts of the interval, its image is the still one spread
/// over 8 equal copies L/8 apart: a variance larger by L²(8² − 1)/(12 · 8²).
#[test]
fn a_moving_object_blurs_over_its_travel_while_the_shutter_is_open() {
    let dir = tempfile::tempdir().unwrap();
    let (still_light, still_centre, still_variance) = light_along_x(dir.path(), 0.0);
    let pixels_per_metre = 16.0 / 0.5;
    for shutter in [0.5f32, 1.0] {
        let (light, centre, variance) = light_along_x(dir.path(), shutter);
        let travel = 12.0 * shutter as f64 / 24.0 * pixels_per_metre;
        let k = 8.0f64;
        let measured = ((variance - still_variance) * 12.0 * k * k / (k * k - 1.0)).sqrt();
        eprintln!("shutter {shutter}: blur {measured:.3} px over a travel of {travel:.3} px; light {light:.4} vs {still_light:.4}; centre {centre:.3} vs {still_centre:.3}");
        assert!((measured / travel - 1.0).abs() < 0.03, "shutter {shutter}: blurred over {measured} px, travelled {travel} px");
        assert!((light / still_light - 1.0).abs() < 0.01, "shutter {shutter}: light {light} vs {still_light}");
        assert!((centre - still_centre).abs() < 0.05, "shutter {shutter}: centred at {centre}, the still at {still_centre}");
    }
}

/// A script that fails at an instant inside the shutter but not at the frame's own time: the
/// error names the frame, the instant and its time, and the script's line.
#[test]
fn an_error_at_a_motion_blur_instant_names_the_instant() {
    let dir = tempfile::tempdir().unwrap();
    let script = moving_ball(0.5).replace("  ball.translation = {12 * t, 0, 0}\n", "  ball.translation = {12 * t, 0, 0}\n  if t > 1 / 24 + 0.004 then error(\"late\") end\n");
    assert!(script.contains("error(\"late\")"));
    let (_keep, scene) = write_script("ball.lua", &script);
    let (code, err) = render(&scene, &dir.path().join("out"), &["--frames", "1..1", "--format", "exr"]);
    assert_ne!(code, 0, "{err}");
    // Instants at 1/24 + (k + 0.5 − 4)/8 · 0.5/24 s: the 7th (k = 6) is the first past 1/24 + 0.004.
    for wanted in ["instant 7 of 8 (t = 0.0482 s)", "ball.lua:", "late"] {
        assert!(err.contains(wanted), "missing {wanted:?} in:\n{err}");
    }
}
