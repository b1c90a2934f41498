//! The scene graph: a hierarchy of named nodes with local transforms, each optionally carrying a
//! shape, a material, a light or a camera, plus scene-wide settings (camera choice, environment,
//! volume, photon budget).
//!
//! The graph is what scripts and glTF files build and animate. Once per frame
//! [`evaluate`](eval::evaluate) resolves world transforms and flattens it into a
//! [`FrameDesc`](crate::frame::FrameDesc), the only thing the GPU pipeline reads.
//!
//! Nodes, shapes and materials are shared (`Rc<RefCell<…>>`): a material assigned to two nodes
//! and edited in `update` changes both, as in Blender.

pub mod environment;
pub mod eval;
pub mod image_header;
pub mod index_fn;
pub mod light;
pub mod material;
pub mod mesh;
pub mod obj;
pub mod shape;

use std::cell::RefCell;
use std::path::PathBuf;
use std::rc::Rc;

use glam::{Mat4, Quat, Vec2, Vec3};

pub use environment::{EnvImage, Environment, EnvironmentSource};
pub use index_fn::{IndexFn, IndexFunction};
pub use light::{Light, LightKind};
pub use material::{AlphaMode, Diffuse, Fog, Glass, Material, Texture2d, Wrap};
pub use mesh::{MeshData, Normals};
pub use shape::Shape;

pub type Shared<T> = Rc<RefCell<T>>;

pub fn shared<T>(t: T) -> Shared<T> {
    Rc::new(RefCell::new(t))
}

/// Where something was defined, for error messages (`scene.lua:12`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Origin(pub String);

impl std::fmt::Display for Origin {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

/// Local transform: scale, then rotate, then translate (glTF's TRS order).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    pub translation: Vec3,
    pub rotation: Quat,
    pub scale: Vec3,
}

impl Default for Transform {
    fn default() -> Self {
        Self { translation: Vec3::ZERO, rotation: Quat::IDENTITY, scale: Vec3::ONE }
    }
}

impl Transform {
    pub fn matrix(&self) -> Mat4 {
        Mat4::from_scale_rotation_translation(self.scale, self.rotation, self.translation)
    }
}

/// A pinhole camera. On the scene it is placed by `position` and `target` (or `rotation`); on a
/// node it looks down the node's local −Z with +Y up, as in glTF.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    pub position: Vec3,
    pub target: Option<Vec3>,
    pub rotation: Option<Quat>,
    pub up: Vec3,
    /// Vertical field of view, radians.
    pub fov_y: f32,
    pub size: (u32, u32),
    /// An orthographic camera: the height of the view, metres (parallel rays; `fov_y` unused).
    pub orthographic: Option<f32>,
    /// A thin lens instead of the pinhole: depth of field.
    pub lens: Lens,
    /// Nothing nearer than this, metres along the view, is seen (Blender's *Clip Start*, glTF's
    /// `znear`): camera rays start on that plane — a way to look through a wall into a room.
    pub clip_start: f32,
}

/// A thin lens (pbrt-v4 §5.2.3): rays through a pixel leave every point of the aperture and meet
/// on the plane in focus, so what lies nearer or farther blurs into the aperture's shape.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lens {
    /// The aperture's diameter, metres (a lens of focal length f at f-number N: f / N); 0: a
    /// pinhole, everything sharp.
    pub aperture: f32,
    /// Distance along the view to the plane in focus, metres; `None`: the scene camera's target's
    /// distance, else [`Lens::DEFAULT_FOCUS`] ([`Camera::focus_distance`]).
    pub focus: Option<f32>,
    /// Blades of the diaphragm: a regular polygon of this many corners (3 or more), or 0 for a
    /// round aperture — the shape out-of-focus highlights (bokeh) take.
    pub blades: u32,
    /// The polygon's turn about the view, radians: 0 puts a corner toward the image's right.
    pub blade_rotation: f32,
    /// Lens shift, as Blender's Shift X/Y: the image moved across the image plane (x right,
    /// y up) in fractions of the frame's larger side — the view keeps its direction, so
    /// verticals stay parallel (architecture), and a subject off-centre is framed without a turn.
    pub shift: Vec2,
}

impl Lens {
    /// The focus distance of a camera with neither `focus` nor a target (Blender's default).
    pub const DEFAULT_FOCUS: f32 = 10.0;
    /// The nearest focus an animated lens is held at, metres (a still one must be > 0).
    pub const MIN_FOCUS: f32 = 1e-4;
    /// The widest aperture taken, metres.
    pub const MAX_APERTURE: f32 = 100.0;
    /// The most blades a diaphragm may have.
    pub const MAX_BLADES: u32 = 64;
    /// The largest lens shift either way, in frames (Blender's limit).
    pub const MAX_SHIFT: f32 = 10.0;

    /// Whether `blades` makes an aperture: 0 (round) or a polygon of 3 to [`Self::MAX_BLADES`].
    pub fn blades_are_valid(blades: u32) -> bool {
        blades == 0 || (3..=Self::MAX_BLADES).contains(&blades)
    }
}

impl Default for Lens {
    fn default() -> Self {
        Self { aperture: 0.0, focus: None, blades: 0, blade_rotation: 0.0, shift: Vec2::ZERO }
    }
}

impl Default for Camera {
    fn default() -> Self {
        Self {
            position: Vec3::new(0.0, 0.0, 3.0),
            target: Some(Vec3::ZERO),
            rotation: None,
            up: Vec3::Y,
            fov_y: 35f32.to_radians(),
            size: (1024, 576),
            orthographic: None,
            lens: Lens::default(),
            clip_start: 0.0,
        }
    }
}

impl Camera {
    /// The largest `clip_start`, metres.
    pub const MAX_CLIP_START: f32 = 1e6;

    /// World orientation (camera looks down its local −Z) when placed on the scene.
    pub fn orientation(&self) -> Quat {
        if let Some(r) = self.rotation {
            return r;
        }
        let target = self.target.unwrap_or(self.position - Vec3::Z);
        look_rotation((target - self.position).normalize_or(Vec3::NEG_Z), self.up)
    }

    /// The distance to the plane in focus: `lens.focus`, else — for the scene's camera, placed
    /// by its `target` — the target's distance, else [`Lens::DEFAULT_FOCUS`].
    pub fn focus_distance(&self, on_node: bool) -> f32 {
        let to_target = self.target.filter(|_| !on_node).map(|t| (t - self.position).length()).filter(|d| *d > 1e-6);
        self.lens.focus.or(to_target).unwrap_or(Lens::DEFAULT_FOCUS)
    }

    /// The camera as a frame sees it, at `position` looking by `orientation`: the scene's camera,
    /// or one on a node (`on_node`: its own `position` and `target` unused).
    pub fn desc(&self, position: Vec3, orientation: Quat, on_node: bool) -> crate::frame::CameraDesc {
        crate::frame::CameraDesc {
            position,
            orientation,
            fov_y: self.fov_y,
            width: self.size.0,
            height: self.size.1,
            orthographic: self.orthographic,
            aperture: self.lens.aperture,
            focus: self.focus_distance(on_node),
            blades: self.lens.blades,
            blade_rotation: self.lens.blade_rotation,
            shift: self.lens.shift,
            clip_start: self.clip_start,
            crop: None,
        }
    }
}

/// The rotation that turns local −Z to `forward` (unit) and local +Y as close to `up` as it
/// can (glTF's camera and light convention). When `forward` is parallel to `up`, +Z stands in.
pub fn look_rotation(forward: Vec3, up: Vec3) -> Quat {
    let up = if forward.cross(up).length_squared() < 1e-8 { Vec3::Z } else { up };
    // Axes: right, up, and back (the object looks down its local −Z).
    let right = forward.cross(up).normalize();
    Quat::from_mat3(&glam::Mat3::from_cols(right, right.cross(forward), -forward))
}

/// Settings of the voxel volume that holds the refractive media.
#[derive(Clone, Debug, PartialEq)]
pub struct VolumeSettings {
    /// Voxels along the longest side of the box.
    pub resolution: u32,
    /// Air around the fitted objects, metres (at least a few voxels are always kept).
    pub margin: f32,
    /// Fixed world box (min, max); fitted to the refractive objects when `None`.
    pub bounds: Option<(Vec3, Vec3)>,
    /// Where `bounds` were last set (`scene.lua:12`), for the error when they are not a box.
    pub bounds_origin: Option<String>,
    /// Default smooth boundary width of solids, voxels.
    pub boundary: f32,
    /// Ray-equation step of the viewing pass, voxels.
    pub step: f32,
    /// Contact distance, metres: where the surfaces of two solids (glass and the liquid in it,
    /// ice and water) lie closer than this along a ray, light crosses them as one interface
    /// between their two media — however they were modelled: coincident, overlapping or with
    /// a hair's gap. 0 turns it off (every surface on its own: a real film of air).
    pub contact: f32,
}

/// The default contact distance (`VolumeSettings::contact`), metres: a quarter millimetre —
/// wider than the gaps and chord errors of a liquid modelled against its glass, thinner than
/// any glass wall.
pub const DEFAULT_CONTACT: f32 = 2.5e-4;

impl Default for VolumeSettings {
    fn default() -> Self {
        Self { resolution: 128, margin: 0.05, bounds: None, bounds_origin: None, boundary: 3.0, step: 0.5, contact: DEFAULT_CONTACT }
    }
}

impl VolumeSettings {
    /// Checks a fixed box: both corners given, and `max` above `min` on every axis.
    pub fn check_bounds(&self, lo: Vec3, hi: Vec3) -> Result<(), String> {
        if !lo.is_finite() || !hi.is_finite() {
            return Err("volume.min and volume.max must be given together".into());
        }
        if hi.cmple(lo).any() {
            return Err(format!("volume.max {hi} must be greater than volume.min {lo} on every axis"));
        }
        Ok(())
    }
}

/// One node of the graph.
#[derive(Clone, Debug, Default)]
pub struct Node {
    pub name: String,
    pub transform: Transform,
    pub children: Vec<Shared<Node>>,
    pub shape: Option<Shared<Shape>>,
    pub material: Option<Shared<Material>>,
    pub camera: Option<Shared<Camera>>,
    pub light: Option<Shared<Light>>,
    pub visible: bool,
    pub origin: Origin,
}

impl Node {
    pub fn new(name: impl Into<String>) -> Self {
        Self { name: name.into(), visible: true, ..Default::default() }
    }
}

/// The element called `chosen`, else the one whose index it is — how `--scene`, `--animation`
/// and `--camera` pick (so unnamed ones can be chosen too, and a name that looks like a number
/// still wins).
pub fn by_name_or_index(names: &[Option<&str>], chosen: &str) -> Option<usize> {
    names.iter().position(|n| *n == Some(chosen)).or_else(|| chosen.parse::<usize>().ok().filter(|&i| i < names.len()))
}

/// Motion blur (Blender's Render ▸ Motion Blur, shutter position Center): the shutter is open
/// for `shutter` frames around each frame's time, and the frame is the mean of the scene
/// rendered at `steps` instants across that interval — the midpoints of equal parts, each with
/// its share of the frame's camera samples and photons, so a blurred frame costs about what a
/// still does plus a volume build per instant. Objects, lights and camera blur alike: each
/// instant is the whole scene at its time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionBlur {
    /// Frames the shutter is open (Blender's Shutter), > 0.
    pub shutter: f32,
    /// Instants across the interval, 2 to [`Self::MAX_STEPS`].
    pub steps: u32,
}

impl MotionBlur {
    pub const DEFAULT_STEPS: u32 = 8;
    pub const MAX_STEPS: u32 = 64;
    /// The longest shutter, frames.
    pub const MAX_SHUTTER: f32 = 100.0;

    /// A scene's motion blur, if its shutter opens over more than one instant.
    pub fn of(shutter: f32, steps: u32) -> Option<Self> {
        (shutter > 0.0 && steps > 1).then_some(Self { shutter, steps })
    }

    /// The instants of a frame at `t` (seconds) at `fps` frames a second: the midpoints of
    /// `steps` equal parts of [t − s/2, t + s/2], s the shutter in seconds.
    pub fn instants(&self, t: f64, fps: f64) -> impl Iterator<Item = f64> + use<> {
        let (open, steps) = (self.shutter as f64 / fps, self.steps);
        (0..steps).map(move |k| t + open * ((k as f64 + 0.5) / steps as f64 - 0.5))
    }
}

/// Diffuse bounces a scene's light takes unless it says otherwise (as Cycles' default).
pub const DEFAULT_BOUNCES: u32 = 4;
/// The most diffuse bounces a scene may ask for (Russian roulette ends most paths long before).
pub const MAX_BOUNCES: u32 = 1024;

/// The whole scene: settings plus the root nodes.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The scene camera (placed by position/target), if any.
    pub camera: Option<Shared<Camera>>,
    pub environment: Shared<Environment>,
    pub volume: Shared<VolumeSettings>,
    pub photons: u32,
    /// Diffuse bounces of bounced light (Cycles' default diffuse bounces); 0 leaves it out.
    pub bounces: u32,
    /// Photons for bounced light; None: as many as `photons`.
    pub bounce_photons: Option<u32>,
    /// A scattering medium filling the volume box (light shafts), if any.
    pub fog: Option<Shared<Fog>>,
    /// Camera rays per pixel.
    pub samples: u32,
    /// The animation's length, seconds, where the script says (live sessions' time slider).
    pub duration: Option<f64>,
    /// Motion blur: how long the shutter stays open, in frames (0: no blur).
    pub shutter: f32,
    /// Instants of the shutter interval a motion-blurred frame is rendered at.
    pub motion_steps: u32,
    pub roots: Vec<Shared<Node>>,
    /// Folder of the scene file: relative asset paths resolve here.
    pub base_dir: PathBuf,
}

impl Default for Scene {
    fn default() -> Self {
        Self {
            camera: None,
            environment: shared(Environment::default()),
            volume: shared(VolumeSettings::default()),
            photons: 70_000,
            bounces: DEFAULT_BOUNCES,
            bounce_photons: None,
            fog: None,
            samples: 4,
            duration: None,
            shutter: 0.0,
            motion_steps: MotionBlur::DEFAULT_STEPS,
            roots: Vec::new(),
            base_dir: PathBuf::from("."),
        }
    }
}

impl Scene {
    /// Depth-first search for a node by name.
    pub fn find(&self, name: &str) -> Option<Shared<Node>> {
        fn walk(nodes: &[Shared<Node>], name: &str) -> Option<Shared<Node>> {
            for n in nodes {
                if n.borrow().name == name {
                    return Some(n.clone());
                }
                if let Some(hit) = walk(&n.borrow().children, name) {
                    return Some(hit);
                }
            }
            None
        }
        walk(&self.roots, name)
    }

    /// The world matrix of `node` (parent · … · local, the order frames are evaluated in), or
    /// `None` when it is not in the scene.
    pub fn world_matrix(&self, node: &Shared<Node>) -> Option<Mat4> {
        fn walk(nodes: &[Shared<Node>], parent: Mat4, target: &Shared<Node>) -> Option<Mat4> {
            nodes.iter().find_map(|n| {
                let world = parent * n.borrow().transform.matrix();
                if Rc::ptr_eq(n, target) { Some(world) } else { walk(&n.borrow().children, world, target) }
            })
        }
        walk(&self.roots, Mat4::IDENTITY, node)
    }

    /// Takes `node` out of the graph, wherever it hangs; false if it was not in it.
    pub fn remove(&mut self, node: &Shared<Node>) -> bool {
        remove_from(&mut self.roots, node)
    }
}

/// Removes `target` from `nodes` or from anywhere below them.
pub fn remove_from(nodes: &mut Vec<Shared<Node>>, target: &Shared<Node>) -> bool {
    if let Some(i) = nodes.iter().position(|n| Rc::ptr_eq(n, target)) {
        nodes.remove(i);
        return true;
    }
    nodes.iter().any(|n| remove_from(&mut n.borrow_mut().children, target))
}
