//! Triangle meshes, in the local space of the node that carries them.

use std::collections::HashMap;
use std::sync::{Arc, Mutex, Weak};

use glam::{Vec2, Vec3};

/// An indexed triangle mesh. Shared (`Arc`) between nodes and frames; a changed mesh is a new
/// `Arc`, so "did this mesh change?" is a pointer comparison.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshData {
    pub positions: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
    /// Per-vertex texture coordinates, if the mesh has them.
    pub uvs: Option<Vec<Vec2>>,
    /// How the surface is shaded between its corners.
    pub normals: Normals,
}

/// The shading normals of a mesh: what a ray that hits it refracts or reflects about. The
/// surface itself (and so the voxelized solid and every ray's hit point) is always the flat
/// triangles; shading normals only bend the normal the optics use, as every renderer does.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum Normals {
    /// Each triangle's own normal: the rule glTF gives for a primitive without NORMAL (and
    /// Blender's, importing an OBJ without `vn`).
    #[default]
    Flat,
    /// One normal per vertex as the file authored it (glTF NORMAL, OBJ `vn`), interpolated
    /// across each triangle.
    Authored(Vec<Vec3>),
    /// Smooth where faces meet at less than this many degrees, sharp beyond (Blender's "smooth
    /// by angle"): computed from the faces, for procedural shapes and `smooth = angle`.
    Crease(f32),
}

// Equality of the data, and (as `Eq`) equal to itself: `Arc<MeshData>`'s == then checks the pointer
// first, so the stage-reuse keys and `FrameDesc::share_unchanged` compare shared data for free.
// (Its floats are checked finite before they reach the GPU.)
impl Eq for MeshData {}

/// What a glass mesh's shape says, each a pass over all its triangles: computed once per shared
/// mesh (`MeshData::glass_facts`), since a glass object that only moves keeps its `Arc` and
/// these ran every frame.
#[derive(Debug)]
pub struct GlassFacts {
    /// [`MeshData::is_closed`].
    pub closed: bool,
    /// [`MeshData::is_flat`].
    pub flat: bool,
    /// [`MeshData::corner_normals`].
    pub corner_normals: Vec<[Vec3; 3]>,
}

/// Faces of a procedural shape meeting at less than this angle share a smooth shading normal
/// (the value Blender's "auto smooth" defaults to); at more, the edge stays sharp.
pub const SMOOTH_CREASE_DEGREES: f32 = 30.0;

impl MeshData {
    /// The glass facts of `mesh`, from a process-wide cache keyed by the shared mesh (entries
    /// go when their mesh is dropped).
    pub fn glass_facts(mesh: &Arc<MeshData>) -> Arc<GlassFacts> {
        static CACHE: Mutex<Vec<(Weak<MeshData>, Arc<GlassFacts>)>> = Mutex::new(Vec::new());
        let mut cache = CACHE.lock().unwrap_or_else(|e| e.into_inner());
        cache.retain(|(m, _)| m.strong_count() > 0);
        if let Some((_, facts)) = cache.iter().find(|(m, _)| std::ptr::eq(m.as_ptr(), Arc::as_ptr(mesh))) {
            return facts.clone();
        }
        let facts = Arc::new(GlassFacts {
            closed: mesh.is_closed(),
            flat: mesh.is_flat(),
            corner_normals: mesh.corner_normals(),
        });
        cache.push((Arc::downgrade(mesh), facts.clone()));
        facts
    }

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

    /// Checks that the mesh can be voxelized: it has vertices and triangles, every vertex is a
    /// finite point, every index names a vertex, and some triangle has an area. The message
    /// counts vertices and triangles from 1, as OBJ files do.
    pub fn check(&self) -> Result<(), String> {
        if self.positions.is_empty() || self.triangles.is_empty() {
            return Err(format!(
                "the mesh is empty ({} vertices, {} triangles); a solid needs a closed surface of triangles",
                self.positions.len(),
                self.triangles.len()
            ));
        }
        if let Some((i, p)) = self.positions.iter().enumerate().find(|(_, p)| !p.is_finite()) {
            return Err(format!("vertex {} is ({}, {}, {}), not a finite point", i + 1, p.x, p.y, p.z));
        }
        let n = self.positions.len();
        if let Some((t, i)) =
            self.triangles.iter().enumerate().find_map(|(t, tri)| tri.iter().find(|&&i| i as usize >= n).map(|&i| (t, i)))
        {
            return Err(format!("triangle {} refers to vertex {}, but the mesh has only {n} vertices", t + 1, i as u64 + 1));
        }
        if self.triangles.iter().all(|t| self.triangle_area2(t) == 0.0) {
            return Err(format!("all {} triangles have zero area, so the mesh encloses nothing", self.triangles.len()));
        }
        Ok(())
    }

    /// Twice the area of a triangle, in f64 (exactly zero for repeated or collinear vertices
    /// given as equal coordinates).
    fn triangle_area2(&self, t: &[u32; 3]) -> f64 {
        let [a, b, c] = t.map(|i| self.positions[i as usize].as_dvec3());
        (b - a).cross(c - a).length()
    }

    /// The triangles the solid voxelization counts: those with three distinct corner positions,
    /// each distinct triangle once. A triangle listed twice (same corners, either winding) would
    /// cancel itself out of the even–odd crossing count and act as a hole; a triangle with two
    /// equal corners bounds nothing. Collinear slivers are kept (the kernels skip them exactly).
    pub fn solid_triangles(&self) -> Vec<[u32; 3]> {
        let mut seen = std::collections::HashSet::with_capacity(self.triangles.len());
        self.triangles
            .iter()
            .filter(|t| {
                let mut corners = t.map(|i| position_key(self.positions[i as usize]));
                corners.sort_unstable();
                corners[0] != corners[1] && corners[1] != corners[2] && seen.insert(corners)
            })
            .copied()
            .collect()
    }

    /// Whether every corner lies in one plane (to 10⁻⁴ of the mesh's size): a pane modelled as
    /// a sheet. The plane is the one through the first triangle with area.
    pub fn is_flat(&self) -> bool {
        let Some((lo, hi)) = self.bounds() else { return false };
        let tolerance = 1e-4 * (hi - lo).length();
        let plane = self.triangles.iter().find_map(|t| {
            let [a, b, c] = t.map(|i| self.positions[i as usize]);
            (b - a).cross(c - a).try_normalize().map(|n| (n, a))
        });
        plane.is_some_and(|(n, a)| self.positions.iter().all(|p| (*p - a).dot(n).abs() <= tolerance))
    }

    /// Whether the surface is closed: every edge (corners welded by position) is shared by an
    /// even number of triangles, so a line crossing the surface alternates outside and inside —
    /// what a sharp interface needs to know which medium a ray is in. Triangles without area
    /// (collinear corners) bound nothing and are left out.
    pub fn is_closed(&self) -> bool {
        let solid: Vec<[u32; 3]> = self.solid_triangles().into_iter().filter(|t| self.triangle_area2(t) > 0.0).collect();
        let edges = self.welded_edge_counts(&solid);
        !edges.is_empty() && edges.values().all(|&n| n % 2 == 0)
    }

    /// How many of `triangles` share each edge, with corners welded by position (UV seams and
    /// hard edges split vertices that are one point of the surface); triangles with two corners
    /// at one position have no edges.
    pub fn welded_edge_counts<'a>(&self, triangles: impl IntoIterator<Item = &'a [u32; 3]>) -> HashMap<[[u32; 3]; 2], u32> {
        let mut edges = HashMap::new();
        for t in triangles {
            let c = t.map(|i| position_key(self.positions[i as usize]));
            if c[0] == c[1] || c[1] == c[2] || c[2] == c[0] {
                continue;
            }
            for (a, b) in [(c[0], c[1]), (c[1], c[2]), (c[2], c[0])] {
                *edges.entry(if a < b { [a, b] } else { [b, a] }).or_default() += 1;
            }
        }
        edges
    }

    /// Whether the surface is mostly bent by a little where it is bent at all: of the length of
    /// its edges between two faces that are not coplanar (corners welded by position), more lies
    /// where the faces meet at less than [`SMOOTH_CREASE_DEGREES`] than at more — a curved
    /// surface cut into triangles (a sphere; a cylinder's side, longer than its rims), unlike a
    /// box (all 90°) or a sheet (no bends).
    pub fn looks_curved(&self) -> bool {
        let faces: Vec<Vec3> = self.face_normals().collect();
        let mut first_face: HashMap<[[u32; 3]; 2], usize> = HashMap::new();
        let (mut bent, mut sharp) = (0.0f32, 0.0f32);
        let (coplanar, crease) = (1f32.to_radians().cos(), SMOOTH_CREASE_DEGREES.to_radians().cos());
        for (k, t) in self.triangles.iter().enumerate() {
            let c = t.map(|i| self.positions[i as usize]);
            for (a, b) in [(c[0], c[1]), (c[1], c[2]), (c[2], c[0])] {
                let (a_key, b_key) = (position_key(a), position_key(b));
                let edge = if a_key < b_key { [a_key, b_key] } else { [b_key, a_key] };
                match first_face.remove(&edge) {
                    Some(j) => {
                        let cos = faces[j].dot(faces[k]);
                        if cos < coplanar {
                            *(if cos > crease { &mut bent } else { &mut sharp }) += a.distance(b);
                        }
                    }
                    None => {
                        first_face.insert(edge, k);
                    }
                }
            }
        }
        bent > sharp
    }

    /// Whether `p` is inside the closed surface this mesh makes under `world`: an odd number of
    /// crossings along a ray (slightly off-axis, so it does not run along the edges of
    /// axis-aligned meshes). Triangles naming a missing vertex are skipped.
    pub fn encloses(&self, world: glam::Mat4, p: Vec3) -> bool {
        let dir = Vec3::new(1.0, 0.0123, 0.0071).normalize();
        let crossings = self
            .triangles
            .iter()
            .filter(|t| t.iter().all(|&i| (i as usize) < self.positions.len()))
            .filter(|t| {
                let v = t.map(|i| world.transform_point3(self.positions[i as usize]));
                crate::bvh::moller_trumbore(&crate::bvh::Triangle { v, receiver: 0, index: 0 }, p, dir).is_some_and(|h| h.0 > 0.0)
            })
            .count();
        crossings % 2 == 1
    }

    /// Shading normals at each corner of each triangle, unit and oriented like the triangle's
    /// own normal (the winding decides which side is which), by the mesh's [`Normals`]. An
    /// authored normal that points against its triangle is turned around (a mesh whose winding
    /// was flipped keeps its normals' shape); one that is zero or not finite gives way to the
    /// triangle's own.
    pub fn corner_normals(&self) -> Vec<[Vec3; 3]> {
        match &self.normals {
            Normals::Flat => self.face_normals().map(|n| [n; 3]).collect(),
            Normals::Crease(degrees) => self.crease_normals(degrees.to_radians()),
            Normals::Authored(per_vertex) => self
                .face_normals()
                .zip(&self.triangles)
                .map(|(own, t)| {
                    t.map(|i| {
                        let n = per_vertex.get(i as usize).and_then(|n| n.try_normalize()).unwrap_or(own);
                        if n.dot(own) < 0.0 { -n } else { n }
                    })
                })
                .collect(),
        }
    }

    /// Each triangle's unit normal by its winding (zero for a triangle without area).
    fn face_normals(&self) -> impl Iterator<Item = Vec3> + '_ {
        self.triangles.iter().map(|t| {
            let [a, b, c] = t.map(|i| self.positions[i as usize]);
            (b - a).cross(c - a).normalize_or_zero()
        })
    }

    /// Shading normals at each corner of each triangle (unit, oriented like the triangle's own
    /// normal): the area-weighted mean of the normals of the triangles around that corner's
    /// position that meet this one at less than `crease` radians, so a curved surface refracts
    /// smoothly while a cube's edges stay sharp (Blender's "auto smooth").
    fn crease_normals(&self, crease: f32) -> Vec<[Vec3; 3]> {
        let face: Vec<Vec3> = self
            .triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| self.positions[i as usize]);
                (b - a).cross(c - a)
            })
            .collect();
        let mut around: std::collections::HashMap<[u32; 3], Vec<usize>> = std::collections::HashMap::new();
        for (k, t) in self.triangles.iter().enumerate() {
            for &i in t {
                around.entry(position_key(self.positions[i as usize])).or_default().push(k);
            }
        }
        let cos_crease = crease.cos();
        self.triangles
            .iter()
            .enumerate()
            .map(|(k, t)| {
                let own = face[k].normalize_or_zero();
                t.map(|i| {
                    let key = position_key(self.positions[i as usize]);
                    let sum: Vec3 = around[&key]
                        .iter()
                        .map(|&j| face[j])
                        .filter(|n| n.normalize_or_zero().dot(own) >= cos_crease)
                        .sum();
                    sum.try_normalize().unwrap_or(own)
                })
            })
            .collect()
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
        normals: Normals::Flat,
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
    geodesic_sphere(radius, 1 << subdivisions.min(10))
}

/// A geodesic sphere: each face of an icosahedron divided into `frequency`² triangles and
/// projected onto the sphere (20·frequency² triangles, any count, not only powers of four).
/// Points on a shared edge are made once from the same integer weights, so neighbouring faces
/// share them exactly and the surface is watertight.
pub fn geodesic_sphere(radius: f32, frequency: u32) -> MeshData {
    let mut m = geodesic(frequency.max(1), |d| d);
    for p in &mut m.positions {
        *p *= radius;
    }
    m
}

/// The unit geodesic sphere with every vertex direction `d` moved to `place(d)`.
fn geodesic(f: u32, place: impl Fn(Vec3) -> Vec3) -> MeshData {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let corners: Vec<glam::DVec3> = [
        (-1.0, t, 0.0), (1.0, t, 0.0), (-1.0, -t, 0.0), (1.0, -t, 0.0),
        (0.0, -1.0, t), (0.0, 1.0, t), (0.0, -1.0, -t), (0.0, 1.0, -t),
        (t, 0.0, -1.0), (t, 0.0, 1.0), (-t, 0.0, -1.0), (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| glam::DVec3::new(x, y, z))
    .collect();
    let faces: [[u32; 3]; 20] = [
        [0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8],
        [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1],
    ];
    let mut index = std::collections::HashMap::new();
    let mut m = MeshData { normals: Normals::Crease(SMOOTH_CREASE_DEGREES), ..Default::default() };
    // A point is Σ wₖ·cornerₖ / f with integer weights; keyed by its (corner, weight) pairs in
    // corner order, it is computed in that order too, whichever face asks for it.
    let mut vertex = |weights: [(u32, u32); 3], m: &mut MeshData| -> u32 {
        let mut key: Vec<(u32, u32)> = weights.into_iter().filter(|w| w.1 > 0).collect();
        key.sort_unstable();
        *index.entry(key.clone()).or_insert_with(|| {
            let p: glam::DVec3 = key.iter().map(|&(c, w)| corners[c as usize] * w as f64).sum();
            m.positions.push(place(p.normalize().as_vec3()));
            m.positions.len() as u32 - 1
        })
    };
    for [a, b, c] in faces {
        let mut at = |i: u32, j: u32, m: &mut MeshData| vertex([(a, f - i - j), (b, i), (c, j)], m);
        for i in 0..f {
            for j in 0..f - i {
                let (p, q, r) = (at(i, j, &mut m), at(i + 1, j, &mut m), at(i, j + 1, &mut m));
                m.triangles.push([p, q, r]);
                if i + j + 1 < f {
                    let s = at(i + 1, j + 1, &mut m);
                    m.triangles.push([q, s, r]);
                }
            }
        }
    }
    m
}

/// A smooth, lumpy glass pebble: a geodesic sphere (20·detail² triangles; detail 16 gives the
/// seed configuration's ~5k) whose radius varies by up to ±`bumps` (relative) with a few
/// low-frequency waves chosen by `seed`. Watertight, star-shaped, outward winding.
pub fn blob(radius: f32, bumps: f32, seed: u32, detail: u32) -> MeshData {
    let mut state = seed as u64 ^ 0x9e37_79b9_7f4a_7c15;
    let mut next = || {
        // SplitMix64: a fixed, platform-independent sequence per seed.
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    };
    const WAVES: usize = 5;
    let waves: Vec<(Vec3, f32, f32)> = (0..WAVES)
        .map(|_| {
            let (z, phi) = (2.0 * next() - 1.0, std::f32::consts::TAU * next());
            let axis = Vec3::new((1.0 - z * z).sqrt() * phi.cos(), z, (1.0 - z * z).sqrt() * phi.sin());
            (axis, 1.5 + 2.5 * next(), std::f32::consts::TAU * next())
        })
        .collect();
    geodesic(detail.max(1), |d| {
        let wave: f32 = waves.iter().map(|(axis, k, phase)| (k * d.dot(*axis) + phase).sin()).sum();
        d * radius * (1.0 + bumps * wave / WAVES as f32)
    })
}

/// A cylinder along local Y, centred: `radius`, `height`, `segments` around.
pub fn cylinder(radius: f32, height: f32, segments: u32) -> MeshData {
    let h = 0.5 * height;
    lathe(&[Vec2::new(0.0, -h), Vec2::new(radius, -h), Vec2::new(radius, h), Vec2::new(0.0, h)], segments, false)
}

/// A torus around local Y: the tube of radius `minor` swept along the circle of radius `major`.
pub fn torus(major: f32, minor: f32, major_segments: u32, minor_segments: u32) -> MeshData {
    let n = minor_segments.max(3);
    let circle: Vec<Vec2> = (0..n)
        .map(|i| {
            let phi = std::f32::consts::TAU * i as f32 / n as f32;
            Vec2::new(major + minor * phi.cos(), minor * phi.sin())
        })
        .collect();
    lathe(&circle, major_segments, true)
}

/// A solid of revolution about local Y: the `profile` of (radius, height) points swept around
/// in `segments` steps (like a lathe, or Blender's Spin). An open profile is closed by flat
/// caps to the axis where it does not start or end on it; `closed` joins its last point back
/// to its first (a torus). Either direction of travel gives outward winding.
pub fn lathe(profile: &[Vec2], segments: u32, closed: bool) -> MeshData {
    let mut points: Vec<Vec2> = profile.iter().map(|p| Vec2::new(p.x.max(0.0), p.y)).collect();
    if let (false, Some(first), Some(last)) = (closed, points.first().copied(), points.last().copied()) {
        if first.x > 0.0 {
            points.insert(0, Vec2::new(0.0, first.y));
        }
        if last.x > 0.0 {
            points.push(Vec2::new(0.0, last.y));
        }
    }
    // Counter-clockwise in the (radius, height) half-plane, the solid on the left, gives
    // outward triangles below; the shoelace area says which way the profile runs.
    let area: f32 = points.iter().zip(points.iter().cycle().skip(1)).map(|(a, b)| a.x * b.y - b.x * a.y).sum();
    if area < 0.0 {
        points.reverse();
    }
    let segments = segments.max(3);
    let mut m = MeshData { normals: Normals::Crease(SMOOTH_CREASE_DEGREES), ..Default::default() };
    // Each profile point becomes a ring of `segments` vertices, or one vertex on the axis.
    let rings: Vec<Vec<u32>> = points
        .iter()
        .map(|p| {
            let count = if p.x == 0.0 { 1 } else { segments };
            (0..count)
                .map(|s| {
                    let theta = std::f32::consts::TAU * s as f32 / segments as f32;
                    m.positions.push(Vec3::new(p.x * theta.cos(), p.y, -p.x * theta.sin()));
                    m.positions.len() as u32 - 1
                })
                .collect()
        })
        .collect();
    let at = |ring: &Vec<u32>, s: u32| ring[(s % segments) as usize % ring.len()];
    let spans = if closed { points.len() } else { points.len().saturating_sub(1) };
    for k in 0..spans {
        let (lo, hi) = (&rings[k], &rings[(k + 1) % rings.len()]);
        for s in 0..segments {
            for t in [[at(lo, s), at(lo, s + 1), at(hi, s + 1)], [at(lo, s), at(hi, s + 1), at(hi, s)]] {
                // A quad next to the axis collapses to one triangle.
                if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
                    m.triangles.push(t);
                }
            }
        }
    }
    m
}
/// The key that welds corners by position: their coordinates' bits, with −0 taken as +0 (a
/// split vertex at a pole or on an axis may be written with either sign of zero).
fn position_key(p: Vec3) -> [u32; 3] {
    (p + Vec3::ZERO).to_array().map(f32::to_bits)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// Every directed edge appears once and its reverse once: closed, consistently wound.
    fn assert_closed(m: &MeshData, what: &str) {
        let mut edges = std::collections::HashMap::new();
        for t in &m.triangles {
            for k in 0..3 {
                *edges.entry((t[k], t[(k + 1) % 3])).or_insert(0) += 1;
            }
        }
        for (&(a, b), &n) in &edges {
            assert_eq!(n, 1, "{what}: edge {a}→{b} used {n} times");
            assert_eq!(edges.get(&(b, a)), Some(&1), "{what}: edge {a}→{b} has no twin");
        }
    }

    fn assert_volume(m: &MeshData, expected: f64, tolerance: f64, what: &str) {
        let v = m.signed_volume();
        assert!((v - expected).abs() < tolerance * expected, "{what}: volume {v}, expected {expected}");
        assert!(m.check().is_ok(), "{what}: {:?}", m.check());
    }

    #[test]
    fn primitives_are_closed_outward_and_of_the_right_volume() {
        assert!((cuboid(Vec3::new(1.0, 2.0, 3.0)).signed_volume() - 6.0).abs() < 1e-9);
        let s = icosphere(1.0, 4);
        assert_eq!(s.triangles.len(), 5120);
        assert_closed(&s, "icosphere");
        assert_volume(&s, 4.0 / 3.0 * PI, 0.01, "icosphere");
        let g = geodesic_sphere(0.5, 71);
        assert_eq!(g.triangles.len(), 20 * 71 * 71);
        assert_closed(&g, "geodesic sphere");
        assert_volume(&g, 4.0 / 3.0 * PI * 0.125, 1e-3, "geodesic sphere");
        let c = cylinder(0.3, 0.8, 128);
        assert_closed(&c, "cylinder");
        assert_volume(&c, PI * 0.09 * 0.8, 1e-3, "cylinder");
        let t = torus(0.5, 0.1, 128, 64);
        assert_closed(&t, "torus");
        assert_volume(&t, 2.0 * PI * PI * 0.5 * 0.01, 3e-3, "torus");
        // A cone given clockwise, starting off the axis: capped and turned outward.
        let cone = lathe(&[Vec2::new(0.0, 1.0), Vec2::new(0.5, 0.0)], 256, false);
        assert_closed(&cone, "cone");
        assert_volume(&cone, PI * 0.25 / 3.0, 1e-3, "cone");
        let b = blob(0.5, 0.15, 7, 16);
        assert_eq!(b.triangles.len(), 5120);
        assert_closed(&b, "blob");
        assert!(b.signed_volume() > 0.0);
        // A plane faces +Y: its triangles' normals point up.
        let p = plane(Vec2::ONE);
        for t in &p.triangles {
            let [a, b, c] = t.map(|i| p.positions[i as usize]);
            assert!((b - a).cross(c - a).y > 0.0);
        }
    }

    #[test]
    fn check_names_what_is_wrong() {
        let mut m = cuboid(Vec3::ONE);
        assert!(m.check().is_ok());
        m.positions[3].y = f32::NAN;
        assert!(m.check().unwrap_err().starts_with("vertex 4 is"), "{:?}", m.check());
        let mut m = cuboid(Vec3::ONE);
        m.triangles[2][1] = 99;
        assert!(m.check().unwrap_err().contains("triangle 3 refers to vertex 100"));
        let flat = MeshData { positions: vec![Vec3::ZERO, Vec3::X, Vec3::X * 2.0], triangles: vec![[0, 1, 2], [0, 0, 1]], ..Default::default() };
        assert!(flat.check().unwrap_err().contains("zero area"));
        assert!(MeshData::default().check().unwrap_err().contains("empty"));
    }

    #[test]
    fn a_sphere_looks_curved_and_a_box_and_a_sheet_do_not() {
        assert!(icosphere(1.0, 2).looks_curved() && cylinder(1.0, 1.0, 64).looks_curved());
        assert!(!cuboid(Vec3::ONE).looks_curved() && !plane(Vec2::ONE).looks_curved());
    }

    #[test]
    fn solid_triangles_drop_repeats_and_collapsed_triangles() {
        let mut m = cuboid(Vec3::ONE);
        let first = m.triangles[0];
        m.triangles.push(first);
        m.triangles.push([first[0], first[2], first[1]]);
        m.triangles.push([0, 0, 1]);
        // A vertex duplicated by position (as OBJ exports split by normals do) still counts.
        m.positions.push(m.positions[first[0] as usize]);
        m.triangles.push([m.positions.len() as u32 - 1, first[1], first[2]]);
        assert_eq!(m.solid_triangles().len(), 12);
    }

    #[test]
    fn corners_split_with_either_sign_of_zero_weld() {
        // An octahedron whose every face has corners of its own, a corner's zero coordinates
        // carrying its face's signs: the split copies of (1, 0, 0) are (1, ±0, ±0).
        let mut m = MeshData::default();
        for s in 0..8 {
            let sign = |bit: u32| if s & (1 << bit) == 0 { 1.0f32 } else { -1.0 };
            let (x, y, z) = (sign(0), sign(1), sign(2));
            let base = m.positions.len() as u32;
            m.positions.extend([Vec3::new(x, y * 0.0, z * 0.0), Vec3::new(x * 0.0, y, z * 0.0), Vec3::new(x * 0.0, y * 0.0, z)]);
            m.triangles.push(if x * y * z > 0.0 { [base, base + 1, base + 2] } else { [base, base + 2, base + 1] });
        }
        assert!(m.positions.iter().any(|p| p.y.to_bits() == (-0.0f32).to_bits()));
        assert!(m.is_closed());
        assert!((m.signed_volume() - 4.0 / 3.0).abs() < 1e-6, "{}", m.signed_volume());
    }
}
