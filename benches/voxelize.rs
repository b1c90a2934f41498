//! GPU time of the voxelize stage on the two meshes: the Stanford bunny (5000
//! triangles) at 128³ and a 100 820-triangle blob at 256³. Run with
//!
//!     cargo bench --profile dev --bench voxelize [-- path/to/bunny.obj] [--runs N]
//!
//! (the GPU's time does not depend on how the Rust is optimized). The bunny is read from the
//! argument, `$REFRAKT_BUNNY`, or `../shared/assets/bunny.obj`.

use std::path::PathBuf;
use std::sync::Arc;

use refrakt::gpu::GpuContext;
use refrakt::pipeline::Renderer;
use refrakt::pipeline::voxelize_mesh::benchmark;
use refrakt::scene::{mesh, obj};

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).filter(|a| a != "--bench").collect();
    let runs = args.iter().position(|a| a == "--runs").and_then(|i| args.get(i + 1)).map_or(Ok(5), |n| n.parse())?;
    let bunny = args
        .iter()
        .find(|a| a.ends_with(".obj"))
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("REFRAKT_BUNNY").map(PathBuf::from))
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/assets/bunny.obj"));
    let ctx = GpuContext::new(None)?;
    let adapter = ctx.adapter_name();
    let mut renderer = Renderer::new(ctx)?;
    let cases = [("bunny", Arc::new(obj::load(&bunny)?), 128), ("blob-100k", Arc::new(mesh::blob(0.5, 0.15, 1, 71)), 256)];
    for (name, m, resolution) in cases {
        match benchmark(&mut renderer, m, resolution, runs)? {
            Some(t) => println!(
                "{{\"mesh\": \"{name}\", \"triangles\": {}, \"volume\": [{}, {}, {}], \"voxelize_meshes_ms\": {:.3}, \
                 \"voxelize_composite_ms\": {:.3}, \"voxelize_ms\": {:.3}, \"runs\": {runs}, \"adapter\": {:?}}}",
                t.triangles, t.dims.x, t.dims.y, t.dims.z, t.meshes_ms, t.composite_ms, t.meshes_ms + t.composite_ms, adapter
            ),
            None => anyhow::bail!("the adapter \"{adapter}\" has no timestamp queries; GPU times cannot be measured"),
        }
    }
    Ok(())
}
