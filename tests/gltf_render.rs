//! A KHR_materials_volume glass sphere from a glTF file renders like the Lua scene of the same
//! index and attenuation: exactly like the Lua mesh of the same icosphere, and like the
//! analytic Lua sphere up to the facets' difference. A base color texture on a glTF floor is
//! sampled on the GPU as its CPU twin `Texture2d::sample` samples it.

mod common;

use common::gltf_builder::GltfBuilder;
use common::*;
use refrakt::scene::mesh::icosphere;
use serde_json::json;

const R: f32 = 0.4;
const IOR: f32 = 1.5;
/// White light keeps this color after DISTANCE metres of the glass.
const COLOR: [f32; 3] = [0.8, 0.6, 0.4];
const DISTANCE: f32 = 0.5;

/// A Lua scene around one ball: `ball` is the node expression (a refrakt.node or an import).
fn scene(ball: &str) -> String {
    format!(
        r#"local r = require("refrakt")
        local scene = r.scene{{
          camera = r.camera{{ position = {{0.3, 0.4, 2.2}}, target = {{0, 0, 0}}, fov = 28, size = {{64, 64}} }},
          environment = r.environment{{ preset = "checker" }},
          volume = {{ resolution = 64 }},
          samples = 1,
        }}
        scene:add({ball})
        return scene"#
    )
}

fn glass_lua(absorbing: bool) -> String {
    if absorbing {
        format!("r.glass{{ ior = {IOR}, color = {{{}, {}, {}}}, distance = {DISTANCE} }}", COLOR[0], COLOR[1], COLOR[2])
    } else {
        format!("r.glass{{ ior = {IOR} }}")
    }
}

/// ball.glb: the same icosphere as `refrakt.icosphere{radius = R}` (4 subdivisions), with the
/// normals refrakt smooths it with (as an exporter writes a smooth sphere's), its material glass
/// by KHR_materials_transmission + _ior + _volume.
fn write_ball(dir: &std::path::Path) {
    let mesh = icosphere(R, 4);
    let mut g = GltfBuilder::new();
    for ext in ["KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_volume"] {
        g.uses(ext, false);
    }
    let m = g.push("materials", json!({ "pbrMetallicRoughness": { "metallicFactor": 0.0, "roughnessFactor": 0.0 }, "extensions": {
        "KHR_materials_transmission": { "transmissionFactor": 1.0 },
        "KHR_materials_ior": { "ior": IOR },
        "KHR_materials_volume": { "thicknessFactor": 0.8, "attenuationColor": COLOR, "attenuationDistance": DISTANCE } } }));
    let positions: Vec<[f32; 3]> = mesh.positions.iter().map(|p| p.to_array()).collect();
    // A sphere has no creases: each vertex's corners share one normal.
    let mut normals = vec![0.0f32; 3 * positions.len()];
    for (t, corners) in mesh.triangles.iter().zip(mesh.corner_normals()) {
        for (&i, n) in t.iter().zip(corners) {
            normals[3 * i as usize..3 * i as usize + 3].copy_from_slice(&n.to_array());
        }
    }
    let normals = g.floats(&normals, "VEC3");
    let mesh = g.mesh(&positions, &mesh.triangles, Some(m));
    g.json["meshes"][mesh]["primitives"][0]["attributes"]["NORMAL"] = json!(normals);
    let n = g.push("nodes", json!({ "name": "ball", "mesh": mesh }));
    g.scene("Ball", &[n]);
    g.write_glb(&dir.join("ball.glb"));
}

fn render(source: &str, dir: &std::path::Path, r: &mut refrakt::pipeline::Renderer) -> Vec<f32> {
    let path = dir.join("scene.lua");
    std::fs::write(&path, source).unwrap();
    let host = load(&path);
    host.update(0.0).unwrap();
    let desc = refrakt::scene::eval::evaluate(&host.scene().borrow(), 0.0, &Default::default()).unwrap();
    r.frame(&desc).unwrap().layer("beauty").unwrap().data.clone()
}

fn mae(a: &[f32], b: &[f32]) -> f32 {
    mean(&a.iter().zip(b).map(|(x, y)| (x - y).abs()).collect::<Vec<_>>())
}

#[test]
fn a_gltf_volume_glass_sphere_renders_like_the_lua_one() {
    let dir = tempfile::tempdir().unwrap();
    write_ball(dir.path());
    let mut r = shared_renderer();
    let gltf = render(&scene(r#"r.gltf("ball.glb")"#), dir.path(), &mut r);
    let node = |shape: &str, absorbing: bool| format!("r.node{{ name = \"ball\", shape = {shape}, material = {} }}", glass_lua(absorbing));
    let lua_mesh = render(&scene(&node(&format!("r.icosphere{{ radius = {R}, subdivisions = 4 }}"), true)), dir.path(), &mut r);
    let lua_sphere = render(&scene(&node(&format!("r.sphere{{ radius = {R} }}"), true)), dir.path(), &mut r);
    let clear = render(&scene(&node(&format!("r.icosphere{{ radius = {R}, subdivisions = 4 }}"), false)), dir.path(), &mut r);
    let covered = gltf.chunks(4).filter(|p| p[3] > 0.0).count();
    let (same_mesh, vs_sphere, vs_clear) = (mae(&gltf, &lua_mesh), mae(&gltf, &lua_sphere), mae(&gltf, &clear));
    eprintln!(
        "glTF ball vs Lua icosphere MAE {same_mesh:.2e}, vs the analytic sphere {vs_sphere:.4}, vs clear glass {vs_clear:.4} \
         (64², 64³, {covered} pixels see the ball)"
    );
    assert!(covered > 800, "the ball should fill much of the image");
    // Same triangles, index and σ = −ln(color)/distance as the Lua glass computes: the frame
    // is deterministic, so the images are the same (the bound allows only float noise).
    assert!(same_mesh < 1e-6, "glTF vs Lua mesh of the same icosphere: MAE {same_mesh}");
    // The analytic sphere differs by the 5120 facets, which shift the refracted checker's edges
    // a little; measured on lavapipe: 0.0026 (tests/mesh_optics.rs finds 0.0027 for a finer
    // mesh at 96²). The bound leaves about 2× room.
    assert!(vs_sphere < 0.006, "glTF ball vs analytic sphere: MAE {vs_sphere}");
    // The absorption matters at that scale (measured 0.052), so a glTF import that dropped or
    // misread KHR_materials_volume would fail both checks above.
    assert!(vs_clear > 10.0 * vs_sphere.max(1e-3), "absorption must change the image: {vs_clear}");
}

/// floor.glb: a 2 m × 2 m floor at y = 0 with texture coordinates 0..2 (so the 4×4 texture
/// continues past its edge once each way, as its sampler's `wrap` [wrapS, wrapT] says: default
/// repeat), textured or plain white.
fn write_floor(dir: &std::path::Path, name: &str, textured: bool, wrap: Option<[u32; 2]>) {
    let mut g = GltfBuilder::new();
    // Lambertian (metallic 0, KHR_materials_specular 0), so textured / white is the texture.
    let mut pbr = json!({ "baseColorFactor": [1.0, 1.0, 1.0, 1.0], "metallicFactor": 0.0 });
    if textured {
        // 4×4 texels of scattered colors, so a shifted or nearest lookup shows.
        let bytes: Vec<u8> = (0..16u32).flat_map(|i| [(i * 53 % 256) as u8, (i * 97 % 256) as u8, (255 - i * 31 % 256) as u8, 255]).collect();
        let mut png = Vec::new();
        let img = image::RgbaImage::from_raw(4, 4, bytes).unwrap();
        image::DynamicImage::ImageRgba8(img).write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png).unwrap();
        let view = g.view(&png);
        g.push("images", json!({ "bufferView": view, "mimeType": "image/png" }));
        match wrap {
            Some([s, t]) => {
                g.push("samplers", json!({ "wrapS": s, "wrapT": t }));
                g.push("textures", json!({ "source": 0, "sampler": 0 }))
            }
            None => g.push("textures", json!({ "source": 0 })),
        };
        pbr["baseColorTexture"] = json!({ "index": 0 });
    }
    g.uses("KHR_materials_specular", false);
    let m = g.push("materials", json!({ "pbrMetallicRoughness": pbr, "extensions": { "KHR_materials_specular": { "specularFactor": 0.0 } } }));
    let pos = g.floats(&[-1.0, 0.0, -1.0, 1.0, 0.0, -1.0, 1.0, 0.0, 1.0, -1.0, 0.0, 1.0], "VEC3");
    let uv = g.floats(&[0.0, 0.0, 2.0, 0.0, 2.0, 2.0, 0.0, 2.0], "VEC2");
    let idx = g.uints(&[0, 2, 1, 0, 3, 2], "SCALAR", 5125);
    g.push("meshes", json!({ "primitives": [{ "attributes": { "POSITION": pos, "TEXCOORD_0": uv }, "indices": idx, "material": m }] }));
    let n = g.push("nodes", json!({ "name": "floor", "mesh": 0 }));
    g.scene("Floor", &[n]);
    g.write_glb(&dir.join(name));
}

/// The texture seen from above against `Texture2d::sample`, with the default sampler (repeat)
/// and with CLAMP_TO_EDGE along u and MIRRORED_REPEAT along v (the floor's second tile shows
/// each mode; a swapped axis or a repeat in their place errs by ~0.3).
#[test]
fn a_base_color_texture_is_sampled_on_the_receiver_like_its_cpu_twin() {
    let dir = tempfile::tempdir().unwrap();
    write_floor(dir.path(), "textured.glb", true, None);
    write_floor(dir.path(), "clamp_mirror.glb", true, Some([33071, 33648]));
    write_floor(dir.path(), "white.glb", false, None);
    // Looking straight down at the floor, lit only by a uniform environment: the radiance of a
    // texel is albedo × the environment, so textured / white is the texture's color there.
    let floor = |file: &str| {
        format!(
            r#"local r = require("refrakt")
            local scene = r.scene{{
              camera = r.camera{{ position = {{0.05, 1.6, 0.03}}, target = {{0.05, 0, 0.03}}, up = {{0, 0, -1}}, fov = 50, size = {{48, 48}} }},
              environment = r.environment{{ color = {{0.5, 0.5, 0.5}} }},
              samples = 1, photons = 0,
            }}
            scene:add(r.gltf("{file}"))
            return scene"#
        )
    };
    let mut r = shared_renderer();
    let white = render(&floor("white.glb"), dir.path(), &mut r);
    for file in ["textured.glb", "clamp_mirror.glb"] {
        let path = dir.path().join("scene.lua");
        std::fs::write(&path, floor(file)).unwrap();
        let host = load(&path);
        host.update(0.0).unwrap();
        let desc = refrakt::scene::eval::evaluate(&host.scene().borrow(), 0.0, &Default::default()).unwrap();
        let texture = desc.receivers[0].diffuse.texture.clone().expect("the floor has its texture");
        let textured = r.frame(&desc).unwrap().layer("beauty").unwrap().data.clone();
        let mut errors = Vec::new();
        for y in 0..48 {
            for x in 0..48 {
                // The camera ray through the pixel's centre meets y = 0 at p; the floor maps
                // x, z ∈ [−1, 1] to u, v ∈ [0, 2].
                let d = desc.camera.ray(x, y);
                let p = desc.camera.position + d * (-desc.camera.position.y / d.y);
                let want = texture.sample(glam::Vec2::new(p.x + 1.0, p.z + 1.0));
                let i = 4 * (y * 48 + x) as usize;
                for c in 0..3 {
                    errors.push((textured[i + c] / white[i + c] - want[c]).abs());
                }
            }
        }
        eprintln!("{file}: texture on the receiver vs Texture2d::sample ({:?}): mean {:.2e}, max {:.2e}", texture.wrap, mean(&errors), max(&errors));
        // The texels go to the GPU in their own 8-bit sRGB encoding (exactly the decoded bytes
        // again), so what is left is float noise in the interpolation: measured 1.3e-6 at most
        // on lavapipe. A half-texel shift or a nearest lookup errs by ~0.1.
        assert!(max(&errors) < 1e-4, "{file}: max error {}", max(&errors));
    }
    // The CPU twin itself is held to each mode's closed form in src/scene/material.rs.
}

/// An asymmetric solid (a tetrahedron off the origin) mirrored by its node's scale −1 in x, and
/// the same solid with its vertices mirrored by hand (and its winding flipped): the voxelized
/// index grids agree, voxel for voxel. (The material's smooth `boundary` keeps the closed mesh
/// in the grid rather than a sharp interface.)
#[test]
fn a_mirrored_gltf_mesh_voxelizes_as_its_mirror_image() {
    let tetra = [[0.1f32, 0.0, 0.0], [0.6, 0.0, 0.0], [0.1, 0.45, 0.0], [0.1, 0.0, 0.5]];
    let tris = [[0u32, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
    let glb = |positions: &[[f32; 3]], tris: &[[u32; 3]], scale: [f32; 3]| {
        let mut g = GltfBuilder::new();
        g.uses("KHR_materials_transmission", false);
        let m = g.push(
            "materials",
            json!({ "pbrMetallicRoughness": { "metallicFactor": 0.0 }, "extensions": { "KHR_materials_transmission": { "transmissionFactor": 1.0 } }, "extras": { "refrakt": { "boundary": 3 } } }),
        );
        let mesh = g.mesh(positions, tris, Some(m));
        let n = g.push("nodes", json!({ "name": "solid", "mesh": mesh, "scale": scale }));
        g.scene("S", &[n]);
        g
    };
    let dir = tempfile::tempdir().unwrap();
    glb(&tetra, &tris, [-1.0, 1.0, 1.0]).write_glb(&dir.path().join("mirrored.glb"));
    let by_hand: Vec<[f32; 3]> = tetra.iter().map(|p| [-p[0], p[1], p[2]]).collect();
    let flipped: Vec<[u32; 3]> = tris.iter().map(|t| [t[0], t[2], t[1]]).collect();
    glb(&by_hand, &flipped, [1.0, 1.0, 1.0]).write_glb(&dir.path().join("by_hand.glb"));
    let mut r = shared_renderer();
    let mut grid = |file: &str| {
        let source = format!(
            r#"local r = require("refrakt")
            local scene = r.scene{{ volume = {{ min = {{-0.7, -0.1, -0.1}}, max = {{0.1, 0.5, 0.6}}, resolution = 32 }} }}
            scene:add(r.gltf("{file}"))
            return scene"#
        );
        let path = dir.path().join("scene.lua");
        std::fs::write(&path, source).unwrap();
        let host = load(&path);
        host.update(0.0).unwrap();
        let desc = refrakt::scene::eval::evaluate(&host.scene().borrow(), 0.0, &Default::default()).unwrap();
        assert!(desc.meshes[0].world.determinant() < 0.0 || file == "by_hand.glb");
        r.build_volume(&desc).unwrap();
        let n: Vec<f32> = bytemuck::cast_slice(&refrakt::gpu::readback::read_buffer(&r.ctx, &r.grids().unwrap().index_field).unwrap()).to_vec();
        n
    };
    let (mirrored, by_hand) = (grid("mirrored.glb"), grid("by_hand.glb"));
    let inside = mirrored.iter().filter(|n| **n > 1.25).count();
    assert!(inside > 50, "the solid covers voxels ({inside})");
    let worst = mirrored.iter().zip(&by_hand).map(|(a, b)| (a - b).abs()).fold(0.0, f32::max);
    assert!(worst < 1e-6, "mirrored by the node vs by hand: n differs by up to {worst}");
}

/// A glTF orthographic camera (xmag 1, ymag 0.5: a 2 m × 1 m view) looking straight down at a
/// glowing 0.5 m square, from 1 m and from 4 m: the square fills the same 8 × 8 of the 32 × 16
/// pixels from both heights (parallel rays: no perspective), and each pixel is lit exactly
/// where the CPU twin's ray (`origin_through`, `ray_through`) meets the square.
#[test]
fn an_orthographic_camera_sees_without_perspective() {
    let dir = tempfile::tempdir().unwrap();
    let mut r = shared_renderer();
    for height in [1.0f32, 4.0] {
        let mut g = GltfBuilder::new();
        let m = g.push("materials", json!({ "pbrMetallicRoughness": { "baseColorFactor": [0.0, 0.0, 0.0, 1.0] }, "emissiveFactor": [1.0, 1.0, 1.0] }));
        let h = 0.25;
        let mesh = g.mesh(&[[-h, 0.0, -h], [h, 0.0, -h], [h, 0.0, h], [-h, 0.0, h]], &[[0, 2, 1], [0, 3, 2]], Some(m));
        let square = g.push("nodes", json!({ "name": "square", "mesh": mesh }));
        g.push("cameras", json!({ "type": "orthographic", "orthographic": { "xmag": 1.0, "ymag": 0.5, "znear": 0.01, "zfar": 100.0 } }));
        let s = std::f32::consts::FRAC_1_SQRT_2;
        let camera = g.push("nodes", json!({ "name": "top", "camera": 0, "translation": [0.0, height, 0.0], "rotation": [-s, 0.0, 0.0, s] }));
        let scene = g.scene("S", &[square, camera]);
        g.json["scenes"][scene]["extras"] = json!({ "refrakt": { "environment": { "color": [0, 0, 0] }, "photons": 0, "samples": 1 } });
        let path = g.write_glb(&dir.path().join("ortho.glb"));
        let loaded = refrakt::render::GltfScene::load(&path, &[], &Default::default()).unwrap();
        let opts = refrakt::scene::eval::EvalOptions { size: Some((32, 16)), ..Default::default() };
        let desc = refrakt::scene::eval::evaluate(&loaded.scene, 0.0, &opts).unwrap();
        assert_eq!(desc.camera.orthographic, Some(1.0), "ymag is half the view's height");
        let beauty = r.frame(&desc).unwrap().layer("beauty").unwrap().data.clone();
        let (mut lit, mut disagree) = (0, 0);
        for y in 0..16u32 {
            for x in 0..32u32 {
                let pixel = glam::Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
                let (o, d) = (desc.camera.origin_through(pixel), desc.camera.ray_through(pixel));
                let p = o + d * (-o.y / d.y);
                let cpu = p.x.abs() < h && p.z.abs() < h;
                let gpu = beauty[4 * (y * 32 + x) as usize] > 0.5;
                lit += usize::from(gpu);
                disagree += usize::from(cpu != gpu);
            }
        }
        eprintln!("orthographic camera {height} m above the square: {lit} pixels lit, {disagree} disagree with the CPU twin");
        assert_eq!((lit, disagree), (64, 0), "{height} m");
    }
}

/// A 16 × 1 PNG of these texels (rgba), added to `g` as texture 0 … n; returns its index.
fn column_texture(g: &mut GltfBuilder, texels: &[[u8; 4]; 16]) -> usize {
    let mut png = Vec::new();
    let img = image::RgbaImage::from_raw(16, 1, texels.concat()).unwrap();
    image::DynamicImage::ImageRgba8(img).write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png).unwrap();
    let view = g.view(&png);
    let image = g.push("images", json!({ "bufferView": view, "mimeType": "image/png" }));
    g.push("textures", json!({ "source": image }))
}

/// textured_ball.glb: a closed icosphere of radius R (3 subdivisions) of clear glass whose
/// texture coordinates project x across u (u = ½ + x / 2.04 R: the ball's −x half samples the
/// texture's left half), with the roughness and tint factors given and, optionally, a
/// metallic-roughness texture (green = `roughness`, one value per column) and a base colour
/// texture (one rgb per column).
fn write_textured_ball(dir: &std::path::Path, name: &str, roughness: f32, tint: [f32; 3], roughness_texture: Option<[u8; 16]>, tint_texture: Option<[[u8; 3]; 16]>) {
    let mesh = icosphere(R, 3);
    let mut g = GltfBuilder::new();
    g.uses("KHR_materials_transmission", false);
    g.uses("KHR_materials_volume", false);
    let mut pbr = json!({ "baseColorFactor": [tint[0], tint[1], tint[2], 1.0], "metallicFactor": 0.0, "roughnessFactor": roughness });
    if let Some(t) = tint_texture {
        pbr["baseColorTexture"] = json!({ "index": column_texture(&mut g, &t.map(|[r, g, b]| [r, g, b, 255])) });
    }
    if let Some(t) = roughness_texture {
        pbr["metallicRoughnessTexture"] = json!({ "index": column_texture(&mut g, &t.map(|v| [0, v, 0, 255])) });
    }
    let m = g.push("materials", json!({ "pbrMetallicRoughness": pbr, "extensions": {
        "KHR_materials_transmission": { "transmissionFactor": 1.0 }, "KHR_materials_volume": { "thicknessFactor": 0.8 } } }));
    let positions: Vec<f32> = mesh.positions.iter().flat_map(|p| p.to_array()).collect();
    let uvs: Vec<f32> = mesh.positions.iter().flat_map(|p| [0.5 + p.x / (2.04 * R), 0.5 + p.z / (2.04 * R)]).collect();
    let pos = g.floats(&positions, "VEC3");
    let uv = g.floats(&uvs, "VEC2");
    let idx = g.uints(&mesh.triangles.concat(), "SCALAR", 5125);
    g.push("meshes", json!({ "primitives": [{ "attributes": { "POSITION": pos, "TEXCOORD_0": uv }, "indices": idx, "material": m }] }));
    let n = g.push("nodes", json!({ "name": "ball", "mesh": 0 }));
    g.scene("Ball", &[n]);
    g.write_glb(&dir.join(name));
}

/// MAE over the pixels of image columns `columns` (64-wide RGBA images).
fn mae_in(a: &[f32], b: &[f32], columns: std::ops::Range<usize>) -> f32 {
    let pick = |img: &[f32]| -> Vec<f32> { img.chunks(4 * 64).flat_map(|row| row[4 * columns.start..4 * columns.end].to_vec()).collect() };
    mae(&pick(a), &pick(b))
}

/// Glass whose roughness factor is 1 (the glTF default) and whose metallic-roughness texture
/// says 0 renders as clear glass, exactly; a texture of 1 as the frosted glass of factor 1; a
/// texture clear on the ball's −x half and frosted on its +x half splits the image so. A base
/// colour texture tints the light that crosses there like the factor does — the camera's rays
/// and the photons alike: with a sun over a floor the caustic is the same.
#[test]
fn textures_on_glass_vary_its_roughness_and_tint_where_the_light_crosses() {
    let dir = tempfile::tempdir().unwrap();
    let white = [1.0; 3];
    write_textured_ball(dir.path(), "clear.glb", 0.0, white, None, None);
    write_textured_ball(dir.path(), "frosted.glb", 1.0, white, None, None);
    write_textured_ball(dir.path(), "texture0.glb", 1.0, white, Some([0; 16]), None);
    write_textured_ball(dir.path(), "texture1.glb", 1.0, white, Some([255; 16]), None);
    let halves: [u8; 16] = std::array::from_fn(|i| if i < 8 { 0 } else { 255 });
    write_textured_ball(dir.path(), "halves.glb", 1.0, white, Some(halves), None);
    let mut r = shared_renderer();
    let mut view = |file: &str| render(&scene(&format!("r.gltf(\"{file}\")")), dir.path(), &mut r);
    let (clear, frosted) = (view("clear.glb"), view("frosted.glb"));
    let (texture0, texture1, split) = (view("texture0.glb"), view("texture1.glb"), view("halves.glb"));
    let apart = mae(&clear, &frosted);
    let (zero, one) = (mae(&texture0, &clear), mae(&texture1, &frosted));
    // The ball spans about columns 14–50; the camera's right is +x. Each half away from the
    // texture's seam (and the seam's ray paths that cross over) is compared.
    let (left, right) = (14..28, 36..50);
    let (left_clear, left_frosted) = (mae_in(&split, &clear, left.clone()), mae_in(&split, &frosted, left));
    let (right_clear, right_frosted) = (mae_in(&split, &clear, right.clone()), mae_in(&split, &frosted, right));
    eprintln!(
        "textured glass (64², checker): clear vs frosted MAE {apart:.4}; texture 0 vs clear {zero:.2e}, texture 1 vs frosted {one:.2e}; \
         split, −x half vs clear {left_clear:.4} / frosted {left_frosted:.4}, +x half vs clear {right_clear:.4} / frosted {right_frosted:.4}"
    );
    assert!(apart > 0.02, "frosted glass must look different from clear: {apart}");
    // Factor × texel is the same number as the factor alone: the images agree to float noise.
    assert!(zero < 1e-5 && one < 1e-5, "texture 0 vs clear {zero}, texture 1 vs frosted {one}");
    assert!(left_clear < 0.25 * left_frosted, "the −x half is clear: {left_clear} vs {left_frosted}");
    // (Light that enters the frosted half and leaves through the clear one, or bounces inside
    // between them, differs from the all-frosted ball's: more so since rough crossings keep the
    // energy masking took (pipeline::rough_albedo) — 0.066 against 0.148, where it was 0.020
    // against 0.099.)
    assert!(right_frosted < 0.5 * right_clear, "the +x half is frosted: {right_frosted} vs {right_clear}");

    // The tint, on the camera's rays and on the photons that make the floor's caustic.
    let red = [1.0, 0.2, 0.2];
    write_textured_ball(dir.path(), "red_factor.glb", 0.0, red, None, None);
    write_textured_ball(dir.path(), "red_texture.glb", 0.0, white, None, Some([[255, 124, 124]; 16]));
    let mut sunlit = |file: &str| {
        let source = format!(
            r#"local r = require("refrakt")
            local scene = r.scene{{
              camera = r.camera{{ position = {{0, 1.2, 2.6}}, target = {{0.3, -0.9, 0}}, fov = 50, size = {{64, 64}} }},
              environment = r.environment{{ color = {{0.05, 0.05, 0.05}} }},
              volume = {{ resolution = 48 }}, samples = 1, photons = 40000,
            }}
            scene:add(r.node{{ shape = r.plane{{ size = {{3, 3}} }}, material = r.diffuse{{ color = {{0.8, 0.8, 0.8}} }}, translation = {{0, -0.9, 0}} }})
            scene:add(r.node{{ light = r.sun{{ direction = {{0.5, -1, 0}}, intensity = 1000 }} }})
            scene:add(r.gltf("{file}"))
            return scene"#
        );
        render(&source, dir.path(), &mut r)
    };
    let (by_factor, by_texture, untinted) = (sunlit("red_factor.glb"), sunlit("red_texture.glb"), sunlit("clear.glb"));
    let (same, tinted) = (mae(&by_factor, &by_texture), mae(&by_factor, &untinted));
    eprintln!("tint (64², sun over a floor, 40k photons): texture vs factor MAE {same:.2e}, tinted vs clear {tinted:.4}");
    // sRGB 124/255 decodes to 0.2016 where the factor is 0.2: 0.8 % more green and blue, 7e-6
    // in this image (measured on lavapipe). The sun's caustic lies beside the ball, in view: a
    // march that left the texture out (white photons, a tinted view) errs by 4.6e-3, and
    // leaving it out everywhere by the whole `tinted` difference (0.010).
    assert!(tinted > 0.005, "the tint must show: {tinted}");
    assert!(same < 0.05 * tinted, "a tint texture must tint like its factor: {same} vs {tinted}");
}
