//! CPU twin of `shaders/voxelize_mesh.wgsl`: the solid of one mesh over its window as plain
//! loops — fixed-point vertices, exact crossings along the three axes, running parity, the
//! vote, and the distance band. Integer steps give the GPU's bits exactly; the distances are
//! the same f32 formulas (equal up to rounding).

use glam::{IVec2, IVec3, Mat4, UVec2, UVec3, Vec3};

use crate::pipeline::voxelize_mesh::{COORD_LIMIT, FAR, MeshWindow};

/// Twin of `transform_vertices`: local → window-local fixed point, 2^`bits` per voxel.
pub fn grid_vertices(positions: &[Vec3], grid_from_local: &Mat4, window: &MeshWindow, bits: u32) -> Vec<IVec3> {
    let step = (1 << bits) as f32;
    let limit = COORD_LIMIT as f32;
    positions
        .iter()
        .map(|p| {
            let g = grid_from_local.transform_point3(*p);
            (g * step).clamp(Vec3::splat(-limit), Vec3::splat(limit)).map(f32::round_ties_even).as_ivec3()
                - window.min.as_ivec3() * (1 << bits)
        })
        .collect()
}

/// Coordinates in the frame (u, v, w) of rays along `axis` (twin of `to_frame`).
fn to_frame<T: Copy>(p: [T; 3], axis: usize) -> [T; 3] {
    [p[(axis + 1) % 3], p[(axis + 2) % 3], p[axis]]
}

fn from_frame<T: Copy>(p: [T; 3], axis: usize) -> [T; 3] {
    let mut out = p;
    out[(axis + 1) % 3] = p[0];
    out[(axis + 2) % 3] = p[1];
    out[axis] = p[2];
    out
}

/// A triangle seen along the rays of one axis (twin of `Crossing`).
struct Crossing {
    a: IVec3,
    b: IVec3,
    c: IVec3,
    normal: [i64; 3],
    first: IVec2,
    size: UVec2,
}

fn normal(a: IVec3, b: IVec3, c: IVec3) -> [i64; 3] {
    let (e1, e2) = ((b - a).as_i64vec3(), (c - a).as_i64vec3());
    [e1.y * e2.z - e1.z * e2.y, e1.z * e2.x - e1.x * e2.z, e1.x * e2.y - e1.y * e2.x]
}

fn crossing(corners: [IVec3; 3], axis: usize, window: &MeshWindow, bits: u32) -> Option<Crossing> {
    let [a, mut b, mut c] = corners.map(|p| IVec3::from(to_frame(p.to_array(), axis)));
    let mut n = normal(a, b, c);
    if n[2] == 0 {
        return None;
    }
    if n[2] < 0 {
        std::mem::swap(&mut b, &mut c);
        n = normal(a, b, c);
    }
    let half = (1 << bits) >> 1;
    let lo = a.truncate().min(b.truncate()).min(c.truncate());
    let hi = a.truncate().max(b.truncate()).max(c.truncate());
    let dims = UVec3::from(to_frame(window.dims.to_array(), axis));
    let first = (-((IVec2::splat(half) - lo) >> bits as i32)).max(IVec2::ZERO);
    let last = ((hi - IVec2::splat(half)) >> bits as i32).min(dims.truncate().as_ivec2() - 1);
    (last.cmpge(first).all()).then(|| Crossing { a, b, c, normal: n, first, size: (last - first + 1).as_uvec2() })
}

/// Twin of `owns`: q inside the half-plane left of p0 → p1, ties moved by (−ε, −ε²).
fn owns(p0: IVec2, p1: IVec2, q: IVec2) -> bool {
    let (a, b) = ((p0 - q).as_i64vec2(), (p1 - q).as_i64vec2());
    let side = (a.x * b.y - a.y * b.x).signum();
    let d = p1 - p0;
    side > 0 || (side == 0 && (d.y > 0 || (d.y == 0 && d.x < 0)))
}

/// The bit marked for column (u, v) of the crossing, if its ray crosses the triangle: the first
/// voxel on or past the plane (twin of `cross_column`).
fn crossing_bit(x: &Crossing, column: IVec2, depth: u32, bits: u32) -> Option<u32> {
    let step = 1 << bits;
    let q = column * step + step / 2;
    let (a, b, c) = (x.a.truncate(), x.b.truncate(), x.c.truncate());
    if !(owns(a, b, q) && owns(b, c, q) && owns(c, a, q)) {
        return None;
    }
    let base = x.normal[0] * (q.x - x.a.x) as i64 + x.normal[1] * (q.y - x.a.y) as i64;
    let past = |j: u32| base + x.normal[2] * (j as i64 * step as i64 + (step / 2) as i64 - x.a.z as i64) >= 0;
    Some((0..depth).find(|&j| past(j)).unwrap_or(depth))
}

/// Twin of `rasterize` (passes 0–2) and `prefix_parity`: the parity words of the window
/// (layout of [`MeshWindow::axis_offsets`]).
pub fn parity_words(vertices: &[IVec3], triangles: &[[u32; 3]], window: &MeshWindow, bits: u32) -> Vec<u32> {
    let (offsets, total) = window.axis_offsets();
    let words = window.axis_words();
    let mut out = vec![0u32; total as usize];
    for axis in 0..3 {
        let dims = UVec3::from(to_frame(window.dims.to_array(), axis));
        for t in triangles {
            let Some(x) = crossing(t.map(|i| vertices[i as usize]), axis, window, bits) else { continue };
            for cv in 0..x.size.y {
                for cu in 0..x.size.x {
                    let column = x.first + UVec2::new(cu, cv).as_ivec2();
                    if let Some(k) = crossing_bit(&x, column, dims.z, bits) {
                        let line = offsets[axis] + (column.x as u32 + dims.x * column.y as u32) * words[axis];
                        out[(line + k / 32) as usize] ^= 1 << (k % 32);
                    }
                }
            }
        }
        // Running XOR along each line.
        for line in 0..window.columns(axis) {
            let mut carry = 0u32;
            for k in 0..words[axis] {
                let w = &mut out[(offsets[axis] + line * words[axis] + k) as usize];
                let mut x = *w;
                for shift in [1, 2, 4, 8, 16] {
                    x ^= x << shift;
                }
                x ^= carry;
                *w = x;
                carry = 0u32.wrapping_sub(x >> 31);
            }
        }
    }
    out
}

fn parity_bit(words: &[u32], base: u32, bit: u32) -> u32 {
    (words[(base + bit / 32) as usize] >> (bit % 32)) & 1
}

/// Twin of the vote in `signed_distance`: whether each window voxel's centre is inside.
pub fn inside(window: &MeshWindow, words: &[u32]) -> Vec<bool> {
    let (offsets, _) = window.axis_offsets();
    let per_line = window.axis_words();
    let mut out = vec![false; window.voxels() as usize];
    for z in 0..window.dims.z {
        for y in 0..window.dims.y {
            for x in 0..window.dims.x {
                let mut votes = 0i32;
                for axis in 0..3 {
                    let p = to_frame([x, y, z], axis);
                    let dims = to_frame(window.dims.to_array(), axis);
                    let base = offsets[axis] + (p[0] + dims[0] * p[1]) * per_line[axis];
                    if parity_bit(words, base, dims[2]) == 0 {
                        votes += if parity_bit(words, base, p[2]) == 1 { 1 } else { -1 };
                    }
                }
                out[window.index(UVec3::new(x, y, z))] = votes > 0;
            }
        }
    }
    out
}

/// Twin of `triangle_distance` (Ericson §5.1.5).
pub fn triangle_distance(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> f32 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return ap.length();
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return bp.length();
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return (ap - ab * (d1 / (d1 - d3))).length();
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return cp.length();
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return (ap - ac * (d2 / (d2 - d6))).length();
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        return (bp - (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)))).length();
    }
    let denom = 1.0 / (va + vb + vc);
    (ap - ab * (vb * denom) - ac * (vc * denom)).length()
}

/// Twin of pass 3 (`band_setup`, `band_column`): each window voxel's distance (voxels) to the
/// nearest triangle within `reach`, `None` beyond.
pub fn band_distance(vertices: &[IVec3], triangles: &[[u32; 3]], window: &MeshWindow, bits: u32, reach: f32) -> Vec<Option<f32>> {
    let mut out = vec![None::<f32>; window.voxels() as usize];
    let scale = 1.0 / (1 << bits) as f32;
    for t in triangles {
        let [a, b, c] = t.map(|i| vertices[i as usize].as_vec3() * scale);
        let n = (b - a).cross(c - a);
        let area2 = n.length();
        if area2 == 0.0 {
            continue;
        }
        let m = n.abs();
        let axis = if m.x >= m.y && m.x >= m.z { 0 } else if m.y >= m.z { 1 } else { 2 };
        let [a, b, c, n] = [a, b, c, n / area2].map(|p| Vec3::from(to_frame(p.to_array(), axis)));
        let dims = UVec3::from(to_frame(window.dims.to_array(), axis));
        let lo = a.truncate().min(b.truncate()).min(c.truncate()) - reach;
        let hi = a.truncate().max(b.truncate()).max(c.truncate()) + reach;
        let first = (lo - 0.5).ceil().as_ivec2().max(IVec2::ZERO);
        let last = (hi - 0.5).floor().as_ivec2().min(dims.truncate().as_ivec2() - 1);
        let half_depth = reach / n.z.abs();
        for cv in first.y..=last.y {
            for cu in first.x..=last.x {
                let centre = IVec2::new(cu, cv).as_vec2() + 0.5;
                let w_plane = a.z - n.truncate().dot(centre - a.truncate()) / n.z;
                let j0 = ((w_plane - half_depth - 0.5 - 1e-3).ceil() as i32).max(0);
                let j1 = ((w_plane + half_depth - 0.5 + 1e-3).floor() as i32).min(dims.z as i32 - 1);
                for j in j0..=j1 {
                    let d = triangle_distance(centre.extend(j as f32 + 0.5), a, b, c);
                    if d < reach {
                        let v = UVec3::from(from_frame([cu as u32, cv as u32, j as u32], axis));
                        let slot = &mut out[window.index(v)];
                        *slot = Some(slot.map_or(d, |s| s.min(d)));
                    }
                }
            }
        }
    }
    out
}

/// Twin of `signed_distance`: ± distance (voxels), negative inside, ±[`FAR`] beyond reach.
pub fn signed_distance(inside: &[bool], band: &[Option<f32>]) -> Vec<f32> {
    inside.iter().zip(band).map(|(&i, d)| d.unwrap_or(FAR) * if i { -1.0 } else { 1.0 }).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bounds the exact tests rely on: with every fixed-point coordinate within ±2^18 of
    /// the grid origin and the window inside a grid of at most 2^16 units, the largest
    /// determinant (`base` + N_w·Δw) fits in an i64 with room to spare.
    #[test]
    fn exact_tests_cannot_overflow() {
        let coord = (COORD_LIMIT as i64) + (1 << 16); // window-local extremes
        let diff = 2 * coord;
        let normal = 2 * diff * diff;
        let determinant = 3 * normal * diff;
        assert!(determinant < i64::MAX / 4, "{determinant}");
    }

    #[test]
    fn frames_round_trip() {
        for axis in 0..3 {
            assert_eq!(from_frame(to_frame([1, 2, 3], axis), axis), [1, 2, 3]);
        }
        // The frames are right-handed: (u, v, w) = (y, z, x), (z, x, y), (x, y, z).
        assert_eq!(to_frame([1, 2, 3], 0), [2, 3, 1]);
        assert_eq!(to_frame([1, 2, 3], 1), [3, 1, 2]);
    }

    /// A column through a shared edge or vertex of a flat fan of triangles is owned by exactly
    /// one of them.
    #[test]
    fn tie_rule_counts_shared_edges_and_vertices_once() {
        let centre = IVec2::new(0, 0);
        let ring: Vec<IVec2> = [(4, 0), (3, 3), (0, 4), (-3, 2), (-4, -1), (-1, -4), (3, -3)]
            .iter()
            .map(|&(x, y)| IVec2::new(x, y))
            .collect();
        let points = [IVec2::new(0, 0), IVec2::new(2, 0), IVec2::new(1, 1), IVec2::new(0, 2), IVec2::new(-2, -2), IVec2::new(3, 0)];
        for q in points {
            let owners = (0..ring.len())
                .filter(|&k| {
                    let (b, c) = (ring[k], ring[(k + 1) % ring.len()]);
                    owns(centre, b, q) && owns(b, c, q) && owns(c, centre, q)
                })
                .count();
            assert_eq!(owners, 1, "point {q} owned by {owners} triangles");
        }
    }
}
