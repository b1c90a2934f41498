//! Evaluating the scene graph at one moment: world transforms, the active camera, and the
//! volume box fitted around the refractive objects — flattened into a [`FrameDesc`].

use anyhow::{Result, anyhow, bail};
use glam::{Mat4, UVec3, Vec3};

use super::{Material, Node, Scene, Shape, Shared};
use crate::frame::{CameraDesc, FieldDesc, FieldKind, FrameDesc, VolumeDesc};

/// Choices the command line can override.
#[derive(Clone, Debug, Default)]
pub struct EvalOptions {
    /// `--size WxH`.
    pub size: Option<(u32, u32)>,
    /// `--volume N`: voxels along the longest side.
    pub resolution: Option<u32>,
    /// `--camera NAME`: a node carrying a camera.
    pub camera: Option<String>,
    /// `--samples N`: camera rays per pixel.
    pub samples: Option<u32>,
}

/// A node with its world matrix.
struct Placed {
    node: Shared<Node>,
    world: Mat4,
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

/// Evaluates the scene as it stands (after `update` ran) into a frame description.
pub fn evaluate(scene: &Scene, time: f64, opts: &EvalOptions) -> Result<FrameDesc> {
    let mut placed = Vec::new();
    flatten(&scene.roots, Mat4::IDENTITY, &mut placed);
    let volume_settings = scene.volume.borrow().clone();
    let resolution = opts.resolution.unwrap_or(volume_settings.resolution);

    let mut fields = Vec::new();
    for p in &placed {
        if let Some(f) = field_of(p)? {
            fields.push(f);
        }
    }
    let volume = fit_volume(&fields, &volume_settings, resolution)?;
    // Boundary widths are set in voxels; now that the voxel size is known, make them metres.
    for f in &mut fields {
        let voxels = if f.boundary < 0.0 { volume_settings.boundary } else { f.boundary };
        f.boundary = voxels * volume.voxel_size;
    }
    let camera = camera_of(scene, &placed, opts)?;
    let samples = opts.samples.unwrap_or(scene.samples);
    Ok(FrameDesc { time, camera, environment: scene.environment.borrow().clone(), volume, fields, samples })
}

/// The analytic index field a node carries, if any. Boundary is still in voxels here.
fn field_of(p: &Placed) -> Result<Option<FieldDesc>> {
    let node = p.node.borrow();
    let Some(shape) = &node.shape else { return Ok(None) };
    let shape = shape.borrow().clone();
    let name = if node.name.is_empty() { format!("(unnamed node made at {})", node.origin) } else { format!("\"{}\"", node.name) };
    let glass = match node.material.as_ref().map(|m| m.borrow().clone()) {
        Some(Material::Glass(g)) => Some(g),
        None => None,
    };
    let glass = match glass {
        Some(g) => g,
        None if shape.is_index_field() => super::Glass { ior: 1.0, ..Default::default() },
        None => bail!(
            "{}: the {} of node {name} needs a material, e.g. material = refrakt.glass{{ior = 1.5}}",
            node.origin,
            shape.kind_name()
        ),
    };
    let (scale, _, _) = p.world.to_scale_rotation_translation();
    if !p.world.is_finite() || scale.min_element() <= 0.0 {
        bail!("{}: node {name} has a degenerate or non-finite transform (scale {scale})", node.origin);
    }
    // Analytic fields measure distance in local units; a non-uniform scale is approximated by
    // the geometric mean (exact for uniform scale, which is what these shapes are for).
    let uniform = (scale.x * scale.y * scale.z).cbrt();
    let (kind, half_size, ior, gradient) = match shape {
        Shape::Sphere { radius, .. } => (FieldKind::Sphere, Vec3::splat(radius), glass.ior, 0.0),
        Shape::Box { size, .. } => (FieldKind::Box, size * 0.5, glass.ior, 0.0),
        Shape::Luneburg { radius, .. } => (FieldKind::Luneburg, Vec3::splat(radius), 1.0, 0.0),
        Shape::Slab { size, ior, gradient, .. } => (FieldKind::Slab, size * 0.5, ior, gradient),
    };
    let boundary_vox = shape.boundary();
    let bounds = world_bounds(&p.world, half_size);
    Ok(Some(FieldDesc {
        name: node.name.clone(),
        kind,
        world_to_local: p.world.inverse(),
        half_size,
        ior,
        gradient,
        // Negative marks "use the volume's default" until the voxel size is known.
        boundary: boundary_vox.unwrap_or(-1.0),
        scale: uniform,
        absorption: glass.absorption,
        scattering: glass.scattering,
        g: glass.g,
        bounds,
    }))
}

/// World AABB of a local box of half extents `h` under `m`.
fn world_bounds(m: &Mat4, h: Vec3) -> (Vec3, Vec3) {
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

/// The volume box: fixed by the script, or fitted around the fields with the margin plus
/// enough voxels of air for the smooth boundary and the gradient stencil.
fn fit_volume(fields: &[FieldDesc], s: &super::VolumeSettings, resolution: u32) -> Result<VolumeDesc> {
    let max_boundary = fields.iter().map(|f| if f.boundary < 0.0 { s.boundary } else { f.boundary }).fold(s.boundary, f32::max);
    let (lo, hi) = match s.bounds {
        Some((lo, hi)) => {
            if !lo.is_finite() || !hi.is_finite() {
                bail!("volume.min and volume.max must be given together");
            }
            if hi.cmple(lo).any() {
                bail!("volume.max {hi} must be greater than volume.min {lo} on every axis");
            }
            (lo, hi)
        }
        None if fields.is_empty() => (Vec3::splat(-0.5), Vec3::splat(0.5)),
        None => {
            let lo = fields.iter().map(|f| f.bounds.0).fold(Vec3::splat(f32::INFINITY), Vec3::min);
            let hi = fields.iter().map(|f| f.bounds.1).fold(Vec3::splat(f32::NEG_INFINITY), Vec3::max);
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
    Ok(VolumeDesc { min, voxel_size, dims, step: s.step * voxel_size })
}

/// The camera for this frame: `--camera NAME` (a node with a camera), else the scene camera,
/// else the first node camera; `--size` overrides the resolution.
fn camera_of(scene: &Scene, placed: &[Placed], opts: &EvalOptions) -> Result<CameraDesc> {
    let node_camera = |p: &Placed| -> Option<CameraDesc> {
        let node = p.node.borrow();
        let cam = node.camera.as_ref()?.borrow().clone();
        let (_, rotation, translation) = p.world.to_scale_rotation_translation();
        Some(CameraDesc { position: translation, orientation: rotation, fov_y: cam.fov_y, width: cam.size.0, height: cam.size.1 })
    };
    let mut desc = if let Some(name) = &opts.camera {
        placed
            .iter()
            .find(|p| p.node.borrow().name == *name && p.node.borrow().camera.is_some())
            .and_then(node_camera)
            .ok_or_else(|| {
                let names: Vec<String> = placed
                    .iter()
                    .filter(|p| p.node.borrow().camera.is_some())
                    .map(|p| format!("\"{}\"", p.node.borrow().name))
                    .collect();
                anyhow!(
                    "--camera \"{name}\": no node of that name carries a camera (cameras: {})",
                    if names.is_empty() { "none".into() } else { names.join(", ") }
                )
            })?
    } else if let Some(cam) = &scene.camera {
        let cam = cam.borrow();
        CameraDesc {
            position: cam.position,
            orientation: cam.orientation(),
            fov_y: cam.fov_y,
            width: cam.size.0,
            height: cam.size.1,
        }
    } else if let Some(d) = placed.iter().find_map(node_camera) {
        d
    } else {
        let d = super::Camera::default();
        CameraDesc { position: d.position, orientation: d.orientation(), fov_y: d.fov_y, width: d.size.0, height: d.size.1 }
    };
    if let Some((w, h)) = opts.size {
        desc.width = w;
        desc.height = h;
    }
    Ok(desc)
}
