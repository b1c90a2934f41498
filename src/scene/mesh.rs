//! Triangle meshes, in the local space of the node that carries them.

use glam::{Vec2, Vec3};

/// An indexed triangle mesh. Shared (`Arc`) between nodes and frames; a changed mesh is a new
/// `Arc`, so "did this mesh change?" is a pointer comparison.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshData {
    pub positions: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
    /// Per-vertex texture coordinates, if the mesh has them.
    pub uvs: Option<Vec<Vec2>>,
}

impl MeshData {
    /// Local bounding box (min, max); `None` for a mesh without vertices.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        let first = *self.positions.first()?;
        Some(self.positions.iter().fold((first, first), |(lo, hi), p| (lo.min(*p), hi.max(*p))))
    }

    /// Signed volume by the divergence theorem (positive for outward, counter-clockwise winding).
    pub fn signed_volume(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| self.positions[i as usize].as_dvec3());
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }
}

/// A `size.x` × `size.y` rectangle in the local XZ plane, centred, facing +Y.
pub fn plane(size: Vec2) -> MeshData {
    let (x, z) = (0.5 * size.x, 0.5 * size.y);
    MeshData {
        positions: vec![Vec3::new(-x, 0.0, -z), Vec3::new(x, 0.0, -z), Vec3::new(x, 0.0, z), Vec3::new(-x, 0.0, z)],
        // Counter-clockwise seen from +Y.
        triangles: vec![[0, 2, 1], [0, 3, 2]],
        uvs: Some(vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)]),
    }
}

/// An axis-aligned box of `size`, centred, outward counter-clockwise winding.
pub fn cuboid(size: Vec3) -> MeshData {
    let h = 0.5 * size;
    let mut m = MeshData { uvs: Some(Vec::new()), ..Default::default() };
    // Each face: its normal axis, sign, and the two in-plane axes ordered so (u × v) = normal.
    for (n, u, v) in [(Vec3::X, Vec3::NEG_Z, Vec3::Y), (Vec3::NEG_X, Vec3::Z, Vec3::Y), (Vec3::Y, Vec3::X, Vec3::NEG_Z),
                      (Vec3::NEG_Y, Vec3::X, Vec3::Z), (Vec3::Z, Vec3::X, Vec3::Y), (Vec3::NEG_Z, Vec3::NEG_X, Vec3::Y)] {
        let base = m.positions.len() as u32;
        for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            m.positions.push((n + u * a + v * b) * h);
            m.uvs.as_mut().expect("set above").push(Vec2::new(0.5 * (a + 1.0), 0.5 * (1.0 - b)));
        }
        m.triangles.push([base, base + 1, base + 2]);
        m.triangles.push([base, base + 2, base + 3]);
    }
    m
}

/// A sphere of `radius` by subdividing an icosahedron `subdivisions` times (20·4ⁿ triangles).
pub fn icosphere(radius: f32, subdivisions: u32) -> MeshData {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut positions: Vec<Vec3> = [
        (-1.0, t, 0.0), (1.0, t, 0.0), (-1.0, -t, 0.0), (1.0, -t, 0.0),
        (0.0, -1.0, t), (0.0, 1.0, t), (0.0, -1.0, -t), (0.0, 1.0, -t),
        (t, 0.0, -1.0), (t, 0.0, 1.0), (-t, 0.0, -1.0), (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8],
        [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        let mut midpoints = std::collections::HashMap::new();
        let mut mid = |a: u32, b: u32, positions: &mut Vec<Vec3>| {
            *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                positions.push((positions[a as usize] + positions[b as usize]).normalize());
                positions.len() as u32 - 1
            })
        };
        let mut next = Vec::with_capacity(triangles.len() * 4);
        for [a, b, c] in triangles {
            let (ab, bc, ca) = (mid(a, b, &mut positions), mid(b, c, &mut positions), mid(c, a, &mut positions));
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        triangles = next;
    }
    MeshData { positions: positions.into_iter().map(|p| p * radius).collect(), triangles, uvs: None }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn primitive_volumes_are_right_and_outward() {
        assert!((cuboid(Vec3::new(1.0, 2.0, 3.0)).signed_volume() - 6.0).abs() < 1e-9);
        let s = icosphere(1.0, 4);
        let v = s.signed_volume();
        assert!(v > 0.0 && (v - 4.0 / 3.0 * std::f64::consts::PI).abs() < 0.01, "icosphere volume {v}");
        // A plane faces +Y: its triangles' normals point up.
        let p = plane(Vec2::ONE);
        for t in &p.triangles {
            let [a, b, c] = t.map(|i| p.positions[i as usize]);
            assert!((b - a).cross(c - a).y > 0.0);
        }
    }
}
