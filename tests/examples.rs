//! Every example scene loads, animates and renders (small, on lavapipe), and shows something.

mod common;

use std::path::PathBuf;

use refrakt::frame::FieldKind;
use refrakt::render::SceneSource;
use refrakt::scene::eval::{EvalOptions, evaluate};

/// The example scenes: Lua scripts and glTF files.
fn examples() -> Vec<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples");
    let scene = |p: &PathBuf| p.extension().is_some_and(|e| e == "lua" || e == "glb" || e == "gltf");
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().path()).filter(scene).collect();
    files.sort();
    files
}

#[test]
fn every_example_animates_and_renders() {
    let files = examples();
    let names: Vec<String> = files.iter().map(|p| p.file_name().unwrap().to_string_lossy().into()).collect();
    for expected in ["default.lua", "gallery.lua", "turntable.lua", "pendulum.glb"] {
        assert!(names.iter().any(|n| n == expected), "examples/{expected} is missing");
    }
    // Small everything: the test is that each example loads, animates and covers the frame,
    // not how it looks (the guide's pictures), and lavapipe marches a million photons slowly.
    // Without bounced light, which tests/lights.rs and tests/mitsuba_caustics.rs check.
    let opts = EvalOptions { size: Some((32, 18)), resolution: Some(24), samples: Some(1), photons: Some(20_000), bounces: Some(0), ..Default::default() };
    let mut renderer = common::renderer();
    for path in &files {
        let mut source = SceneSource::load(path, &[], &Default::default()).unwrap_or_else(|e| panic!("{e:#}"));
        let mut coverage = Vec::new();
        for t in [0.0, 0.5] {
            let desc = source.frame_desc(t, &opts).unwrap_or_else(|e| panic!("{}: {e:#}", path.display()));
            let image = renderer.frame(&desc).unwrap();
            let covered = (0..18).flat_map(|y| (0..32).map(move |x| (x, y))).filter(|&(x, y)| image.beauty(x, y)[3] > 0.5).count();
            coverage.push(covered);
        }
        // (At 32×18 the wine glass's own silhouette is 30 pixels: glass covers what its surface
        // covers, not a smoothing band around it.)
        assert!(coverage[0] > 16, "{}: the objects should fill part of the frame ({coverage:?} pixels)", path.display());
        if source.is_animated() {
            // Moving objects change what covers the frame (or at least keep covering it).
            assert!(coverage[1] > 16, "{}: {coverage:?}", path.display());
        }
    }
}

#[test]
fn the_turntable_lens_is_a_lua_function_field_that_turns() {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples/turntable.lua");
    let host = common::load(&path);
    let opts = EvalOptions { resolution: Some(24), ..Default::default() };
    let at = |t: f64| {
        host.update(t).unwrap();
        evaluate(&host.scene().borrow(), t, &opts).unwrap()
    };
    let (a, b) = (at(0.25), at(0.5));
    let lens = |d: &refrakt::frame::FrameDesc| d.fields.iter().find(|f| f.name == "lens").unwrap().clone();
    let (la, lb) = (lens(&a), lens(&b));
    assert!(matches!(&la.kind, FieldKind::Sampled(s) if !s.values.is_empty()));
    // A quarter of a 2 s loop per 0.5 s: 45° between t = 0.25 and t = 0.5.
    let turn = (la.world_to_local * lb.world_to_local.inverse()).transform_vector3(glam::Vec3::X);
    assert!((turn.dot(glam::Vec3::X) - 45f32.to_radians().cos()).abs() < 1e-4, "{turn}");
    // The ball bobs.
    let ball = |d: &refrakt::frame::FrameDesc| d.fields.iter().find(|f| f.name == "ball").unwrap().world_to_local.inverse().w_axis.y;
    assert!((ball(&a) - ball(&b)).abs() > 0.1);
}

#[test]
fn the_pendulum_glb_swings_its_ball_and_squashes_its_drop() {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples/pendulum.glb");
    let mut source = SceneSource::load(&path, &[], &Default::default()).unwrap();
    let opts = EvalOptions { resolution: Some(24), ..Default::default() };
    let mut at = |t: f64| source.frame_desc(t, &opts).unwrap();
    let (rest, swung, squashed) = (at(0.0), at(0.5), at(1.5));
    let mesh = |d: &refrakt::frame::FrameDesc, name: &str| d.meshes.iter().find(|m| m.name == name).unwrap().clone();
    // θ(t) = 28° · sin(2πt / 2 s) about +Z at the pivot, 1.6 m up, the ball 1.15 m below it.
    let x = |d: &refrakt::frame::FrameDesc| mesh(d, "Ball").world.w_axis.x;
    assert!(x(&rest).abs() < 1e-4);
    assert!((x(&swung) - 1.15 * 28f32.to_radians().sin()).abs() < 1e-3, "{}", x(&swung));
    // The drop's morph weight is 1 at 0.5 s and 1.5 s: 60 % of its height.
    let height = |d: &refrakt::frame::FrameDesc| {
        let (lo, hi) = mesh(d, "Drop").mesh.bounds().unwrap();
        hi.y - lo.y
    };
    assert!((height(&squashed) / height(&rest) - 0.6).abs() < 1e-3);
    assert!(squashed.receivers.iter().any(|r| r.name == "Floor" && r.diffuse.texture.is_some()));
    assert_eq!(rest.fields.len(), 1, "the Luneburg lens from the node extras");
}
