//! Index fields given as a function n(x, y, z) by a script (`refrakt.field{n = function …}`).
//!
//! The GPU cannot call back into Lua, so such a field is sampled on the CPU, once per frame, at
//! the centres of the voxels its box covers; the voxelize stage then composites those samples
//! like any analytic field (smooth coverage at the box faces, `shaders/voxelize.wgsl`). One call
//! per voxel makes this the slow way to define n: a field filling a 128³ volume costs two
//! million script calls a frame. The scene module knows nothing of Lua; the script host supplies
//! the function through [`IndexFunction`].

use std::any::Any;
use std::rc::Rc;

use anyhow::Result;
use glam::{IVec3, UVec3, Vec3};

use super::eval::world_bounds;

use crate::frame::{FieldDesc, IndexSamples, VolumeDesc};

/// n as a function of position in the local frame of the node carrying the field.
pub trait IndexFunction {
    /// n at each point. Errors name where the function was defined and the offending point.
    fn sample(&self, points: &[Vec3]) -> Result<Vec<f32>>;
    /// For the script host to recover its own function (`field.n` read back in Lua).
    fn as_any(&self) -> &dyn Any;
}

/// A shared [`IndexFunction`]; two handles are equal when they are the same function.
#[derive(Clone)]
pub struct IndexFn(pub Rc<dyn IndexFunction>);

impl std::fmt::Debug for IndexFn {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("IndexFn(…)")
    }
}

impl PartialEq for IndexFn {
    fn eq(&self, other: &Self) -> bool {
        Rc::ptr_eq(&self.0, &other.0)
    }
}

/// Samples `n` for `field` (placed, boundary in metres) at every voxel centre of `volume` where
/// the field's coverage can be non-zero: the world box around the field's local box grown by
/// half the boundary width. Points outside the local box are clamped onto it, so the function
/// is only ever asked about its own box, and n is continued constantly through the boundary.
pub fn sample_over_voxels(field: &FieldDesc, n: &IndexFn, volume: &VolumeDesc) -> Result<IndexSamples> {
    let grown = field.half_size + Vec3::splat(0.5 * field.boundary / field.scale);
    let (lo, hi) = world_bounds(&field.world_to_local.inverse(), grown);
    // Voxel i has its centre at min + (i + ½)·h: the first centre ≥ lo and the last ≤ hi.
    let to_index = |p: Vec3| (p - volume.min) / volume.voxel_size - 0.5;
    let first = to_index(lo).ceil().as_ivec3().max(IVec3::ZERO);
    let last = to_index(hi).floor().as_ivec3().min(volume.dims.as_ivec3() - 1);
    let dims = (last - first + 1).max(IVec3::ZERO).as_uvec3();
    let first = first.as_uvec3();
    let mut points = Vec::with_capacity((dims.x * dims.y * dims.z) as usize);
    for z in 0..dims.z {
        for y in 0..dims.y {
            for x in 0..dims.x {
                let world = volume.voxel_centre(first + UVec3::new(x, y, z));
                let local = field.world_to_local.transform_point3(world);
                points.push(local.clamp(-field.half_size, field.half_size));
            }
        }
    }
    let values = if points.is_empty() { Vec::new() } else { n.0.sample(&points)? };
    Ok(IndexSamples { first, dims, values: values.into(), origin: volume.min, voxel_size: volume.voxel_size })
}
