//! `refrakt bench --quick` runs on a CPU adapter and emits complete JSON: every field present,
//! every time positive, also for the edit-to-image latency of `refrakt watch`. The numbers
//! themselves are not asserted (speed is measured, not tested).

use std::process::Command;

use serde_json::Value;

fn positive(v: &Value, what: &str) -> f64 {
    let x = v.as_f64().unwrap_or_else(|| panic!("{what} missing or not a number: {v}"));
    assert!(x > 0.0 && x.is_finite(), "{what} = {x}");
    x
}

#[test]
fn quick_bench_emits_complete_json() {
    let out = Command::new(env!("CARGO_BIN_EXE_refrakt")).args(["bench", "--quick", "--scenes", "seed,heavy,grin,watch"]).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let report: Value = serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("not JSON ({e}): {}", String::from_utf8_lossy(&out.stdout)));
    assert!(report["adapter"].as_str().is_some_and(|a| !a.is_empty()));
    positive(&report["bare_kernels"]["march_steps_per_s"], "bare march rate");
    positive(&report["bare_kernels"]["view_steps_per_s"], "bare view rate");
    let scenes = report["scenes"].as_array().expect("scenes");
    let names: Vec<&str> = scenes.iter().map(|s| s["name"].as_str().unwrap()).collect();
    assert_eq!(names, ["seed", "heavy", "grin"]);
    for s in scenes {
        let name = s["name"].as_str().unwrap();
        positive(&s["frames"], "frames");
        for what in ["gpu_ms", "wall_ms"] {
            positive(&s[what]["median"], &format!("{name}.{what}.median"));
            positive(&s[what]["p90"], &format!("{name}.{what}.p90"));
        }
        // Every stage of the frame ran and was timed.
        for stage in ["voxelize", "gradient", "octree", "photons", "march", "caustics", "view"] {
            positive(&s["stages_ms"][stage]["median"], &format!("{name}.{stage}"));
        }
        positive(&s["photon_steps_per_s"], &format!("{name} photon steps/s"));
        positive(&s["view_steps_per_s"], &format!("{name} view steps/s"));
        positive(&s["fraction_of_bare_kernels"]["march"], &format!("{name} march fraction"));
        positive(&s["fraction_of_bare_kernels"]["view"], &format!("{name} view fraction"));
        for key in ["size", "volume", "photons", "samples", "triangles", "lights", "fog"] {
            assert!(!s["settings"][key].is_null(), "{name}.settings.{key} missing");
        }
        // What the frame's light costs: every built-in scene has receivers under a lit
        // environment, so its caustic photons, a bounce population as large (the default) and
        // the environment's shadow rays, two per pair (`ENV_PAIRS_PER_SAMPLE`).
        let traced = &s["settings"]["photons_traced"];
        assert_eq!(traced["caustic"], s["settings"]["photons"], "{name}: caustic photons traced");
        assert_eq!(traced["bounce"], s["settings"]["photons"], "{name}: bounce photons traced");
        assert_eq!(s["settings"]["environment_shadow_rays"], 2 * refrakt::pipeline::view::ENV_PAIRS_PER_SAMPLE, "{name}: sky shadow rays");
    }
    // Saving edits of the default scene under `refrakt watch`: each kind timed, and a camera
    // move never built the volume again.
    let watch = &report["watch_latency"];
    positive(&watch["edits"], "watch edits");
    positive(&watch["debounce_ms"], "watch debounce");
    for key in ["size", "volume", "photons", "samples"] {
        assert!(!watch["settings"][key].is_null(), "watch_latency.settings.{key} missing");
    }
    for (mode, edits) in [("progressive", watch), ("without_fast_frame", &watch["without_fast_frame"])] {
        for edit in ["camera_edit", "object_edit"] {
            for what in ["first_image_ms", "final_image_ms", "notice_to_final_ms"] {
                positive(&edits[edit][what]["median"], &format!("{mode} {edit}.{what}.median"));
                positive(&edits[edit][what]["p90"], &format!("{mode} {edit}.{what}.p90"));
            }
            assert!(edits[edit]["photon_traces"].as_u64().is_some(), "{mode} {edit}.photon_traces missing");
        }
        assert_eq!(edits["camera_edit"]["volume_builds"], 0, "{mode}: a camera move reuses the volume");
        positive(&edits["object_edit"]["volume_builds"], &format!("{mode}: an object edit builds the volume"));
    }

    // The seed and heavy scenes are meshes: mesh voxelization ran and was timed.
    positive(&scenes[0]["stages_ms"]["voxelize.meshes"]["median"], "seed mesh voxelization");
    assert!(scenes[0]["settings"]["triangles"].as_u64().unwrap() > 4000);
}

#[test]
fn a_scene_file_can_be_benchmarked() {
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/default.lua");
    let out = Command::new(env!("CARGO_BIN_EXE_refrakt")).args(["bench", "--quick", "--quality", "--scenes", scene]).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let report: Value = serde_json::from_slice(&out.stdout).unwrap();
    let s = &report["scenes"][0];
    assert_eq!(s["name"], scene);
    positive(&s["gpu_ms"]["median"], "default.lua gpu_ms");
    // The default scene's sun traces photons: the photon stages ran and were timed.
    positive(&s["stages_ms"]["march"]["median"], "default.lua march");
    positive(&s["stages_ms"]["view"]["median"], "default.lua view");
    // `--quality` measures a scene file's caustic noise too (1/8 to 8× its photons against 64×),
    // and the noise falls from the fewest photons to the most.
    let points = s["quality"]["points"].as_array().expect("a scene file's quality curve");
    let rmse = |p: &Value| p["caustic_rmse"].as_f64().unwrap();
    assert_eq!(points.len(), 7);
    assert!(rmse(&points[0]) > rmse(&points[6]) && rmse(&points[6]) > 0.0, "{points:?}");
    assert!(report["seed_quality"].is_null(), "seed's own curve stays seed's");
}

/// `--scenes frames`: `refrakt render --frames` end to end under each flow, with the split of
/// its time; and `--compare`, the guard, fails a run slower than an earlier one beyond noise.
#[test]
fn frames_bench_reports_each_flow_and_compare_guards_against_slowing_down() {
    let dir = tempfile::tempdir().unwrap();
    let first = dir.path().join("first.json");
    let bench = |args: &[&str]| Command::new(env!("CARGO_BIN_EXE_refrakt")).args(["bench", "--quick", "--frames", "3"]).args(args).output().unwrap();
    let out = bench(&["--scenes", "grin,frames", "--out", first.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let mut report: Value = serde_json::from_slice(&std::fs::read(&first).unwrap()).unwrap();
    let flows = report["frame_output"]["flows"].as_array().unwrap().clone();
    let names: Vec<&str> = flows.iter().map(|f| f["flow"].as_str().unwrap()).collect();
    assert_eq!(names, ["exr zip, 2 in flight, 1 writer (as before)", "exr zip", "exr none"]);
    positive(&report["frame_output"]["encode"]["one_core"][0]["encode_ms"], "encode cost");
    for f in &flows {
        let flow = f["flow"].as_str().unwrap();
        assert_eq!(f["frames"], 3, "{flow}");
        positive(&f["fps"], &format!("{flow} fps"));
        positive(&f["mb_per_frame"], &format!("{flow} MB per frame"));
        for part in ["evaluate", "submit", "readback", "encode", "write", "gpu"] {
            positive(&f["ms_per_frame"][part], &format!("{flow} {part}"));
        }
        assert!(f["bound"]["by"].as_str().is_some_and(|b| !b.is_empty()), "{f}");
    }
    // An earlier run ten times faster at the view stage: this one is slower beyond any noise.
    let view = &mut report["scenes"][0]["stages_ms"]["view"];
    for q in ["median", "p90"] {
        view[q] = serde_json::json!(view[q].as_f64().unwrap() / 10.0);
    }
    let faster = dir.path().join("faster.json");
    std::fs::write(&faster, report.to_string()).unwrap();
    let out = bench(&["--scenes", "grin", "--compare", faster.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{stderr}");
    assert!(stderr.contains("slower than") && stderr.contains("grin: view"), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}

/// `--scenes serve`: the real server and a WebSocket client; both phases deliver frames, a
/// camera move never rebuilds the volume or retraces photons, a light move retraces photons on
/// the volume it keeps, and every time is there.
#[test]
fn serve_bench_drives_the_server_and_splits_the_time() {
    let out = Command::new(env!("CARGO_BIN_EXE_refrakt")).args(["bench", "--quick", "--scenes", "serve"]).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let report: Value = serde_json::from_slice(&out.stdout).unwrap();
    let serve = &report["serve"];
    assert_eq!(serve["size"], serde_json::json!([96, 54]));
    for phase in ["orbit", "light_drag"] {
        let p = &serve[phase];
        let frames = positive(&p["frames"], "frames");
        positive(&p["frames_per_second"], "frames/s");
        assert!(p["moves_sent"].as_f64().unwrap() > frames, "{phase}: more moves than frames (newest wins)");
        assert_eq!(p["reused_volume"].as_f64(), Some(frames), "{phase}: the volume is never rebuilt");
        let photons_reused = if phase == "orbit" { frames } else { 0.0 };
        assert_eq!(p["reused_photons"].as_f64(), Some(photons_reused), "{phase}: photons reused only while orbiting");
        for what in ["render_ms", "readback_ms", "encode_ms", "delivery_ms", "latency_ms"] {
            positive(&p[what]["median"], &format!("{phase}.{what}"));
        }
        positive(&p["gpu_ms"]["view"]["median"], "view pass");
    }
    assert!(serve["orbit"]["gpu_ms"]["photons"].is_null(), "no photon stage while orbiting");
    positive(&serve["light_drag"]["gpu_ms"]["march"]["median"], "march while dragging a light");
}
