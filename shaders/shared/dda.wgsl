// Exact traversal of the cells a segment crosses (Amanatides & Woo, "A Fast Voxel Traversal
// Algorithm for Ray Tracing", Eurographics 1987), with the length of the segment in each cell.
// Coordinates are in cell units (cell c spans [c, c+1) on each axis).
//
//     var dda = dda_begin(a, b);
//     while dda_more(dda) { let cell = dda.cell; let length = dda_advance(&dda); … }
//
// The CPU twin is src/cpu/dda.rs.

struct Dda {
    cell: vec3<i32>,
    step: vec3<i32>,
    // Segment parameter (0 at a, 1 at b) where the traversal crosses the next face on each axis.
    t_next: vec3<f32>,
    t_delta: vec3<f32>,
    t: f32,
    // Length of the whole segment, in cell units.
    length: f32,
}

fn dda_begin(a: vec3<f32>, b: vec3<f32>) -> Dda {
    let d = b - a;
    let cell = vec3<i32>(floor(a));
    let step = vec3<i32>(sign(d));
    let inv = 1.0 / abs(d);
    let frac = a - floor(a);
    let to_face = select(frac, 1.0 - frac, d > vec3<f32>(0.0));
    // Axes the segment does not move along never cross a face.
    let t_next = select(vec3<f32>(2.0), to_face * inv, d != vec3<f32>(0.0));
    let t_delta = select(vec3<f32>(2.0), inv, d != vec3<f32>(0.0));
    return Dda(cell, step, t_next, t_delta, 0.0, length(d));
}

fn dda_more(dda: Dda) -> bool {
    return dda.t < 1.0;
}

// Length (cell units) of the segment inside the current cell; moves to the next cell.
fn dda_advance(dda: ptr<function, Dda>) -> f32 {
    let t_exit = min(min(min((*dda).t_next.x, (*dda).t_next.y), (*dda).t_next.z), 1.0);
    let inside = (t_exit - (*dda).t) * (*dda).length;
    (*dda).t = t_exit;
    if t_exit < 1.0 {
        if (*dda).t_next.x <= (*dda).t_next.y && (*dda).t_next.x <= (*dda).t_next.z {
            (*dda).cell.x += (*dda).step.x;
            (*dda).t_next.x += (*dda).t_delta.x;
        } else if (*dda).t_next.y <= (*dda).t_next.z {
            (*dda).cell.y += (*dda).step.y;
            (*dda).t_next.y += (*dda).t_delta.y;
        } else {
            (*dda).cell.z += (*dda).step.z;
            (*dda).t_next.z += (*dda).t_delta.z;
        }
    }
    return inside;
}
