//! The integrator against closed-form optics (DESIGN.md, "Physics checks").

mod common;

use common::*;
use glam::Vec3;
use refrakt::cpu::ray::{self, Integrator, RayState};
use refrakt::gpu::types::{ProbeRay, ProbeRecord};
use refrakt::pipeline::probe::ProbeOptions;

fn lens_scene(resolution: u32) -> String {
    format!(
        r#"local r = require("refrakt")
        local scene = r.scene{{ volume = {{ resolution = {resolution}, margin = 0.05 }} }}
        scene:add(r.node{{ name = "lens", shape = r.luneburg{{ radius = 0.5 }} }})
        return scene"#
    )
}

/// Where a straight ray from `x` along `d` last crossed the sphere |p| = r (looking backwards).
fn back_intersect_sphere(x: Vec3, d: Vec3, r: f32) -> Option<Vec3> {
    // |x + t d|² = r²  →  t² + 2 (x·d) t + |x|² − r² = 0; the exit is the larger root.
    let b = x.dot(d);
    let disc = b * b - (x.length_squared() - r * r);
    (disc >= 0.0).then(|| x + d * (-b + disc.sqrt()))
}

/// Random rays hitting a sphere of radius `r` at the origin with impact parameter ≤ `b_max`·r:
/// (origin, direction, entry point P).
fn rays_into_sphere(n: usize, r: f32, b_max: f32, seed: u64) -> Vec<(Vec3, Vec3, Vec3)> {
    let mut rng = Rng(seed);
    (0..n)
        .map(|_| {
            let d = rng.unit_vector();
            let e = d.any_orthonormal_vector();
            let e = (glam::Quat::from_axis_angle(d, rng.range(0.0, std::f32::consts::TAU)) * e).normalize();
            let b = r * b_max * rng.next_f32().sqrt();
            let p = e * b - d * (r * r - b * b).sqrt();
            (p - d * r, d, p)
        })
        .collect()
}

struct LensErrors {
    /// |exit point − R·d| / R
    position: Vec<f32>,
    /// angle between exit direction and −P/R, radians
    direction: Vec<f32>,
}

fn luneburg_errors(resolution: u32) -> LensErrors {
    let desc = frame_from_lua(&lens_scene(resolution));
    let mut r = renderer();
    r.build_volume(&desc).unwrap();
    let radius = 0.5;
    let rays = rays_into_sphere(400, radius, 0.9, 7);
    let probe: Vec<ProbeRay> =
        rays.iter().map(|(o, d, _)| ProbeRay { origin: (*o).into(), dir: (*d).into(), ..Default::default() }).collect();
    let out = r.probe(&probe, &ProbeOptions::endpoints(desc.volume.step, 100_000)).unwrap();
    let mut errors = LensErrors { position: vec![], direction: vec![] };
    for (i, (_, d, p)) in rays.iter().enumerate() {
        let end: ProbeRecord = out[2 * i + 1];
        let dir = Vec3::from(end.v).normalize();
        let exit = back_intersect_sphere(Vec3::from(end.x), dir, radius).expect("the exit ray meets the lens");
        errors.position.push((exit - *d * radius).length() / radius);
        errors.direction.push(dir.dot(-*p / radius).clamp(-1.0, 1.0).acos());
    }
    errors
}

#[test]
fn luneburg_lens_focuses_on_the_far_pole() {
    let coarse = luneburg_errors(64);
    let fine = luneburg_errors(128);
    for (name, e) in [("64³", &coarse), ("128³", &fine)] {
        eprintln!(
            "Luneburg {name}: exit point error mean {:.4} R, max {:.4} R; direction error mean {:.3}°, max {:.3}°",
            mean(&e.position),
            max(&e.position),
            mean(&e.direction).to_degrees(),
            max(&e.direction).to_degrees()
        );
    }
    // Measured on lavapipe: 64³ 0.0011 R / 0.067° mean, 128³ 0.0006 R / 0.033° mean. The bounds
    // leave about 2× room; the errors come from the grid (a voxel is R/28 at 64³ and R/57 at
    // 128³: trilinear ∇n and the smoothed rim) and halve with it.
    assert!(mean(&coarse.position) < 0.003 && max(&coarse.position) < 0.012, "64³ exit points");
    assert!(mean(&coarse.direction).to_degrees() < 0.15 && max(&coarse.direction).to_degrees() < 1.0, "64³ exit directions");
    assert!(mean(&fine.position) < 0.0015 && max(&fine.position) < 0.006, "128³ exit points");
    assert!(mean(&fine.direction).to_degrees() < 0.08 && max(&fine.direction).to_degrees() < 0.6, "128³ exit directions");
    assert!(mean(&fine.position) < 0.75 * mean(&coarse.position), "exit point error must shrink with resolution");
    assert!(mean(&fine.direction) < 0.75 * mean(&coarse.direction), "direction error must shrink with resolution");
}

/// Least-squares fit y = a + b·x; returns (a, b).
fn fit_line(x: &[f32], y: &[f32]) -> (f32, f32) {
    let n = x.len() as f32;
    let (mx, my) = (x.iter().sum::<f32>() / n, y.iter().sum::<f32>() / n);
    let sxy: f32 = x.iter().zip(y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f32 = x.iter().map(|a| (a - mx) * (a - mx)).sum();
    let b = sxy / sxx;
    (my - b * mx, b)
}

#[test]
fn glass_sphere_focuses_paraxial_light_at_the_closed_form_distance() {
    let (n, radius) = (1.5f32, 0.4f32);
    let desc = frame_from_lua(&format!(
        r#"local r = require("refrakt")
        local scene = r.scene{{ volume = {{ resolution = 128, margin = 0.05 }} }}
        scene:add(r.node{{ name = "ball", shape = r.sphere{{ radius = {radius} }}, material = r.glass{{ ior = {n} }} }})
        return scene"#
    ));
    let mut r = renderer();
    r.build_volume(&desc).unwrap();
    // Parallel rays along +z at heights h in several azimuths; after the ball each crosses the
    // axis at z = f(h). Spherical aberration makes f(h) = f₀ + c·h² + …: fit and take f₀.
    let mut rays = Vec::new();
    let mut heights = Vec::new();
    for k in 1..=8 {
        let h = radius * 0.03 * k as f32;
        for a in 0..4 {
            let phi = a as f32 * std::f32::consts::FRAC_PI_2 + 0.3;
            rays.push(ProbeRay { origin: [h * phi.cos(), h * phi.sin(), -1.0], dir: [0.0, 0.0, 1.0], ..Default::default() });
            heights.push(h);
        }
    }
    let out = r.probe(&rays, &ProbeOptions::endpoints(desc.volume.step, 100_000)).unwrap();
    let mut h2 = Vec::new();
    let mut focus = Vec::new();
    for (i, h) in heights.iter().enumerate() {
        let end = out[2 * i + 1];
        let (x, d) = (Vec3::from(end.x), Vec3::from(end.v).normalize());
        // Meridional ray: where its radial distance from the axis reaches zero.
        let radial = glam::Vec2::new(x.x, x.y);
        let t = -radial.length() / glam::Vec2::new(d.x, d.y).dot(radial.normalize());
        h2.push(h * h);
        focus.push(x.z + t * d.z);
    }
    let (f0, _) = fit_line(&h2, &focus);
    let expected = n * radius / (2.0 * (n - 1.0));
    // The smooth boundary (3 voxels wide) spreads the refracting surface over r = R ± w/2, and
    // f ∝ R: the paraxial focus may sit anywhere within ± f/R · w/2.
    let w = 3.0 * desc.volume.voxel_size;
    let tolerance = expected / radius * w / 2.0;
    eprintln!("glass sphere: paraxial focus {f0:.4} m from the centre, closed form {expected:.4} m, tolerance {tolerance:.4} m");
    assert!((f0 - expected).abs() < tolerance, "paraxial focus {f0} vs {expected} ± {tolerance}");
}

#[test]
fn linear_slab_bends_toward_higher_index_and_conserves_n_cos() {
    let (n0, g) = (1.5f32, 0.5f32);
    let desc = frame_from_lua(&format!(
        r#"local r = require("refrakt")
        local scene = r.scene{{ volume = {{ resolution = 96, margin = 0.05 }} }}
        scene:add(r.node{{ name = "slab", shape = r.slab{{ size = {{1.2, 0.5, 1.2}}, ior = {n0}, gradient = {g} }} }})
        return scene"#
    ));
    let mut r = renderer();
    r.build_volume(&desc).unwrap();
    let steps = 160u32;
    let mut rays = Vec::new();
    for (k, angle) in [0.0f32, 10.0, 20.0, -15.0, 30.0].iter().enumerate() {
        let a = angle.to_radians();
        let az = 0.7 * k as f32;
        let dir = Vec3::new(a.cos() * az.cos(), a.sin(), a.cos() * az.sin());
        rays.push(ProbeRay { origin: (-dir * 0.35 + Vec3::new(0.0, -0.02, 0.0)).into(), dir: dir.into(), ..Default::default() });
    }
    let opts = ProbeOptions { step: desc.volume.step, max_steps: steps, record_every: 1, records_per_ray: steps + 2, integrator: 0, max_step: 0.0 };
    let out = r.probe(&rays, &opts).unwrap();
    for (i, ray) in rays.iter().enumerate() {
        let recs = &out[i * (steps as usize + 2)..(i + 1) * (steps as usize + 2) - 1];
        // Only the slab's interior: the layers are planes of constant y, n = n₀ + g·y.
        // The first stretch of the path in the interior (slots after the ray left the volume
        // were never written; steep rays are totally reflected at the faces and come back).
        let inside: Vec<&ProbeRecord> = recs
            .iter()
            .enumerate()
            .take_while(|(k, r)| r.steps == *k as u32 && r.x[1].abs() < 0.2 && r.x[0].abs() < 0.5 && r.x[2].abs() < 0.5)
            .map(|(_, r)| r)
            .collect();
        assert!(inside.len() > 40, "ray {i} should spend its steps inside the slab, took {}", inside.len());
        let invariant = |r: &ProbeRecord| {
            let v = Vec3::from(r.v);
            r.n * glam::Vec2::new(v.x, v.z).length() / v.length()
        };
        let i0 = invariant(inside[0]);
        let drift = inside.iter().map(|r| (invariant(r) - i0).abs() / i0).fold(0.0, f32::max);
        // n is stored in 16 bits (spacing 2⁻¹⁰ near 1.5): 1e-3 relative is the storage floor.
        assert!(drift < 1.5e-3, "ray {i}: n·cos θ drifts by {drift}");
        // Bending toward higher n: the upward component of the direction only grows.
        let up: Vec<f32> = inside.iter().map(|r| Vec3::from(r.v).normalize().y).collect();
        assert!(up.windows(2).all(|w| w[1] >= w[0] - 1e-5), "ray {i} must bend toward +y");
        if ray.dir[1] == 0.0 {
            // A ray launched along the layers has curvature g/n₀: after arc length s it has
            // risen by s²·g/(2n₀) (to leading order).
            let last = inside.last().unwrap();
            let s = (Vec3::from(last.x) - Vec3::from(inside[0].x)).length();
            let rise = last.x[1] - inside[0].x[1];
            let expected = s * s * g / (2.0 * n0);
            assert!((rise - expected).abs() < 0.05 * expected, "rise {rise} vs {expected} over {s} m");
        }
    }
}

/// A smooth gradient-index ball: n = 1 + a·(1 − r²/R²)³ inside, 1 outside. Unlike the
/// Luneburg lens, n is C² everywhere (its gradient has no jump at the surface), which is what a
/// convergence order needs to show.
fn smooth_ball(radius: f32, a: f32) -> ray::Analytic<impl Fn(Vec3) -> glam::Vec4> {
    ray::Analytic(move |x: Vec3| {
        let q = x.length_squared() / (radius * radius);
        if q >= 1.0 {
            return glam::Vec4::new(0.0, 0.0, 0.0, 1.0);
        }
        let u = 1.0 - q;
        // ∇n = a·3u²·(−2x/R²)
        (x * (-6.0 * a * u * u / (radius * radius))).extend(1.0 + a * u * u * u)
    })
}

/// Exit directions of a fixed set of rays through the smooth ball at step `h`.
fn smooth_ball_exits(integrator: Integrator, h: f32) -> Vec<Vec3> {
    let radius = 0.5;
    let field = smooth_ball(radius, 0.5);
    rays_into_sphere(32, radius, 0.8, 3)
        .iter()
        .map(|(o, d, _)| {
            let s = RayState::start(&field, *o, *d);
            ray::trace_out_of_sphere(&field, s, h, Vec3::ZERO, radius, 10_000_000, integrator).0.dir()
        })
        .collect()
}

#[test]
fn leapfrog_is_second_order_and_euler_first_order() {
    // Reference: velocity Verlet at a step 32× finer than the finest tested.
    let reference = smooth_ball_exits(Integrator::Leapfrog, 0.5 / 4096.0);
    // Steps coarse enough that f32 rounding (≈ 2·10⁻⁵ rad over thousands of steps) stays below
    // the truncation error being measured.
    let steps = [0.5f32 / 4.0, 0.5 / 8.0, 0.5 / 16.0, 0.5 / 32.0];
    let order = |integ| {
        let e: Vec<f32> = steps
            .iter()
            .map(|&h| {
                let exits = smooth_ball_exits(integ, h);
                exits.iter().zip(&reference).map(|(a, b)| a.dot(*b).clamp(-1.0, 1.0).acos()).sum::<f32>() / exits.len() as f32
            })
            .collect();
        let (_, slope) = fit_line(&steps.map(f32::ln), &e.iter().map(|x| x.ln()).collect::<Vec<_>>());
        (e, slope)
    };
    let (leapfrog, p_leapfrog) = order(Integrator::Leapfrog);
    let (euler, p_euler) = order(Integrator::Euler);
    eprintln!("exit direction error (rad) at h = R/4 … R/32: leapfrog {leapfrog:?} (order {p_leapfrog:.2}), euler {euler:?} (order {p_euler:.2})");
    assert!((0.8..1.3).contains(&p_euler), "Euler should converge at first order, measured {p_euler}");
    assert!(p_leapfrog > 1.8, "velocity Verlet should converge at second order, measured {p_leapfrog}");
    // At the same cost per step, the second-order step is far more accurate.
    assert!(leapfrog[1] * 10.0 < euler[1], "leapfrog {} vs euler {} at h = R/8", leapfrog[1], euler[1]);
}

#[test]
fn adaptive_steps_keep_the_luneburg_focus_and_skip_the_air() {
    // A lens in a box three times its size: most of every ray's path is air.
    let desc = frame_from_lua(&lens_scene(64).replace("resolution = 64, margin = 0.05", "resolution = 64, margin = 0.6"));
    let mut r = renderer();
    r.build_volume(&desc).unwrap();
    let radius = 0.5;
    let rays = rays_into_sphere(300, radius, 0.9, 5);
    let probe: Vec<ProbeRay> =
        rays.iter().map(|(o, d, _)| ProbeRay { origin: (*o - *d).into(), dir: (*d).into(), ..Default::default() }).collect();
    let h = desc.volume.step;
    let fixed = r.probe(&probe, &ProbeOptions::endpoints(h, 100_000)).unwrap();
    let adaptive = r.probe(&probe, &ProbeOptions { max_step: 64.0 * desc.volume.voxel_size, ..ProbeOptions::endpoints(h, 100_000) }).unwrap();
    let (mut steps_fixed, mut steps_adaptive) = (0, 0);
    let (mut err_fixed, mut err_adaptive) = (Vec::new(), Vec::new());
    for (i, (_, _, p)) in rays.iter().enumerate() {
        let (f, a) = (fixed[2 * i + 1], adaptive[2 * i + 1]);
        steps_fixed += f.steps;
        steps_adaptive += a.steps;
        let expected = -*p / radius;
        err_fixed.push(Vec3::from(f.v).normalize().angle_between(expected).to_degrees());
        err_adaptive.push(Vec3::from(a.v).normalize().angle_between(expected).to_degrees());
    }
    eprintln!(
        "adaptive: {steps_adaptive} steps vs {steps_fixed} fixed; exit direction error vs −P/R: mean {:.4}° (fixed {:.4}°), max {:.3}° (fixed {:.3}°)",
        mean(&err_adaptive), mean(&err_fixed), max(&err_adaptive), max(&err_fixed)
    );
    assert!((steps_adaptive as f32) < 0.6 * steps_fixed as f32, "{steps_adaptive} vs {steps_fixed}");
    // Straight jumps only cross cells where n (and so ∇n) is flat: the optics do not change.
    assert!(mean(&err_adaptive) < 1.1 * mean(&err_fixed) + 0.005, "adaptive steps lose accuracy");
    assert!(max(&err_adaptive) < 1.5 * max(&err_fixed), "adaptive steps lose accuracy on some ray");
}
