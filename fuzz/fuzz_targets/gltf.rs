//! A `.glb` from arbitrary bytes: imported, posed and evaluated, or refused; never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;
use refrakt::gltf::ImportOptions;
use refrakt::lua::sandbox::FileAccess;
use refrakt::scene::eval::{EvalOptions, evaluate};

fuzz_target!(|data: &[u8]| {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.glb");
    std::fs::write(&path, data).unwrap();
    let access = FileAccess::new(dir.path(), &[]).unwrap();
    if let Ok(mut import) = refrakt::gltf::import(&path, "scene.glb", &access, &ImportOptions::default()) {
        let mut scene = refrakt::scene::Scene { roots: std::mem::take(&mut import.roots), ..Default::default() };
        import.settings.apply(&mut scene);
        for t in [0.0, 0.7] {
            import.player.pose(t);
            import.player.deform(&scene);
            let _ = evaluate(&scene, t, &EvalOptions { resolution: Some(16), ..Default::default() });
        }
    }
});
