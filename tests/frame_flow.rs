//! How frames flow from the GPU to disk (`--frames-in-flight`, `--writers`,
//! `--exr-compression`): the files do not depend on the flow, byte for byte; every EXR codec
//! writes what a reader reads back; and a run reports where its time went.

mod common;

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::{Arc, Mutex};

use common::write_script;
use refrakt::output::exr::{ExrCodec, ExrSettings};
use refrakt::output::{Format, Image, Layer};
use refrakt::render::{FrameFlow, FrameSplit, RenderOptions, SceneOptions};

/// A glass ball rolling over a floor under a sun, in fog: every stage runs every frame
/// (volume, photons with caustics and fog deposits, view), at a tiny size.
const ROLLING_BALL: &str = r#"local r = require("refrakt")
local scene = r.scene{ volume = { resolution = 16, min = {-0.6, -0.5, -0.6}, max = {0.6, 0.5, 0.6} },
                       photons = 3000, samples = 1,
                       camera = r.camera{ position = {0, 0.6, 2}, target = {0, 0, 0}, size = {20, 14} } }
scene.fog = r.fog{ density = 0.3 }
scene:add(r.node{ name = "ball", shape = r.sphere{ radius = 0.25 }, material = r.glass{ ior = 1.5 } })
scene:add(r.node{ name = "floor", translation = {0, -0.4, 0}, shape = r.plane{ size = {2, 2} },
                  material = r.diffuse{ color = {1, 1, 1} } })
scene:add(r.node{ name = "sun", light = r.sun{ direction = {0.2, -1, 0.1}, intensity = 683, angular_diameter = 0 } })
function update(scene, t)
  scene:find("ball").translation = {0.3 * math.sin(4 * t), 0, 0}
end
return scene
"#;

fn options(out: &Path, flow: FrameFlow) -> RenderOptions {
    RenderOptions {
        frames: Some("0..4".parse().unwrap()),
        time: 0.0,
        out: out.to_path_buf(),
        name: None,
        formats: vec![Format::Exr, Format::Png],
        png: Default::default(),
        skip_existing: false,
        progress: refrakt::progress::ProgressMode::Quiet,
        adapter: None,
        gpus: vec![],
        chunk: 1,
        scene: SceneOptions { fps: 24.0, eval: Default::default(), allow_read: vec![], limits: Default::default(), gltf: Default::default(), params: Default::default() },
        flow,
    }
}

/// Every file in `dir`, by name.
fn files(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap())
        .map(|e| (e.file_name().to_string_lossy().to_string(), std::fs::read(e.path()).unwrap()))
        .collect()
}

fn flow(frames_in_flight: usize, writers: usize, codec: ExrCodec) -> FrameFlow {
    FrameFlow { frames_in_flight, writers, exr: ExrSettings { codec, half: false, parallel: false, layers: Default::default() }, split: None }
}

#[test]
fn frames_are_the_same_bytes_whatever_the_frames_in_flight_and_writers() {
    let (dir, scene) = write_script("ball.lua", ROLLING_BALL);
    let render = |name: &str, flow: FrameFlow| {
        let out = dir.path().join(name);
        refrakt::render::run(&scene, &options(&out, flow)).unwrap();
        files(&out)
    };
    // One frame at a time, written on one thread (its EXRs compressed on all cores) …
    let sequential = render("sequential", flow(1, 1, ExrCodec::Zip));
    assert_eq!(sequential.len(), 10, "5 frames, EXR and PNG: {:?}", sequential.keys());
    assert!(sequential.keys().all(|f| !refrakt::output::is_temporary(f)));
    // … against frames overlapped on the GPU and written side by side.
    for (frames_in_flight, writers) in [(2, 2), (4, 3)] {
        let overlapped = render(&format!("overlapped-{frames_in_flight}-{writers}"), flow(frames_in_flight, writers, ExrCodec::Zip));
        assert_eq!(overlapped.keys().collect::<Vec<_>>(), sequential.keys().collect::<Vec<_>>());
        for (name, bytes) in &sequential {
            assert!(overlapped[name] == *bytes, "{name} differs with {frames_in_flight} frames in flight and {writers} writers");
        }
    }
    // The frames differ from one another (the ball moves), so equal files are not a fluke.
    assert_ne!(sequential["ball.0000.exr"], sequential["ball.0004.exr"]);
}

#[test]
fn a_run_says_where_its_time_went() {
    let (dir, scene) = write_script("ball.lua", ROLLING_BALL);
    let split = Arc::new(Mutex::new(FrameSplit::default()));
    let out = dir.path().join("out");
    let flow = FrameFlow { split: Some(split.clone()), ..flow(3, 2, ExrCodec::None) };
    refrakt::render::run(&scene, &options(&out, flow)).unwrap();
    let s = split.lock().unwrap().clone();
    assert_eq!(s.frames, 5);
    for (part, seconds) in
        [("evaluate", s.evaluate_s), ("submit", s.submit_s), ("readback", s.readback_s), ("convert", s.convert_s), ("encode", s.encode_s), ("write", s.write_s)]
    {
        assert!(seconds > 0.0, "{part}: {s:?}");
    }
    let on_disk: usize = files(&out).values().map(Vec::len).sum();
    assert_eq!(s.bytes, on_disk as u64);
}

/// `Renderer::finish_mapped` hands a frame over still mapped, for another thread to convert (the
/// frame writers do): a caller may hold as many as `HANDED_OFF_FRAMES` such frames past those in
/// flight — each keeps a staging buffer of its own — and go on submitting; each converts, on
/// any thread, into the image `finish` gives; and once converted, their buffers serve again.
#[test]
fn frames_handed_over_mapped_convert_to_the_image_finish_gives() {
    let desc = common::frame_from_lua(ROLLING_BALL);
    let mut r = common::renderer();
    r.set_frames_in_flight(2).unwrap();
    let expected = r.frame(&desc).unwrap();
    let mut in_flight = std::collections::VecDeque::new();
    let mut held = Vec::new();
    for _ in 0..2 + refrakt::pipeline::HANDED_OFF_FRAMES {
        in_flight.push_back(r.submit(&desc).unwrap());
        if in_flight.len() == r.frames_in_flight() {
            held.push(r.finish_mapped(in_flight.pop_front().unwrap()).unwrap());
        }
    }
    while let Some(ticket) = in_flight.pop_front() {
        held.push(r.finish_mapped(ticket).unwrap());
    }
    assert_eq!(held.len(), 2 + refrakt::pipeline::HANDED_OFF_FRAMES);
    let images: Vec<Image> = std::thread::scope(|s| {
        let threads: Vec<_> = held.into_iter().map(|frame| s.spawn(move || frame.image())).collect();
        threads.into_iter().map(|t| t.join().unwrap()).collect()
    });
    assert!(images.iter().all(|image| *image == expected));
    // Every buffer was given back: as many frames again go through without waiting.
    for _ in 0..2 + refrakt::pipeline::HANDED_OFF_FRAMES {
        let ticket = r.submit(&desc).unwrap();
        assert!(r.finish_mapped(ticket).unwrap().image() == expected);
    }
}

/// A frame of noisy values in every layer `render` writes.
fn noisy_image() -> Image {
    let (w, h) = (37u32, 19u32);
    let n = (w * h) as usize;
    let mut state = 0x1234_5678u32;
    let mut noise = |count: usize, scale: f32| -> Vec<f32> {
        (0..count)
            .map(|_| {
                state ^= state << 13;
                state ^= state >> 17;
                state ^= state << 5;
                scale * (state as f32 / u32::MAX as f32)
            })
            .collect()
    };
    Image {
        width: w,
        height: h,
        layers: vec![
            Layer::new("beauty", &["R", "G", "B", "A"], noise(4 * n, 3.0)),
            Layer::new("depth", &["Z"], noise(n, 1e10)),
            Layer::new("caustic", &["R", "G", "B"], noise(3 * n, 20.0)),
        ],
    }
}

#[test]
fn every_lossless_exr_codec_reads_back_exactly_and_dwaa_close() {
    let dir = tempfile::tempdir().unwrap();
    let image = noisy_image();
    let mut sizes = BTreeMap::new();
    for codec in [ExrCodec::Zip, ExrCodec::Zips, ExrCodec::Piz, ExrCodec::Rle, ExrCodec::Dwaa, ExrCodec::None] {
        for half in [false, true] {
            let path = dir.path().join(format!("{codec:?}-{half}.exr"));
            let settings = ExrSettings { codec, half, parallel: false, layers: Default::default() };
            let bytes = refrakt::output::exr::encode(&image, settings).unwrap();
            // Compressing on all cores gives the same file.
            assert!(refrakt::output::exr::encode(&image, ExrSettings { parallel: true, ..settings }).unwrap() == bytes, "{codec:?}");
            std::fs::write(&path, &bytes).unwrap();
            sizes.insert((format!("{codec:?}"), half), bytes.len());
            let back = refrakt::output::exr::read(&path).unwrap();
            assert_eq!(back.layers.len(), image.layers.len());
            for a in &image.layers {
                let b = back.layer(&a.name).unwrap_or_else(|| panic!("{codec:?}: no layer {}", a.name));
                assert_eq!(a.channels, b.channels, "{codec:?}");
                // Lossless codecs keep 32-bit floats exactly and half floats to 11 bits; DWAA
                // codes colors (not depth) lossily, full floats too.
                let color = a.name != "depth";
                let tolerance = match (codec, color, half) {
                    (ExrCodec::Dwaa, true, _) => 0.1,
                    (_, true, true) => 1.0 / 1024.0,
                    _ => 0.0,
                };
                let worst = a.data.iter().zip(&b.data).map(|(x, y)| (x - y).abs() / x.abs().max(1.0)).fold(0.0f32, f32::max);
                eprintln!("{codec:?}, half {half}, {}: worst relative error {worst}", a.name);
                assert!(worst <= tolerance, "{codec:?} half {half} {}: off by {worst}", a.name);
            }
        }
    }
    // Half floats are smaller than full ones, and compression smaller than none.
    assert!(sizes[&("None".into(), true)] < sizes[&("None".into(), false)], "{sizes:?}");
    assert!(sizes[&("Zip".into(), false)] < sizes[&("None".into(), false)], "{sizes:?}");
}

/// `render --layers`: the EXR keeps the layers named and no others, each as the full frame has
/// it; the beauty layer alone is all the GPU brings back.
#[test]
fn an_exr_keeps_only_the_layers_asked_for() {
    let image = noisy_image();
    let dir = tempfile::tempdir().unwrap();
    for (codec, names) in [(ExrCodec::Zip, "caustic,beauty"), (ExrCodec::None, "depth"), (ExrCodec::Piz, "beauty , depth")] {
        let settings = ExrSettings { codec, half: false, parallel: false, layers: names.parse().unwrap() };
        let path = dir.path().join(format!("{codec:?}.exr"));
        std::fs::write(&path, refrakt::output::exr::encode(&image, settings).unwrap()).unwrap();
        let back = refrakt::output::exr::read(&path).unwrap();
        let kept: Vec<&str> = back.layers.iter().map(|l| l.name.as_str()).collect();
        let wanted: Vec<&str> = image.layers.iter().map(|l| l.name.as_str()).filter(|n| names.contains(n)).collect();
        assert_eq!(kept.len(), wanted.len(), "{codec:?} {names}: {kept:?}");
        for layer in &back.layers {
            assert!(*layer == *image.layer(&layer.name).unwrap(), "{codec:?}: layer {} changed", layer.name);
        }
    }
    let err = "beauty,albedo".parse::<refrakt::output::LayerSet>().unwrap_err();
    assert!(err.contains("no layer \"albedo\"") && err.contains("indirect"), "{err}");

    let (dir, scene) = write_script("ball.lua", ROLLING_BALL);
    let render = |name: &str, layers: &str| {
        let out = dir.path().join(name);
        let mut flow = flow(2, 2, ExrCodec::Zip);
        flow.exr.layers = layers.parse().unwrap();
        refrakt::render::run(&scene, &RenderOptions { formats: vec![Format::Exr], ..options(&out, flow) }).unwrap();
        refrakt::output::exr::read(&out.join("ball.0003.exr")).unwrap()
    };
    let all = render("all", "all");
    let beauty = render("beauty", "beauty");
    assert_eq!(all.layers.len(), refrakt::output::LAYER_NAMES.len());
    assert_eq!(beauty.layers.len(), 1);
    assert!(beauty.layers[0] == all.layers[0], "the beauty layer alone is the full frame's");
}
