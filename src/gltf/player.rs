//! The imported scene over time: each frame the selected animations set the nodes' transforms
//! and morph weights, then meshes with morph targets or a skin are deformed on the CPU into new
//! meshes (in their node's local frame), which the renderer voxelizes like any changed mesh.
//! A mesh whose deformed shape did not change keeps its `Arc`, so it is not voxelized again.

use std::cell::RefCell;
use std::collections::HashMap;
use std::rc::{Rc, Weak};
use std::sync::Arc;

use glam::{Mat4, Vec3};

use super::animation::{Clip, Pose, Target};
use super::pointer;
use super::mesh::Part;
use crate::scene::{Camera, Light, Material, MeshData, Node, Normals, Scene, Shape, Shared};

/// A skin (§3.7.3): the joint nodes and their inverse bind matrices.
pub struct Skin {
    pub joints: Vec<Weak<RefCell<Node>>>,
    pub inverse_bind: Vec<Mat4>,
}

/// A mesh that morph weights or a skin deform.
pub struct Deformable {
    /// The node carrying the mesh shape.
    pub node: Weak<RefCell<Node>>,
    /// The glTF node whose weights drive the morph targets.
    pub weights_of: usize,
    pub part: Part,
    pub skin: Option<Skin>,
    /// The mesh on the node now.
    pub current: Arc<MeshData>,
}

/// What animation pointers can drive, by glTF index: each light's and camera's copies (one per
/// node that carries it) and each material (shared by its nodes; dangling where unused).
#[derive(Default)]
pub struct Animated {
    pub lights: Vec<Vec<Weak<RefCell<Light>>>>,
    /// The area light of each node (from its extras; dangling for the others).
    pub area_lights: Vec<Weak<RefCell<Light>>>,
    pub cameras: Vec<Vec<Weak<RefCell<Camera>>>>,
    pub materials: Vec<Weak<RefCell<Material>>>,
}

pub struct Player {
    /// The built node of each glTF node (dangling for nodes outside the imported scene).
    pub nodes: Vec<Weak<RefCell<Node>>>,
    /// The animations that play.
    pub clips: Vec<Clip>,
    /// Morph weights of each glTF node now (node.weights, else its mesh's, then animated).
    pub weights: Vec<Vec<f32>>,
    pub deformables: Vec<Deformable>,
    animated: Animated,
    scratch: Vec<f32>,
}

/// World matrices of every node in the scene, by node identity.
fn world_matrices(scene: &Scene) -> HashMap<*const RefCell<Node>, Mat4> {
    fn walk(nodes: &[Shared<Node>], parent: Mat4, out: &mut HashMap<*const RefCell<Node>, Mat4>) {
        for n in nodes {
            let world = parent * n.borrow().transform.matrix();
            out.insert(Rc::as_ptr(n), world);
            walk(&n.borrow().children, world, out);
        }
    }
    let mut out = HashMap::new();
    walk(&scene.roots, Mat4::IDENTITY, &mut out);
    out
}

impl Player {
    pub fn new(nodes: Vec<Weak<RefCell<Node>>>, clips: Vec<Clip>, weights: Vec<Vec<f32>>, deformables: Vec<Deformable>) -> Self {
        Self { nodes, clips, weights, deformables, animated: Animated::default(), scratch: Vec::new() }
    }

    /// The lights, cameras and materials its animation pointers drive.
    pub fn with_animated(self, animated: Animated) -> Self {
        Self { animated, ..self }
    }

    /// Whether any node it animates or deforms still exists (a script may drop an import).
    pub fn is_alive(&self) -> bool {
        self.nodes.iter().any(|n| n.strong_count() > 0)
    }

    pub fn is_animated(&self) -> bool {
        self.clips.iter().any(|c| !c.channels.is_empty())
    }

    /// The length of the longest clip, seconds (its samplers' last key); `None` when nothing
    /// is animated.
    pub fn duration(&self) -> Option<f64> {
        let ends = self.clips.iter().flat_map(|c| c.channels.iter().filter_map(|ch| c.samplers.get(ch.sampler)?.times.last().copied()));
        ends.map(f64::from).reduce(f64::max)
    }

    /// Sets transforms and weights to the animations' values at `t` seconds.
    pub fn pose(&mut self, t: f64) {
        let (nodes, weights, animated) = (&self.nodes, &mut self.weights, &self.animated);
        for clip in &self.clips {
            clip.sample(t as f32, &mut self.scratch, |i, pose| {
                match pose {
                    Pose::Weights(w) => {
                        weights[i].clear();
                        weights[i].extend_from_slice(w);
                        return;
                    }
                    Pose::Property(target, v) => return animated.set(target, i, v),
                    _ => {}
                }
                let Some(node) = nodes[i].upgrade() else { return };
                let mut node = node.borrow_mut();
                match pose {
                    Pose::Translation(v) => node.transform.translation = v,
                    Pose::Rotation(q) => node.transform.rotation = q,
                    Pose::Scale(v) => node.transform.scale = v,
                    Pose::Weights(_) | Pose::Property(..) => {}
                }
            });
        }
    }

    /// Deforms morphed and skinned meshes for the transforms and weights the scene has now.
    pub fn deform(&mut self, scene: &Scene) {
        if self.deformables.is_empty() {
            return;
        }
        let worlds = if self.deformables.iter().any(|d| d.skin.is_some()) { world_matrices(scene) } else { HashMap::new() };
        for d in &mut self.deformables {
            let Some(node) = d.node.upgrade() else { continue };
            let weights = &self.weights[d.weights_of];
            let mut positions = morph(&d.part.rest.positions, &d.part.targets, weights);
            let mut normals = match &d.part.rest.normals {
                Normals::Authored(rest) => Normals::Authored(morph(rest, &d.part.normal_targets, weights)),
                other => other.clone(),
            };
            if let Some(skin) = &d.skin {
                match skin_matrices(skin, &node, &worlds) {
                    Some(joints) => {
                        skin_vertices(&mut positions, &d.part, |m, p| m.transform_point3(p), &joints);
                        if let Normals::Authored(n) = &mut normals {
                            // Normals turn with the joints (their rotation and uniform scale;
                            // they are normalized when used).
                            skin_vertices(n, &d.part, |m, n| m.transform_vector3(n), &joints);
                        }
                    }
                    // A joint or the mesh is not in the scene (or cannot be inverted): keep the last shape.
                    None => continue,
                }
            }
            if positions == d.current.positions && normals == d.current.normals {
                continue;
            }
            let mesh = Arc::new(MeshData { positions, triangles: d.part.rest.triangles.clone(), uvs: d.part.rest.uvs.clone(), normals });
            let node = node.borrow();
            if let Some(shape) = &node.shape {
                // Only a shape that is still the imported mesh is replaced: a script may have
                // given the node a shape of its own.
                if let Shape::Mesh { mesh: m, .. } = &mut *shape.borrow_mut()
                    && Arc::ptr_eq(m, &d.current)
                {
                    *m = mesh.clone();
                }
            }
            d.current = mesh;
        }
    }
}

impl Animated {
    /// Sets property `target` of light, camera or material `index` to `v`.
    fn set(&self, target: Target, index: usize, v: &[f32]) {
        match target {
            Target::Light(p) => live(self.lights.get(index)).for_each(|l| pointer::apply_light(&mut l.borrow_mut(), p, v)),
            Target::AreaLight(p) => {
                if let Some(l) = self.area_lights.get(index).and_then(Weak::upgrade) {
                    pointer::apply_light(&mut l.borrow_mut(), p, v);
                }
            }
            Target::Camera(p) => live(self.cameras.get(index)).for_each(|c| pointer::apply_camera(&mut c.borrow_mut(), p, v)),
            Target::Material(p) => {
                if let Some(m) = self.materials.get(index).and_then(Weak::upgrade) {
                    pointer::apply_material(&mut m.borrow_mut(), p, v);
                }
            }
            _ => {}
        }
    }
}

/// The copies in `all` that still exist.
fn live<T>(all: Option<&Vec<Weak<RefCell<T>>>>) -> impl Iterator<Item = Shared<T>> + '_ {
    all.into_iter().flatten().filter_map(Weak::upgrade)
}

/// §3.7.2.2: the morphed position (or normal) is the rest one plus Σ wᵢ · (displacement of
/// target i).
fn morph(rest: &[Vec3], targets: &[Vec<Vec3>], weights: &[f32]) -> Vec<Vec3> {
    let mut p = rest.to_vec();
    for (target, &w) in targets.iter().zip(weights) {
        if w != 0.0 {
            for (p, d) in p.iter_mut().zip(target) {
                *p += w * *d;
            }
        }
    }
    p
}

/// §3.7.3.1: joint matrix j = (world of the mesh node)⁻¹ · (world of joint j) · inverseBind j,
/// which places the skinned vertices in the mesh node's local frame (where refrakt keeps them;
/// the spec's "the skinned mesh's own transform is ignored" is its world matrix cancelling out).
fn skin_matrices(skin: &Skin, node: &Shared<Node>, worlds: &HashMap<*const RefCell<Node>, Mat4>) -> Option<Vec<Mat4>> {
    let mesh_world = worlds.get(&Rc::as_ptr(node))?;
    if mesh_world.determinant().abs() < 1e-20 {
        return None;
    }
    let to_local = mesh_world.inverse();
    skin.joints
        .iter()
        .zip(&skin.inverse_bind)
        .map(|(j, ibm)| Some(to_local * *worlds.get(&Rc::as_ptr(&j.upgrade()?))? * *ibm))
        .collect()
}

/// Linear blend skinning: p' = Σₖ wₖ · apply(joint matrix(jₖ), p) over the vertex's influences
/// (a point for positions, a direction for normals).
fn skin_vertices(values: &mut [Vec3], part: &Part, apply: impl Fn(&Mat4, Vec3) -> Vec3, joints: &[Mat4]) {
    let Some(inf) = &part.influences else { return };
    let k = inf.per_vertex;
    for (v, p) in values.iter_mut().enumerate() {
        let mut sum = Vec3::ZERO;
        for i in v * k..(v + 1) * k {
            let w = inf.weights[i];
            if w != 0.0 {
                sum += w * apply(&joints[inf.joints[i] as usize], *p);
            }
        }
        *p = sum;
    }
}
