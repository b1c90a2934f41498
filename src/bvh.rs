//! A bounding volume hierarchy over the opaque receivers' triangles, built on the CPU once per
//! change and traversed on the GPU (`shaders/shared/bvh.wgsl`) by camera, shadow and photon rays.
//!
//! Interior nodes have `count = 0` and their first child in `first` (never 0, the root), so a
//! root with `first = 0, count = 0` is the empty tree.
//!
//! Median split on the longest centroid axis, up to [`LEAF_SIZE`] triangles per leaf: receiver
//! sets are small (floors, walls, props), so build speed and simplicity beat SAH quality here.
//! [`Bvh::intersect`] is the CPU twin of the GPU traversal.

use glam::Vec3;

use crate::gpu::types::{BvhNode, BvhTriangle};

pub const LEAF_SIZE: usize = 4;
/// Deeper trees would overflow the GPU traversal stack (`BVH_STACK` in `bvh.wgsl`).
pub const MAX_DEPTH: u32 = 30;
/// Centroid bins per axis the SAH split is chosen among.
const SAH_BINS: usize = 12;

/// A world-space triangle with the receiver it belongs to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triangle {
    pub v: [Vec3; 3],
    pub receiver: u32,
    /// Its index among the receiver mesh's triangles (to find its texture coordinates after
    /// the build has reordered the triangles).
    pub index: u32,
}

impl Triangle {
    fn centroid(&self) -> Vec3 {
        (self.v[0] + self.v[1] + self.v[2]) / 3.0
    }

    /// Unnormalized geometric normal (v1 − v0) × (v2 − v0).
    pub fn normal(&self) -> Vec3 {
        (self.v[1] - self.v[0]).cross(self.v[2] - self.v[0])
    }
}

pub struct Bvh {
    pub nodes: Vec<BvhNode>,
    /// Triangles in leaf order.
    pub triangles: Vec<Triangle>,
}

/// A ray hit: distance along the ray, triangle index (in leaf order), barycentrics (u, v).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    pub triangle: u32,
    pub u: f32,
    pub v: f32,
}

impl Bvh {
    /// Builds the hierarchy; degenerate (zero-area or non-finite) triangles are dropped.
    pub fn build(mut triangles: Vec<Triangle>) -> Self {
        triangles.retain(|t| t.v.iter().all(|v| v.is_finite()) && t.normal().length_squared() > 0.0);
        let mut bvh = Bvh { nodes: Vec::with_capacity(2 * triangles.len() / LEAF_SIZE + 1), triangles };
        let n = bvh.triangles.len();
        bvh.nodes.push(BvhNode::default());
        bvh.split(0, 0, n, 0);
        bvh
    }

    fn bounds(&self, first: usize, end: usize) -> (Vec3, Vec3) {
        self.triangles[first..end].iter().flat_map(|t| t.v).fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), p| (lo.min(p), hi.max(p)),
        )
    }

    fn split(&mut self, node: usize, first: usize, end: usize, depth: u32) {
        let (lo, hi) = if end > first { self.bounds(first, end) } else { (Vec3::ZERO, Vec3::ZERO) };
        self.nodes[node].min = lo.into();
        self.nodes[node].max = hi.into();
        if end - first <= LEAF_SIZE || depth >= MAX_DEPTH {
            self.nodes[node].first = first as u32;
            self.nodes[node].count = (end - first) as u32;
            return;
        }
        let (clo, chi) = self.triangles[first..end].iter().map(Triangle::centroid).fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), c| (lo.min(c), hi.max(c)),
        );
        let mid = match self.sah_split(first, end, clo, chi) {
            Some(mid) => mid,
            None => {
                // No useful plane (coincident centroids): halve along the longest axis.
                let extent = chi - clo;
                let axis = if extent.x >= extent.y && extent.x >= extent.z { 0 } else if extent.y >= extent.z { 1 } else { 2 };
                let mid = first + (end - first) / 2;
                self.triangles[first..end].select_nth_unstable_by(mid - first, |a, b| a.centroid()[axis].total_cmp(&b.centroid()[axis]));
                mid
            }
        };
        let left = self.nodes.len();
        self.nodes.push(BvhNode::default());
        self.nodes.push(BvhNode::default());
        self.nodes[node].first = left as u32;
        self.nodes[node].count = 0;
        self.split(left, first, mid, depth + 1);
        self.split(left + 1, mid, end, depth + 1);
    }

    /// GPU form of the triangles: v0 and two edges (what Möller–Trumbore needs).
    /// The surface area heuristic over `SAH_BINS` centroid bins per axis (Wald 2007): the plane
    /// that minimizes area(left)·count(left) + area(right)·count(right), i.e. the expected work of
    /// a ray that meets the node. Partitions the triangles there and returns the split index;
    /// `None` when every centroid falls in one bin.
    fn sah_split(&mut self, first: usize, end: usize, clo: Vec3, chi: Vec3) -> Option<usize> {
        let extent = chi - clo;
        let bin_of = |c: Vec3, axis: usize| (((c[axis] - clo[axis]) / extent[axis] * SAH_BINS as f32) as usize).min(SAH_BINS - 1);
        let area = |lo: Vec3, hi: Vec3| {
            let e = (hi - lo).max(Vec3::ZERO);
            e.x * e.y + e.y * e.z + e.z * e.x
        };
        let empty = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        let mut best: Option<(f32, usize, usize)> = None;
        for axis in 0..3 {
            if extent[axis] <= 0.0 {
                continue;
            }
            let mut bins = [(empty, 0usize); SAH_BINS];
            for t in &self.triangles[first..end] {
                let b = &mut bins[bin_of(t.centroid(), axis)];
                for p in t.v {
                    b.0 = (b.0.0.min(p), b.0.1.max(p));
                }
                b.1 += 1;
            }
            // Sweep from the right, then from the left, costing each of the SAH_BINS − 1 planes.
            let mut right = [0.0f32; SAH_BINS];
            let (mut bounds, mut count) = (empty, 0);
            for k in (1..SAH_BINS).rev() {
                bounds = (bounds.0.min(bins[k].0.0), bounds.1.max(bins[k].0.1));
                count += bins[k].1;
                right[k] = area(bounds.0, bounds.1) * count as f32;
            }
            let (mut bounds, mut count) = (empty, 0);
            for k in 0..SAH_BINS - 1 {
                bounds = (bounds.0.min(bins[k].0.0), bounds.1.max(bins[k].0.1));
                count += bins[k].1;
                let cost = area(bounds.0, bounds.1) * count as f32 + right[k + 1];
                if count > 0 && count < end - first && best.is_none_or(|b| cost < b.0) {
                    best = Some((cost, axis, k));
                }
            }
        }
        let (_, axis, plane) = best?;
        let (mut i, mut j) = (first, end);
        while i < j {
            if bin_of(self.triangles[i].centroid(), axis) <= plane {
                i += 1;
            } else {
                j -= 1;
                self.triangles.swap(i, j);
            }
        }
        Some(i)
    }

    pub fn gpu_triangles(&self) -> Vec<BvhTriangle> {
        self.triangles
            .iter()
            .map(|t| BvhTriangle {
                v0: t.v[0].into(),
                receiver: t.receiver,
                e1: (t.v[1] - t.v[0]).into(),
                _pad0: 0,
                e2: (t.v[2] - t.v[0]).into(),
                _pad1: 0,
            })
            .collect()
    }

    /// Closest hit along origin + t·dir with t in (t_min, t_max) — twin of `bvh_closest_hit`.
    pub fn intersect(&self, origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> Option<Hit> {
        if self.triangles.is_empty() {
            return None;
        }
        let inv = dir.recip();
        let mut best: Option<Hit> = None;
        let mut limit = t_max;
        let mut stack = vec![0u32];
        while let Some(i) = stack.pop() {
            let node = &self.nodes[i as usize];
            if !slab_hit(origin, inv, node.min.into(), node.max.into(), t_min, limit) {
                continue;
            }
            if node.count == 0 {
                if node.first == 0 {
                    continue; // the empty tree
                }
                stack.push(node.first);
                stack.push(node.first + 1);
                continue;
            }
            for k in node.first..node.first + node.count {
                if let Some((t, u, v)) = moller_trumbore(&self.triangles[k as usize], origin, dir) {
                    if t > t_min && t < limit {
                        limit = t;
                        best = Some(Hit { t, triangle: k, u, v });
                    }
                }
            }
        }
        best
    }
}

fn slab_hit(o: Vec3, inv: Vec3, lo: Vec3, hi: Vec3, t_min: f32, t_max: f32) -> bool {
    let t0 = (lo - o) * inv;
    let t1 = (hi - o) * inv;
    let near = t0.min(t1).max_element().max(t_min);
    let far = t0.max(t1).min_element().min(t_max);
    near <= far
}

/// Möller–Trumbore ray/triangle intersection: (t, u, v), both faces.
pub fn moller_trumbore(tri: &Triangle, o: Vec3, d: Vec3) -> Option<(f32, f32, f32)> {
    let e1 = tri.v[1] - tri.v[0];
    let e2 = tri.v[2] - tri.v[0];
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-12 {
        return None;
    }
    let inv_det = 1.0 / det;
    let s = o - tri.v[0];
    let u = s.dot(p) * inv_det;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = d.dot(q) * inv_det;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    Some((e2.dot(q) * inv_det, u, v))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn brute_force(tris: &[Triangle], o: Vec3, d: Vec3) -> Option<f32> {
        tris.iter().filter_map(|t| moller_trumbore(t, o, d).map(|h| h.0)).filter(|&t| t > 1e-4).min_by(f32::total_cmp)
    }

    #[test]
    fn bvh_finds_the_same_closest_hits_as_brute_force() {
        let mesh = crate::scene::mesh::icosphere(1.0, 3);
        let tris: Vec<Triangle> = mesh
            .triangles
            .iter()
            .map(|t| Triangle { v: t.map(|i| mesh.positions[i as usize]), receiver: 0, index: 0 })
            .collect();
        let bvh = Bvh::build(tris.clone());
        assert!(bvh.nodes.len() > 100);
        let mut seed = 1u32;
        let mut rnd = || {
            seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
            (seed >> 8) as f32 / (1 << 24) as f32 * 2.0 - 1.0
        };
        for _ in 0..500 {
            let o = Vec3::new(rnd(), rnd(), rnd()) * 3.0;
            let d = Vec3::new(rnd(), rnd(), rnd()).normalize();
            let a = bvh.intersect(o, d, 1e-4, f32::INFINITY).map(|h| h.t);
            let b = brute_force(&tris, o, d);
            assert_eq!(a.is_some(), b.is_some());
            if let (Some(a), Some(b)) = (a, b) {
                assert!((a - b).abs() < 1e-5);
            }
        }
    }
}
