//! Every example scene loads, animates and renders (small, on lavapipe), and shows something.

mod common;

use std::path::PathBuf;

use refrakt::frame::FieldKind;
use refrakt::scene::eval::{EvalOptions, evaluate};

fn examples() -> Vec<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples");
    let mut files: Vec<PathBuf> =
        std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().path()).filter(|p| p.extension().is_some_and(|e| e == "lua")).collect();
    files.sort();
    files
}

#[test]
fn every_example_animates_and_renders() {
    let files = examples();
    let names: Vec<String> = files.iter().map(|p| p.file_name().unwrap().to_string_lossy().into()).collect();
    for expected in ["default.lua", "gallery.lua", "turntable.lua"] {
        assert!(names.iter().any(|n| n == expected), "examples/{expected} is missing");
    }
    let opts = EvalOptions { size: Some((32, 18)), resolution: Some(24), samples: Some(1), ..Default::default() };
    let mut renderer = common::renderer();
    for path in &files {
        let host = common::load(path);
        let mut coverage = Vec::new();
        for t in [0.0, 0.5] {
            host.update(t).unwrap_or_else(|e| panic!("{}: {e:#}", path.display()));
            let desc = evaluate(&host.scene().borrow(), t, &opts).unwrap_or_else(|e| panic!("{}: {e:#}", path.display()));
            let image = renderer.frame(&desc).unwrap();
            let covered = (0..18).flat_map(|y| (0..32).map(move |x| (x, y))).filter(|&(x, y)| image.beauty(x, y)[3] > 0.5).count();
            coverage.push(covered);
        }
        assert!(coverage[0] > 32, "{}: the objects should fill part of the frame ({coverage:?} pixels)", path.display());
        if host.is_animated() {
            // Moving objects change what covers the frame (or at least keep covering it).
            assert!(coverage[1] > 32, "{}: {coverage:?}", path.display());
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
