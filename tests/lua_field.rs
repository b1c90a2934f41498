//! Index fields defined by a script function, `refrakt.field{n = function(x, y, z) … end}`:
//! sampled on the CPU at voxel centres, composited on the GPU like the analytic fields.

mod common;

use common::*;
use refrakt::cpu;
use refrakt::frame::FieldKind;
use refrakt::gpu::readback;
use refrakt::lua::{Limits, ScriptHost};
use refrakt::scene::eval::{EvalOptions, evaluate};

/// A function-defined field (rotated, non-uniformly scaled, with absorption) overlapping an
/// analytic sphere that is composited after it.
const SCENE: &str = r#"
local r = require("refrakt")
local scene = r.scene{ volume = { resolution = 40, margin = 0.02 } }
scene:add(r.node{ name = "rod", translation = {0.05, 0, 0}, rotation = {10, 25, 40}, scale = {1.2, 0.8, 1},
                  shape = r.field{ size = {0.6, 0.3, 0.4},
                                   n = function(x, y, z) return 1.5 - 2.0 * (x * x + z * z) + 0.3 * y end },
                  material = r.glass{ absorption = {0.5, 0.2, 0} } })
scene:add(r.node{ name = "ball", translation = {0.25, 0.1, 0}, shape = r.sphere{ radius = 0.15 },
                  material = r.glass{ ior = 1.33 } })
return scene
"#;

#[test]
fn voxelize_of_a_sampled_field_matches_cpu() {
    let desc = frame_from_lua(SCENE);
    let FieldKind::Sampled(samples) = &desc.fields[0].kind else { panic!("the rod is a sampled field") };
    assert!(samples.values.len() > 1000, "the block covers the rod: {:?}", samples.dims);
    let mut r = renderer();
    r.build_volume(&desc).unwrap();
    let gpu: Vec<f32> = bytemuck::cast_slice(&readback::read_buffer(&r.ctx, &r.grids().unwrap().index_field).unwrap()).to_vec();
    let cpu = cpu::field::rasterize(&desc.fields, &desc.volume);
    let worst = gpu.iter().zip(&cpu).map(|(a, b)| (a - b).abs()).fold(0.0, f32::max);
    // The same f32 formulas on both sides; only the analytic sphere's sqrt may round differently.
    assert!(worst < 2e-5, "largest difference in n between GPU and CPU: {worst}");
    assert!(cpu.iter().any(|&n| n > 1.45), "the rod's interior index is reached");
    // And a second frame with a moved rod (a resized block, the samples buffer refilled).
    let moved = SCENE.replace("translation = {0.05, 0, 0}", "translation = {-0.1, 0.05, 0}");
    let desc = frame_from_lua(&moved);
    r.build_volume(&desc).unwrap();
    let gpu: Vec<f32> = bytemuck::cast_slice(&readback::read_buffer(&r.ctx, &r.grids().unwrap().index_field).unwrap()).to_vec();
    let cpu = cpu::field::rasterize(&desc.fields, &desc.volume);
    let worst = gpu.iter().zip(&cpu).map(|(a, b)| (a - b).abs()).fold(0.0, f32::max);
    assert!(worst < 2e-5, "after moving: {worst}");
}

/// `n = ior + gradient · y` written as a function gives the analytic slab's grid: the function
/// sees the node's local coordinates, in metres, centred on the node. (With a hard boundary:
/// within a smooth one the slab continues its gradient outward, a function field its surface
/// value.)
#[test]
fn a_function_field_reproduces_the_analytic_slab() {
    let scene = |shape: &str| {
        format!(
            r#"local r = require("refrakt")
            local scene = r.scene{{ volume = {{ resolution = 32, boundary = 0, min = {{-0.5, -0.5, -0.5}}, max = {{0.5, 0.5, 0.5}} }} }}
            scene:add(r.node{{ translation = {{0.05, -0.02, 0}}, rotation = {{0, 30, 20}}, shape = {shape} }})
            return scene"#
        )
    };
    let slab = frame_from_lua(&scene("r.slab{ size = {0.6, 0.3, 0.5}, ior = 1.4, gradient = 0.8 }"));
    let field = frame_from_lua(&scene("r.field{ size = {0.6, 0.3, 0.5}, n = function(x, y, z) return 1.4 + 0.8 * y end }"));
    let a = cpu::field::rasterize(&slab.fields, &slab.volume);
    let b = cpu::field::rasterize(&field.fields, &field.volume);
    let worst = a.iter().zip(&b).map(|(a, b)| (a - b).abs()).fold(0.0, f32::max);
    assert!(worst < 1e-6, "function field vs analytic slab: {worst}");
    assert!(a.iter().any(|&n| n > 1.45) && a.iter().any(|&n| n < 1.35 && n > 1.01), "the gradient is inside the grid");
}

#[test]
fn the_function_is_asked_only_about_its_own_box() {
    // Outside the box (within the smooth boundary) n is continued from the box's surface.
    let desc = frame_from_lua(
        r#"local r = require("refrakt")
        local scene = r.scene{ volume = { resolution = 24, boundary = 4 } }
        scene:add(r.node{ rotation = {0, 45, 0}, shape = r.field{ size = {0.4, 0.2, 0.3}, n = function(x, y, z)
          assert(math.abs(x) <= 0.2 + 1e-6 and math.abs(y) <= 0.1 + 1e-6 and math.abs(z) <= 0.15 + 1e-6,
                 "asked outside the box")
          return 1.5
        end } })
        return scene"#,
    );
    let FieldKind::Sampled(samples) = &desc.fields[0].kind else { panic!() };
    assert!(samples.values.iter().all(|&n| n == 1.5));
}

/// The error evaluating the scene `body` fails with (a short time budget only where asked, so
/// a loaded machine cannot turn the other cases into timeouts).
fn field_error_within(body: &str, budget: std::time::Duration) -> String {
    let source = format!("local r = require(\"refrakt\")\nlocal scene = r.scene{{ volume = {{ resolution = 16 }} }}\n{body}\nreturn scene\n");
    let (_dir, path) = write_script("scene.lua", &source);
    let limits = Limits { time_budget: budget, ..Limits::default() };
    let host = match ScriptHost::load(&path, &[], &limits) {
        Ok(h) => h,
        Err(e) => return format!("{e:#}"),
    };
    let scene = host.scene().borrow();
    format!("{:#}", evaluate(&scene, 0.0, &EvalOptions::default()).expect_err("must fail"))
}

fn field_error(body: &str) -> String {
    field_error_within(body, Limits::default().time_budget)
}

#[test]
fn a_bad_value_names_where_the_function_was_defined_and_the_point() {
    let e = field_error("scene:add(r.node{ shape = r.field{ size = {1, 1, 1},\n  n = function(x, y, z)\n    if x > 0.2 then return nil end\n    return 1.2\n  end } })");
    assert!(e.contains("scene.lua:4: field.n(") && e.contains("returned nil") && e.contains("from 1 to 4"), "{e}");
    let e = field_error("scene:add(r.node{ shape = r.field{ size = {2, 1, 1}, n = function(x, y, z) return math.sqrt(1 - 4 * x * x) + 1 end } })");
    assert!(e.contains("scene.lua:3: field.n(") && e.contains("returned nan"), "{e}");
}

#[test]
fn errors_inside_the_function_carry_their_line() {
    let e = field_error("scene:add(r.node{ shape = r.field{ size = {1, 1, 1}, n = function(x, y, z)\n  return x.y\nend } })");
    assert!(e.contains("scene.lua:4:") && e.contains("attempt to index"), "{e}");
    let e = field_error_within(
        "scene:add(r.node{ shape = r.field{ size = {1, 1, 1}, n = function(x, y, z)\n  while true do end\nend } })",
        std::time::Duration::from_millis(300),
    );
    assert!(e.contains("scene.lua:4:") && e.contains("ran for more than"), "{e}");
}

#[test]
fn the_function_cannot_change_the_scene_being_evaluated() {
    let e = field_error("scene:add(r.node{ shape = r.field{ size = {1, 1, 1}, n = function(x, y, z)\n  scene.photons = 5\n  return 1.5\nend } })");
    assert!(e.contains("scene.lua:4: the scene cannot be changed while a frame is being evaluated"), "{e}");
}

#[test]
fn field_constructor_errors() {
    let e = field_error("scene:add(r.node{ shape = r.field{ size = {1, 1, 1} } })");
    assert!(e.contains("scene.lua:3: field needs a field \"n\""), "{e}");
    let e = field_error("scene:add(r.node{ shape = r.field{ n = 1.5, size = {1, 1, 1} } })");
    assert!(e.contains("scene.lua:3: field.n must be a function(x, y, z)"), "{e}");
    let e = field_error("scene:add(r.node{ shape = r.field{ n = function() return 1 end } })");
    assert!(e.contains("scene.lua:3: field needs a field \"size\""), "{e}");
    let e = field_error("scene:add(r.node{ shape = r.field{ n = function() return 1 end, size = {1, 1, 1} }, material = r.diffuse{} })");
    assert!(e.contains("scene.lua:3:") && e.contains("must be glass, not diffuse"), "{e}");
}
