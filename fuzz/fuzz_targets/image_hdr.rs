//! An environment `.hdr` from arbitrary bytes: refused or read, never a panic, never an
//! allocation sized by a lying header (run with `-rss_limit_mb=2560`).
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sky.hdr");
    std::fs::write(&path, data).unwrap();
    let _ = refrakt::scene::environment::load_image(&path);
});
