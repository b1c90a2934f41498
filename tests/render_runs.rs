//! `refrakt render` as a run: interrupted with Ctrl-C (said at once, exit 130, only whole files
//! left), resumed with `--skip-existing` (the count says what was rendered), and timed per frame
//! without counting overlapping pipelined work twice.

mod common;

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::write_script;

/// A tiny Luneburg lens, with `extra` Lua before `return scene`.
fn lens(extra: &str) -> String {
    format!(
        r#"local r = require("refrakt")
local scene = r.scene{{
  camera = r.camera{{ position = {{0, 0, 3}}, target = {{0, 0, 0}}, fov = 35, size = {{16, 12}} }},
  volume = {{ resolution = 16 }},
  samples = 1,
}}
scene:add(r.node{{ shape = r.luneburg{{ radius = 0.5 }} }})
{extra}
return scene
"#
    )
}

/// An `update` that says "ready" on stderr, then keeps the CPU busy for a while: a signal sent
/// on "ready" arrives in the middle of the frame, after the render loop's own check.
const SLOW_UPDATE: &str = "function update(scene, t)\n  print(\"ready\")\n  local t0 = os.clock()\n  while os.clock() - t0 < 1.5 do end\nend";

/// Renders the lens with SLOW_UPDATE (one frame) and sends SIGINT `signals` times, 150 ms
/// apart, once its update has begun. Returns (exit code, stderr, the files left in --out).
#[cfg(unix)]
fn interrupted_render(signals: usize) -> (i32, String, Vec<String>) {
    let (dir, path) = write_script("slow.lua", &lens(SLOW_UPDATE));
    let out = dir.path().join("out");
    let mut child = Command::new(env!("CARGO_BIN_EXE_refrakt"))
        .args(["render", path.to_str().unwrap(), "--out", out.to_str().unwrap(), "--format", "png", "--progress", "lines"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut lines = BufReader::new(child.stderr.take().unwrap()).lines().map_while(Result::ok);
    let mut err = String::new();
    for line in lines.by_ref() {
        err.push_str(&line);
        err.push('\n');
        if line.contains("ready") {
            break;
        }
    }
    assert!(err.contains("ready"), "the update ran: {err}");
    for _ in 0..signals {
        assert!(Command::new("kill").args(["-INT", &child.id().to_string()]).status().unwrap().success());
        std::thread::sleep(Duration::from_millis(150));
    }
    for line in lines {
        err.push_str(&line);
        err.push('\n');
    }
    let code = child.wait().unwrap().code().unwrap_or(-1);
    let mut files: Vec<String> =
        std::fs::read_dir(&out).map(|d| d.map(|e| e.unwrap().file_name().to_string_lossy().into()).collect()).unwrap_or_default();
    files.sort();
    (code, err, files)
}

#[cfg(unix)]
#[test]
fn one_ctrl_c_says_at_once_it_stops_after_the_frame_and_exits_130() {
    let (code, err, files) = interrupted_render(1);
    assert!(err.contains("stopping after the frame in hand; press Ctrl-C again to stop now"), "{err}");
    assert_eq!(code, 130, "{err}");
    assert!(err.contains("interrupted; the frame in hand was finished and written whole"), "{err}");
    assert_eq!(files, ["slow.png"], "the frame in hand, whole, and no temporary: {err}");
}

#[cfg(unix)]
#[test]
fn a_second_ctrl_c_stops_at_once() {
    let started = Instant::now();
    let (code, err, files) = interrupted_render(2);
    assert_eq!(code, 130, "{err}");
    assert!(err.contains("stopping now"), "{err}");
    assert!(files.iter().all(|f| !refrakt::output::is_temporary(f)), "{files:?}");
    assert!(!err.contains("panicked"), "{err}");
    eprintln!("stopped {:.1} s after the start", started.elapsed().as_secs_f64());
}

fn render_json(path: &Path, out: &Path, extra: &[&str]) -> Vec<serde_json::Value> {
    let output = Command::new(env!("CARGO_BIN_EXE_refrakt"))
        .args(["render", path.to_str().unwrap(), "--out", out.to_str().unwrap(), "--format", "png", "--progress", "json"])
        .args(extra)
        .output()
        .unwrap();
    assert_eq!(output.status.code(), Some(0), "{}", String::from_utf8_lossy(&output.stderr));
    String::from_utf8_lossy(&output.stdout).lines().map(|l| serde_json::from_str(l).unwrap()).collect()
}

#[test]
fn a_resumed_render_counts_what_it_rendered_and_frame_times_add_up() {
    let (dir, path) = write_script("lens.lua", &lens(""));
    let out = dir.path().join("out");
    let events = render_json(&path, &out, &["--frames", "0..3"]);
    // Frames are pipelined: each frame's seconds is its share of the run, so they add up to
    // no more than the whole (times from each frame's own start would overlap).
    let frames: Vec<&serde_json::Value> = events.iter().filter(|e| e["event"] == "frame").collect();
    assert_eq!(frames.len(), 4);
    let sum: f64 = frames.iter().map(|e| e["seconds"].as_f64().unwrap()).sum();
    let done = events.iter().find(|e| e["event"] == "done").unwrap();
    assert!(sum <= done["seconds"].as_f64().unwrap() + 1e-3, "{sum} s in frames, {done}");
    assert_eq!(done["frames"], 4);

    std::fs::remove_file(out.join("lens.0002.png")).unwrap();
    let events = render_json(&path, &out, &["--frames", "0..3", "--skip-existing"]);
    let done = events.iter().find(|e| e["event"] == "done").unwrap();
    assert_eq!((done["frames"].as_u64(), done["skipped"].as_u64()), (Some(1), Some(3)), "{done}");
    let output = Command::new(env!("CARGO_BIN_EXE_refrakt"))
        .args(["render", path.to_str().unwrap(), "--out", out.to_str().unwrap(), "--format", "png", "--progress", "lines"])
        .args(["--frames", "0..3", "--skip-existing"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&output.stderr);
    assert!(err.contains("rendered 0 frame(s)") && err.contains("skipped 4 whose files exist"), "{err}");
}

#[test]
fn stale_temporaries_of_a_killed_run_are_removed_at_the_start() {
    let (dir, path) = write_script("scene.lua", "local x = = 1\n");
    let out = dir.path().join("out");
    std::fs::create_dir_all(&out).unwrap();
    let an_hour_ago = std::time::SystemTime::now() - Duration::from_secs(3600);
    // Process ids on Linux stay below 2^22: 999999999 never ran.
    let stale = out.join(".scene.0001.tmp-999999999.exr");
    let young = out.join(".scene.0002.tmp-999999998.exr");
    let other = out.join(".notes.tmp-mine.txt");
    for (p, old) in [(&stale, true), (&young, false), (&other, true)] {
        let f = std::fs::File::create(p).unwrap();
        if old {
            f.set_modified(an_hour_ago).unwrap();
        }
    }
    let output = Command::new(env!("CARGO_BIN_EXE_refrakt"))
        .args(["render", path.to_str().unwrap(), "--out", out.to_str().unwrap(), "--progress", "quiet"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{err}");
    assert!(!stale.exists(), "the killed run's temporary is removed: {err}");
    assert!(err.contains("removed 1 temporary file(s) that an interrupted refrakt left"), "{err}");
    assert!(young.exists() && other.exists(), "a young temporary and someone else's file stay");
}

/// A frame is waited for part by part (the bar's progress within a frame): the volume, the
/// photons and the view, in order; a camera move reuses the first two and waits for the view.
#[test]
fn a_frame_is_waited_for_part_by_part() {
    use refrakt::pipeline::parts::Part;
    let lit = |z: f32| {
        common::frame_from_lua(&format!(
            r#"local r = require("refrakt")
            local scene = r.scene{{ camera = r.camera{{ position = {{0, 0.5, {z}}}, target = {{0, 0, 0}}, size = {{16, 12}} }},
                                   volume = {{ resolution = 16 }}, photons = 2000, samples = 1 }}
            scene:add(r.node{{ shape = r.sphere{{ radius = 0.3 }}, material = r.glass{{ ior = 1.5 }} }})
            scene:add(r.node{{ translation = {{0, -0.5, 0}}, shape = r.plane{{ size = {{2, 2}} }}, material = r.diffuse{{}} }})
            scene:add(r.node{{ light = r.sun{{ direction = {{0, -1, 0}}, intensity = 3 }} }})
            return scene"#
        ))
    };
    let mut renderer = common::renderer();
    let mut parts_of = |desc| {
        let ticket = renderer.submit(&desc).unwrap();
        let mut seen = Vec::new();
        renderer.wait(&ticket, &mut |p| seen.push(p.clone())).unwrap();
        renderer.finish(ticket).unwrap();
        seen
    };
    let seen = parts_of(lit(3.0));
    let order: Vec<Part> = seen.iter().filter_map(|p| p.current).fold(Vec::new(), |mut v, p| {
        if v.last() != Some(&p) {
            v.push(p);
        }
        v
    });
    assert_eq!(order, [Part::Volume, Part::Photons, Part::View]);
    assert!(seen.windows(2).all(|w| w[0].done <= w[1].done && w[0].elapsed <= w[1].elapsed), "{seen:?}");
    let last = seen.last().unwrap();
    assert_eq!((last.done, last.parts, last.current), (3, 3, None));
    assert!(seen.iter().any(|p| p.current == Some(Part::Photons) && p.photons == 2000));
    // The camera moved: volume and photons come from the cache, only the view is waited for.
    let seen = parts_of(lit(2.5));
    assert!(seen.iter().all(|p| p.parts == 1 && p.current.is_none_or(|c| c == Part::View)), "{seen:?}");
}
