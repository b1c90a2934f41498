//! The Lua scene graph: world transforms of nested nodes, graph editing, the vector, rotation
//! and color helpers, and errors that carry the script's file:line.

mod common;

use common::*;
use glam::{EulerRot, Mat4, Quat, Vec3};
use refrakt::lua::{Limits, ScriptHost};

fn close(a: Vec3, b: Vec3, tol: f32) -> bool {
    (a - b).abs().max_element() < tol
}

fn mat_close(a: &Mat4, b: &Mat4) -> bool {
    a.to_cols_array().iter().zip(b.to_cols_array()).all(|(x, y)| (x - y).abs() < 1e-5)
}

/// Euler angles in degrees, X then Y then Z (Blender's "XYZ"), built axis by axis.
fn euler(x: f32, y: f32, z: f32) -> Mat4 {
    Mat4::from_rotation_z(z.to_radians()) * Mat4::from_rotation_y(y.to_radians()) * Mat4::from_rotation_x(x.to_radians())
}

/// Three nested nodes with rotations and non-uniform scales: the world matrix of each is the
/// product T·R·S of its ancestors and itself, as glTF defines it.
const NESTED: &str = r#"
local r = require("refrakt")
local scene = r.scene{ volume = { resolution = 16 } }
local base = scene:add(r.node{ name = "base", translation = {1, 2, 3}, rotation = {0, 0, 90}, scale = {2, 1, 0.5} })
local arm = base:add(r.node{ name = "arm", translation = {1, 0, 0}, rotation = {30, 0, 0}, scale = {1, 3, 1} })
arm:add(r.node{ name = "hand", translation = {0, 0.5, 0.2}, rotation = {0, 45, 10}, scale = {0.5, 0.25, 2},
                shape = r.box{ size = {0.1, 0.2, 0.3} }, material = r.diffuse{} })
arm:add(r.node{ name = "lamp", translation = {0, 1, 0}, light = r.spot{ intensity = 100 } })
base:add(r.node{ name = "gem", translation = {0, 0, 1}, rotation = {0, 90, 0},
                 shape = r.sphere{ radius = 0.1 }, material = r.glass{} })
return scene
"#;

#[test]
fn world_transforms_of_nested_nodes_match_glam_by_hand() {
    let desc = frame_from_lua(NESTED);
    let t = Mat4::from_translation;
    let s = Mat4::from_scale;
    let base = t(Vec3::new(1.0, 2.0, 3.0)) * euler(0.0, 0.0, 90.0) * s(Vec3::new(2.0, 1.0, 0.5));
    let arm = base * t(Vec3::X) * euler(30.0, 0.0, 0.0) * s(Vec3::new(1.0, 3.0, 1.0));
    let hand = arm * t(Vec3::new(0.0, 0.5, 0.2)) * euler(0.0, 45.0, 10.0) * s(Vec3::new(0.5, 0.25, 2.0));
    let gem = base * t(Vec3::Z) * euler(0.0, 90.0, 0.0);

    let receiver = desc.receivers.iter().find(|r| r.name == "hand").expect("the hand is a receiver");
    assert!(mat_close(&receiver.world, &hand), "hand:\n{}\nvs by hand\n{hand}", receiver.world);
    let field = desc.fields.iter().find(|f| f.name == "gem").expect("the gem is a field");
    assert!(mat_close(&field.world_to_local, &gem.inverse()), "gem");

    // A point worked through by hand: the arm's origin is base·(1, 0, 0) = T + Rz90·(2, 0, 0)
    // = (1, 2, 3) + (0, 2, 0); the non-uniform scale of the base stretches it to 2 first.
    assert!(close(arm.transform_point3(Vec3::ZERO), Vec3::new(1.0, 4.0, 3.0), 1e-5));
    // The lamp sits at arm·(0, 1, 0): the arm's 3× y scale, its 30° turn about x, then the base.
    let lamp = desc.lights.iter().find(|l| l.name == "lamp").unwrap();
    let by_hand = base.transform_point3(Vec3::X + euler(30.0, 0.0, 0.0).transform_vector3(Vec3::new(0.0, 3.0, 0.0)));
    assert!(close(lamp.position, by_hand, 1e-5), "{} vs {by_hand}", lamp.position);
}

#[test]
fn to_world_agrees_with_the_frame() {
    // The script places a point light at a corner of the hand's box, found with scene:to_world.
    let source = NESTED.replace(
        "return scene",
        "local corner = scene:to_world(scene:find(\"hand\"), {0.05, 0.1, 0.15})\n\
         scene:add(r.node{ name = \"probe\", translation = corner, light = r.point{} })\n\
         local o = scene:to_world(scene:find(\"arm\"))\n\
         assert(math.abs(o[1] - 1) < 1e-5 and math.abs(o[2] - 4) < 1e-5 and math.abs(o[3] - 3) < 1e-5)\n\
         return scene",
    );
    let desc = frame_from_lua(&source);
    let hand = desc.receivers.iter().find(|r| r.name == "hand").unwrap();
    let corner = hand.world.transform_point3(Vec3::new(0.05, 0.1, 0.15));
    let probe = desc.lights.iter().find(|l| l.name == "probe").unwrap();
    assert!(close(probe.position, corner, 1e-5), "{} vs {corner}", probe.position);
}

#[test]
fn rotations_follow_blender_xyz_euler_and_quaternion_helpers_agree() {
    let source = r#"
      local r = require("refrakt")
      local q = r.euler{30, 45, 60}
      local a = r.axis_angle({0, 0, 1}, 60) * r.axis_angle({0, 1, 0}, 45) * r.axis_angle({1, 0, 0}, 30)
      assert(math.abs(q.w - a.w) < 1e-6 and math.abs(q.x - a.x) < 1e-6, "euler = Rz·Ry·Rx")
      local e = q:euler()
      assert(math.abs(e[1] - 30) < 1e-3 and math.abs(e[2] - 45) < 1e-3 and math.abs(e[3] - 60) < 1e-3)
      local v = r.axis_angle({0, 1, 0}, 90) * {0, 0, -1}
      assert(math.abs(v[1] + 1) < 1e-6, "+90° about y turns −z to −x")
      local half = r.slerp(r.quat{1, 0, 0, 0}, r.axis_angle({0, 1, 0}, 90), 0.5)
      assert(math.abs(half:euler()[2] - 45) < 1e-3)
      local look = r.look_at({0, 0, 0}, {3, 0, 0})
      local fwd = look * {0, 0, -1}
      assert(math.abs(fwd[1] - 1) < 1e-6, "look_at turns −z toward the target")
      local up = look * {0, 1, 0}
      assert(math.abs(up[2] - 1) < 1e-6, "and keeps +y up")
      return r.scene{}
    "#;
    let (_dir, path) = write_script("scene.lua", source);
    load(&path);
    // The Rust side applies the same convention.
    let q = refrakt::lua::convert::euler_degrees(Vec3::new(30.0, 45.0, 60.0));
    let by_hand = Quat::from_euler(EulerRot::ZYX, 60f32.to_radians(), 45f32.to_radians(), 30f32.to_radians());
    assert!(q.abs_diff_eq(by_hand, 1e-6));
}

#[test]
fn vector_and_color_helpers() {
    let source = r##"
      local r = require("refrakt")
      local v = r.vec
      local function eq(a, b) return math.abs(a[1] - b[1]) + math.abs(a[2] - b[2]) + math.abs(a[3] - b[3]) < 1e-6 end
      assert(eq(v.add({1, 2, 3}, {1, 1, 1}), {2, 3, 4}))
      assert(eq(v.sub({1, 2, 3}, {1, 1, 1}), {0, 1, 2}))
      assert(eq(v.mul({1, 2, 3}, {2, 2, 0}), {2, 4, 0}))
      assert(eq(v.scale({1, 2, 3}, 2), {2, 4, 6}))
      assert(eq(v.cross({1, 0, 0}, {0, 1, 0}), {0, 0, 1}))
      assert(v.dot({1, 2, 3}, {4, 5, 6}) == 32)
      assert(v.length({3, 4, 0}) == 5 and v.distance({1, 1, 1}, {1, 1, 3}) == 2)
      assert(eq(v.normalize({0, 0, 2}), {0, 0, 1}))
      assert(eq(v.lerp({0, 0, 0}, {2, 4, 6}, 0.25), {0.5, 1, 1.5}))
      assert(eq(v.add({x = 1, y = 2, z = 3}, {0, 0, 0}), {1, 2, 3}), "named components work too")
      assert(eq(r.srgb("#ffffff"), {1, 1, 1}) and eq(r.srgb{0, 0, 0}, {0, 0, 0}))
      assert(math.abs(r.srgb{0.5, 0.5, 0.5}[1] - 0.21404) < 1e-4, "sRGB 0.5 is 0.214 linear")
      return r.scene{}
    "##;
    let (_dir, path) = write_script("scene.lua", source);
    load(&path);
}

fn assert_error(body: &str, needles: &[&str]) {
    let e = load_error(body, &Limits::default());
    for n in needles {
        assert!(e.contains(n), "the error should contain {n:?}:\n{e}");
    }
}

#[test]
fn helper_errors_name_the_line_and_argument() {
    assert_error("r.vec.normalize({0, 0, 0})", &["scene.lua:3:", "refrakt.vec.normalize: v must not be the zero vector"]);
    assert_error("local x = r.vec.add({1, 2}, {0, 0, 0})", &["scene.lua:3:", "refrakt.vec.add.a must be a vector {x, y, z}"]);
    assert_error("r.look_at({1, 1, 1}, {1, 1, 1})", &["scene.lua:3:", "from and to are the same point"]);
    assert_error("r.srgb(\"#ggg\")", &["scene.lua:3:", "not a hex color"]);
    assert_error("r.srgb{255, 128, 0}", &["scene.lua:3:", "divide by 255"]);
    assert_error("r.slerp(r.euler{0, 0, 0}, \"up\", 0.5)", &["scene.lua:3:", "refrakt.slerp.b must be Euler angles"]);
    assert_error("r.glass{ color = {1.5, 0.5, 0.5} }", &["scene.lua:3:", "glass.color must have components in (0, 1]"]);
    assert_error("r.glass{ color = {0, 0.5, 0.5}, distance = 0.1 }", &["scene.lua:3:", "glass.color must have components in (0, 1]"]);
    assert_error("r.camera{ aperture = -0.1 }", &["scene.lua:3:", "camera.aperture"]);
    assert_error("r.camera{ blades = 2 }", &["scene.lua:3:", "camera.blades must be 0 (a round aperture) or a whole number from 3 to 64"]);
    assert_error("r.camera{ focus = 0 }", &["scene.lua:3:", "camera.focus"]);
    assert_error("r.camera{ shift = {0.1} }", &["scene.lua:3:", "camera.shift must be a pair {x, y} of numbers from -10 to 10"]);
    assert_error("r.camera{ shift = {0, 11} }", &["scene.lua:3:", "camera.shift"]);
    assert_error("scene.shutter = -0.5", &["scene.lua:3:", "scene.shutter must be frames the shutter is open, from 0 (no motion blur) to 100"]);
    assert_error("scene.motion_steps = 0", &["scene.lua:3:", "scene.motion_steps"]);
    let blurred = frame_from_lua(
        r#"local r = require("refrakt")
        local scene = r.scene{ shutter = 0.5, motion_steps = 6 }
        assert(scene.shutter == 0.5 and scene.motion_steps == 6, "read back")
        return scene"#,
    );
    assert_eq!(blurred.motion_blur, Some(refrakt::scene::MotionBlur { shutter: 0.5, steps: 6 }));
    assert_eq!(frame_from_lua("return require('refrakt').scene{}").motion_blur, None, "no shutter by default");
}

/// A camera's thin lens: set and read back; the scene camera's focus defaults to its target's
/// distance, a node camera's (placed by its node, not a target) to 10 m.
#[test]
fn a_camera_lens_reads_back_and_focuses_on_its_target_by_default() {
    let lua = |focus: &str| {
        frame_from_lua(&format!(
            r#"local r = require("refrakt")
            local cam = r.camera{{ position = {{0, 0, 4}}, target = {{0, 0, 1}}, aperture = 0.02, blades = 7, blade_rotation = 10 }}
            assert(cam.aperture == 0.02 and cam.blades == 7 and math.abs(cam.blade_rotation - 10) < 1e-4, "fields read back")
            assert(cam.focus == nil, "no focus set")
            {focus}
            return r.scene{{ camera = cam }}"#
        ))
    };
    let c = lua("").camera;
    assert_eq!((c.aperture, c.focus, c.blades), (0.02, 3.0, 7));
    assert_eq!(lua("cam.focus = 1.5; assert(cam.focus == 1.5)").camera.focus, 1.5);
    let shifted = lua("cam.shift = {0.1, -0.25}; assert(cam.shift[1] == 0.1 and cam.shift[2] == -0.25, 'shift reads back')").camera;
    assert_eq!(shifted.shift, glam::Vec2::new(0.1, -0.25));
    let on_node = frame_from_lua(
        r#"local r = require("refrakt")
        local scene = r.scene{}
        scene:add(r.node{ translation = {0, 0, 2}, camera = r.camera{ aperture = 0.01 } })
        return scene"#,
    );
    assert_eq!(on_node.camera.focus, refrakt::scene::Lens::DEFAULT_FOCUS);
}

#[test]
fn graph_editing() {
    let source = r#"
      local r = require("refrakt")
      local scene = r.scene{}
      local a = scene:add(r.node{ name = "a" })
      local b = a:add(r.node{ name = "b" })
      local c = b:add(r.node{ name = "c" })
      assert(scene:find("c") == c and a:find("c") == c and scene:find("nobody") == nil)
      assert(#scene.children == 1 and scene.children[1] == a and #a.children == 1)
      assert(scene:remove(c) and scene:find("c") == nil and not scene:remove(c))
      b.children = { c }
      assert(a:remove(c) and #b.children == 0)
      scene.children = { a, r.node{ name = "d" } }
      assert(scene:find("d") ~= nil)
      return scene
    "#;
    let (_dir, path) = write_script("scene.lua", source);
    load(&path);
}

#[test]
fn cycles_are_refused() {
    assert_error("local a = r.node{}\nlocal b = a:add(r.node{})\nb:add(a)", &["scene.lua:5:", "its own ancestor"]);
    assert_error("local a = r.node{}\nlocal b = a:add(r.node{})\nb.children = { a }", &["scene.lua:5:", "its own ancestor"]);
    assert_error("local a = r.node{}\na.children = { a }", &["scene.lua:4:", "its own ancestor"]);
}

#[test]
fn errors_carry_file_and_line() {
    assert_error("local x = = 1", &["scene.lua:3:", "unexpected symbol"]);
    assert_error("local t = nil\nprint(t.x)", &["scene.lua:4:", "attempt to index a nil value"]);
    assert_error("scene:add(r.node{ light = r.point{ intensity = \"bright\" } })", &["scene.lua:3:", "point.intensity must be a number ≥ 0, got \"bright\""]);
    assert_error("local n = r.node{}\nn.tranlsation = {0, 1, 0}", &["scene.lua:4:", "node has no field \"tranlsation\" (did you mean translation?)"]);
    assert_error("scene.camra = r.camera{}", &["scene.lua:3:", "did you mean camera?"]);
    assert_error("scene:add(r.sphere{ radius = 1 })", &["scene.lua:3:", "scene:add.node must be a refrakt.node{…}, got a refrakt.sphere"]);
}

#[test]
fn errors_in_modules_name_the_module_file() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("lib")).unwrap();
    std::fs::write(dir.path().join("lib/glass.lua"), "local r = require(\"refrakt\")\nreturn r.glass{ ior = 9 }\n").unwrap();
    let path = dir.path().join("scene.lua");
    std::fs::write(&path, "local r = require(\"refrakt\")\nlocal g = require(\"lib.glass\")\nreturn r.scene{}\n").unwrap();
    let e = format!("{:#}", ScriptHost::load(&path, &[], &Limits::default()).err().unwrap());
    assert!(e.contains("lib/glass.lua:2:") && e.contains("glass.ior must be a number from 1 to 4, got 9"), "{e}");
}

#[test]
fn modules_are_loaded_once_and_shared() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("materials.lua"), "local r = require(\"refrakt\")\nloads = (loads or 0) + 1\nreturn { water = r.glass{ ior = 1.33 } }\n").unwrap();
    let path = dir.path().join("scene.lua");
    std::fs::write(
        &path,
        "local r = require(\"refrakt\")\nlocal a = require(\"materials\")\nlocal b = require(\"materials\")\n\
         assert(a == b and a.water == b.water and loads == 1)\nreturn r.scene{}\n",
    )
    .unwrap();
    let host = ScriptHost::load(&path, &[], &Limits::default()).unwrap_or_else(|e| panic!("{e:#}"));
    let read: Vec<String> = host.files_read().iter().map(|p| p.file_name().unwrap().to_string_lossy().into()).collect();
    assert_eq!(read, ["scene.lua", "materials.lua"], "watch sees the module");
}

#[test]
fn update_errors_name_their_line() {
    let source = "local r = require(\"refrakt\")\nlocal scene = r.scene{}\nlocal ball = scene:add(r.node{ name = \"ball\" })\n\
                  function update(scene, t)\n  ball.translation = {0, t, \"up\"}\nend\nreturn scene\n";
    let (_dir, path) = write_script("scene.lua", source);
    let host = load(&path);
    let e = format!("{:#}", host.update(0.5).err().unwrap());
    assert!(e.contains("scene.lua:5:") && e.contains("node.translation must be a vector"), "{e}");
}

#[test]
fn param_returns_its_default_and_checks_its_settings() {
    let (_dir, path) = write_script(
        "scene.lua",
        "local r = require(\"refrakt\")\nlocal a = r.param{ name = \"ior\", default = 1.5, min = 1, max = 2 }\n\
         local b = r.param{ name = \"ior\", default = 1.5, min = 1, max = 2 }\nassert(a == b)\nreturn r.scene{}\n",
    );
    let host = load(&path);
    let params = host.params();
    assert_eq!(params.len(), 1);
    assert_eq!((params[0].value, params[0].min, params[0].max, params[0].step), (1.5, 1.0, 2.0, 0.01));
    let set = std::collections::BTreeMap::from([("ior".to_string(), 7.0)]);
    let clamped = refrakt::lua::ScriptHost::load_with_params(&path, &[], &Default::default(), &set).unwrap();
    assert_eq!(clamped.params()[0].value, 2.0, "a value set from outside is clamped to the range");

    let limits = Default::default();
    for (body, says) in [
        ("r.param{ name = \"x\", default = 1, min = 2, max = 1 }", "min (2) must be less than max (1)"),
        ("r.param{ name = \"x\", default = 5, min = 0, max = 1 }", "outside min..max"),
        ("r.param{ name = \"x\", default = 0, min = 0 }", "param.max"),
        ("r.param{ name = \"x\", default = 0, min = 0, max = 1, slider = 2 }", "has no field \"slider\""),
        ("r.param{ name = \"x\", default = 0, min = 0, max = 1 }\nr.param{ name = \"x\", default = 0, min = 0, max = 2 }", "declared twice"),
    ] {
        let e = load_error(body, &limits);
        assert!(e.contains("scene.lua:") && e.contains(says), "{body}: {e}");
    }
}
