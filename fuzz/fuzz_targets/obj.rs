//! An OBJ mesh from arbitrary bytes: refused or read, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("mesh.obj");
    std::fs::write(&path, data).unwrap();
    let _ = refrakt::scene::obj::load(&path);
});
