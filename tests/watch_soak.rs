//! A soak test of `refrakt watch`: many edits of every kind in a row — writes in place, saves
//! by rename, syntax errors and their fixes, mesh changes — each checked to show in the preview
//! (no edit missed or merged away), with the process's memory and the edit-to-frame latency
//! sampled. On lavapipe the GPU's buffers live in the process, so its resident memory (RSS)
//! covers them too; the renderer's grid allocations must not grow either.
//!
//! CI runs 200 edits at the default debounce. A long run by hand:
//! `REFRAKT_SOAK_EDITS=2000 cargo test --release --test watch_soak -- --nocapture`.

mod common;

use std::time::{Duration, Instant};

use common::watch::*;

/// Growth of resident memory allowed between the end of the warm-up and the last edit: the
/// allocator's slack, plus 16 KiB per edit (lavapipe's leak of a shader variant per volume
/// rebuild, now avoided, was ~60 KiB per edit of this mix; 2000 edits measured +0 MiB).
const RSS_SLACK_MIB: f64 = 4.0;
const RSS_GROWTH_PER_EDIT_MIB: f64 = 16.0 / 1024.0;
/// Edits before the memory baseline is taken (allocators and driver caches settle).
const WARM_UP: usize = 20;

const GEM: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";

/// A ball and an OBJ gem in front of the environment color `env`.
fn scene(env: &str) -> String {
    ball(env).replace(
        "return scene",
        "scene:add(r.node{ name = \"gem\", translation = {0.6, 0, 0}, scale = 0.3, shape = r.mesh{ file = \"gem.obj\" }, \
         material = r.glass{ ior = 1.4 } })\nreturn scene",
    )
}

/// Resident memory of process `pid`, MiB (Linux).
fn rss_mib(pid: u32) -> Option<f64> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let line = status.lines().find(|l| l.starts_with("VmRSS:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}

#[cfg(target_os = "linux")]
#[test]
fn many_edits_of_every_kind_all_show_and_memory_stays_bounded() {
    let edits: usize = std::env::var("REFRAKT_SOAK_EDITS").ok().and_then(|v| v.parse().ok()).unwrap_or(200);
    let dir = folder_with(&[("scene.lua", &scene("0.2, 0.3, 0.4")), ("gem.obj", GEM)]);
    let (path, out, gem) = (dir.path().join("scene.lua"), dir.path().join("preview.exr"), dir.path().join("gem.obj"));
    let debounce = refrakt::watch::DEFAULT_DEBOUNCE.as_millis().to_string();
    let mut w = Watch::start(&path, &out, &["--no-progressive", "--debounce", &debounce]);
    w.frame();
    let pid = w.child.id();
    let (mut latencies, mut rss) = (Vec::new(), Vec::new());
    let mut baseline = None;
    let mut allocations = None;
    for i in 0..edits {
        let color = [(i % 10) as f32 / 10.0 + 0.05, 0.5, ((i / 10) % 10) as f32 / 10.0 + 0.05];
        let env = format!("{}, {}, {}", color[0], color[1], color[2]);
        let saved = Instant::now();
        // A write in place, a save by rename, a mesh change, a syntax error, its fix.
        let (expect_error, mesh) = (i % 5 == 3, i % 5 == 2);
        match i % 5 {
            0 => write(&path, &scene(&env)),
            2 => write(&gem, &GEM.replace("v 0 0 1", &format!("v 0 0 {}", 1.0 + (i % 7) as f32 * 0.05))),
            3 => save_by_rename(&path, &scene(&env).replace("samples = 1", "samples = = 1")),
            _ => save_by_rename(&path, &scene(&env)),
        }
        let event = w.next();
        latencies.push(saved.elapsed().as_secs_f64());
        let kind = event["event"].as_str().unwrap_or_default().to_string();
        assert_eq!(kind, if expect_error { "error" } else { "frame" }, "edit {i}\n{}", w.history());
        if expect_error {
            assert!(event["message"].as_str().unwrap().contains("scene.lua:6:"), "{event}");
        } else if !mesh {
            assert_color(&out, color);
        }
        if !expect_error {
            let grids = event["stats"]["grid_allocations"].as_u64();
            assert_eq!(*allocations.get_or_insert(grids), grids, "the volume's size never changes, so its grids are kept: {event}");
        }
        if i % 10 == 0 || i + 1 == edits {
            let mib = rss_mib(pid).expect("the process's memory");
            rss.push((i, mib));
            if i == WARM_UP {
                baseline = Some(mib);
            }
        }
        // Nothing else comes of one edit (an error edit renders nothing).
        if let Ok(extra) = w.events.recv_timeout(Duration::from_millis(30)) {
            w.seen.push(extra.clone());
            assert!(!matches!(extra["event"].as_str(), Some("frame" | "error")), "one event per edit, yet {extra}\n{}", w.history());
        }
    }
    let last = rss.last().unwrap().1;
    let baseline = baseline.unwrap_or(rss[0].1);
    let mut sorted = latencies.clone();
    sorted.sort_by(f64::total_cmp);
    eprintln!(
        "{edits} edits: save → event median {:.0} ms, p95 {:.0} ms, max {:.0} ms; RSS after {WARM_UP} edits {baseline:.0} MiB, \
         at the end {last:.0} MiB (max {:.0} MiB); samples {:?}",
        1e3 * percentile(&sorted, 0.5),
        1e3 * percentile(&sorted, 0.95),
        1e3 * sorted[sorted.len() - 1],
        rss.iter().map(|r| r.1).fold(0.0, f64::max),
        rss.iter().map(|&(i, m)| (i, m.round() as u64)).collect::<Vec<_>>()
    );
    let bound = RSS_SLACK_MIB + RSS_GROWTH_PER_EDIT_MIB * edits as f64;
    assert!(last - baseline <= bound, "resident memory grew {:.1} MiB over {edits} edits (bound {bound:.1} MiB)", last - baseline);
}
