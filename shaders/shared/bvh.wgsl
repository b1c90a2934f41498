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

// Where o + t·d enters the box [lo, hi] within (t_min, t_max), or NO_ENTRY if it misses it.
const NO_ENTRY: f32 = 3.4e38;

fn bvh_entry(o: vec3<f32>, inv: vec3<f32>, lo: vec3<f32>, hi: vec3<f32>, t_min: f32, t_max: f32) -> f32 {
    let t0 = (lo - o) * inv;
    let t1 = (hi - o) * inv;
    let near = max(max(max(min(t0.x, t1.x), min(t0.y, t1.y)), min(t0.z, t1.z)), t_min);
    let far = min(min(min(max(t0.x, t1.x), max(t0.y, t1.y)), max(t0.z, t1.z)), t_max);
    return select(NO_ENTRY, near, near <= far);
}

fn bvh_slab(o: vec3<f32>, inv: vec3<f32>, lo: vec3<f32>, hi: vec3<f32>, t_min: f32, t_max: f32) -> bool {
    return bvh_entry(o, inv, lo, hi, t_min, t_max) < NO_ENTRY;
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
//
// Ordered traversal: an interior node's two children are both tested against the ray where the
// node is visited, the nearer one entered at once and the farther one pushed with its entry
// distance — so every node is read once, a missed child is never pushed, and a pushed one that
// lies beyond the closest hit found meanwhile is dropped without being read again. This is the
// pass's hot loop: every branch of a view ray and every photon casts it at each interface.
// Triangles whose receiver word is `skip` are passed over (a contact partner's search skips the
// surface it starts from; 0xffffffff skips none).
fn bvh_closest_hit(o: vec3<f32>, d: vec3<f32>, t_min: f32, t_max: f32, skip: u32) -> BvhHit {
    var hit = BvhHit(t_max, 0xffffffffu, 0.0, 0.0);
    let inv = 1.0 / d;
    var node = bvh_nodes[0];
    if (node.count == 0u && node.first == 0u) || bvh_entry(o, inv, node.min, node.max, t_min, t_max) == NO_ENTRY {
        return hit;
    }
    var stack: array<u32, BVH_STACK>;
    var stack_entry: array<f32, BVH_STACK>;
    var top = 0u;
    loop {
        if node.count == 0u {
            let a = bvh_nodes[node.first];
            let b = bvh_nodes[node.first + 1u];
            let ta = bvh_entry(o, inv, a.min, a.max, t_min, hit.t);
            let tb = bvh_entry(o, inv, b.min, b.max, t_min, hit.t);
            if ta < NO_ENTRY && tb < NO_ENTRY {
                let a_first = ta <= tb;
                if top < BVH_STACK {
                    stack[top] = select(node.first, node.first + 1u, a_first);
                    stack_entry[top] = max(ta, tb);
                    top++;
                }
                if a_first {
                    node = a;
                } else {
                    node = b;
                }
                continue;
            }
            if ta < NO_ENTRY {
                node = a;
                continue;
            }
            if tb < NO_ENTRY {
                node = b;
                continue;
            }
        } else {
            for (var k = node.first; k < node.first + node.count; k++) {
                let h = moller_trumbore(k, o, d);
                if h.t > t_min && h.t < hit.t && bvh_triangles[k].receiver != skip {
                    hit = h;
                }
            }
        }
        // Resume with the nearest pushed node the closest hit has not ruled out.
        loop {
            if top == 0u {
                return hit;
            }
            top--;
            if stack_entry[top] <= hit.t {
                break;
            }
        }
        node = bvh_nodes[stack[top]];
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
// triangle found instead of looking for the closest (children tested at their parent, as in
// bvh_closest_hit, but in any order).
fn bvh_any_hit(o: vec3<f32>, d: vec3<f32>, t_min: f32, t_max: f32) -> bool {
    let inv = 1.0 / d;
    var node = bvh_nodes[0];
    if (node.count == 0u && node.first == 0u) || !bvh_slab(o, inv, node.min, node.max, t_min, t_max) {
        return false;
    }
    var stack: array<u32, BVH_STACK>;
    var top = 0u;
    loop {
        if node.count == 0u {
            let a = bvh_slab(o, inv, bvh_nodes[node.first].min, bvh_nodes[node.first].max, t_min, t_max);
            let b = bvh_slab(o, inv, bvh_nodes[node.first + 1u].min, bvh_nodes[node.first + 1u].max, t_min, t_max);
            if a && b && top < BVH_STACK {
                stack[top] = node.first + 1u;
                top++;
            }
            if a || b {
                node = bvh_nodes[select(node.first + 1u, node.first, a)];
                continue;
            }
        } else {
            for (var k = node.first; k < node.first + node.count; k++) {
                let t = moller_trumbore(k, o, d).t;
                if t > t_min && t < t_max {
                    return true;
                }
            }
        }
        if top == 0u {
            return false;
        }
        top--;
        node = bvh_nodes[stack[top]];
    }
    return false;
}
