//! A bounding volume hierarchy over the opaque receivers' triangles, built on the CPU once per
//! change and traversed on the GPU (`shaders/shared/bvh.wgsl`) by camera, shadow and photon rays.
//!
//! Interior nodes have `count = 0` and their first child in `first` (never 0, the root), so a
//! root with `first = 0, count = 0` is the empty tree.
//!
//! Binned SAH splits, up to [`LEAF_SIZE`] triangles per leaf. [`Bvh::build_placed`] builds one
//! tree per mesh and keeps its shape between frames ([`MeshTrees`]): a mesh that only moves is
//! refitted (its triangles re-placed in the same leaf order, the boxes recomputed) in O(n)
//! instead of rebuilt, and a small top tree joins the meshes. [`Bvh::intersect`] is the CPU
//! twin of the GPU traversal.

use glam::Vec3;

use crate::gpu::types::{BvhNode, BvhTriangle};

pub const LEAF_SIZE: usize = 4;
/// Deeper trees would overflow the GPU traversal stack (`BVH_STACK` in `bvh.wgsl`).
pub const MAX_DEPTH: u32 = 30;
/// Centroid bins per axis the SAH split is chosen among.
const SAH_BINS: usize = 12;
/// How much worse (in [`Bvh::sah_cost`]) a refitted mesh tree may get than it was when built
/// before it is built afresh: a turning mesh's boxes, cut for another pose, grow and overlap.
const REFIT_SLACK: f32 = 1.1;
/// Levels of [`MAX_DEPTH`] kept for the top tree over the meshes of [`Bvh::build_placed`]
/// (median splits: up to 2⁶ meshes); a mesh's own tree gets the rest.
const TOP_DEPTH: u32 = 6;

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

/// One mesh's world-space triangles, in the mesh's own order, for [`Bvh::build_placed`].
pub struct Placed {
    /// What identifies the mesh between frames (its `Arc`'s address).
    pub mesh: usize,
    pub triangles: Vec<Triangle>,
}

/// A mesh's own tree: nodes with mesh-local indices, and which of its triangles each leaf slot
/// holds.
struct MeshTree {
    nodes: Vec<BvhNode>,
    order: Vec<u32>,
    /// Its [`Bvh::sah_cost`] when built.
    cost: f32,
}

/// The shapes of the meshes' trees from the last [`Bvh::build_placed`], by mesh.
///
/// A tree found here is reused for the same mesh at any placement: refitting keeps the
/// hierarchy correct whatever the triangles are (every box is recomputed around what it
/// holds), so a stale entry could only cost speed, never a missed hit. A rigid motion keeps
/// the tree as good as a fresh build, up to its boxes being axis-aligned in the world.
#[derive(Default)]
pub struct MeshTrees {
    trees: Vec<(usize, MeshTree)>,
}

fn is_valid(t: &Triangle) -> bool {
    t.v.iter().all(|v| v.is_finite()) && t.normal().length_squared() > 0.0
}

/// Half the surface area of a box (what the SAH weighs a node by; empty boxes have none).
fn half_area(lo: Vec3, hi: Vec3) -> f32 {
    let e = (hi - lo).max(Vec3::ZERO);
    e.x * e.y + e.y * e.z + e.z * e.x
}

fn union(a: &BvhNode, b: &BvhNode) -> (Vec3, Vec3) {
    (Vec3::from(a.min).min(b.min.into()), Vec3::from(a.max).max(b.max.into()))
}

impl Bvh {
    /// Builds the hierarchy; degenerate (zero-area or non-finite) triangles are dropped.
    pub fn build(triangles: Vec<Triangle>) -> Self {
        Self::build_to_depth(triangles, MAX_DEPTH)
    }

    fn build_to_depth(mut triangles: Vec<Triangle>, max_depth: u32) -> Self {
        triangles.retain(is_valid);
        let mut bvh = Bvh { nodes: Vec::with_capacity(2 * triangles.len() / LEAF_SIZE + 1), triangles };
        let n = bvh.triangles.len();
        bvh.nodes.push(BvhNode::default());
        bvh.split(0, 0, n, max_depth);
        bvh
    }

    /// The hierarchy over several meshes: each mesh's tree from `trees` (refitted to where its
    /// triangles are now) or built afresh, joined by a top tree; `trees` keeps this build's.
    /// The result traverses exactly like [`Bvh::build`]'s — one node array, one triangle array
    /// — so the GPU sees no difference. Beyond 2^[`TOP_DEPTH`] meshes, one tree over them all.
    pub fn build_placed(meshes: Vec<Placed>, trees: &mut MeshTrees) -> Self {
        if meshes.len() > 1 << TOP_DEPTH {
            trees.trees.clear();
            return Self::build(meshes.into_iter().flat_map(|m| m.triangles).collect());
        }
        let mut kept = Vec::with_capacity(meshes.len());
        let mut parts = Vec::with_capacity(meshes.len());
        for m in meshes {
            let cached = trees.trees.iter().position(|(k, t)| *k == m.mesh && t.fits(&m.triangles));
            let (mut tree, refitted) = match cached {
                Some(i) => (trees.trees.swap_remove(i).1, true),
                None => (MeshTree::build(&m.triangles), false),
            };
            let mut part = tree.place(&m.triangles);
            if refitted && part.sah_cost() > REFIT_SLACK * tree.cost {
                tree = MeshTree::build(&m.triangles);
                part = tree.place(&m.triangles);
            }
            if !part.triangles.is_empty() {
                parts.push(part);
            }
            kept.push((m.mesh, tree));
        }
        trees.trees = kept;
        Self::join(parts)
    }

    /// One tree over the meshes' placed trees: a top tree of median splits over their root
    /// boxes, whose leaves are the meshes' roots.
    fn join(parts: Vec<Bvh>) -> Self {
        let mut bvh = Bvh { nodes: vec![BvhNode::default()], triangles: Vec::with_capacity(parts.iter().map(|p| p.triangles.len()).sum()) };
        let mut order: Vec<usize> = (0..parts.len()).collect();
        if !order.is_empty() {
            bvh.join_node(0, &parts, &mut order);
        }
        bvh
    }

    fn join_node(&mut self, slot: usize, parts: &[Bvh], items: &mut [usize]) {
        if let [one] = items {
            self.append(slot, &parts[*one]);
            return;
        }
        let roots = || items.iter().map(|&i| &parts[i].nodes[0]);
        let (lo, hi) = roots().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), n| (lo.min(n.min.into()), hi.max(n.max.into())));
        let centre = |i: &usize| (Vec3::from(parts[*i].nodes[0].min) + Vec3::from(parts[*i].nodes[0].max)) * 0.5;
        let axis = (hi - lo).max_position();
        let mid = items.len() / 2;
        items.select_nth_unstable_by(mid, |a, b| centre(a)[axis].total_cmp(&centre(b)[axis]));
        let left = self.nodes.len();
        self.nodes.extend([BvhNode::default(); 2]);
        self.nodes[slot] = BvhNode { min: lo.into(), first: left as u32, max: hi.into(), count: 0 };
        let (a, b) = items.split_at_mut(mid);
        self.join_node(left, parts, a);
        self.join_node(left + 1, parts, b);
    }

    /// Appends a placed mesh tree: its root into `slot`, the rest after the nodes already here,
    /// its indices shifted to where its nodes and triangles now are.
    fn append(&mut self, slot: usize, part: &Bvh) {
        let (node_base, triangle_base) = (self.nodes.len() as u32 - 1, self.triangles.len() as u32);
        let shift = |mut n: BvhNode| {
            n.first += if n.count == 0 { node_base } else { triangle_base };
            n
        };
        self.nodes[slot] = shift(part.nodes[0]);
        self.nodes.extend(part.nodes[1..].iter().map(|&n| shift(n)));
        self.triangles.extend_from_slice(&part.triangles);
    }

    /// The surface area heuristic's cost of the tree: the expected boxes and triangles a ray
    /// through the root tests, Σ area(node)/area(root) × (1, or the triangles of a leaf).
    fn sah_cost(&self) -> f32 {
        let area = |n: &BvhNode| half_area(n.min.into(), n.max.into());
        let root = area(&self.nodes[0]).max(f32::MIN_POSITIVE);
        self.nodes.iter().map(|n| area(n) * n.count.max(1) as f32).sum::<f32>() / root
    }

    fn bounds(&self, first: usize, end: usize) -> (Vec3, Vec3) {
        self.triangles[first..end].iter().flat_map(|t| t.v).fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), p| (lo.min(p), hi.max(p)),
        )
    }

    /// Splits `node` (triangles `first..end`) down to leaves, at most `levels` more levels.
    fn split(&mut self, node: usize, first: usize, end: usize, levels: u32) {
        let (lo, hi) = if end > first { self.bounds(first, end) } else { (Vec3::ZERO, Vec3::ZERO) };
        self.nodes[node].min = lo.into();
        self.nodes[node].max = hi.into();
        if end - first <= LEAF_SIZE || levels == 0 {
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
        self.split(left, first, mid, levels - 1);
        self.split(left + 1, mid, end, levels - 1);
    }

    /// GPU form of the triangles: v0 and two edges (what Möller–Trumbore needs).
    /// The surface area heuristic over `SAH_BINS` centroid bins per axis (Wald 2007): the plane
    /// that minimizes area(left)·count(left) + area(right)·count(right), i.e. the expected work of
    /// a ray that meets the node. Partitions the triangles there and returns the split index;
    /// `None` when every centroid falls in one bin.
    fn sah_split(&mut self, first: usize, end: usize, clo: Vec3, chi: Vec3) -> Option<usize> {
        let extent = chi - clo;
        let bin_of = |c: Vec3, axis: usize| (((c[axis] - clo[axis]) / extent[axis] * SAH_BINS as f32) as usize).min(SAH_BINS - 1);
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
                right[k] = half_area(bounds.0, bounds.1) * count as f32;
            }
            let (mut bounds, mut count) = (empty, 0);
            for k in 0..SAH_BINS - 1 {
                bounds = (bounds.0.min(bins[k].0.0), bounds.1.max(bins[k].0.1));
                count += bins[k].1;
                let cost = half_area(bounds.0, bounds.1) * count as f32 + right[k + 1];
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

impl MeshTree {
    /// A fresh tree over a mesh's valid triangles (leaving room for the top tree).
    fn build(triangles: &[Triangle]) -> Self {
        // Each triangle carries its index in the mesh's list through the build.
        let tagged = triangles.iter().enumerate().map(|(i, t)| Triangle { index: i as u32, ..*t }).collect();
        let bvh = Bvh::build_to_depth(tagged, MAX_DEPTH - TOP_DEPTH);
        MeshTree { order: bvh.triangles.iter().map(|t| t.index).collect(), cost: bvh.sah_cost(), nodes: bvh.nodes }
    }

    /// Whether this tree can hold these triangles: its leaves name exactly the valid ones.
    fn fits(&self, triangles: &[Triangle]) -> bool {
        let valid = triangles.iter().filter(|t| is_valid(t)).count();
        valid == self.order.len() && self.order.iter().all(|&i| triangles.get(i as usize).is_some_and(is_valid))
    }

    /// The mesh's triangles in this tree's leaf order, every box refitted around them.
    fn place(&self, triangles: &[Triangle]) -> Bvh {
        let triangles: Vec<Triangle> = self.order.iter().map(|&i| triangles[i as usize]).collect();
        let mut bvh = Bvh { nodes: self.nodes.clone(), triangles };
        // Children come after their parent (`split` pushes them), so one backward sweep
        // sees every child before its parent.
        for i in (0..bvh.nodes.len()).rev() {
            let n = bvh.nodes[i];
            let (lo, hi) = match (n.count, n.first) {
                (0, 0) => continue, // the empty tree
                (0, c) => union(&bvh.nodes[c as usize], &bvh.nodes[c as usize + 1]),
                (count, first) => bvh.bounds(first as usize, (first + count) as usize),
            };
            (bvh.nodes[i].min, bvh.nodes[i].max) = (lo.into(), hi.into());
        }
        bvh
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

    /// An icosphere's triangles placed by `world`, tagged as receiver `receiver`.
    fn sphere(world: glam::Mat4, receiver: u32) -> Vec<Triangle> {
        let mesh = crate::scene::mesh::icosphere(1.0, 3);
        let p: Vec<Vec3> = mesh.positions.iter().map(|&v| world.transform_point3(v)).collect();
        mesh.triangles.iter().enumerate().map(|(k, t)| Triangle { v: t.map(|i| p[i as usize]), receiver, index: k as u32 }).collect()
    }

    /// Every closest hit of 500 random rays equals brute force's, triangle and all.
    fn assert_hits_like_brute_force(bvh: &Bvh, tris: &[Triangle]) {
        let mut seed = 1u32;
        let mut rnd = || {
            seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
            (seed >> 8) as f32 / (1 << 24) as f32 * 2.0 - 1.0
        };
        for _ in 0..500 {
            let o = Vec3::new(rnd(), rnd(), rnd()) * 3.0;
            let d = Vec3::new(rnd(), rnd(), rnd()).normalize();
            let a = bvh.intersect(o, d, 1e-4, f32::INFINITY);
            let b = brute_force(tris, o, d);
            assert_eq!(a.is_some(), b.is_some());
            if let (Some(a), Some(b)) = (a, b) {
                assert!((a.t - b).abs() < 1e-5);
                let hit = &bvh.triangles[a.triangle as usize];
                assert!(moller_trumbore(hit, o, d).is_some_and(|h| (h.0 - a.t).abs() < 1e-6), "the hit names its triangle");
            }
        }
    }

    /// The deepest leaf's depth (root = 0).
    fn depth(bvh: &Bvh, node: usize) -> u32 {
        let n = &bvh.nodes[node];
        if n.count > 0 || n.first == 0 { 0 } else { 1 + depth(bvh, n.first as usize).max(depth(bvh, n.first as usize + 1)) }
    }

    #[test]
    fn bvh_finds_the_same_closest_hits_as_brute_force() {
        let tris = sphere(glam::Mat4::IDENTITY, 0);
        let bvh = Bvh::build(tris.clone());
        assert!(bvh.nodes.len() > 100);
        assert_hits_like_brute_force(&bvh, &tris);
    }

    #[test]
    fn moving_meshes_are_refitted_and_hit_like_a_fresh_build() {
        let mut trees = MeshTrees::default();
        let place = |t: f32| {
            let spin = glam::Mat4::from_rotation_y(t) * glam::Mat4::from_rotation_x(0.7 * t);
            vec![
                Placed { mesh: 1, triangles: sphere(glam::Mat4::from_translation(Vec3::new(-1.0, 0.0, 0.0)) * spin, 0) },
                Placed { mesh: 2, triangles: sphere(glam::Mat4::from_translation(Vec3::new(1.2 * t.cos(), 0.5, 0.0)) * glam::Mat4::from_scale(Vec3::new(0.5, 1.0, 0.8)), 1) },
                Placed { mesh: 3, triangles: vec![] },
            ]
        };
        for t in [0.0, 0.8, 2.5] {
            let meshes = place(t);
            let all: Vec<Triangle> = meshes.iter().flat_map(|m| m.triangles.clone()).collect();
            let placed = Bvh::build_placed(meshes, &mut trees);
            assert_eq!(trees.trees.len(), 3, "every mesh's tree is kept");
            assert_eq!(placed.triangles.len(), all.len());
            assert!(depth(&placed, 0) <= MAX_DEPTH);
            assert_hits_like_brute_force(&placed, &all);
            // The same rays against one tree over everything: same hits.
            assert_hits_like_brute_force(&Bvh::build(all.clone()), &all);
        }
        // A mesh that only slides keeps its tree; a mesh of another size is rebuilt.
        let order = trees.trees[1].1.order.clone();
        Bvh::build_placed(place(4.0), &mut trees);
        assert_eq!(trees.trees[1].1.order, order);
        let mut fewer = place(4.0);
        fewer[0].triangles.truncate(100);
        Bvh::build_placed(fewer, &mut trees);
        assert_eq!(trees.trees[0].1.order.len(), 100);
    }

    #[test]
    fn a_turning_mesh_is_rebuilt_before_its_refitted_boxes_grow_too_loose() {
        // A turning sphere: the boxes cut for its first pose (halves, quarters, …) grow and
        // overlap, where a fresh build would cut it as before.
        let turned = |angle: f32| {
            let world = glam::Mat4::from_rotation_z(angle) * glam::Mat4::from_rotation_x(angle);
            vec![Placed { mesh: 7, triangles: sphere(world, 0) }]
        };
        let mut trees = MeshTrees::default();
        let mut rebuilds = 0;
        for step in 0..=9 {
            let before = trees.trees.first().map(|(_, t)| t.cost);
            let bvh = Bvh::build_placed(turned(step as f32 * 0.1), &mut trees);
            let tree = &trees.trees[0].1;
            rebuilds += usize::from(before.is_some_and(|c| c != tree.cost));
            assert!(bvh.sah_cost() <= REFIT_SLACK * tree.cost * 1.0001, "step {step}: {} against {}", bvh.sah_cost(), tree.cost);
        }
        // (Each turn costs it ~4 %: rebuilt every third turn or so, not every one.)
        assert!((1..=5).contains(&rebuilds), "{rebuilds} rebuilds in 9 turns of 0.1 rad");
    }

    #[test]
    fn many_meshes_keep_the_tree_within_the_gpu_stack() {
        let meshes = |n: usize| {
            (0..n).map(|i| Placed { mesh: i, triangles: sphere(glam::Mat4::from_translation(Vec3::new(i as f32 * 0.3, 0.0, 0.0)), i as u32) }).collect::<Vec<_>>()
        };
        for n in [64, 65] {
            let all: Vec<Triangle> = meshes(n).into_iter().flat_map(|m| m.triangles).collect();
            let bvh = Bvh::build_placed(meshes(n), &mut MeshTrees::default());
            assert!(depth(&bvh, 0) <= MAX_DEPTH, "{n} meshes: depth {}", depth(&bvh, 0));
            assert_eq!(bvh.triangles.len(), all.len());
        }
    }
}
