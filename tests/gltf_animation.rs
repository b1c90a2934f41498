//! glTF animation against the glTF 2.0 spec's formulas, computed here independently in f64:
//! STEP, LINEAR (slerp for rotations) and CUBICSPLINE (Hermite, tangents scaled by the keyframe
//! interval, quaternions normalized) at and between keyframes; morph weights; a skinned mesh's
//! vertices at a pose; animations chosen by name; a Lua `update` on top of a glTF animation.

mod common;

use std::path::{Path, PathBuf};
use std::sync::Arc;

use common::gltf_builder::GltfBuilder;
use glam::{DQuat, DVec3, DVec4, Mat4, Quat, Vec3};
use refrakt::gltf::ImportOptions;
use refrakt::render::GltfScene;
use refrakt::scene::{MeshData, Normals, Scene, Shape};
use serde_json::json;

/// Keyframe times with unequal intervals, so a formula that forgets t_d fails.
const TIMES: [f32; 3] = [0.0, 1.0, 3.0];
/// Times to check: before, at and between keyframes, and after the last.
const PROBES: [f32; 8] = [-0.5, 0.0, 0.25, 1.0, 1.7, 2.2, 3.0, 4.5];

fn load(path: &Path, opts: &ImportOptions) -> GltfScene {
    GltfScene::load(path, &[], opts).unwrap_or_else(|e| panic!("{e:#}"))
}

fn write(g: &GltfBuilder, name: &str) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let path = g.write_glb(&dir.path().join(name));
    (dir, path)
}

/// An animation's channels and samplers, as they are added.
#[derive(Default)]
struct Anim {
    channels: Vec<serde_json::Value>,
    samplers: Vec<serde_json::Value>,
}

impl Anim {
    /// A channel on node `node`: a sampler over TIMES with `values` (already laid out as the
    /// interpolation needs: 3 per keyframe for CUBICSPLINE).
    fn channel(&mut self, g: &mut GltfBuilder, node: usize, path: &str, interpolation: &str, values: &[f32], kind: &str) {
        let input = g.floats(&TIMES, "SCALAR");
        let output = g.floats(values, kind);
        self.samplers.push(json!({ "input": input, "output": output, "interpolation": interpolation }));
        self.channels.push(json!({ "sampler": self.samplers.len() - 1, "target": { "node": node, "path": path } }));
    }

    fn add_to(self, g: &mut GltfBuilder, name: &str) {
        g.push("animations", json!({ "name": name, "channels": self.channels, "samplers": self.samplers }));
    }
}

/// The keyframe interval [k, k+1] holding t and the fraction u, or the clamped end keyframe.
enum At {
    Key(usize),
    Between(usize, f64),
}

fn locate(t: f32) -> At {
    let t = t as f64;
    let times: Vec<f64> = TIMES.iter().map(|&x| x as f64).collect();
    if t <= times[0] {
        return At::Key(0);
    }
    if t >= times[2] {
        return At::Key(2);
    }
    let k = if t < times[1] { 0 } else { 1 };
    At::Between(k, (t - times[k]) / (times[k + 1] - times[k]))
}

fn interval(k: usize) -> f64 {
    (TIMES[k + 1] - TIMES[k]) as f64
}

/// Appendix C.3, in f64: p = (2u³−3u²+1)vₖ + t_d(u³−2u²+u)bₖ + (−2u³+3u²)vₖ₊₁ + t_d(u³−u²)aₖ₊₁.
fn hermite(v0: DVec4, b0: DVec4, v1: DVec4, a1: DVec4, td: f64, u: f64) -> DVec4 {
    let (u2, u3) = (u * u, u * u * u);
    v0 * (2.0 * u3 - 3.0 * u2 + 1.0) + b0 * (td * (u3 - 2.0 * u2 + u)) + v1 * (-2.0 * u3 + 3.0 * u2) + a1 * (td * (u3 - u2))
}

/// Appendix C.2, in f64: a = acos|q₀·q₁|, s = sign(q₀·q₁), q = sin(a(1−u))/sin a · q₀ + s·sin(au)/sin a · q₁.
fn slerp(q0: DVec4, q1: DVec4, u: f64) -> DVec4 {
    let d = q0.dot(q1);
    let a = d.abs().acos();
    let s = d.signum();
    q0 * ((a * (1.0 - u)).sin() / a.sin()) + q1 * (s * (a * u).sin() / a.sin())
}

fn d4(v: &[f32]) -> DVec4 {
    DVec4::new(v[0] as f64, v[1] as f64, v[2] as f64, v.get(3).copied().unwrap_or(0.0) as f64)
}

fn node_transform(s: &Scene, name: &str) -> refrakt::scene::Transform {
    s.find(name).unwrap().borrow().transform
}

#[test]
fn translation_step_linear_and_cubic_spline_match_the_spec_at_and_between_keyframes() {
    let mut g = GltfBuilder::new();
    let values: [[f32; 3]; 3] = [[0.0, 1.0, 2.0], [3.0, -1.0, 0.5], [-2.0, 4.0, 1.0]];
    // CUBICSPLINE: (in-tangent, value, out-tangent) per keyframe.
    let tangents_in: [[f32; 3]; 3] = [[9.0, 9.0, 9.0], [1.0, 2.0, -3.0], [0.5, -0.5, 2.0]];
    let tangents_out: [[f32; 3]; 3] = [[-1.0, 0.5, 4.0], [2.0, 0.0, -1.0], [9.0, 9.0, 9.0]];
    let nodes: Vec<usize> = ["step", "linear", "cubic"].iter().map(|n| g.push("nodes", json!({ "name": n }))).collect();
    let mut anim = Anim::default();
    let flat: Vec<f32> = values.iter().flatten().copied().collect();
    anim.channel(&mut g, nodes[0], "translation", "STEP", &flat, "VEC3");
    anim.channel(&mut g, nodes[1], "translation", "LINEAR", &flat, "VEC3");
    let cubic: Vec<f32> = (0..3).flat_map(|k| [tangents_in[k], values[k], tangents_out[k]]).flatten().collect();
    anim.channel(&mut g, nodes[2], "translation", "CUBICSPLINE", &cubic, "VEC3");
    anim.add_to(&mut g, "move");
    g.scene("S", &nodes);
    let (_dir, path) = write(&g, "t.glb");
    let mut s = load(&path, &ImportOptions::default());
    for t in PROBES {
        s.player.pose(t as f64);
        let (step, linear, cubic) = match locate(t) {
            At::Key(k) => (d4(&values[k]), d4(&values[k]), d4(&values[k])),
            At::Between(k, u) => (
                d4(&values[k]),
                d4(&values[k]) * (1.0 - u) + d4(&values[k + 1]) * u,
                hermite(d4(&values[k]), d4(&tangents_out[k]), d4(&values[k + 1]), d4(&tangents_in[k + 1]), interval(k), u),
            ),
        };
        for (name, want) in [("step", step), ("linear", linear), ("cubic", cubic)] {
            let got = node_transform(&s.scene, name).translation.as_dvec3();
            assert!((got - want.truncate()).length() < 1e-5, "{name} at t = {t}: {got} vs {want}");
        }
    }
}

#[test]
fn rotation_linear_is_a_shortest_arc_slerp_and_cubic_spline_is_normalized() {
    let mut g = GltfBuilder::new();
    // q₂ is on the far hemisphere from q₁: the slerp must flip it (the shorter arc).
    let qs = [Quat::IDENTITY, Quat::from_rotation_y(1.2), -Quat::from_euler(glam::EulerRot::XYZ, 0.4, 2.0, -0.3)];
    assert!(qs[1].dot(qs[2]) < 0.0);
    let nodes: Vec<usize> = ["linear", "cubic", "scaled"].iter().map(|n| g.push("nodes", json!({ "name": n }))).collect();
    let mut anim = Anim::default();
    let flat: Vec<f32> = qs.iter().flat_map(|q| q.to_array()).collect();
    anim.channel(&mut g, nodes[0], "rotation", "LINEAR", &flat, "VEC4");
    let tan = [[0.1f32, -0.2, 0.3, 0.0], [0.5, 0.1, -0.4, 0.2], [-0.3, 0.2, 0.1, 0.1]];
    let cubic: Vec<f32> = (0..3).flat_map(|k| [tan[k], qs[k].to_array(), tan[2 - k]]).flatten().collect();
    anim.channel(&mut g, nodes[1], "rotation", "CUBICSPLINE", &cubic, "VEC4");
    let scales = [1.0f32, 1.0, 1.0, 2.0, 0.5, 1.0, 0.25, 3.0, 1.5];
    anim.channel(&mut g, nodes[2], "scale", "LINEAR", &scales, "VEC3");
    anim.add_to(&mut g, "animation");
    g.scene("S", &nodes);
    let (_dir, path) = write(&g, "r.glb");
    let mut s = load(&path, &ImportOptions::default());
    let q4 = |q: Quat| d4(&q.to_array());
    for t in PROBES {
        s.player.pose(t as f64);
        let (linear, cubic, scale) = match locate(t) {
            At::Key(k) => (q4(qs[k]), q4(qs[k]), d4(&scales[3 * k..3 * k + 3])),
            At::Between(k, u) => (
                slerp(q4(qs[k]), q4(qs[k + 1]), u),
                hermite(q4(qs[k]), d4(&tan[2 - k]), q4(qs[k + 1]), d4(&tan[k + 1]), interval(k), u).normalize(),
                d4(&scales[3 * k..3 * k + 3]) * (1.0 - u) + d4(&scales[3 * k + 3..3 * k + 6]) * u,
            ),
        };
        // q and −q are the same rotation.
        let same = |got: Quat, want: DVec4| {
            let got = q4(got);
            (got - want).length().min((got + want).length())
        };
        let tr = |n: &str| node_transform(&s.scene, n);
        assert!(same(tr("linear").rotation, linear) < 1e-5, "slerp at t = {t}: {:?} vs {linear}", tr("linear").rotation);
        assert!(same(tr("cubic").rotation, cubic) < 1e-5, "cubic rotation at t = {t}: {:?} vs {cubic}", tr("cubic").rotation);
        assert!((tr("scaled").scale.as_dvec3() - scale.truncate()).length() < 1e-5, "scale at t = {t}");
    }
    // The slerp between q₁ and −q₂ turns at constant angular speed: half way is half the angle.
    s.player.pose(2.0);
    let half = DQuat::from_vec4(q4(qs[1])).angle_between(DQuat::from_vec4(q4(node_transform(&s.scene, "linear").rotation)));
    let full = DQuat::from_vec4(q4(qs[1])).angle_between(DQuat::from_vec4(q4(qs[2])));
    assert!((half - 0.5 * full).abs() < 1e-5, "{half} vs {full} / 2");
}

fn mesh_of(s: &Scene, name: &str) -> Arc<MeshData> {
    match &*s.find(name).unwrap().borrow().shape.as_ref().unwrap().borrow() {
        Shape::Mesh { mesh, .. } => mesh.clone(),
        other => panic!("{other:?}"),
    }
}

const TETRA: [[f32; 3]; 4] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
const TETRA_TRIS: [u32; 12] = [0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3];

#[test]
fn morph_weights_blend_the_targets_and_unchanged_meshes_keep_their_arc() {
    let mut g = GltfBuilder::new();
    let base: Vec<f32> = TETRA.iter().flatten().copied().collect();
    let d0 = [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.5]];
    let d1 = [[0.0f32, -0.5, 0.0], [0.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 0.0]];
    let pos = g.floats(&base, "VEC3");
    let t0 = g.floats(&d0.iter().flatten().copied().collect::<Vec<_>>(), "VEC3");
    let t1 = g.floats(&d1.iter().flatten().copied().collect::<Vec<_>>(), "VEC3");
    let idx = g.uints(&TETRA_TRIS, "SCALAR", 5125);
    // Normals morph too (their displacements blend like the positions'); a target may leave them out.
    let n = g.floats(&[0.0f32, 0.0, 1.0].repeat(4), "VEC3");
    let dn0 = [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.0]];
    let n0 = g.floats(&dn0.iter().flatten().copied().collect::<Vec<_>>(), "VEC3");
    let morph = g.push("meshes", json!({ "primitives": [{ "attributes": { "POSITION": pos, "NORMAL": n }, "indices": idx,
        "targets": [{ "POSITION": t0, "NORMAL": n0 }, { "POSITION": t1 }] }], "weights": [0.25, 0.0] }));
    let plain = g.push("meshes", json!({ "primitives": [{ "attributes": { "POSITION": pos }, "indices": idx }] }));
    let m = g.push("nodes", json!({ "name": "morph", "mesh": morph }));
    let still = g.push("nodes", json!({ "name": "still", "mesh": plain }));
    let weights = [0.0f32, 0.0, 1.0, 0.5, 0.2, 1.0];
    let mut anim = Anim::default();
    anim.channel(&mut g, m, "weights", "LINEAR", &weights, "SCALAR");
    anim.add_to(&mut g, "animation");
    g.scene("S", &[m, still]);
    let (_dir, path) = write(&g, "m.glb");
    let mut s = load(&path, &ImportOptions::default());
    let mut seen = Vec::new();
    for t in [0.0f32, 0.5, 2.0, 3.0, 4.0] {
        s.player.pose(t as f64);
        s.player.deform(&s.scene);
        let w = match locate(t) {
            At::Key(k) => [weights[2 * k] as f64, weights[2 * k + 1] as f64],
            At::Between(k, u) => [0, 1].map(|i| weights[2 * k + i] as f64 * (1.0 - u) + weights[2 * k + 2 + i] as f64 * u),
        };
        let mesh = mesh_of(&s.scene, "morph");
        for v in 0..4 {
            // §3.7.2.2: position = base + Σ wᵢ · targetᵢ.
            let want = DVec3::from(TETRA[v].map(f64::from)) + DVec3::from(d0[v].map(f64::from)) * w[0] + DVec3::from(d1[v].map(f64::from)) * w[1];
            assert!((mesh.positions[v].as_dvec3() - want).length() < 1e-6, "vertex {v} at t = {t}");
            let Normals::Authored(normals) = &mesh.normals else { panic!("{:?}", mesh.normals) };
            let want = DVec3::Z + DVec3::from(dn0[v].map(f64::from)) * w[0];
            assert!((normals[v].as_dvec3() - want).length() < 1e-6, "normal {v} at t = {t}");
        }
        seen.push((mesh, mesh_of(&s.scene, "still")));
    }
    assert!(!Arc::ptr_eq(&seen[1].0, &seen[2].0), "a morphed mesh is a new mesh");
    assert!(Arc::ptr_eq(&seen[3].0, &seen[4].0), "after the last keyframe the shape holds: the same Arc, not voxelized again");
    assert!(seen.windows(2).all(|w| Arc::ptr_eq(&w[0].1, &w[1].1)), "a mesh nothing deforms keeps its Arc");
}

/// A bar of three vertices along +y, skinned to two joints: "root" at the origin and "tip" at
/// y = 1 (its child), under an "Armature" node that is moved and turned.
#[test]
fn a_skinned_mesh_follows_its_joints_and_ignores_its_own_transform() {
    let mut g = GltfBuilder::new();
    let verts = [[0.2f32, 0.0, 0.0], [0.2, 1.0, 0.0], [0.2, 2.0, 0.1], [-0.2, 1.5, 0.0]];
    let joints = [0u32, 0, 0, 0, 0, 1, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0];
    let weights = [1.0f32, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.3, 0.7, 0.0, 0.0];
    let pos = g.floats(&verts.iter().flatten().copied().collect::<Vec<_>>(), "VEC3");
    let j = g.uints(&joints, "VEC4", 5123);
    let w = g.floats(&weights, "VEC4");
    let idx = g.uints(&[0, 1, 2, 0, 2, 3, 0, 3, 1, 1, 3, 2], "SCALAR", 5125);
    let normal = g.floats(&[1.0f32, 0.0, 0.0].repeat(4), "VEC3");
    let mesh = g.push("meshes", json!({ "primitives": [{ "attributes": { "POSITION": pos, "NORMAL": normal, "JOINTS_0": j, "WEIGHTS_0": w }, "indices": idx }] }));
    // Bind pose: root at the origin, tip at y = 1 (the bind matrices are their inverses).
    let ibm: Vec<f32> = [Mat4::IDENTITY, Mat4::from_translation(Vec3::Y).inverse()].iter().flat_map(|m| m.to_cols_array()).collect();
    let ibm = g.floats(&ibm, "MAT4");
    let tip = g.push("nodes", json!({ "name": "tip", "translation": [0.0, 1.0, 0.0] }));
    let root = g.push("nodes", json!({ "name": "root", "children": [tip] }));
    let skinned = g.push("nodes", json!({ "name": "bar", "mesh": mesh, "skin": 0, "translation": [5.0, 0.0, 0.0], "scale": [2.0, 2.0, 2.0] }));
    let arm_t = Vec3::new(1.0, -0.5, 2.0);
    let arm_r = Quat::from_rotation_x(0.3);
    let armature = g.push("nodes", json!({ "name": "Armature", "translation": arm_t.to_array(), "rotation": arm_r.to_array(), "children": [root, skinned] }));
    g.push("skins", json!({ "joints": [root, tip], "inverseBindMatrices": ibm, "skeleton": root }));
    let bend = [Quat::IDENTITY, Quat::from_rotation_z(std::f32::consts::FRAC_PI_2), Quat::from_rotation_z(std::f32::consts::FRAC_PI_2)];
    let mut anim = Anim::default();
    anim.channel(&mut g, tip, "rotation", "LINEAR", &bend.iter().flat_map(|q| q.to_array()).collect::<Vec<_>>(), "VEC4");
    anim.add_to(&mut g, "animation");
    g.scene("S", &[armature]);
    let (_dir, path) = write(&g, "skin.glb");
    let mut s = load(&path, &ImportOptions::default());
    for (t, angle) in [(0.0, 0.0f32), (0.5, 0.25 * std::f32::consts::PI), (1.0, std::f32::consts::FRAC_PI_2)] {
        s.player.pose(t);
        s.player.deform(&s.scene);
        // By hand: joint worlds from the TRS values above, then Σ w · world · inverseBind · p.
        let armature = Mat4::from_rotation_translation(arm_r, arm_t);
        let root_world = armature;
        let tip_world = armature * Mat4::from_rotation_translation(Quat::from_rotation_z(angle), Vec3::Y);
        let joint = [root_world, tip_world * Mat4::from_translation(Vec3::Y).inverse()];
        let mesh = mesh_of(&s.scene, "bar");
        let bar_world = s.scene.world_matrix(&s.scene.find("bar").unwrap()).unwrap();
        for v in 0..4 {
            let p = Vec3::from(verts[v]);
            let want: Vec3 = (0..4).map(|i| weights[4 * v + i] * joint[joints[4 * v + i] as usize].transform_point3(p)).sum();
            let got = bar_world.transform_point3(mesh.positions[v]);
            assert!((got - want).length() < 1e-5, "vertex {v} at t = {t}: {got} vs {want}");
            // The normal turns with the joints: Σ w · (joint · inverseBind) applied to a direction.
            let want: Vec3 = (0..4).map(|i| weights[4 * v + i] * joint[joints[4 * v + i] as usize].transform_vector3(Vec3::X)).sum();
            let Normals::Authored(normals) = &mesh.normals else { panic!("{:?}", mesh.normals) };
            let got = bar_world.transform_vector3(normals[v]);
            assert!(got.normalize().dot(want.normalize()) > 1.0 - 1e-6, "normal {v} at t = {t}: {got} vs {want}");
        }
    }
    // A check of the hand computation itself: fully bent, the tip vertex (weight 1 on "tip")
    // sits 1 m from the tip joint along the joint's turned −x.
    let tip_joint = Mat4::from_rotation_translation(arm_r, arm_t).transform_point3(Vec3::Y);
    let got = s.scene.world_matrix(&s.scene.find("bar").unwrap()).unwrap().transform_point3(mesh_of(&s.scene, "bar").positions[2]);
    assert!((got - tip_joint - arm_r * Vec3::new(-1.0, 0.2, 0.1)).length() < 1e-5);
}

fn two_animations() -> GltfBuilder {
    let mut g = GltfBuilder::new();
    let n = g.push("nodes", json!({ "name": "mover" }));
    for (name, v) in [("Up", [0.0f32, 1.0, 0.0]), ("Side", [1.0, 0.0, 0.0])] {
        let mut anim = Anim::default();
        let values: Vec<f32> = [0.0f32, 1.0, 2.0].iter().flat_map(|k| v.map(|x| x * k)).collect();
        anim.channel(&mut g, n, "translation", "LINEAR", &values, "VEC3");
        anim.add_to(&mut g, name);
    }
    g.scene("S", &[n]);
    g
}

#[test]
fn animations_are_picked_by_name_and_all_play_by_default() {
    let (_dir, path) = write(&two_animations(), "two.glb");
    let at = |name: Option<&str>, t: f64| {
        let mut s = load(&path, &ImportOptions { animation: name.map(str::to_string), ..Default::default() });
        s.player.pose(t);
        node_transform(&s.scene, "mover").translation
    };
    assert_eq!(at(Some("Up"), 1.0), Vec3::new(0.0, 1.0, 0.0));
    assert_eq!(at(Some("Side"), 3.0), Vec3::new(2.0, 0.0, 0.0));
    assert_eq!(at(None, 1.0), Vec3::new(1.0, 0.0, 0.0), "all play, the later animation wins the shared channel");
    let import = refrakt::gltf::import(&path, "two.glb", &refrakt::lua::sandbox::FileAccess::new(path.parent().unwrap(), &[]).unwrap(), &ImportOptions::default()).unwrap();
    assert!(import.warnings.iter().any(|w| w.to_string().contains("\"Up\" and \"Side\" both drive")), "{:?}", import.warnings);
    let e = format!("{:#}", GltfScene::load(&path, &[], &ImportOptions { animation: Some("Down".into()), ..Default::default() }).err().unwrap());
    assert!(e.contains("no animation called \"Down\"") && e.contains("0 \"Up\", 1 \"Side\""), "{e}");
}

#[test]
fn a_lua_update_runs_on_top_of_the_gltf_animation() {
    let dir = tempfile::tempdir().unwrap();
    two_animations().write_glb(&dir.path().join("two.glb"));
    let script = r#"local r = require("refrakt")
        local scene = r.scene{}
        scene:add(r.gltf{ file = "two.glb", animation = "Up" })
        function update(scene, t)
          scene:find("mover").rotation = {0, 90 * t, 0}
        end
        return scene"#;
    std::fs::write(dir.path().join("scene.lua"), script).unwrap();
    let host = common::load(&dir.path().join("scene.lua"));
    for t in [0.5, 1.5] {
        host.update(t).unwrap();
        let tr = node_transform(&host.scene().borrow(), "mover");
        // Keyframes 0, 1, 2 m at TIMES 0, 1, 3 s.
        let up = if t <= 1.0 { t } else { 1.0 + (t - 1.0) / 2.0 } as f32;
        assert!((tr.translation - Vec3::new(0.0, up, 0.0)).length() < 1e-6, "the glTF's translation at {t}: {}", tr.translation);
        assert!(1.0 - tr.rotation.dot(Quat::from_rotation_y((90.0 * t as f32).to_radians())).abs() < 1e-6, "the script's rotation at {t}: {:?}", tr.rotation);
    }
}

/// KHR_animation_pointer (as Blender's exporter writes for animated light power and colour, a
/// camera's lens, material values): channels without a node, aimed by a JSON pointer. A light's
/// colour, intensity and spot cones, a camera's yfov, a material's base colour and emissive
/// strength and a node's translation follow their samplers; a pointer to a property refrakt does
/// not animate is said once and the file loads.
#[test]
fn animation_pointers_drive_lights_cameras_and_materials() {
    use refrakt::scene::{LightKind, Material};
    let mut g = GltfBuilder::new();
    g.uses("KHR_animation_pointer", true);
    g.uses("KHR_lights_punctual", false);
    g.json["extensions"] = json!({ "KHR_lights_punctual": { "lights": [
        { "type": "spot", "intensity": 10.0, "color": [1.0, 1.0, 1.0], "spot": { "innerConeAngle": 0.2, "outerConeAngle": 0.6 } } ] } });
    g.push("cameras", json!({ "type": "perspective", "perspective": { "yfov": 0.5, "znear": 0.1 } }));
    let m = g.push("materials", json!({ "pbrMetallicRoughness": { "baseColorFactor": [1.0, 1.0, 1.0, 1.0], "metallicFactor": 0.0 } }));
    let mesh = g.mesh(&TETRA, &[[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], Some(m));
    let lamp = g.push("nodes", json!({ "name": "lamp", "extensions": { "KHR_lights_punctual": { "light": 0 } } }));
    let cam = g.push("nodes", json!({ "name": "cam", "camera": 0, "translation": [0.0, 0.0, 5.0] }));
    let thing = g.push("nodes", json!({ "name": "thing", "mesh": mesh }));
    // Keyframes at 0, 1 and 3 s (TIMES), LINEAR.
    let mut anim = Anim::default();
    let pointers: [(&str, Vec<f32>, &str); 8] = [
        ("/extensions/KHR_lights_punctual/lights/0/intensity", vec![10.0, 30.0, 30.0], "SCALAR"),
        ("/extensions/KHR_lights_punctual/lights/0/color", vec![1.0, 1.0, 1.0, 1.0, 0.5, 0.0, 1.0, 0.5, 0.0], "VEC3"),
        ("/extensions/KHR_lights_punctual/lights/0/spot/outerConeAngle", vec![0.6, 0.8, 0.8], "SCALAR"),
        ("/cameras/0/perspective/yfov", vec![0.5, 1.0, 1.0], "SCALAR"),
        ("/materials/0/pbrMetallicRoughness/baseColorFactor", vec![1.0, 1.0, 1.0, 1.0, 0.0, 0.5, 1.0, 0.5, 0.0, 0.5, 1.0, 0.5], "VEC4"),
        ("/nodes/2/translation", vec![0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 2.0, 0.0, 0.0], "VEC3"),
        ("/cameras/0/perspective/znear", vec![0.1, 0.2, 0.2], "SCALAR"),
        ("/cameras/0/perspective/zfar", vec![100.0, 200.0, 200.0], "SCALAR"),
    ];
    for (pointer, values, kind) in &pointers {
        let input = g.floats(&TIMES, "SCALAR");
        let output = g.floats(values, kind);
        anim.samplers.push(json!({ "input": input, "output": output, "interpolation": "LINEAR" }));
        anim.channels.push(json!({ "sampler": anim.samplers.len() - 1,
            "target": { "path": "pointer", "extensions": { "KHR_animation_pointer": { "pointer": pointer } } } }));
    }
    anim.add_to(&mut g, "lights camera action");
    g.scene("S", &[lamp, cam, thing]);
    let (dir, path) = write(&g, "pointer.glb");
    let access = refrakt::lua::sandbox::FileAccess::new(dir.path(), &[]).unwrap();
    let import = refrakt::gltf::import(&path, "pointer.glb", &access, &ImportOptions::default()).unwrap_or_else(|e| panic!("{e:#}"));
    let said: Vec<String> = import.warnings.iter().map(|w| w.to_string()).filter(|w| w.contains("KHR_animation_pointer")).collect();
    assert!(said.len() == 1 && said[0].contains("/cameras/0/perspective/zfar") && said[0].contains("keep the file's values"), "{said:?}");

    let mut s = load(&path, &ImportOptions::default());
    assert_eq!(s.player.duration(), Some(3.0));
    s.player.pose(0.5);
    let node = |name: &str| s.scene.find(name).unwrap();
    let light = node("lamp").borrow().light.clone().unwrap();
    let light = light.borrow();
    assert!((light.intensity - 20.0).abs() < 1e-5, "intensity {}", light.intensity);
    assert!((light.color - Vec3::new(1.0, 0.75, 0.5)).length() < 1e-6, "colour {}", light.color);
    let LightKind::Spot { angle, blend } = light.kind else { panic!("{:?}", light.kind) };
    // The outer cone widens to 0.7; the inner one stays 0.2.
    assert!((angle - 0.7).abs() < 1e-6 && (angle * (1.0 - blend) - 0.2).abs() < 1e-6, "{angle}, {blend}");
    let (fov, clip_start) = {
        let camera = node("cam").borrow().camera.clone().unwrap();
        let camera = camera.borrow();
        (camera.fov_y, camera.clip_start)
    };
    assert!((fov - 0.75).abs() < 1e-6 && (clip_start - 0.15).abs() < 1e-6, "yfov {fov}, znear {clip_start}");
    let material = node("thing").borrow().material.clone().unwrap();
    let Material::Diffuse(d) = &*material.borrow() else { panic!() };
    assert!((d.color - Vec3::new(0.5, 0.75, 1.0)).length() < 1e-6 && (d.alpha - 0.75).abs() < 1e-6, "{} {}", d.color, d.alpha);
    assert!((node_transform(&s.scene, "thing").translation - Vec3::new(1.0, 0.0, 0.0)).length() < 1e-6);
    // The frame carries them: the light's radiant intensity is the candela over 683 lm/W.
    let desc = refrakt::scene::eval::evaluate(&s.scene, 0.5, &Default::default()).unwrap();
    assert!((desc.lights[0].radiant.x - 20.0 / 683.0).abs() < 1e-6, "{}", desc.lights[0].radiant);
    assert!((desc.camera.clip_start - 0.15).abs() < 1e-6, "{}", desc.camera.clip_start);
}

/// A glass's index, dispersion and glow keyed in Blender (KHR_materials_ior `ior`,
/// KHR_materials_dispersion `dispersion`, KHR_materials_emissive_strength, through
/// KHR_animation_pointer) follow their samplers into the frame: a liquid that thickens, a lens
/// that changes, a lamp's shade that brightens.
#[test]
fn animation_pointers_drive_a_glasss_index_dispersion_and_glow() {
    use refrakt::scene::Material;
    let mut g = GltfBuilder::new();
    g.uses("KHR_animation_pointer", true);
    for ext in ["KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_dispersion", "KHR_materials_emissive_strength"] {
        g.uses(ext, false);
    }
    let m = g.push("materials", json!({ "pbrMetallicRoughness": { "metallicFactor": 0.0 }, "emissiveFactor": [1.0, 0.5, 0.25], "extensions": {
        "KHR_materials_transmission": { "transmissionFactor": 1.0 }, "KHR_materials_ior": { "ior": 1.5 },
        "KHR_materials_dispersion": { "dispersion": 0.0 }, "KHR_materials_emissive_strength": { "emissiveStrength": 2.0 } } }));
    let mesh = g.mesh(&TETRA, &[[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], Some(m));
    let thing = g.push("nodes", json!({ "name": "thing", "mesh": mesh }));
    let mut anim = Anim::default();
    for (pointer, values) in [
        ("/materials/0/extensions/KHR_materials_ior/ior", [1.5f32, 1.33, 1.33]),
        ("/materials/0/extensions/KHR_materials_dispersion/dispersion", [0.0, 1.0, 1.0]),
        ("/materials/0/extensions/KHR_materials_emissive_strength/emissiveStrength", [2.0, 6.0, 6.0]),
    ] {
        let input = g.floats(&TIMES, "SCALAR");
        let output = g.floats(&values, "SCALAR");
        anim.samplers.push(json!({ "input": input, "output": output, "interpolation": "LINEAR" }));
        anim.channels.push(json!({ "sampler": anim.samplers.len() - 1,
            "target": { "path": "pointer", "extensions": { "KHR_animation_pointer": { "pointer": pointer } } } }));
    }
    anim.add_to(&mut g, "index action");
    g.scene("S", &[thing]);
    let (_dir, path) = write(&g, "index.glb");
    let mut s = load(&path, &ImportOptions::default());
    s.player.pose(0.5);
    let material = s.scene.find("thing").unwrap().borrow().material.clone().unwrap();
    let Material::Glass(glass) = &*material.borrow() else { panic!("a transmissive material is glass") };
    assert!((glass.ior - 1.415).abs() < 1e-5 && (glass.dispersion - 0.5).abs() < 1e-6, "{} {}", glass.ior, glass.dispersion);
    // A glowing shade's strength keyed (Blender's Emission Strength): 2 → 4 at t = 0.5.
    assert!((glass.emitted() - Vec3::new(4.0, 2.0, 1.0)).length() < 1e-5, "{}", glass.emitted());
    let desc = refrakt::scene::eval::evaluate(&s.scene, 0.5, &Default::default()).unwrap();
    assert!((desc.meshes[0].glass.ior - 1.415).abs() < 1e-5, "the frame's glass: {}", desc.meshes[0].glass.ior);
}
