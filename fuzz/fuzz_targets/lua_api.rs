//! A scene script from arbitrary bytes (seed the corpus with examples/*.lua): loaded in the
//! sandbox with a short time budget and a small memory limit, updated and evaluated, or refused
//! with a message naming the script; never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;
use refrakt::lua::{Limits, ScriptHost};
use refrakt::scene::eval::{EvalOptions, evaluate};

fuzz_target!(|data: &[u8]| {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.lua");
    std::fs::write(&path, data).unwrap();
    let limits = Limits { time_budget: std::time::Duration::from_millis(200), memory_bytes: 64 << 20 };
    match ScriptHost::load(&path, &[], &limits) {
        Ok(host) => {
            if host.update(0.25).is_ok() {
                let scene = host.scene().borrow();
                let _ = evaluate(&scene, 0.25, &EvalOptions { resolution: Some(16), size: Some((8, 6)), ..Default::default() });
            }
        }
        Err(e) => assert!(format!("{e:#}").contains("scene.lua"), "{e:#}"),
    }
});
