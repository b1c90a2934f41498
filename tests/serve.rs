//! `refrakt serve` as a page uses it: the real binary on a free port, a WebSocket client, a
//! tiny scene (64×36, a 32³ volume, a few thousand photons) in a temporary folder. Speed is never
//! asserted; "no queue" is checked by counting frames and by the server's memory.

mod common;

use std::path::Path;
use std::time::{Duration, Instant};

use serde_json::{Value, json};

use common::serve::{Client, Received, Server, picture};
use common::watch::{folder_with, save_by_rename};

/// A glass ball on a floor under a spot light, seen by `CAMERA`: photons land on the floor.
const SCENE: &str = r#"local r = require("refrakt")
local scene = r.scene{
  camera = r.camera{ CAMERA, fov = 35, size = {64, 36} },
  environment = r.environment{ color = {ENV} },
  volume = { resolution = 32 },
  photons = 4000,
  samples = 1,
}
scene:add(r.node{ name = "ball", shape = r.sphere{ radius = 0.4 }, material = r.glass{ ior = 1.5 } })
scene:add(r.node{ name = "floor", translation = {0, -0.5, 0}, shape = r.plane{ size = {4, 4} },
                  material = r.diffuse{ color = {0.8, 0.8, 0.8} } })
scene:add(r.node{ name = "key", translation = {0.5, 2, 0.5}, light = r.spot{ target = {0, -0.5, 0}, intensity = 3000, angle = 30 } })
return scene
"#;

const SCENE_CAMERA: &str = "position = {0, 0.5, 3}, target = {0, 0, 0}";

/// A still view refines by default; tests of other things leave it at the scene's samples.
const NO_REFINE: &[&str] = &["--refine", "0"];

fn scene(camera: &str, env: &str) -> String {
    SCENE.replace("CAMERA", camera).replace("ENV", env)
}

fn floats(bytes: &[u8]) -> Vec<f32> {
    bytes.chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect()
}

fn reused(header: &Value) -> (bool, bool) {
    (header["reused"]["volume"].as_bool().unwrap(), header["reused"]["photons"].as_bool().unwrap())
}

/// `refrakt render` of `source` (as scene.lua in `dir`): the beauty layer.
fn render_beauty(dir: &Path, source: &str) -> Vec<f32> {
    let path = dir.join("reference.lua");
    std::fs::write(&path, source).unwrap();
    let out = dir.join("out");
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_refrakt"))
        .args(["render", path.to_str().unwrap(), "--out", out.to_str().unwrap(), "--format", "exr", "--progress", "quiet"])
        .status()
        .unwrap();
    assert!(status.success());
    let image = refrakt::output::exr::read(&out.join("reference.exr")).unwrap_or_else(|e| panic!("{e:#}"));
    image.layers[0].data.clone()
}

#[test]
fn a_camera_move_reruns_only_the_view_pass_and_equals_render_with_that_camera() {
    let dir = folder_with(&[("scene.lua", &scene(SCENE_CAMERA, "0.1, 0.1, 0.12"))]);
    let server = Server::start(&dir.path().join("scene.lua"), NO_REFINE);
    let mut page = Client::connect(&server);
    let info = page.event("scene");
    assert_eq!(info["size"], json!([64, 36]));
    assert_eq!(info["lights"][0]["name"], "key");
    assert_eq!(info["lights"][0]["kind"], "spot");
    let (first, jpeg) = page.frame("jpeg", |_| true);
    assert_eq!(reused(&first), (false, false), "the first frame builds everything: {first}");
    assert_eq!(picture(&first, &jpeg).dimensions(), (64, 36));

    let pose = json!({ "position": [1.5, 0.75, 2.5], "target": [0.25, 0, 0], "fov": 35 });
    page.send(json!({ "type": "camera", "id": 7, "camera": pose }));
    let (moved, _) = page.frame("jpeg", |h| h["input"] == 7);
    assert_eq!(reused(&moved), (true, true), "a camera move reruns only the view pass: {moved}");
    let gpu: Vec<&str> = moved["times"]["gpu"].as_array().unwrap().iter().map(|s| s[0].as_str().unwrap()).collect();
    assert!(!gpu.iter().any(|s| s.contains("photon") || s.contains("voxel")), "GPU stages of a camera move: {gpu:?}");

    page.send(json!({ "type": "hdr" }));
    let (hdr, payload) = page.frame("hdr", |h| h["input"] == 7);
    assert_eq!((hdr["channels"].as_u64(), hdr["width"].as_u64()), (Some(4), Some(64)));
    let served = floats(&payload);
    let reference = render_beauty(dir.path(), &scene("position = {1.5, 0.75, 2.5}, target = {0.25, 0, 0}", "0.1, 0.1, 0.12"));
    assert_eq!(served.len(), reference.len());
    let differ = served.iter().zip(&reference).filter(|(a, b)| a != b).count();
    assert_eq!(differ, 0, "the served frame equals refrakt render's with that camera ({differ} values differ)");
    assert!(reference.iter().any(|&v| v > 0.2), "the reference shows something lit");

    // A light move retraces the photons on the volume already built.
    page.send(json!({ "type": "light", "id": 8, "name": "key", "position": [-0.5, 2, 0.5] }));
    let (lit, _) = page.frame("jpeg", |h| h["input"] == 8);
    assert_eq!(reused(&lit), (true, false), "a light move retraces photons only: {lit}");
}

#[test]
fn a_lua_error_reaches_the_page_and_the_next_good_save_recovers() {
    let dir = folder_with(&[("scene.lua", &scene(SCENE_CAMERA, "0.2, 0.3, 0.4"))]);
    let path = dir.path().join("scene.lua");
    let server = Server::start(&path, NO_REFINE);
    let mut page = Client::connect(&server);
    let (first, _) = page.frame("jpeg", |_| true);

    save_by_rename(&path, &scene(SCENE_CAMERA, "0.2, 0.3, 0.4").replace("photons = 4000", "photons = = 4000"));
    let error = page.event("error");
    let message = error["message"].as_str().unwrap();
    assert!(message.contains("scene.lua:6:"), "the message names file:line: {message}");
    assert_eq!(error["kept"], true, "the last good frame stays");

    // A page that connects now sees the error too, with the last good frame.
    let mut late = Client::connect(&server);
    assert!(late.event("error")["message"].as_str().unwrap().contains("scene.lua:6:"));
    let (kept, _) = late.frame("jpeg", |_| true);
    assert_eq!(kept["frame"], first["frame"]);

    save_by_rename(&path, &scene(SCENE_CAMERA, "0.9, 0.1, 0.1"));
    // The page hears that the error is gone, and gets the new frame (in either order).
    let (mut ok, mut fixed) = (false, None);
    page.wait_for("the fix's frame and the ok", |r| {
        match r {
            Received::Event(e) if e["type"] == "ok" => ok = true,
            Received::Frame { header, payload } if header["frame"].as_u64() > first["frame"].as_u64() => fixed = Some(picture(header, payload)),
            _ => {}
        }
        (ok && fixed.is_some()).then_some(())
    });
    // Pixel (0, 0) sees the environment: now red.
    let img = fixed.unwrap();
    let px = img.get_pixel(0, 0);
    assert!(px[0] > 150 && px[1] < 100 && px[2] < 100, "the fixed scene's red environment: {px:?}");
}

#[test]
fn origin_host_and_token_checks_refuse_what_they_must() {
    let dir = folder_with(&[("scene.lua", &scene(SCENE_CAMERA, "0.2, 0.3, 0.4"))]);
    let local = Server::start(&dir.path().join("scene.lua"), NO_REFINE);
    let url = local.ws_url();
    let own = format!("http://127.0.0.1:{}", local.port);
    assert!(Client::connect_with(&url, &[("Origin", &own)]).is_ok(), "the server's own page");
    let refused = |r: Result<Client, String>| r.err().is_some_and(|e| e.contains("403"));
    assert!(refused(Client::connect_with(&url, &[("Origin", "http://evil.example")])), "another site's page");
    assert!(refused(Client::connect_with(&url, &[("Origin", "null")])));
    let rebound = format!("evil.example:{}", local.port);
    assert!(refused(Client::connect_with(&url, &[("Host", &rebound), ("Origin", &format!("http://{rebound}"))])), "DNS rebinding");
    assert!(local.url.ends_with('/') && !local.url.contains("token"), "no token on loopback: {}", local.url);
    assert!(local.get_status("/").contains("200"));
    for path in ["/Cargo.toml", "/../scene.lua", "/scene.lua", "/web/app.js"] {
        assert!(local.get_status(path).contains("404"), "{path} is not served");
    }

    let open = Server::start(&dir.path().join("scene.lua"), &["--bind", "0.0.0.0", "--refine", "0"]);
    assert!(open.url.contains("?token="), "beyond loopback the URL carries a token: {}", open.url);
    let with_token = open.ws_url();
    let without = format!("ws://127.0.0.1:{}/ws", open.port);
    assert!(refused(Client::connect_with(&without, &[])), "no token");
    assert!(refused(Client::connect_with(&format!("{without}?token=0123"), &[])), "a wrong token");
    let mut page = Client::connect_with(&with_token, &[]).expect("the right token");
    page.frame("jpeg", |_| true);
}

/// Floods the server with camera moves; each flood yields a handful of frames (newest state
/// wins), the last move is on screen soon after it is sent, and memory does not grow.
#[test]
fn a_flood_of_camera_messages_never_queues_nor_grows_memory() {
    let dir = folder_with(&[("scene.lua", &scene(SCENE_CAMERA, "0.2, 0.3, 0.4"))]);
    let server = Server::start(&dir.path().join("scene.lua"), NO_REFINE);
    let mut page = Client::connect(&server);
    page.frame("jpeg", |_| true);
    let camera = |i: u64| json!({ "type": "camera", "id": i, "camera": { "position": [3.0 * (i as f64 * 0.01).sin(), 0.5, 3.0 * (i as f64 * 0.01).cos()], "target": [0, 0, 0], "fov": 35 } });

    // One move, for the time a frame takes.
    let started = Instant::now();
    page.send(camera(1));
    page.frame("jpeg", |h| h["input"] == 1);
    let one = started.elapsed();

    const FLOOD: u64 = 1500;
    let mut rss = Vec::new();
    for round in 0..4 {
        let (first, last) = (2 + round * FLOOD, 1 + (round + 1) * FLOOD);
        page.forget_skipped(); // count this round's frames only
        let started = Instant::now();
        page.send_all((first..=last).map(camera));
        let mut frames = 0;
        let latency = page.wait_for("the flood's last move on screen", |r| match r {
            Received::Frame { header, .. } if header["kind"] == "jpeg" => {
                frames += 1;
                (header["input"] == last).then(|| started.elapsed())
            }
            _ => None,
        });
        eprintln!("flood round {round}: {frames} frames for {FLOOD} moves, the last shown after {latency:?} (one move: {one:?}), RSS {} KiB", server.rss_kib());
        assert!(frames < FLOOD / 10, "round {round}: {frames} frames for {FLOOD} moves: frames queued");
        assert!(latency < 4 * one + Duration::from_secs(2), "round {round}: the last move took {latency:?} to show (one move: {one:?})");
        rss.push(server.rss_kib());
        std::thread::sleep(Duration::from_millis(1500)); // the rate limit's bucket refills
    }
    let growth = rss[3] as i64 - rss[1] as i64;
    assert!(growth < 8 * 1024, "memory grew by {growth} KiB over two floods (RSS per round: {rss:?} KiB)");

    // Beyond the burst allowance, messages are dropped with a warning; the server stays.
    page.send_all((100_000..103_000).map(camera));
    let warning = page.event("warning");
    assert!(warning["message"].as_str().unwrap().contains("too many"), "{warning}");
    std::thread::sleep(Duration::from_millis(2500));
    page.send(camera(200_000));
    page.frame("jpeg", |h| h["input"] == 200_000);
}

#[test]
fn display_changes_reencode_and_layers_come_from_the_next_frame() {
    let dir = folder_with(&[("scene.lua", &scene(SCENE_CAMERA, "0.2, 0.3, 0.4"))]);
    let server = Server::start(&dir.path().join("scene.lua"), NO_REFINE);
    let mut page = Client::connect(&server);
    let (first, payload) = page.frame("jpeg", |_| true);
    let dark = picture(&first, &payload);
    page.send(json!({ "type": "display", "layer": "beauty", "exposure": 2.0, "tonemap": "clamp", "quality": 90 }));
    let (bright, payload) = page.frame("jpeg", |h| h["frame"] == first["frame"]);
    let light = picture(&bright, &payload);
    assert_eq!(bright["layer"], "beauty");
    let mean = |img: &image::RgbImage| img.pixels().map(|p| p.0.iter().map(|&c| c as f64).sum::<f64>()).sum::<f64>();
    assert!(mean(&light) > mean(&dark) * 1.3, "two stops brighter, without rendering again");

    page.send(json!({ "type": "display", "layer": "depth", "exposure": 0.0, "tonemap": "neutral", "quality": 90 }));
    let (depth, _) = page.frame("jpeg", |h| h["layer"] == "depth");
    assert!(depth["frame"].as_u64() > first["frame"].as_u64(), "the depth layer needs a frame read back with every layer");
    assert_eq!(reused(&depth), (true, true));
    page.send(json!({ "type": "display", "layer": "nonsense", "exposure": 0.0, "tonemap": "neutral", "quality": 90 }));
    assert!(page.event("warning")["message"].as_str().unwrap().contains("does not understand"));
    page.send(json!({ "type": "camera", "camera": { "position": [0, 0, 0], "target": [0, 0, 0], "fov": 35 } }));
    assert!(page.event("warning")["message"].as_str().unwrap().contains("same point"));
}

#[test]
fn a_param_slider_runs_the_script_again_with_its_value() {
    let source = scene(SCENE_CAMERA, r#"r.param{ name = "red", default = 0.2, min = 0, max = 1 }, 0.3, 0.4"#);
    let dir = folder_with(&[("scene.lua", &source)]);
    let server = Server::start(&dir.path().join("scene.lua"), NO_REFINE);
    let mut page = Client::connect(&server);
    let info = page.event("scene");
    assert_eq!(info["params"], json!([{ "name": "red", "value": 0.2, "default": 0.2, "min": 0.0, "max": 1.0, "step": 0.01 }]));
    page.frame("jpeg", |_| true);
    page.send(json!({ "type": "param", "id": 3, "name": "red", "value": 0.9 }));
    let (mut told, mut frame) = (None, None);
    page.wait_for("the new scene event and frame", |r| {
        match r {
            Received::Event(e) if e["type"] == "scene" => told = Some(e["params"][0]["value"].clone()),
            Received::Frame { header, payload } if header["input"] == 3 => frame = Some(picture(header, payload)),
            _ => {}
        }
        (told.is_some() && frame.is_some()).then_some(())
    });
    assert_eq!(told, Some(json!(0.9)), "the page is told the value in use");
    let img = frame.unwrap();
    let px = img.get_pixel(0, 0);
    assert!(px[0] > 200 && px[0] as i32 - px[2] as i32 > 40, "the environment's red follows the slider: {px:?}");
}

/// The state one page sets reaches the others, and a page that connects later starts from it;
/// what answers one page (HDR values, the edits as Lua) reaches no other.
#[test]
fn pages_share_one_state_and_replies_go_to_the_page_that_asked() {
    let dir = folder_with(&[("scene.lua", &scene(SCENE_CAMERA, "0.2, 0.3, 0.4"))]);
    let server = Server::start(&dir.path().join("scene.lua"), NO_REFINE);
    let (mut a, mut b) = (Client::connect(&server), Client::connect(&server));
    let me = a.event("hello")["connection"].as_u64().unwrap();
    a.frame("jpeg", |_| true);
    let pose = json!({ "position": [1.5, 0.75, 2.5], "target": [0.25, 0.0, 0.0], "fov": 40.0 });
    a.send(json!({ "type": "camera", "id": 5, "camera": pose }));
    a.send(json!({ "type": "light", "id": 6, "name": "key", "intensity": 2.0 }));
    a.send(json!({ "type": "display", "id": 7, "layer": "caustic", "exposure": 1.0, "tonemap": "aces", "quality": 80 }));
    let in_step = |s: &Value| s["camera"] == pose && s["lights"]["key"]["intensity"] == 2.0 && s["display"]["layer"] == "caustic";
    let seen = b.wait_for("the state a set", |r| match r {
        Received::Event(e) if e["type"] == "state" && in_step(e) => Some(e.clone()),
        _ => None,
    });
    assert_eq!((seen["by"].as_u64(), seen["id"].as_u64(), seen["can_undo"].as_bool()), (Some(me), Some(7), Some(true)), "{seen}");
    let (frame, _) = b.frame("jpeg", |h| h["input"] == 6 && h["layer"] == "caustic");
    assert!(frame["revision"].as_u64().unwrap() >= 2, "{frame}");

    // A page that connects now (a reload) is told the same state before anything else changes.
    let mut late = Client::connect(&server);
    let first = late.event("state");
    assert!(in_step(&first), "a reloaded page starts from the session's state: {first}");
    assert_eq!(late.frame("jpeg", |_| true).0["layer"], "caustic");

    // Undo steps back over a's light edit, for every page.
    b.send(json!({ "type": "undo" }));
    late.wait_for("the undone light", |r| match r {
        Received::Event(e) if e["type"] == "state" && e["lights"].get("key").is_none() && e["camera"] == pose => Some(()),
        _ => None,
    });

    // a's HDR request and its edits as Lua are answered to a alone.
    a.send(json!({ "type": "hdr", "region": [10, 5, 4, 3] }));
    a.send(json!({ "type": "lua" }));
    let (hdr, payload) = a.frame("hdr", |_| true);
    assert_eq!((hdr["region"].clone(), hdr["layer"].clone(), hdr["channels"].as_u64()), (json!([10, 5, 4, 3]), json!("caustic"), Some(3)), "{hdr}");
    assert_eq!(payload.len(), 4 * 3 * 3 * 4, "4 × 3 pixels of 3 floats");
    let lua = a.event("lua")["lua"].as_str().unwrap().to_string();
    assert!(lua.contains("scene.camera = r.camera{ position = {1.5, 0.75, 2.5}"), "{lua}");
    a.send(json!({ "type": "hdr", "region": [60, 30, 10, 10] }));
    assert!(a.event("warning")["message"].as_str().unwrap().contains("not inside"));
    let until = Instant::now() + Duration::from_secs(2);
    while let Some(left) = until.checked_duration_since(Instant::now()) {
        match b.next_within(left) {
            Some(Received::Frame { header, .. }) => assert_ne!(header["kind"], "hdr", "b received a's HDR values"),
            Some(Received::Event(e)) => assert!(e["type"] != "lua" && e["type"] != "warning", "b received a's answer: {e}"),
            None => break,
        }
    }
}

/// Light and param names the scene lacks are refused, whatever their number: the server's maps
/// hold only the scene's names, so 20,000 unknown names grow nothing.
#[test]
fn unknown_names_are_refused_and_grow_nothing() {
    let dir = folder_with(&[("scene.lua", &scene(SCENE_CAMERA, "0.2, 0.3, 0.4"))]);
    let server = Server::start(&dir.path().join("scene.lua"), NO_REFINE);
    let mut pages: Vec<Client> = (0..4).map(|_| Client::connect(&server)).collect();
    pages[0].frame("jpeg", |_| true);
    let name = |i: usize| format!("{i:06}{}", "x".repeat(200));
    let light = |i: usize| json!({ "type": "light", "id": i + 1, "name": name(i), "position": [0.0, 1.0, 0.0] });
    let flood = |pages: &mut Vec<Client>, range: std::ops::Range<usize>| {
        let per = range.len() / pages.len();
        for (k, page) in pages.iter_mut().enumerate() {
            let first = range.start + k * per;
            page.send_all((first..first + per).map(light));
        }
    };
    flood(&mut pages, 0..2000); // warm up the connections' buffers
    std::thread::sleep(Duration::from_millis(1500));
    let before = server.rss_kib();
    for round in 0..6 {
        flood(&mut pages, 2000 + round * 3000..2000 + (round + 1) * 3000);
        std::thread::sleep(Duration::from_millis(1000)); // within every page's and the server's rate
    }
    std::thread::sleep(Duration::from_millis(500));
    let after = server.rss_kib();
    let mut warnings = Vec::new();
    for page in &mut pages {
        while let Some(r) = page.next_within(Duration::from_millis(200)) {
            if let Received::Event(e) = r
                && e["type"] == "warning"
            {
                warnings.push(e["message"].as_str().unwrap().to_string());
            }
        }
    }
    eprintln!("20,000 unknown light names: RSS {before} → {after} KiB, {} warnings", warnings.len());
    assert!(warnings.iter().all(|w| w.contains("no light of that name")), "none were dropped by the rate limits: {:?}", warnings.iter().find(|w| !w.contains("no light")));
    assert!(warnings.len() < 4 * 200, "warnings are rate-limited too: {}", warnings.len());
    assert!(after < before + 2048, "memory grew by {} KiB for 18,000 unknown names", after as i64 - before as i64);
    pages[0].send(json!({ "type": "param", "name": "nope", "value": 1.0 }));
    assert!(pages[0].event("warning")["message"].as_str().unwrap().contains("no param of that name"));
    pages[0].send(json!({ "type": "light", "id": 99, "name": "key", "position": [0.0, 1.5, 0.0] }));
    let state = pages[1].event("state");
    assert_eq!(state["lights"].as_object().unwrap().len(), 1, "only the scene's light: {state}");
}

/// A still view keeps refining: each frame averages more camera rays, the page is told what the
/// renderer is doing, and the still converges to `refrakt render --samples N`.
#[test]
fn a_still_view_refines_to_render_with_that_many_samples() {
    let source = scene(SCENE_CAMERA, "0.2, 0.3, 0.4");
    let dir = folder_with(&[("scene.lua", &source)]);
    let server = Server::start(&dir.path().join("scene.lua"), &["--refine", "8"]);
    let mut page = Client::connect(&server);
    let (mut samples, mut busy) = (Vec::new(), Vec::new());
    page.wait_for("the still refined to 8 samples", |r| {
        match r {
            Received::Frame { header, .. } if header["kind"] == "jpeg" => samples.push(header["samples"].as_u64().unwrap()),
            Received::Event(e) if e["type"] == "activity" && e["busy"] == true => busy.push(e.clone()),
            _ => {}
        }
        (samples.last() == Some(&8)).then_some(())
    });
    assert!(samples.windows(2).all(|w| w[0] < w[1]) && samples[0] == 1, "the samples of the frames rise: {samples:?}");
    // (The first frame, building everything on lavapipe, takes over a second; a quick pass of
    // the view alone may show no busy indicator.)
    assert!(busy.iter().any(|a| a["refining"] == false && a["stage"].is_string()), "the page hears what the first frame is doing: {busy:?}");
    assert!(busy.iter().all(|a| a["refining"] == false || (a["target"] == 8 && a["samples"].as_u64() > Some(1))), "{busy:?}");
    std::thread::sleep(Duration::from_millis(300));
    page.send(json!({ "type": "hdr" }));
    let (hdr, payload) = page.frame("hdr", |_| true);
    assert_eq!(hdr["samples"], 8, "the refinement stops at its target: {hdr}");
    let served = floats(&payload);
    let reference = render_beauty(dir.path(), &source.replace("samples = 1,", "samples = 8,"));
    let one = render_beauty(dir.path(), &source);
    let differ = |a: &[f32], b: &[f32]| a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0f32, f32::max);
    let peak = reference.iter().fold(0.0f32, |m, v| m.max(v.abs()));
    eprintln!("refined vs render --samples 8: max |Δ| {:.2e} (peak {peak:.3}); vs 1 sample {:.3}", differ(&served, &reference), differ(&one, &reference));
    assert!(differ(&served, &reference) <= 1e-5 * peak.max(1.0), "the refined still is render --samples 8's (float rounding apart)");
    assert!(differ(&one, &reference) > 1e-2, "8 samples differ from 1: the test could tell");
}
