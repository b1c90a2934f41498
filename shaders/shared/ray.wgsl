// Curved rays through a gradient-index medium.
//
// The ray equation (Sun et al. 2008, §3, after Born & Wolf): with arc length s and v = n·dir,
//     dx/ds = v / n,    dv/ds = ∇n.
// Reparametrised by σ with ds = n dσ it becomes dx/dσ = v, dv/dσ = n∇n = ∇(n²/2): a separable
// Hamiltonian system, H = |v|²/2 − n²/2 = 0. Velocity Verlet (kick–drift–kick) on it is
// symplectic and second order, and the closing kick's field sample is the next step's opening
// one, so a step costs one texture fetch — the same as the paper's first-order Euler step.
//
// Needs: #import shared/types.wgsl, shared/grid.wgsl. The CPU twin is src/cpu/ray.rs.

struct RayState {
    x: vec3<f32>,
    // v = n·dir (not renormalised: H stays bounded under a symplectic step).
    v: vec3<f32>,
    // (∇n, n) sampled at x.
    g: vec4<f32>,
}

fn ray_start(ior_grid: texture_3d<f32>, lin: sampler, grid: GridParams, x: vec3<f32>, dir: vec3<f32>) -> RayState {
    let g = sample_ior(ior_grid, lin, grid, x);
    return RayState(x, dir * g.w, g);
}

// One step of arc length ≈ h with velocity Verlet in σ (Δσ = h / n(x₀)).
fn march_step(ior_grid: texture_3d<f32>, lin: sampler, grid: GridParams, s: ptr<function, RayState>, h: f32) {
    let n0 = (*s).g.w;
    let dsigma = h / n0;
    let v_half = (*s).v + (0.5 * dsigma * n0) * (*s).g.xyz;
    let x1 = (*s).x + dsigma * v_half;
    let g1 = sample_ior(ior_grid, lin, grid, x1);
    (*s).v = v_half + (0.5 * dsigma * g1.w) * g1.xyz;
    (*s).x = x1;
    (*s).g = g1;
}

// The paper's forward Euler step (first order), kept for comparison tests.
fn march_step_euler(ior_grid: texture_3d<f32>, lin: sampler, grid: GridParams, s: ptr<function, RayState>, h: f32) {
    let x1 = (*s).x + (h / (*s).g.w) * (*s).v;
    (*s).v = (*s).v + h * (*s).g.xyz;
    (*s).x = x1;
    (*s).g = sample_ior(ior_grid, lin, grid, x1);
}

fn ray_dir(s: RayState) -> vec3<f32> {
    return normalize(s.v);
}
