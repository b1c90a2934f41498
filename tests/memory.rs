//! Frame after frame, refrakt's memory stays where it is: scenes rendered again and again with
//! the reuse of unchanged stages turned off, so every stage runs every frame. On lavapipe the
//! GPU's buffers and the driver's compiled shaders live in the process, so the process's heap
//! and resident memory cover them too.
//!
//! Why this exists: Mesa 22.3's lavapipe specialises a compute shader on the values of uniforms
//! that its loop bounds and branches read ("uniform inlining") and, where that shrinks the shader
//! enough, compiles the variant again at every dispatch without freeing the last one. With
//! `voxelize.wgsl` looping up to `params.field_count`, every volume rebuild (every edit in
//! `watch`, every frame of an animation) grew the process by ~0.5 MiB. The heap is what shows
//! it: resident memory can stay flat for a while as the leak fills memory freed earlier.

mod common;

use common::*;

/// Frames rendered before the baseline is taken (allocators and driver caches settle).
const WARM_UP: usize = 4;
/// Frames measured after the baseline.
const FRAMES: usize = 20;
/// Growth of the heap allowed over the measured frames (the leak above: ~10 MiB).
const HEAP_GROWTH_BOUND_MIB: f64 = 1.0;
/// Growth of resident memory allowed over the measured frames.
const RSS_GROWTH_BOUND_MIB: f64 = 4.0;

/// `watch_soak`'s scene: a glass ball and a glass tetrahedron mesh, no lights.
const BALL_AND_GEM: &str = r#"local r = require("refrakt")
local scene = r.scene{
  camera = r.camera{ position = {0, 0, 3}, target = {0, 0, 0}, fov = 35, size = {32, 24} },
  environment = r.environment{ color = {0.2, 0.3, 0.4} },
  volume = { resolution = 20 },
  samples = 1,
}
scene:add(r.node{ name = "ball", shape = r.sphere{ radius = 0.4 }, material = r.glass{ ior = 1.5 } })
scene:add(r.node{ name = "gem", translation = {0.6, 0, 0}, scale = 0.3,
                  shape = r.mesh{ vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}},
                                  triangles = {{1, 3, 2}, {1, 2, 4}, {1, 4, 3}, {2, 3, 4}} },
                  material = r.glass{ ior = 1.4 } })
return scene
"#;

/// Every stage: dispersive sharp glass, a mesh, a gradient-index lens, fog, a floor, a sun and
/// a spot.
const EVERY_STAGE: &str = r#"local r = require("refrakt")
local scene = r.scene{
  camera = r.camera{ position = {0, 0.6, 3}, target = {0, 0, 0}, fov = 35, size = {40, 24} },
  environment = r.environment{ color = {0.1, 0.1, 0.12} },
  volume = { resolution = 24, min = {-1, -1, -1}, max = {1, 1, 1} },
  fog = r.fog{ density = 0.2 },
  photons = 3000, samples = 1,
}
scene:add(r.node{ name = "ball", translation = {-0.4, 0, 0}, shape = r.sphere{ radius = 0.3 },
                  material = r.glass{ ior = 1.5, abbe = 20 } })
scene:add(r.node{ name = "lens", translation = {0.4, 0, 0}, shape = r.luneburg{ radius = 0.3 } })
scene:add(r.node{ name = "gem", translation = {0, 0.5, 0}, scale = 0.3,
                  shape = r.mesh{ vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}},
                                  triangles = {{1, 3, 2}, {1, 2, 4}, {1, 4, 3}, {2, 3, 4}} },
                  material = r.glass{ ior = 1.4 } })
scene:add(r.node{ name = "floor", translation = {0, -0.9, 0}, shape = r.plane{ size = {2, 2} },
                  material = r.diffuse{ color = {0.8, 0.8, 0.8} } })
scene:add(r.node{ name = "sun", light = r.sun{ direction = {0.2, -1, 0.1}, intensity = 683 } })
scene:add(r.node{ name = "spot", translation = {0, 0.95, 0.5},
                  light = r.spot{ target = {0, -0.9, 0}, intensity = 500, angle = 30 } })
return scene
"#;

/// Resident memory of this process, MiB.
fn rss_mib() -> f64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap();
    let line = status.lines().find(|l| l.starts_with("VmRSS:")).unwrap();
    line.split_whitespace().nth(1).unwrap().parse::<f64>().unwrap() / 1024.0
}

/// glibc's `struct mallinfo2`.
#[repr(C)]
struct MallocInfo {
    arena: usize,
    ordblks: usize,
    smblks: usize,
    hblks: usize,
    hblkhd: usize,
    usmblks: usize,
    fsmblks: usize,
    uordblks: usize,
    fordblks: usize,
    keepcost: usize,
}

unsafe extern "C" {
    fn mallinfo2() -> MallocInfo;
}

/// Bytes in use on the heap, all arenas (the driver's threads included), MiB.
fn heap_mib() -> f64 {
    // SAFETY: mallinfo2 only reads the allocator's statistics (glibc 2.33 and later).
    let info = unsafe { mallinfo2() };
    (info.uordblks + info.hblkhd) as f64 / (1 << 20) as f64
}

/// Renders `source` WARM_UP + FRAMES times; (heap, resident) growth over the last FRAMES, MiB.
fn growth_over_frames(source: &str) -> (f64, f64) {
    let desc = frame_from_lua(source);
    let mut r = renderer();
    r.settings.reuse_unchanged = false;
    for _ in 0..WARM_UP {
        r.frame(&desc).unwrap();
    }
    let (heap, rss) = (heap_mib(), rss_mib());
    for _ in 0..FRAMES {
        r.frame(&desc).unwrap();
    }
    (heap_mib() - heap, rss_mib() - rss)
}

#[cfg(all(target_os = "linux", target_env = "gnu"))]
#[test]
fn frame_after_frame_memory_stays_bounded() {
    for (name, source) in [("ball and gem", BALL_AND_GEM), ("every stage", EVERY_STAGE)] {
        let (heap, rss) = growth_over_frames(source);
        println!("{name}: over {FRAMES} frames after {WARM_UP}, heap {heap:+.2} MiB, resident {rss:+.2} MiB");
        assert!(heap < HEAP_GROWTH_BOUND_MIB, "{name}: the heap grew {heap:.2} MiB over {FRAMES} frames (bound {HEAP_GROWTH_BOUND_MIB})");
        assert!(rss < RSS_GROWTH_BOUND_MIB, "{name}: resident memory grew {rss:.2} MiB over {FRAMES} frames (bound {RSS_GROWTH_BOUND_MIB})");
    }
}
