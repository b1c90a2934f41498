//! Evaluating the scene graph at one moment: world transforms, the active camera, lights, and
//! the volume box fitted around the refractive objects — flattened into a [`FrameDesc`].

use std::sync::Arc;

use anyhow::{Result, anyhow, bail};
use glam::{Mat4, UVec3, Vec3};

use super::light::LUMENS_PER_WATT;
use super::environment::Environment;
use super::{Glass, IndexFn, LightKind, Material, MeshData, Node, Scene, Shape, Shared, index_fn, mesh};
use crate::frame::{CameraDesc, FieldDesc, FieldKind, FogDesc, FrameDesc, LightDesc, LightShape, MeshInstance, Receiver, VolumeDesc};

/// Choices the command line can override.
#[derive(Clone, Debug, Default)]
pub struct EvalOptions {
    /// `--size WxH`.
    pub size: Option<(u32, u32)>,
    /// `--region X,Y,W,H`: only this part of the frame (pixels from its top-left corner).
    pub region: Option<Region>,
    /// `--volume N`: voxels along the longest side.
    pub resolution: Option<u32>,
    /// `--camera NAME` or `INDEX`: a node carrying a camera, by name or by its place among the
    /// camera nodes.
    pub camera: Option<String>,
    /// `--samples N`: camera rays per pixel.
    pub samples: Option<u32>,
    /// `--photons N`: the photon budget.
    pub photons: Option<u32>,
    /// `--bounces N`: diffuse bounces of bounced light.
    pub bounces: Option<u32>,
    /// `--environment PRESET|FILE[:INTENSITY]`: the environment in place of the scene's.
    pub environment: Option<Environment>,
}

/// A node with its world matrix.
pub struct Placed {
    pub node: Shared<Node>,
    pub world: Mat4,
}

/// The visible nodes in evaluation order (depth first, parents before children) with their
/// world matrices: the order a frame's lights and shapes come in.
pub fn placed_nodes(scene: &Scene) -> Vec<Placed> {
    let mut placed = Vec::new();
    flatten(&scene.roots, Mat4::IDENTITY, &mut placed);
    placed
}

fn flatten(nodes: &[Shared<Node>], parent: Mat4, out: &mut Vec<Placed>) {
    for n in nodes {
        let node = n.borrow();
        if !node.visible {
            continue;
        }
        let world = parent * node.transform.matrix();
        out.push(Placed { node: n.clone(), world });
        flatten(&node.children, world, out);
    }
}

/// What the nodes contribute, before the volume (and so the voxel size) is known.
#[derive(Default)]
struct Contents {
    fields: Vec<FieldDesc>,
    /// Fields defined by a script function (index into `fields`): sampled once the volume is known.
    functions: Vec<(usize, IndexFn)>,
    meshes: Vec<MeshInstance>,
    receivers: Vec<Receiver>,
    lights: Vec<LightDesc>,
}

/// Evaluates the scene as it stands (after `update` ran) into a frame description.
pub fn evaluate(scene: &Scene, time: f64, opts: &EvalOptions) -> Result<FrameDesc> {
    let placed = placed_nodes(scene);
    let settings = scene.volume.borrow().clone();
    let resolution = opts.resolution.unwrap_or(settings.resolution);

    let mut c = Contents::default();
    for p in &placed {
        place_shape(p, &mut c)?;
        if let Some(light) = light_of(p)? {
            c.lights.push(light);
        }
    }
    let mut bounds: Vec<(Vec3, Vec3, Option<f32>)> = c.fields.iter().map(|f| (f.bounds.0, f.bounds.1, opt_boundary(f.boundary))).collect();
    bounds.extend(c.meshes.iter().map(|m| (m.bounds.0, m.bounds.1, opt_boundary(m.boundary))));
    let volume = fit_volume(&bounds, &settings, resolution)?;
    // Boundary widths are set in voxels; now that the voxel size is known, make them metres.
    let metres = |b: f32| if b < 0.0 { settings.boundary } else { b } * volume.voxel_size;
    // Sharp objects are voxelized only to mark where they are (`interfaces::MARK_WIDTH_VOXELS`).
    let mark = crate::pipeline::interfaces::MARK_WIDTH_VOXELS;
    for f in &mut c.fields {
        f.boundary = metres(if f.sharp { mark } else { f.boundary });
    }
    for m in &mut c.meshes {
        m.boundary = metres(if m.sharp { mark } else { m.boundary });
    }
    for (i, n) in &c.functions {
        let samples = index_fn::sample_over_voxels(&c.fields[*i], n, &volume)?;
        c.fields[*i].kind = FieldKind::Sampled(Arc::new(samples));
    }
    let camera = camera_of(scene, &placed, opts)?;
    let fog = scene.fog.as_ref().map(|f| {
        let f = f.borrow();
        FogDesc { scattering: f.scattering, absorption: f.absorption, g: f.g }
    });
    Ok(FrameDesc {
        time,
        camera,
        environment: opts.environment.clone().unwrap_or_else(|| scene.environment.borrow().clone()),
        volume,
        fields: c.fields,
        meshes: c.meshes,
        receivers: c.receivers,
        lights: c.lights,
        fog,
        photons: opts.photons.unwrap_or(scene.photons),
        bounces: opts.bounces.unwrap_or(scene.bounces),
        bounce_photons: bounce_photons(scene, opts.photons),
        samples: opts.samples.unwrap_or(scene.samples),
        motion_blur: super::MotionBlur::of(scene.shutter, scene.motion_steps),
    })
}

/// The bounce photons: the scene's (as many as its `photons` unless it says), scaled as
/// `--photons` scales the caustic budget, so one option makes a quick preview of both.
fn bounce_photons(scene: &Scene, photons: Option<u32>) -> u32 {
    let own = scene.bounce_photons.unwrap_or(scene.photons);
    match photons {
        Some(p) if scene.photons > 0 => (own as f64 * p as f64 / scene.photons as f64).round().min((1u32 << 30) as f64) as u32,
        Some(p) => p,
        None => own,
    }
}

/// Boundaries are stored as voxels, negative meaning "the volume's default", until the voxel
/// size is known.
fn opt_boundary(b: f32) -> Option<f32> {
    (b >= 0.0).then_some(b)
}

fn display_name(node: &Node) -> String {
    if node.name.is_empty() { format!("(unnamed node made at {})", node.origin) } else { format!("\"{}\"", node.name) }
}

/// Sorts a node's shape into fields, refractive meshes or receivers.
fn place_shape(p: &Placed, c: &mut Contents) -> Result<()> {
    let node = p.node.borrow();
    let Some(shape) = &node.shape else { return Ok(()) };
    let shape = shape.borrow().clone();
    let name = display_name(&node);
    let (scale, _, _) = p.world.to_scale_rotation_translation();
    let det = p.world.determinant();
    if !p.world.is_finite() || det == 0.0 || !det.is_finite() {
        bail!("{}: node {name} has a degenerate or non-finite transform (scale {scale})", node.origin);
    }
    let material = node.material.as_ref().map(|m| m.borrow().clone());
    // Triangles may be mirrored (a negative scale, common in glTF files): the solid
    // voxelization counts crossings and receivers are two-sided, so winding does not matter.
    // Analytic fields measure distance in local units and need a positive scale.
    let triangles = matches!(material, Some(Material::Diffuse(_))) || matches!(shape, Shape::Mesh { .. });
    if !triangles && scale.min_element() <= 0.0 {
        bail!(
            "{}: node {name} is mirrored (scale {scale}); an analytic {} cannot be, give it a positive scale",
            node.origin,
            shape.kind_name()
        );
    }
    match (material, &shape) {
        (Some(Material::Diffuse(diffuse)), _) => {
            let mesh = match &shape {
                Shape::Plane { size } => Arc::new(mesh::plane(*size)),
                Shape::Box { size, .. } => Arc::new(mesh::cuboid(*size)),
                Shape::Sphere { radius, .. } => Arc::new(mesh::icosphere(*radius, 4)),
                Shape::Mesh { mesh, .. } => mesh.clone(),
                other => bail!(
                    "{}: node {name}: a {} defines an index of refraction, so its material must be glass, not diffuse",
                    node.origin,
                    other.kind_name()
                ),
            };
            c.receivers.push(Receiver { name: node.name.clone(), mesh, world: p.world, diffuse });
        }
        (Some(Material::Glass(glass)), Shape::Mesh { mesh, boundary, .. }) => {
            c.meshes.push(mesh_instance(&node, mesh, p.world, glass, *boundary)?);
        }
        // A plane of glass is a sheet (a window pane, a film): it has no inside to be a solid.
        (Some(Material::Glass(glass)), Shape::Plane { size }) => {
            if glass.thin == Some(false) {
                bail!("{}: node {name}: a plane has no inside, so its glass cannot be a solid (thin = false); use a box or a mesh", node.origin)
            }
            let sheet = Glass { thin: Some(true), ..glass };
            c.meshes.push(mesh_instance(&node, &Arc::new(mesh::plane(*size)), p.world, sheet, None)?);
        }
        (Some(Material::Glass(glass)), _) => push_field(c, &node, &shape, p.world, scale, glass),
        (None, s) if s.is_index_field() => {
            push_field(c, &node, &shape, p.world, scale, Glass { ior: 1.0, ..Default::default() })
        }
        (None, s) => bail!(
            "{}: the {} of node {name} needs a material, e.g. material = refrakt.glass{{ior = 1.5}} or refrakt.diffuse{{color = {{0.8, 0.8, 0.8}}}}",
            node.origin,
            s.kind_name()
        ),
    }
    Ok(())
}

fn mesh_instance(node: &Node, mesh: &Arc<MeshData>, world: Mat4, glass: Glass, boundary: Option<f32>) -> Result<MeshInstance> {
    // Every mesh reaches the GPU through here (Lua, OBJ, glTF), so it is checked here.
    mesh.check().map_err(|e| anyhow!("{}: the mesh of node {}: {e}", node.origin, display_name(node)))?;
    let (lo, hi) = mesh.bounds().ok_or_else(|| anyhow!("{}: the mesh of node {} has no vertices", node.origin, display_name(node)))?;
    let h = 0.5 * (hi - lo);
    let centre = Mat4::from_translation(0.5 * (lo + hi));
    // A glass mesh whose material does not say whether it is a sheet: a flat one is a pane,
    // a closed one a solid, an open curved one is voxelized as the solid it bounds (robust to
    // holes, as before sharp interfaces) — the first and last are guesses the frame warns of.
    // Tinted glass of index 1 (a gel, a coloured film, a tile of KHR_materials_transmission with
    // an index of 1) bends nothing but still colours what crosses it, as glTF tints at each
    // surface: sharp, a sheet where it is one (`thin`, or flat) and a solid where it is closed;
    // only an open solid of it would be air (`FrameDesc::warnings` says so).
    let refracts = is_sharp(&glass, boundary);
    let gel = !refracts && boundary.is_none() && glass.tinted();
    let facts = (refracts || gel).then(|| MeshData::glass_facts(mesh));
    let closed = facts.as_ref().is_some_and(|f| f.closed);
    let flat = glass.thin.is_none() && facts.as_ref().is_some_and(|f| f.flat);
    let guessed = refracts && glass.thin.is_none() && (flat || !closed);
    let thin = (refracts || gel) && glass.thin.unwrap_or(flat);
    let sharp = closed || thin;
    let mut glass = glass;
    if thin {
        // A sheet has no inside to absorb or scatter in.
        glass.absorption = Vec3::ZERO;
        glass.scattering = Vec3::ZERO;
    }
    Ok(MeshInstance {
        name: node.name.clone(),
        origin: node.origin.0.clone(),
        mesh: mesh.clone(),
        world,
        glass,
        boundary: boundary.unwrap_or(-1.0),
        bounds: world_bounds(&(world * centre), h),
        sharp,
        thin,
        guessed,
    })
}

/// Whether a glass object becomes a sharp interface: it refracts (n differs from air's) and its
/// script did not ask for a smooth boundary of a chosen width (`boundary = …` keeps the paper's
/// smoothed step, as before sharp interfaces existed).
fn is_sharp(glass: &Glass, boundary: Option<f32>) -> bool {
    boundary.is_none() && glass.refracts()
}

fn push_field(c: &mut Contents, node: &Node, shape: &Shape, world: Mat4, scale: Vec3, glass: Glass) {
    if let Shape::Field { n, .. } = shape {
        c.functions.push((c.fields.len(), n.clone()));
    }
    c.fields.push(field_of(node, shape, world, scale, glass));
}

/// The index field a node carries. Boundary is still in voxels here; a function-defined field
/// gets its samples once the volume is known.
fn field_of(node: &Node, shape: &Shape, world: Mat4, scale: Vec3, glass: Glass) -> FieldDesc {
    // Analytic fields measure distance in local units; a non-uniform scale is approximated by
    // the geometric mean (exact for uniform scale, which is what these shapes are for).
    let uniform = (scale.x * scale.y * scale.z).cbrt();
    let (kind, half_size, ior, gradient) = match shape {
        Shape::Sphere { radius, .. } => (FieldKind::Sphere, Vec3::splat(*radius), glass.ior, 0.0),
        Shape::Box { size, .. } => (FieldKind::Box, *size * 0.5, glass.ior, 0.0),
        Shape::Luneburg { radius, .. } => (FieldKind::Luneburg, Vec3::splat(*radius), 1.0, 0.0),
        Shape::Slab { size, ior, gradient, .. } => (FieldKind::Slab, *size * 0.5, *ior, *gradient),
        Shape::Field { size, .. } => (FieldKind::Sampled(Arc::default()), *size * 0.5, 1.0, 0.0),
        Shape::Mesh { .. } | Shape::Plane { .. } => unreachable!("meshes and planes are not analytic fields"),
    };
    // A thin sphere or box is a shell (a soap bubble). Tinted glass of index 1 is sharp too, a
    // shell or a solid (a coloured globe of film, a tinted ball that bends nothing), as tinted
    // glass of index 1 is in `mesh_instance`.
    let shell = glass.thin == Some(true);
    let sharp = matches!(shape, Shape::Sphere { .. } | Shape::Box { .. })
        && (is_sharp(&glass, shape.boundary()) || (shape.boundary().is_none() && glass.tinted()));
    let thin = sharp && shell;
    let mut glass = glass;
    if thin {
        // A shell has no inside to absorb or scatter in (as a sheet, `mesh_instance`).
        glass.absorption = Vec3::ZERO;
        glass.scattering = Vec3::ZERO;
    }
    FieldDesc {
        name: node.name.clone(),
        kind,
        world_to_local: world.inverse(),
        half_size,
        ior,
        gradient,
        boundary: shape.boundary().unwrap_or(-1.0),
        sharp,
        scale: uniform,
        thin,
        glass,
        bounds: world_bounds(&world, half_size),
    }
}

/// The light a node carries, in world space and radiometric units.
fn light_of(p: &Placed) -> Result<Option<LightDesc>> {
    let node = p.node.borrow();
    let Some(light) = &node.light else { return Ok(None) };
    let light = light.borrow().clone();
    let (_, rotation, position) = p.world.to_scale_rotation_translation();
    let mut direction = rotation * Vec3::NEG_Z;
    if let Some(t) = light.target {
        direction = (t - position).try_normalize().ok_or_else(|| {
            anyhow!("{}: the light of node {} aims at its own position", node.origin, display_name(&node))
        })?;
    }
    if let Some(d) = light.direction {
        direction = d.try_normalize().ok_or_else(|| anyhow!("{}: light direction must not be zero", node.origin))?;
    }
    let (right, up) = match light.kind {
        LightKind::Rect { .. } if light.target.is_none() && light.direction.is_none() => (rotation * Vec3::X, rotation * Vec3::Y),
        _ => {
            let right = direction.any_orthonormal_vector();
            (right, direction.cross(right))
        }
    };
    let shape = match light.kind {
        LightKind::Point => LightShape::Point,
        LightKind::Spot { angle, blend } => {
            LightShape::Spot { cos_outer: angle.cos(), cos_inner: (angle * (1.0 - blend)).cos() }
        }
        LightKind::Sun { angular_diameter } => LightShape::Sun { half_angle: 0.5 * angular_diameter },
        LightKind::Rect { size, round } => LightShape::Rect { size, round },
    };
    Ok(Some(LightDesc {
        name: node.name.clone(),
        shape,
        position,
        direction,
        right,
        up,
        radiant: light.color * light.intensity / LUMENS_PER_WATT,
        radius: light.radius,
        visible: light.visible && !matches!(light.kind, LightKind::Sun { .. }),
    }))
}

/// World AABB of a local box of half extents `h` under `m`.
pub(super) fn world_bounds(m: &Mat4, h: Vec3) -> (Vec3, Vec3) {
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    for i in 0..8 {
        let c = Vec3::new(
            if i & 1 == 0 { -h.x } else { h.x },
            if i & 2 == 0 { -h.y } else { h.y },
            if i & 4 == 0 { -h.z } else { h.z },
        );
        let w = m.transform_point3(c);
        lo = lo.min(w);
        hi = hi.max(w);
    }
    (lo, hi)
}

/// The volume box: fixed by the script, or fitted around the refractive objects with the
/// margin plus enough voxels of air for the smooth boundary and the gradient stencil.
fn fit_volume(objects: &[(Vec3, Vec3, Option<f32>)], s: &super::VolumeSettings, resolution: u32) -> Result<VolumeDesc> {
    let max_boundary = objects.iter().filter_map(|o| o.2).fold(s.boundary, f32::max);
    let (lo, hi) = match s.bounds {
        Some((lo, hi)) => {
            s.check_bounds(lo, hi).map_err(|e| match &s.bounds_origin {
                Some(at) => anyhow::anyhow!("{at}: {e}"),
                None => anyhow::anyhow!(e),
            })?;
            (lo, hi)
        }
        None if objects.is_empty() => (Vec3::splat(-0.5), Vec3::splat(0.5)),
        None => {
            let lo = objects.iter().map(|o| o.0).fold(Vec3::splat(f32::INFINITY), Vec3::min);
            let hi = objects.iter().map(|o| o.1).fold(Vec3::splat(f32::NEG_INFINITY), Vec3::max);
            // Pad: the margin, half the boundary (which extends outside the surface) and two
            // voxels for the central differences, in a voxel size that itself depends on the pad.
            let pad_voxels = 0.5 * max_boundary + 2.0;
            let extent = (hi - lo).max_element() + 2.0 * s.margin;
            let voxel = extent / (resolution as f32 - 2.0 * pad_voxels).max(1.0);
            let pad = Vec3::splat(s.margin + pad_voxels * voxel);
            (lo - pad, hi + pad)
        }
    };
    let extent = hi - lo;
    let voxel_size = extent.max_element() / resolution as f32;
    if !(voxel_size.is_finite() && voxel_size > 0.0) {
        bail!("the volume box {lo} → {hi} is degenerate");
    }
    let dims = (extent / voxel_size).ceil().as_uvec3().max(UVec3::splat(4));
    // Centre the voxel grid on the box (rounding up may add a fraction of a voxel).
    let min = 0.5 * (lo + hi) - 0.5 * dims.as_vec3() * voxel_size;
    Ok(VolumeDesc { min, voxel_size, dims, step: s.step * voxel_size, contact: s.contact })
}

/// The nodes that carry a camera, in evaluation order: what `--camera INDEX` counts (and
/// `refrakt dump` lists as `cameras`).
pub fn camera_nodes(placed: &[Placed]) -> Vec<&Placed> {
    placed.iter().filter(|p| p.node.borrow().camera.is_some()).collect()
}

/// A part of the frame to render alone (`--region`, Blender's border render): `size` pixels
/// from `origin`, the frame's top-left corner being (0, 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Region {
    pub origin: (u32, u32),
    pub size: (u32, u32),
}

impl Region {
    /// The camera's image narrowed to this region of its frame, which it must lie in.
    fn apply(&self, camera: &mut CameraDesc) -> Result<()> {
        let (frame, (x, y), (w, h)) = ((camera.width, camera.height), self.origin, self.size);
        if x as u64 + w as u64 > frame.0 as u64 || y as u64 + h as u64 > frame.1 as u64 {
            bail!("--region {x},{y},{w},{h} reaches past the {}×{} frame (it must lie inside: x + width ≤ {}, y + height ≤ {})", frame.0, frame.1, frame.0, frame.1);
        }
        camera.crop = Some(crate::frame::Crop { frame, origin: self.origin });
        (camera.width, camera.height) = self.size;
        Ok(())
    }
}

/// The camera for this frame: `--camera NAME` or `INDEX` (a node with a camera), else the scene
/// camera, else the first node camera; `--size` overrides the resolution, `--region` narrows
/// the image to a part of the frame.
fn camera_of(scene: &Scene, placed: &[Placed], opts: &EvalOptions) -> Result<CameraDesc> {
    let node_camera = |p: &Placed| -> Option<CameraDesc> {
        let node = p.node.borrow();
        let cam = node.camera.as_ref()?.borrow().clone();
        let (_, rotation, translation) = p.world.to_scale_rotation_translation();
        Some(cam.desc(translation, rotation, true))
    };
    let mut desc = if let Some(chosen) = &opts.camera {
        let cameras = camera_nodes(placed);
        let names: Vec<String> = cameras.iter().map(|p| p.node.borrow().name.clone()).collect();
        let named: Vec<Option<&str>> = names.iter().map(|n| Some(n.as_str()).filter(|n| !n.is_empty())).collect();
        super::by_name_or_index(&named, chosen).and_then(|i| node_camera(cameras[i])).ok_or_else(|| {
            let list: Vec<String> = names.iter().enumerate().map(|(i, n)| if n.is_empty() { format!("{i} (unnamed)") } else { format!("{i} \"{n}\"") }).collect();
            anyhow!(
                "--camera \"{chosen}\": no node of that name carries a camera, and there is no camera of that index (cameras: {})",
                if list.is_empty() { "none".into() } else { list.join(", ") }
            )
        })?
    } else if let Some(cam) = &scene.camera {
        let cam = cam.borrow();
        cam.desc(cam.position, cam.orientation(), false)
    } else if let Some(d) = placed.iter().find_map(node_camera) {
        d
    } else {
        let d = super::Camera::default();
        d.desc(d.position, d.orientation(), false)
    };
    if let Some((w, h)) = opts.size {
        desc.width = w;
        desc.height = h;
    }
    if let Some(region) = &opts.region {
        region.apply(&mut desc)?;
    }
    Ok(desc)
}
