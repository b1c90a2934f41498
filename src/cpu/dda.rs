//! CPU twin of `shaders/shared/dda.wgsl`: the cells a segment crosses and its length in each.

use glam::{IVec3, Vec3};

/// (cell, length inside it) for the segment a → b, in cell units, in the order crossed.
pub fn traverse(a: Vec3, b: Vec3) -> Vec<(IVec3, f32)> {
    let d = b - a;
    let length = d.length();
    let mut cell = a.floor().as_ivec3();
    // WGSL's sign(): 0 for 0 (Rust's signum gives 1).
    let step = IVec3::from(d.to_array().map(|c| if c > 0.0 { 1 } else if c < 0.0 { -1 } else { 0 }));
    let inv = d.abs().recip();
    let frac = a - a.floor();
    let to_face = Vec3::select(d.cmpgt(Vec3::ZERO), Vec3::ONE - frac, frac);
    let moving = d.cmpne(Vec3::ZERO);
    let mut t_next = Vec3::select(moving, to_face * inv, Vec3::splat(2.0));
    let t_delta = Vec3::select(moving, inv, Vec3::splat(2.0));
    let mut t = 0.0f32;
    let mut out = Vec::new();
    while t < 1.0 {
        let t_exit = t_next.min_element().min(1.0);
        out.push((cell, (t_exit - t) * length));
        t = t_exit;
        if t_exit < 1.0 {
            if t_next.x <= t_next.y && t_next.x <= t_next.z {
                cell.x += step.x;
                t_next.x += t_delta.x;
            } else if t_next.y <= t_next.z {
                cell.y += step.y;
                t_next.y += t_delta.y;
            } else {
                cell.z += step.z;
                t_next.z += t_delta.z;
            }
        }
    }
    out
}
