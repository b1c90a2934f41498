//! The node hierarchy of one glTF scene (§3.5) as refrakt scene-graph nodes: transforms, meshes
//! with their materials, cameras (§3.10), KHR_lights_punctual lights, the analytic fields and
//! "ignore" roles of refrakt's node extras, and the skins and morph targets that deform meshes.

use std::cell::RefCell;
use std::collections::HashMap;
use std::rc::{Rc, Weak};

use anyhow::{Result, anyhow, bail};
use glam::{Mat4, Quat, Vec3};

use super::accessor::Accessors;
use super::extras::{self, FieldExtras, FieldType, NodeRole};
use super::material::{self, Converted, Materials, UvMap};
use super::mesh::{self, Part};
use super::player::{Animated, Deformable, Skin};
use crate::scene::{Camera, Glass, Light, LightKind, Material, Node, Normals, Origin, Shape, Shared, shared};
use crate::warnings::Collector;

/// Height of the image a glTF camera gets when the file gives only its aspect ratio (the width
/// follows from it; `--size` overrides both). 576 keeps refrakt's default 1024×576 for 16:9.
const DEFAULT_HEIGHT: u32 = 576;

/// Angular diameter of a glTF directional light: refrakt's sun default (the real sun, and
/// Blender's default sun angle), since glTF gives none.
const SUN_ANGULAR_DIAMETER_DEG: f32 = 0.53;

/// The built graph of one scene.
pub struct Graph {
    pub roots: Vec<Shared<Node>>,
    /// The node made for each glTF node (dangling where a node is not in the scene).
    pub nodes: Vec<Weak<RefCell<Node>>>,
    pub weights: Vec<Vec<f32>>,
    pub deformables: Vec<Deformable>,
    /// The lights, cameras and materials made of each glTF one, for animation pointers.
    pub animated: Animated,
}

/// A converted material, shared by every node that uses it: (material, boundary, where its
/// texture is sampled).
#[derive(Clone)]
struct MaterialEntry(Shared<Material>, Option<f32>, Option<UvMap>);

struct Builder<'a, 'b> {
    acc: &'a Accessors<'a>,
    materials: Materials<'b>,
    converted: HashMap<Option<usize>, MaterialEntry>,
    meshes: HashMap<usize, Vec<Part>>,
    graph: Graph,
    /// (deformable, skin index) pairs whose joints are filled in once every node exists.
    skinned: Vec<(usize, usize)>,
    /// (mesh, primitive) pairs already checked: for normals, and glass for enclosing a volume
    /// and for metal.
    checked: std::collections::HashSet<(usize, usize)>,
    /// The KHR_materials_variants variant chosen (its index), if any.
    variant: Option<usize>,
    warnings: &'a mut Collector,
}

pub fn build(doc: &gltf::Document, acc: &Accessors, materials: Materials, roots: &[usize], variant: Option<usize>, warnings: &mut Collector) -> Result<Graph> {
    let n = doc.nodes().count();
    let animated = Animated {
        lights: vec![Vec::new(); doc.lights().map_or(0, |l| l.count())],
        area_lights: (0..n).map(|_| Weak::new()).collect(),
        cameras: vec![Vec::new(); doc.cameras().count()],
        materials: (0..doc.materials().count()).map(|_| Weak::new()).collect(),
    };
    let graph = Graph { roots: Vec::new(), nodes: (0..n).map(|_| Weak::new()).collect(), weights: vec![Vec::new(); n], deformables: Vec::new(), animated };
    let mut b = Builder { acc, materials, converted: HashMap::new(), meshes: HashMap::new(), graph, skinned: Vec::new(), checked: Default::default(), variant, warnings };
    for &r in roots {
        let node = doc.nodes().nth(r).ok_or_else(|| anyhow!("{}: nodes[{r}] does not exist", acc.file))?;
        let built = b.node(&node)?;
        b.graph.roots.push(built);
    }
    b.bind_skins(doc)?;
    for (index, entry) in &b.converted {
        if let Some(slot) = index.and_then(|i| b.graph.animated.materials.get_mut(i)) {
            *slot = Rc::downgrade(&entry.0);
        }
    }
    Ok(b.graph)
}

/// §3.5.2: a node's matrix must be a TRS (no shear); refrakt keeps transforms as TRS.
fn transform(node: &gltf::Node, file: &str, what: &str) -> Result<crate::scene::Transform> {
    let t = match node.transform() {
        gltf::scene::Transform::Matrix { matrix } => {
            let m = Mat4::from_cols_array_2d(&matrix);
            let (scale, rotation, translation) = m.to_scale_rotation_translation();
            let back = Mat4::from_scale_rotation_translation(scale, rotation, translation);
            let tolerance = 1e-4 * m.abs().to_cols_array().iter().fold(1.0f32, |a, b| a.max(*b));
            if !(back - m).abs().to_cols_array().iter().all(|d| *d <= tolerance) {
                bail!("{file}: {what}: its matrix has shear or is degenerate; glTF requires a matrix made of translation, rotation and scale");
            }
            crate::scene::Transform { translation, rotation, scale }
        }
        gltf::scene::Transform::Decomposed { translation, rotation, scale } => crate::scene::Transform {
            translation: Vec3::from(translation),
            // Quaternions written as text drift off unit length; the spec requires unit ones.
            rotation: Quat::from_array(rotation).normalize(),
            scale: Vec3::from(scale),
        },
    };
    if !(t.translation.is_finite() && t.rotation.is_finite() && t.scale.is_finite()) {
        bail!("{file}: {what}: its transform is not finite (a zero rotation quaternion?)");
    }
    Ok(t)
}

impl<'a> Builder<'a, '_> {
    fn file(&self) -> &'a str {
        self.acc.file
    }

    fn node(&mut self, g: &gltf::Node) -> Result<Shared<Node>> {
        let what = format!("nodes[{}]{}", g.index(), mesh::quoted(g.name()));
        let mut node = Node::new(g.name().unwrap_or(""));
        node.origin = Origin(format!("{} nodes[{}]", self.file(), g.index()));
        node.transform = transform(g, self.file(), &what)?;
        let settings = extras::node_settings(g, self.file(), self.warnings)?;
        let role = settings.role.clone();
        let node = shared(node);
        self.graph.nodes[g.index()] = Rc::downgrade(&node);
        if role != Some(NodeRole::Ignore) {
            self.camera(g, &node, &what)?;
            self.light(g, &node, &settings)?;
            match role {
                Some(NodeRole::Field(f)) => self.field(g, &node, &f)?,
                _ => self.mesh(g, &node)?,
            }
        }
        for child in g.children() {
            let c = self.node(&child)?;
            node.borrow_mut().children.push(c);
        }
        Ok(node)
    }

    fn camera(&mut self, g: &gltf::Node, node: &Shared<Node>, what: &str) -> Result<()> {
        let Some(cam) = g.camera() else { return Ok(()) };
        let lens = extras::lens(&cam, self.file(), &format!("cameras[{}]{}", cam.index(), mesh::quoted(cam.name())), self.warnings)?;
        match cam.projection() {
            gltf::camera::Projection::Perspective(p) => {
                let size = match p.aspect_ratio() {
                    Some(a) if a.is_finite() && a > 0.0 => (((DEFAULT_HEIGHT as f32 * a).round() as u32).clamp(1, 16384), DEFAULT_HEIGHT),
                    _ => Camera::default().size,
                };
                let fov_y = p.yfov();
                if !(fov_y > 0.0 && fov_y < std::f32::consts::PI) {
                    self.warnings.about(format!("{what} (yfov {fov_y})"), "its camera's yfov is not an angle in (0, π); the camera is skipped");
                    return Ok(());
                }
                let clip_start = self.clip_start(p.znear(), what);
                self.place_camera(&cam, node, Camera { fov_y, size, lens, clip_start, ..Camera::default() });
            }
            // §3.10.3: xmag and ymag are half the view's width and height.
            gltf::camera::Projection::Orthographic(o) => {
                let (xmag, ymag) = (o.xmag(), o.ymag());
                if !(xmag.is_finite() && ymag.is_finite() && xmag != 0.0 && ymag != 0.0) {
                    self.warnings.about(format!("{what} (xmag {xmag}, ymag {ymag})"), "its orthographic camera's xmag and ymag must be finite and non-zero; the camera is skipped");
                    return Ok(());
                }
                let aspect = (xmag / ymag).abs();
                let size = (((DEFAULT_HEIGHT as f32 * aspect).round() as u32).clamp(1, 16384), DEFAULT_HEIGHT);
                let clip_start = self.clip_start(o.znear(), what);
                self.place_camera(&cam, node, Camera { size, orthographic: Some(2.0 * ymag.abs()), clip_start, ..Camera::default() });
            }
        }
        Ok(())
    }

    /// A camera's `znear` as where its rays start (`Camera::clip_start`, as Blender's importer
    /// makes it the Clip Start Cycles honours); one that is not a distance ≥ 0 is said, and 0 used.
    fn clip_start(&mut self, znear: f32, what: &str) -> f32 {
        if (0.0..=Camera::MAX_CLIP_START).contains(&znear) {
            return znear;
        }
        self.warnings.about(format!("{what} (znear {znear})"), "its camera's znear is not a distance from 0 to 1e6 m; its rays start at the camera");
        0.0
    }

    /// Puts the camera made of glTF camera `cam` on `node`, noted for animation pointers.
    fn place_camera(&mut self, cam: &gltf::Camera, node: &Shared<Node>, camera: Camera) {
        let camera = shared(camera);
        self.graph.animated.cameras[cam.index()].push(Rc::downgrade(&camera));
        node.borrow_mut().camera = Some(camera);
    }

    /// KHR_lights_punctual: intensity in candela (point, spot) or lux (directional), which is
    /// what refrakt's lights take; spot cones by their outer and inner half-angles; a point or
    /// spot light's bulb radius from the node's `extras.refrakt.light_radius`. An area light
    /// (which KHR_lights_punctual lacks) from the node's `extras.refrakt.light`; whether the
    /// camera sees either from `extras.refrakt.light_visible`.
    fn light(&mut self, g: &gltf::Node, node: &Shared<Node>, settings: &extras::NodeSettings) -> Result<()> {
        let bulb = g.light().is_some_and(|l| !matches!(l.kind(), gltf::khr_lights_punctual::Kind::Directional));
        let what = || format!("nodes[{}]{}", g.index(), mesh::quoted(g.name()));
        if settings.light_radius.is_some() && !bulb {
            self.warnings.about(what(), "extras.refrakt.light_radius is for point and spot lights; skipped");
        }
        let visible = settings.light_visible.unwrap_or(false);
        if settings.light_visible.is_some() && !bulb && settings.rect.is_none() {
            self.warnings.about(what(), "extras.refrakt.light_visible is for point, spot and area lights (a sun is never seen); skipped");
        }
        if let Some(r) = &settings.rect {
            if g.light().is_some() {
                self.warnings.about(what(), "has a KHR_lights_punctual light, which it keeps; extras.refrakt.light skipped");
            } else {
                // The node's transform, animated or not, places and aims it; its power, colour
                // and size animate through pointers into the node's extras.
                let light = shared(Light { color: r.color, intensity: r.intensity, visible, ..Light::new(LightKind::Rect { size: r.size, round: r.round }) });
                self.graph.animated.area_lights[g.index()] = Rc::downgrade(&light);
                node.borrow_mut().light = Some(light);
                return Ok(());
            }
        }
        let Some(l) = g.light() else { return Ok(()) };
        let what = format!("KHR_lights_punctual lights[{}]{}", l.index(), mesh::quoted(l.name()));
        let kind = match l.kind() {
            gltf::khr_lights_punctual::Kind::Point => LightKind::Point,
            gltf::khr_lights_punctual::Kind::Directional => LightKind::Sun { angular_diameter: SUN_ANGULAR_DIAMETER_DEG.to_radians() },
            gltf::khr_lights_punctual::Kind::Spot { inner_cone_angle, outer_cone_angle } => {
                if !(outer_cone_angle > 0.0 && outer_cone_angle <= std::f32::consts::FRAC_PI_2 && (0.0..outer_cone_angle).contains(&inner_cone_angle)) {
                    bail!("{}: {what}: spot cone angles must satisfy 0 ≤ innerConeAngle < outerConeAngle ≤ π/2 (got {inner_cone_angle}, {outer_cone_angle})", self.file());
                }
                // refrakt's spot is full inside angle·(1 − blend).
                LightKind::Spot { angle: outer_cone_angle, blend: 1.0 - inner_cone_angle / outer_cone_angle }
            }
        };
        let color = Vec3::from(l.color());
        let intensity = l.intensity();
        if !(color.is_finite() && color.min_element() >= 0.0 && intensity.is_finite() && intensity >= 0.0) {
            bail!("{}: {what}: color and intensity must be finite and ≥ 0", self.file());
        }
        let mut light = Light { color, intensity, visible: bulb && visible, ..Light::new(kind) };
        if let (true, Some(r)) = (bulb, settings.light_radius) {
            light.radius = r;
        }
        let light = shared(light);
        self.graph.animated.lights[l.index()].push(Rc::downgrade(&light));
        node.borrow_mut().light = Some(light);
        Ok(())
    }

    /// The refrakt material of glTF material `index` (None: the default material), made once.
    fn material(&mut self, index: Option<usize>) -> Result<MaterialEntry> {
        if let Some(m) = self.converted.get(&index) {
            return Ok(m.clone());
        }
        let Converted { material, boundary, uv } = match index.and_then(|i| self.materials.doc.materials().nth(i)) {
            Some(m) => self.materials.convert(&m, self.warnings)?,
            None => material::default_material(),
        };
        let entry = MaterialEntry(shared(material), boundary, uv);
        self.converted.insert(index, entry.clone());
        Ok(entry)
    }

    fn parts(&mut self, m: &gltf::Mesh) -> Result<Vec<Part>> {
        if let Some(p) = self.meshes.get(&m.index()) {
            return Ok(p.clone());
        }
        let mut uv_maps = HashMap::new();
        for p in m.primitives() {
            let i = mesh::material_of(&p, self.variant);
            uv_maps.insert(i, self.material(i)?.2);
        }
        let parts = mesh::read_mesh(m, self.acc, self.variant, |i| uv_maps.get(&i).copied().flatten())?;
        for p in parts.iter().filter(|p| p.rest.uvs.is_none()) {
            if let Some(uv) = uv_maps.get(&p.material).copied().flatten() {
                self.warnings.about(
                    format!("meshes[{}]{} primitives[{}]", m.index(), mesh::quoted(m.name()), p.primitive),
                    format!("has no TEXCOORD_{} for its material's textures; they are not used", uv.set),
                );
            }
        }
        self.meshes.insert(m.index(), parts.clone());
        Ok(parts)
    }

    /// The node's mesh: one primitive goes on the node itself, several on one child node each
    /// ("NAME.0", "NAME.1", …), since a refrakt node has one shape and one material.
    fn mesh(&mut self, g: &gltf::Node, node: &Shared<Node>) -> Result<()> {
        let Some(m) = g.mesh() else { return Ok(()) };
        let parts = self.parts(&m)?;
        let targets = parts.iter().map(|p| p.targets.len()).max().unwrap_or(0);
        let weights = g.weights().or(m.weights()).map(<[f32]>::to_vec).unwrap_or_default();
        self.graph.weights[g.index()] = (0..targets).map(|k| weights.get(k).copied().unwrap_or(0.0)).collect();
        let single = parts.len() == 1;
        for part in parts {
            let MaterialEntry(material, boundary, _) = self.material(part.material)?;
            // Once per mesh primitive, however many nodes share it.
            if self.checked.insert((m.index(), part.primitive)) {
                self.warn_if_flat_but_curved(g, &m, &part);
                if let Material::Glass(glass) = &*material.borrow() {
                    self.warn_if_no_volume(g, &m, &part, glass.thin);
                    self.warn_if_metallic(&part, glass);
                }
            }
            let source = format!("{} meshes[{}]{}", self.file(), m.index(), mesh::quoted(m.name()));
            let shape = Shape::Mesh { mesh: part.rest.clone(), source, boundary };
            let carrier = if single {
                node.clone()
            } else {
                let name = node.borrow().name.clone();
                let mut child = Node::new(format!("{name}.{}", part.primitive));
                child.origin = node.borrow().origin.clone();
                let child = shared(child);
                node.borrow_mut().children.push(child.clone());
                child
            };
            {
                let mut c = carrier.borrow_mut();
                c.shape = Some(shared(shape));
                c.material = Some(material);
            }
            let skinned = g.skin().filter(|_| part.influences.is_some());
            if !part.targets.is_empty() || skinned.is_some() {
                if let Some(s) = &skinned {
                    self.skinned.push((self.graph.deformables.len(), s.index()));
                }
                let current = part.rest.clone();
                self.graph.deformables.push(Deformable { node: Rc::downgrade(&carrier), weights_of: g.index(), part, skin: None, current });
            }
        }
        Ok(())
    }

    /// How a transmissive primitive will render when its material and its shape disagree, once
    /// per mesh primitive: a closed solid whose material is thin-walled (transmission without
    /// KHR_materials_volume) renders as a thin shell, and a closed but flat solid encloses
    /// nothing to voxelize. (An open mesh with a thickness is a guess the frame warns of.)
    fn warn_if_no_volume(&mut self, g: &gltf::Node, m: &gltf::Mesh, part: &Part, thin: Option<bool>) {
        let what = primitive_name(g, m, part);
        let why = mesh::encloses_no_volume(&part.rest);
        if thin == Some(true) && why.is_none() {
            self.warnings.about(
                what,
                "a closed solid whose material is thin-walled (transmission without KHR_materials_volume, as glTF defines \
                 it), so it renders as a thin shell that bends nothing; for solid glass give the material \
                 KHR_materials_volume with thicknessFactor > 0, or extras.refrakt.thin = false",
            );
        } else if let (Some(false), Some(why)) = (thin, why.filter(|w| w.contains("flat"))) {
            self.warnings.about(
                what,
                format!(
                    "extras.refrakt.thin is false, but {why}; refrakt renders such glass as the solid a closed mesh \
                     encloses, so it will not show (leave thin unset for a sheet, or give the sheet a thickness, e.g. \
                     Blender's Solidify modifier, and re-export)"
                ),
            );
        }
    }

    /// A primitive without NORMAL is shaded flat, as §3.7.2.1 requires; where its faces meet at
    /// the small angles of a curved surface, the exporter most likely left its normals out, and
    /// the facets will show (in glass most of all: each refracts on its own).
    fn warn_if_flat_but_curved(&mut self, g: &gltf::Node, m: &gltf::Mesh, part: &Part) {
        if part.rest.normals == Normals::Flat && part.rest.looks_curved() {
            self.warnings.about(
                primitive_name(g, m, part),
                "has no NORMAL attribute, so it is shaded flat as glTF requires, though its faces meet at the small angles \
                 of a curved surface: its facets will show; export it with normals (Blender: Export ▸ Data ▸ Mesh ▸ Normals) \
                 for a smooth surface",
            );
        }
    }

    /// Glass that is all metal, with no texture to say where: glTF's metallicFactor defaults to
    /// 1, so a transmissive material written without it (by hand, or by a tool that leaves
    /// defaults out) is a mirror, in refrakt as in every glTF viewer. Said, as the likely slip.
    fn warn_if_metallic(&mut self, part: &Part, glass: &Glass) {
        let Some((index, m)) = part.material.and_then(|i| Some((i, self.materials.doc.materials().nth(i)?))) else { return };
        if glass.metallic >= 1.0 && glass.roughness_texture.is_none() {
            self.warnings.about(
                format!("materials[{index}]{}", mesh::quoted(m.name())),
                "is transmissive but metallic 1 (metallicFactor 1, glTF's default when it is left out): its surface is \
                 metal, which reflects and passes nothing, as glTF viewers show it; write \"metallicFactor\": 0 for glass",
            );
        }
    }

    /// An analytic field from the node's extras, in place of its mesh. Its medium comes from
    /// the mesh's (first) material when that is glass; a sphere or box takes the index the
    /// extras give.
    fn field(&mut self, g: &gltf::Node, node: &Shared<Node>, f: &FieldExtras) -> Result<()> {
        let first = match g.mesh() {
            Some(m) => m.primitives().next().map(|p| mesh::material_of(&p, self.variant)),
            None => None,
        };
        let mut glass = match first {
            Some(i) => match &*self.material(i)?.0.borrow() {
                Material::Glass(g) => g.clone(),
                Material::Diffuse(_) => Glass::default(),
            },
            None => Glass::default(),
        };
        glass.ior = f.ior;
        let shape = match f.kind {
            FieldType::Luneburg => Shape::Luneburg { radius: f.radius, boundary: f.boundary },
            FieldType::Sphere => Shape::Sphere { radius: f.radius, boundary: f.boundary },
            FieldType::Box => Shape::Box { size: f.size, boundary: f.boundary },
            FieldType::Slab => Shape::Slab { size: f.size, ior: f.ior, gradient: f.gradient, boundary: f.boundary },
        };
        let mut n = node.borrow_mut();
        n.shape = Some(shared(shape));
        n.material = Some(shared(Material::Glass(glass)));
        Ok(())
    }

    /// §3.7.3: joints are nodes anywhere in the scene, so skins are bound once all exist.
    fn bind_skins(&mut self, doc: &gltf::Document) -> Result<()> {
        for &(d, s) in &self.skinned {
            let skin = doc.skins().nth(s).ok_or_else(|| anyhow!("{}: skins[{s}] does not exist", self.acc.file))?;
            let what = format!("skins[{s}]{}", mesh::quoted(skin.name()));
            let joints: Vec<usize> = skin.joints().map(|j| j.index()).collect();
            let inverse_bind = match skin.inverse_bind_matrices() {
                Some(a) => {
                    let m = self.acc.floats_of(a.index(), &format!("{what} inverseBindMatrices"), 16)?;
                    if m.len() < joints.len() || m.values.iter().any(|x| !x.is_finite()) {
                        bail!("{}: {what}: inverseBindMatrices needs a finite matrix per joint ({}), it has {}", self.acc.file, joints.len(), m.len());
                    }
                    m.values.chunks_exact(16).map(Mat4::from_cols_slice).collect()
                }
                // §3.7.3.1: "When undefined, each matrix is a 4x4 identity matrix."
                None => vec![Mat4::IDENTITY; joints.len()],
            };
            let deformable = &mut self.graph.deformables[d];
            let inf = deformable.part.influences.as_ref().expect("skinned parts have influences");
            if let Some(j) = inf.joints.iter().find(|&&j| j as usize >= joints.len()) {
                bail!("{}: {what}: a vertex names joint {j}, but the skin has {} joints", self.acc.file, joints.len());
            }
            let missing = joints.iter().filter(|&&j| self.graph.nodes[j].strong_count() == 0).count();
            if missing > 0 {
                self.warnings.about(format!("{what} ({missing} of its joints)"), "joints are not in the imported scene; the mesh keeps its rest shape");
            }
            let joints = joints.iter().map(|&j| self.graph.nodes[j].clone()).collect();
            deformable.skin = Some(Skin { joints, inverse_bind });
        }
        Ok(())
    }
}

/// "meshes[i] "name" primitives[j] (on nodes[k] "name")", as warnings name a primitive.
fn primitive_name(g: &gltf::Node, m: &gltf::Mesh, part: &Part) -> String {
    format!("meshes[{}]{} primitives[{}] (on nodes[{}]{})", m.index(), mesh::quoted(m.name()), part.primitive, g.index(), mesh::quoted(g.name()))
}
