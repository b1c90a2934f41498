//! Shapes a node can carry.

use std::sync::Arc;

use glam::{Vec2, Vec3};

use super::MeshData;
use super::index_fn::IndexFn;

/// `Sphere` and `Box` are exact analytic solids: with a glass material they become constant-index
/// fields, with a diffuse one opaque receivers. `Luneburg` and `Slab` are index fields that
/// define n themselves (a material, if given, adds only absorption and scattering). `Mesh` is a
/// triangle mesh (from a file, a procedural primitive or glTF). `Plane` is a rectangle in the
/// node's local XZ plane facing +Y — a floor or a wall for caustics to land on. `Field` is an
/// index field a script defines by a function n(x, y, z) inside a box of `size`, sampled on the
/// CPU (see `index_fn`).
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    Sphere { radius: f32, boundary: Option<f32> },
    Box { size: Vec3, boundary: Option<f32> },
    /// n(r) = sqrt(2 − (r/R)²): parallel light entering focuses on the far pole.
    Luneburg { radius: f32, boundary: Option<f32> },
    /// n(y) = ior + gradient · y inside a box of `size`, y along the node's local +Y from its centre.
    Slab { size: Vec3, ior: f32, gradient: f32, boundary: Option<f32> },
    /// A triangle mesh; `source` says where it came from (a file path, "icosphere", …).
    Mesh { mesh: Arc<MeshData>, source: String, boundary: Option<f32> },
    Plane { size: Vec2 },
    Field { size: Vec3, n: IndexFn, boundary: Option<f32> },
}

impl Shape {
    pub fn kind_name(&self) -> &'static str {
        match self {
            Shape::Sphere { .. } => "sphere",
            Shape::Box { .. } => "box",
            Shape::Luneburg { .. } => "luneburg",
            Shape::Slab { .. } => "slab",
            Shape::Mesh { .. } => "mesh",
            Shape::Plane { .. } => "plane",
            Shape::Field { .. } => "field",
        }
    }

    /// Smooth boundary width override, in voxels.
    pub fn boundary(&self) -> Option<f32> {
        match self {
            Shape::Sphere { boundary, .. }
            | Shape::Box { boundary, .. }
            | Shape::Luneburg { boundary, .. }
            | Shape::Slab { boundary, .. }
            | Shape::Mesh { boundary, .. }
            | Shape::Field { boundary, .. } => *boundary,
            Shape::Plane { .. } => None,
        }
    }

    /// Whether the shape defines its own index (so a material's `ior` does not apply).
    pub fn is_index_field(&self) -> bool {
        matches!(self, Shape::Luneburg { .. } | Shape::Slab { .. } | Shape::Field { .. })
    }

    /// Half extents of the shape's local bounding box, centred on the node's origin (meshes:
    /// the half extents of their bounds around the origin).
    pub fn local_half_extent(&self) -> Vec3 {
        match self {
            Shape::Sphere { radius, .. } | Shape::Luneburg { radius, .. } => Vec3::splat(*radius),
            Shape::Box { size, .. } | Shape::Slab { size, .. } | Shape::Field { size, .. } => *size * 0.5,
            Shape::Mesh { mesh, .. } => mesh.bounds().map_or(Vec3::ZERO, |(lo, hi)| lo.abs().max(hi.abs())),
            Shape::Plane { size } => Vec3::new(size.x * 0.5, 0.0, size.y * 0.5),
        }
    }
}
