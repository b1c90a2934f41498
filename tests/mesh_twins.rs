//! The mesh-solid kernels (`shaders/voxelize_mesh.wgsl`) against their CPU twin
//! (`refrakt::cpu::mesh`) on small meshes: identical parity bits (so identical inside/outside
//! at every voxel), fixed-point vertices within one unit, distances within f32 rounding.

mod common;

use common::*;
use refrakt::cpu::mesh as twin;
use refrakt::frame::FrameDesc;
use refrakt::pipeline::voxelize_mesh::{self, FAR, MeshWindow};

/// Compares the GPU's solid of the scene's only mesh with the twin's.
fn compare(name: &str, desc: &FrameDesc) {
    let mut r = renderer();
    r.build_volume(desc).unwrap();
    let m = &desc.meshes[0];
    let stage = r.mesh_voxels();
    let window = stage.window(0).expect("the mesh is in the volume");
    assert_eq!(Some(window), MeshWindow::of(m, &desc.volume));
    let (_, words, vertices) = stage.read_scratch(&r.ctx).unwrap();
    let gpu_sd = stage.read_signed_distance(&r.ctx, 0).unwrap();

    let bits = voxelize_mesh::fixed_bits(desc.volume.dims);
    let transform = voxelize_mesh::grid_from_local(m, &desc.volume);
    let cpu_vertices = twin::grid_vertices(&m.mesh.positions, &transform, &window, bits);
    let worst_vertex = vertices.iter().zip(&cpu_vertices).map(|(g, c)| (*g - *c).abs().max_element()).max().unwrap();
    // The 4×4 transform may round differently (fused multiply–add on the GPU); snapping to
    // fixed point then differs by at most one unit (1/2^bits voxel).
    assert!(worst_vertex <= 1, "{name}: fixed-point vertices differ by {worst_vertex} units");

    // From the GPU's own vertices, the twin must reproduce every parity bit.
    let triangles = m.mesh.solid_triangles();
    let cpu_words = twin::parity_words(&vertices, &triangles, &window, bits);
    let differing = words.iter().zip(&cpu_words).filter(|(a, b)| a != b).count();
    assert_eq!(differing, 0, "{name}: {differing} of {} parity words differ", words.len());

    let inside = twin::inside(&window, &cpu_words);
    let reach = voxelize_mesh::reach(m, &desc.volume);
    let cpu_sd = twin::signed_distance(&inside, &twin::band_distance(&vertices, &triangles, &window, bits, reach));
    let mut worst = 0.0f32;
    for (i, (g, c)) in gpu_sd.iter().zip(&cpu_sd).enumerate() {
        assert_eq!(g.is_sign_negative(), c.is_sign_negative(), "{name}: voxel {i} inside on one side only ({g} vs {c})");
        if g.abs() == FAR || c.abs() == FAR {
            // Out of reach on one side: the other can only be a hair within it.
            let near = if g.abs() == FAR { c.abs() } else { g.abs() };
            assert!(near == FAR || near > reach - 1e-4, "{name}: voxel {i}: {g} vs {c}");
        } else {
            worst = worst.max((g - c).abs());
        }
    }
    assert!(worst < 1e-4, "{name}: distances differ by up to {worst} voxels");
    let solid = inside.iter().filter(|&&i| i).count();
    eprintln!("{name}: window {}, {solid} voxels inside, {} parity words identical, distances within {worst:.1e}", window.dims, words.len());
    assert!(solid > 0 && solid < inside.len(), "{name}: the test should have both inside and outside");
}

fn scene(volume: &str, nodes: &str) -> FrameDesc {
    frame_from_lua(&format!(
        r#"local r = require("refrakt")
        local scene = r.scene{{ volume = {{ {volume} }} }}
        {nodes}
        return scene"#
    ))
}

#[test]
fn rotated_blob_matches_twin() {
    compare(
        "blob",
        &scene(
            "resolution = 40",
            r#"scene:add(r.node{ rotation = {23, 41, -17}, shape = r.blob{ radius = 0.4, detail = 8, seed = 3 },
                                 material = r.glass{ ior = 1.5 } })"#,
        ),
    );
}

#[test]
fn torus_with_large_triangles_matches_twin() {
    // Few segments: long triangles that take the large-work path.
    compare(
        "torus",
        &scene(
            "resolution = 48",
            r#"scene:add(r.node{ rotation = {60, 10, 0}, shape = r.torus{ major_radius = 0.5, minor_radius = 0.2,
                                 major_segments = 7, minor_segments = 5 }, material = r.glass{ ior = 1.5 } })"#,
        ),
    );
}

#[test]
fn open_soup_and_huge_cube_match_twin() {
    // A random triangle soup (not closed: the vote decides) in a fixed box.
    let mut rng = Rng(0xfeed);
    let mut verts = Vec::new();
    let mut tris = Vec::new();
    for t in 0..60 {
        for _ in 0..3 {
            verts.push(format!("{{{}, {}, {}}}", rng.range(-0.5, 0.5), rng.range(-0.5, 0.5), rng.range(-0.5, 0.5)));
        }
        tris.push(format!("{{{}, {}, {}}}", 3 * t + 1, 3 * t + 2, 3 * t + 3));
    }
    compare(
        "soup",
        &scene(
            "resolution = 32, min = {-0.5, -0.5, -0.5}, max = {0.5, 0.5, 0.5}",
            &format!(
                "scene:add(r.node{{ shape = r.mesh{{ vertices = {{{}}}, triangles = {{{}}} }}, material = r.glass{{}} }})",
                verts.join(", "),
                tris.join(", ")
            ),
        ),
    );
    // A cube far larger than the fixed volume, its corner inside it: clipped, still solid.
    compare(
        "huge cube",
        &scene(
            "resolution = 24, min = {-0.5, -0.5, -0.5}, max = {0.5, 0.5, 0.5}",
            r#"scene:add(r.node{ translation = {2.3, 2.2, 2.1}, rotation = {5, 3, 0}, shape = r.cube{ size = {5, 5, 5} },
                                 material = r.glass{} })"#,
        ),
    );
}
