//! A view for glTF files that bring no camera (most real ones), as glTF viewers give them: a
//! camera that frames the scene's bounds over the whole of the chosen animation, and a neutral
//! studio environment when the file sets none.
//!
//! The camera looks at the centre of the bounds from the front (+Z, glTF's "front" for a model
//! facing the viewer), raised by [`ELEVATION_DEG`] so floors where caustics land are seen, with
//! refrakt's default 35° vertical field of view, from the distance at which the bounding
//! sphere just fits the narrower of the image's two fields of view.

use anyhow::Result;
use glam::{Mat4, Vec3};

use super::Player;
use crate::scene::eval::placed_nodes;
use crate::scene::environment::{self, Environment, EnvironmentSource};
use crate::scene::{Camera, Scene, Shape, shared};

/// How far above the horizontal the default camera looks down at the scene.
pub const ELEVATION_DEG: f32 = 15.0;

/// Most scene times sampled for the bounds of an animated scene.
const MAX_SAMPLES: usize = 512;

/// Samples per second of animation between keyframes (extremes of rotations, skins and
/// cubic splines fall between keyframes).
const SAMPLES_PER_SECOND: f64 = 24.0;

/// World bounds (min, max) of a box of local `lo`..`hi` under `world`: its eight corners.
fn world_box(world: &Mat4, lo: Vec3, hi: Vec3) -> (Vec3, Vec3) {
    let mut b = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    for i in 0..8 {
        let corner = Vec3::new(if i & 1 == 0 { lo.x } else { hi.x }, if i & 2 == 0 { lo.y } else { hi.y }, if i & 4 == 0 { lo.z } else { hi.z });
        let p = world.transform_point3(corner);
        b = (b.0.min(p), b.1.max(p));
    }
    b
}

/// The local bounds of a shape, centred on its node (meshes: their own bounds).
fn local_bounds(shape: &Shape) -> Option<(Vec3, Vec3)> {
    match shape {
        Shape::Mesh { mesh, .. } => mesh.bounds(),
        other => {
            let h = other.local_half_extent();
            Some((-h, h))
        }
    }
}

/// World bounds of every visible shape of the scene as it stands.
pub fn shape_bounds(scene: &Scene) -> Option<(Vec3, Vec3)> {
    let mut all: Option<(Vec3, Vec3)> = None;
    for p in placed_nodes(scene) {
        let node = p.node.borrow();
        let Some((lo, hi)) = node.shape.as_ref().and_then(|s| local_bounds(&s.borrow())) else { continue };
        let (a, b) = world_box(&p.world, lo, hi);
        if a.is_finite() && b.is_finite() {
            all = Some(all.map_or((a, b), |(l, h)| (l.min(a), h.max(b))));
        }
    }
    all
}

/// Scene times (seconds) at which the animations are sampled for the bounds: every keyframe and
/// a regular grid over their duration, at most [`MAX_SAMPLES`] in all.
pub fn sample_times(player: &Player) -> Vec<f64> {
    if !player.is_animated() {
        return vec![0.0];
    }
    let duration = player.clips.iter().map(|c| c.duration()).fold(0.0f32, f32::max) as f64;
    let steps = ((duration * SAMPLES_PER_SECOND).ceil() as usize).clamp(1, MAX_SAMPLES / 2);
    let mut times: Vec<f64> = (0..=steps).map(|i| duration * i as f64 / steps as f64).collect();
    for clip in &player.clips {
        for s in &clip.samplers {
            times.extend(s.times.iter().map(|&t| t as f64).filter(|&t| t >= 0.0));
        }
    }
    times.sort_by(f64::total_cmp);
    times.dedup();
    if times.len() > MAX_SAMPLES {
        let every = times.len().div_ceil(MAX_SAMPLES);
        let last = *times.last().expect("not empty");
        times = times.into_iter().step_by(every).collect();
        times.push(last);
    }
    times
}

/// Bounds of the scene over all `times`, posing and deforming it at each (the caller poses it
/// again for the frame it renders).
pub fn animated_bounds(scene: &Scene, player: &mut Player, times: &[f64]) -> Option<(Vec3, Vec3)> {
    let mut all: Option<(Vec3, Vec3)> = None;
    for &t in times {
        player.pose(t);
        player.deform(scene);
        if let Some((a, b)) = shape_bounds(scene) {
            all = Some(all.map_or((a, b), |(l, h)| (l.min(a), h.max(b))));
        }
    }
    all
}

/// The default camera for bounds `lo`..`hi` and an image of `size` (width, height).
pub fn default_camera(lo: Vec3, hi: Vec3, size: (u32, u32)) -> Camera {
    let base = Camera { size, ..Camera::default() };
    let centre = 0.5 * (lo + hi);
    let radius = (0.5 * (hi - lo).length()).max(1e-3);
    let aspect = size.0.max(1) as f32 / size.1.max(1) as f32;
    let half_y = 0.5 * base.fov_y;
    let half_x = (half_y.tan() * aspect).atan();
    // A sphere of radius r seen from distance d fills a half-angle asin(r / d).
    let distance = radius / half_y.min(half_x).sin();
    let e = ELEVATION_DEG.to_radians();
    let from = Vec3::new(0.0, e.sin(), e.cos());
    Camera { position: centre + distance * from, target: Some(centre), ..base }
}

/// Lights `scene` by the neutral "studio" preset, as glTF viewers light a file that sets no
/// environment of its own.
pub fn light_by_studio(scene: &mut Scene) -> Result<()> {
    let image = environment::preset("studio")?;
    scene.environment = shared(Environment { source: EnvironmentSource::Preset { name: "studio".into(), image }, ..Environment::default() });
    Ok(())
}

/// A file with its own camera but no environment: lit by the studio preset, said once.
pub fn light_without_environment(scene: &mut Scene, file: &str) -> Result<()> {
    light_by_studio(scene)?;
    crate::warnings::say(&crate::warnings::Warning {
        file: Some(file.to_string()),
        message: "the file sets no environment, so the neutral \"studio\" environment lights it, as glTF viewers do \
                  (choose another with --environment PRESET|FILE[:INTENSITY], or set extras.refrakt.environment on \
                  the scene; docs/gltf.md#files-without-a-camera)"
            .into(),
        ..Default::default()
    });
    Ok(())
}

/// What glTF viewers show a file without a camera: a camera framing the scene's bounds over all
/// of its (chosen) animation, and — when the file sets no environment — the neutral "studio"
/// one; said in the log, since the user did not ask for either.
pub fn view_without_camera(scene: &mut Scene, player: &mut Player, no_environment: bool, size: Option<(u32, u32)>, file: &str) -> Result<()> {
    let times = sample_times(player);
    let bounds = animated_bounds(scene, player, &times);
    let size = size.unwrap_or(Camera::default().size);
    let mut said = Vec::new();
    if let Some((lo, hi)) = bounds {
        let camera = default_camera(lo, hi, size);
        said.push(format!(
            "a default camera at ({:.3}, {:.3}, {:.3}) frames the scene's bounds ({:.3}, {:.3}, {:.3}) → ({:.3}, {:.3}, {:.3}){}, \
             from the front and {}° above, with a {}° vertical field of view",
            camera.position.x, camera.position.y, camera.position.z, lo.x, lo.y, lo.z, hi.x, hi.y, hi.z,
            if times.len() > 1 { format!(" over {} sampled times of its animation", times.len()) } else { String::new() },
            ELEVATION_DEG,
            camera.fov_y.to_degrees().round(),
        ));
        scene.camera = Some(shared(camera));
    }
    if no_environment {
        light_by_studio(scene)?;
        said.push("the neutral \"studio\" environment lights it".into());
    }
    if !said.is_empty() {
        crate::warnings::say(&crate::warnings::Warning {
            file: Some(file.to_string()),
            message: format!(
                "the file has no camera, so {} (add a camera to the file, or pick the view in a Lua scene with \
                 refrakt.gltf; docs/gltf.md#files-without-a-camera)",
                said.join(", and ")
            ),
            ..Default::default()
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bounding_sphere_just_fits_the_narrower_field_of_view() {
        for size in [(1024, 576), (300, 900)] {
            let cam = default_camera(Vec3::new(-1.0, -2.0, -3.0), Vec3::new(3.0, 2.0, 1.0), size);
            let centre = Vec3::new(1.0, 0.0, -1.0);
            assert_eq!(cam.target, Some(centre));
            let radius = Vec3::new(2.0, 2.0, 2.0).length();
            let half_y = 0.5 * cam.fov_y;
            let half_x = (half_y.tan() * size.0 as f32 / size.1 as f32).atan();
            let seen = (radius / (cam.position - centre).length()).asin();
            assert!((seen - half_y.min(half_x)).abs() < 1e-5, "{size:?}: {seen} vs {half_y} / {half_x}");
            let dir = (cam.position - centre).normalize();
            assert!((dir.y - ELEVATION_DEG.to_radians().sin()).abs() < 1e-6 && dir.x == 0.0 && dir.z > 0.0);
        }
    }
}
