// Closest-hit ray queries against the opaque receivers' BVH (built on the CPU by src/bvh.rs,
// whose `Bvh::intersect` is the CPU twin). Interior nodes (count 0) store their first child —
// never the root, so `first = 0, count = 0` marks an empty tree; the second child is the next
// node. Triangles are tested both-sided with Möller–Trumbore.
//
// Expects the stage to declare `bvh_nodes: array<BvhNode>` and `bvh_triangles: array<BvhTriangle>`
// (storage, read). Needs shared/types.wgsl.

const BVH_STACK: u32 = 32u;

struct BvhHit {
    t: f32,
    triangle: u32,
    u: f32,
    v: f32,
}

fn bvh_slab(o: vec3<f32>, inv: vec3<f32>, lo: vec3<f32>, hi: vec3<f32>, t_min: f32, t_max: f32) -> bool {
    let t0 = (lo - o) * inv;
    let t1 = (hi - o) * inv;
    let near = max(max(max(min(t0.x, t1.x), min(t0.y, t1.y)), min(t0.z, t1.z)), t_min);
    let far = min(min(min(max(t0.x, t1.x), max(t0.y, t1.y)), max(t0.z, t1.z)), t_max);
    return near <= far;
}

// Möller–Trumbore: where o + t·d crosses triangle k (either face); t = −1 if it misses.
fn moller_trumbore(k: u32, o: vec3<f32>, d: vec3<f32>) -> BvhHit {
    let tri = bvh_triangles[k];
    let p = cross(d, tri.e2);
    let det = dot(tri.e1, p);
    let inv_det = 1.0 / det;
    let s = o - tri.v0;
    let u = dot(s, p) * inv_det;
    let q = cross(s, tri.e1);
    let v = dot(d, q) * inv_det;
    if abs(det) < 1e-12 || u < 0.0 || u > 1.0 || v < 0.0 || u + v > 1.0 {
        return BvhHit(-1.0, k, 0.0, 0.0);
    }
    return BvhHit(dot(tri.e2, q) * inv_det, k, u, v);
}

// The closest triangle along o + t·d with t in (t_min, t_max); t = t_max when none.
fn bvh_closest_hit(o: vec3<f32>, d: vec3<f32>, t_min: f32, t_max: f32) -> BvhHit {
    var hit = BvhHit(t_max, 0xffffffffu, 0.0, 0.0);
    let inv = 1.0 / d;
    var stack: array<u32, BVH_STACK>;
    var top = 1u;
    stack[0] = 0u;
    while top > 0u {
        top--;
        let node = bvh_nodes[stack[top]];
        if !bvh_slab(o, inv, node.min, node.max, t_min, hit.t) {
            continue;
        }
        if node.count == 0u {
            if node.first != 0u && top + 2u <= BVH_STACK {
                // Nearer child last, so it is visited first and the far one is often culled
                // by the closer hit it finds (child centres projected on the ray).
                let a = bvh_nodes[node.first];
                let b = bvh_nodes[node.first + 1u];
                let b_nearer = dot(b.min + b.max - a.min - a.max, d) < 0.0;
                stack[top] = select(node.first + 1u, node.first, b_nearer);
                stack[top + 1u] = select(node.first, node.first + 1u, b_nearer);
                top += 2u;
            }
            continue;
        }
        for (var k = node.first; k < node.first + node.count; k++) {
            let h = moller_trumbore(k, o, d);
            if h.t > t_min && h.t < hit.t {
                hit = h;
            }
        }
    }
    return hit;
}

fn bvh_triangle_normal(k: u32) -> vec3<f32> {
    let tri = bvh_triangles[k];
    return normalize(cross(tri.e1, tri.e2));
}

// Whether the segment o → o + d·len can reach any receiver at all (it meets their root box).
// Marching loops use it to skip the traversal while a bent path is nowhere near a receiver.
fn bvh_may_hit(o: vec3<f32>, d: vec3<f32>, len: f32) -> bool {
    let root = bvh_nodes[0];
    if root.count == 0u && root.first == 0u {
        return false;
    }
    return bvh_slab(o, 1.0 / d, root.min, root.max, 0.0, len);
}

// Whether anything lies along o + t·d for t in (t_min, t_max): shadow rays stop at the first
// triangle found instead of looking for the closest.
fn bvh_any_hit(o: vec3<f32>, d: vec3<f32>, t_min: f32, t_max: f32) -> bool {
    let inv = 1.0 / d;
    var stack: array<u32, BVH_STACK>;
    var top = 1u;
    stack[0] = 0u;
    while top > 0u {
        top--;
        let node = bvh_nodes[stack[top]];
        if !bvh_slab(o, inv, node.min, node.max, t_min, t_max) {
            continue;
        }
        if node.count == 0u {
            if node.first != 0u && top + 2u <= BVH_STACK {
                stack[top] = node.first;
                stack[top + 1u] = node.first + 1u;
                top += 2u;
            }
            continue;
        }
        for (var k = node.first; k < node.first + node.count; k++) {
            let t = moller_trumbore(k, o, d).t;
            if t > t_min && t < t_max {
                return true;
            }
        }
    }
    return false;
}
