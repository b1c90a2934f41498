//! Glass with sharp interfaces against closed forms: Fresnel reflection and transmission at a
//! slab and a ball, caustic energy in absolute terms, exact shadow edges and silhouettes.

mod common;

use common::*;
use glam::{Vec2, Vec3};
use refrakt::cpu::interface::{fresnel_dielectric, reflect, refract, slab_transmittance};
use refrakt::output::{Image, Layer};

/// Pixel `i` of a layer as rgb (its first three channels).
fn rgb(layer: &Layer, i: usize) -> Vec3 {
    let c = layer.channels.len();
    Vec3::new(layer.data[c * i], layer.data[c * i + 1], layer.data[c * i + 2])
}

fn layer<'a>(image: &'a Image, name: &str) -> &'a Layer {
    image.layer(name).unwrap_or_else(|| panic!("no {name} layer"))
}

/// Where the ray through pixel (x, y) meets the floor plane y = `floor_y`.
fn floor_point(desc: &refrakt::frame::FrameDesc, x: u32, y: u32, floor_y: f32) -> Vec3 {
    let d = desc.camera.ray(x, y);
    let o = desc.camera.position;
    o + d * ((floor_y - o.y) / d.y)
}

/// A clear glass slab (1.2 × 0.2 × 1.2 m, n = 1.5) 1 m above a white floor under a vertical
/// sun of 1000 lux (the issue's case, at 48³): the floor under it gets the slab's transmittance
/// T = (1 − R)/(1 + R) of the light — every internal reflection summed — as caustic light, in
/// absolute terms. Seen from above through the slab, the camera gets T of that again.
#[test]
fn a_slab_passes_one_minus_r_over_one_plus_r_in_absolute_terms() {
    let t = slab_transmittance(1.5);
    slab_in_the_sun("", Vec3::splat(t));
}

/// The slab with a KHR_materials_specular layer (factor 0.5, colour (1, 0.5, 0)): each surface
/// reflects R′ = 0.5 · 0.04 · colour at normal incidence, (0.02, 0.01, 0), so the slab passes
/// (1 − R′)/(1 + R′) per channel — all of the blue — where the plain slab passes 0.923 of each:
/// photons and camera rays carry the coloured split per channel.
#[test]
fn a_specular_layer_on_a_slab_passes_the_complement_of_its_coloured_reflection() {
    let r = Vec3::new(0.02, 0.01, 0.0);
    slab_in_the_sun("specular = 0.5, specular_color = {1, 0.5, 0}", (Vec3::ONE - r) / (Vec3::ONE + r));
}

/// `a_slab_passes_one_minus_r_over_one_plus_r_in_absolute_terms` with more `glass` fields and
/// the slab's transmittance `t` per channel.
fn slab_in_the_sun(glass: &str, t: Vec3) {
    let desc = frame_from_lua(
        &r#"local r = require("refrakt")
        local scene = r.scene{
          camera = r.camera{ position = {0, 6, 0.01}, target = {0, -1, 0}, fov = 30, size = {48, 48} },
          environment = r.environment{ color = {0, 0, 0} },
          volume = { resolution = 48 }, photons = 200000, samples = 1,
        }
        scene:add(r.node{ name = "floor", translation = {0, -1, 0}, shape = r.plane{ size = {6, 6} },
                          material = r.diffuse{ color = {0.8, 0.8, 0.8} } })
        scene:add(r.node{ name = "slab", shape = r.box{ size = {1.2, 0.2, 1.2} }, material = r.glass{ ior = 1.5, GLASS } })
        scene:add(r.node{ name = "sun", light = r.sun{ direction = {0, -1, 0}, intensity = 1000 } })
        return scene"#
            .replace("GLASS", glass),
    );
    let mut r = renderer();
    let image = r.frame(&desc).unwrap();
    let e_sun = 1000.0 / 683.0;
    // Irradiance on the floor's caustic chart under the middle of the slab.
    let (c, e) = chart(&r, 0, 2);
    let mut under = Vec::new();
    for j in 0..c.height {
        for i in 0..c.width {
            if texel_centre(&c, i, j).abs().max_element() < 0.45 {
                let texel = e[(i + c.width * j) as usize];
                under.push(Vec3::new(texel[0], texel[1], texel[2]));
            }
        }
    }
    let e_under = under.iter().sum::<Vec3>() / under.len() as f32;
    // What the camera sees: the open floor beside the slab, E·albedo/π; under it, through it.
    let (caustic, direct) = (layer(&image, "caustic"), layer(&image, "direct"));
    let open = e_sun * 0.8 / std::f32::consts::PI;
    let (mut seen_under, mut seen_outside) = (Vec::new(), Vec::new());
    for y in 0..desc.camera.height {
        for x in 0..desc.camera.width {
            let p = floor_point(&desc, x, y, -1.0);
            let i = (y * desc.camera.width + x) as usize;
            let m = p.x.abs().max(p.z.abs());
            if m > 0.75 && m < 1.2 {
                seen_outside.push(rgb(direct, i) + rgb(caustic, i));
            }
            if m < 0.45 {
                seen_under.push(rgb(caustic, i));
            }
        }
    }
    let average = |v: &[Vec3]| v.iter().sum::<Vec3>() / v.len() as f32;
    let (seen_under, seen_outside) = (average(&seen_under), average(&seen_outside));
    for k in 0..3 {
        eprintln!(
            "slab{}, channel {k}: floor irradiance under it {:.4} W/m² = {:.4} of the sun's {e_sun:.4}, T = {:.4}; \
             seen: open floor {:.4} (closed form {open:.4}), under the slab through it {:.4} of that, T² = {:.4}",
            if glass.is_empty() { String::new() } else { format!(" ({glass})") },
            e_under[k],
            e_under[k] / e_sun,
            t[k],
            seen_outside[k],
            seen_under[k] / open,
            t[k] * t[k]
        );
        assert!((e_under[k] / e_sun / t[k] - 1.0).abs() < 0.015, "caustic irradiance under the slab, channel {k}: {} vs {}", e_under[k], t[k] * e_sun);
        assert!((seen_outside[k] / open - 1.0).abs() < 0.005, "direct light on the open floor, channel {k}: {} vs {open}", seen_outside[k]);
        assert!((seen_under[k] / open / (t[k] * t[k]) - 1.0).abs() < 0.015, "the floor seen through the slab, channel {k}: {} vs {}", seen_under[k], t[k] * t[k] * open);
    }
}

/// Photons through an absorbing slab wider than the volume: the fraction that reaches the floor
/// is Fresnel's and Beer–Lambert's together, T = (1 − R)² e^{−κL} / (1 − R² e^{−2κL}).
#[test]
fn an_absorbing_slab_transmits_the_fresnel_and_beer_lambert_closed_form() {
    let (kappa, thickness) = (Vec3::new(1.0, 2.0, 4.0), 0.2f32);
    let desc = frame_from_lua(&format!(
        r#"local r = require("refrakt")
        local scene = r.scene{{ volume = {{ resolution = 48, min = {{-0.5, -0.3, -0.5}}, max = {{0.5, 0.3, 0.5}} }},
                               photons = 60000, camera = r.camera{{ size = {{8, 8}} }}, environment = r.environment{{ color = {{0, 0, 0}} }} }}
        scene:add(r.node{{ name = "slab", shape = r.box{{ size = {{3, {thickness}, 3}} }},
                          material = r.glass{{ ior = 1.5, absorption = {{{}, {}, {}}} }} }})
        scene:add(r.node{{ name = "floor", translation = {{0, -1, 0}}, shape = r.plane{{ size = {{4, 4}} }},
                          material = r.diffuse{{ color = {{1, 1, 1}} }} }})
        scene:add(r.node{{ name = "sun", light = r.sun{{ direction = {{0, -1, 0}}, intensity = 683, angular_diameter = 0 }} }})
        return scene"#,
        kappa.x, kappa.y, kappa.z
    ));
    let mut r = renderer();
    r.frame(&desc).unwrap();
    let s = r.photon_stats().unwrap();
    let rf = fresnel_dielectric(1.0, 1.5) as f64;
    assert_received_per_channel(&s, "absorbing slab", 0.01, |c| {
        let a = (-kappa[c] * thickness).exp() as f64;
        (1.0 - rf).powi(2) * a / (1.0 - rf * rf * a * a)
    });
}

/// The share of the emitted flux that reached a receiver, per channel, against a closed form
/// within a relative `tolerance` (in a black environment: the sun's photons alone).
fn assert_received_per_channel(s: &refrakt::pipeline::march::PhotonStats, what: &str, tolerance: f64, closed_form: impl Fn(usize) -> f64) {
    for c in 0..3 {
        let (ratio, expected) = (s.received[c] / s.emitted[c], closed_form(c));
        eprintln!("{what}, channel {c}: received/emitted {ratio:.4}, closed form {expected:.4}");
        assert!((ratio / expected - 1.0).abs() < tolerance, "{what}, channel {c}: {ratio} vs {expected}");
    }
}

/// The exact radiance along a camera ray through a glass ball of radius `r` at the origin in an
/// environment: first-surface reflection plus the transmitted paths with all their internal
/// reflections, split by Fresnel at every surface — to the same depth and weight cut-off as the
/// view pass (8 events, 2·10⁻³).
#[allow(clippy::too_many_arguments)]
fn ball_radiance(o: Vec3, d: Vec3, r: f32, n: f32, tint: Vec3, env: &dyn Fn(Vec3) -> Vec3, events: u32, weight: f32, inside: bool) -> Vec3 {
    let b = o.dot(d);
    let c = o.length_squared() - r * r;
    let disc = b * b - c;
    let t = if disc < 0.0 { None } else if inside { Some(-b + disc.sqrt()) } else { Some(-b - disc.sqrt()).filter(|t| *t > 0.0) };
    let Some(t) = t else { return env(d) };
    let p = o + t * d;
    let outward = p / r;
    let facing = if outward.dot(d) < 0.0 { outward } else { -outward };
    let eta = if inside { 1.0 / n } else { n };
    let rf = fresnel_dielectric(-d.dot(facing), eta);
    let events = events + 1;
    let mut l = Vec3::ZERO;
    let reflected = reflect(d, facing);
    if rf >= 1.0 {
        return if events >= 8 { Vec3::ZERO } else { ball_radiance(p, reflected, r, n, tint, env, events, weight, inside) };
    }
    if weight * rf > 2e-3 {
        l += rf * ball_radiance(p + facing * 1e-5, reflected, r, n, tint, env, events, weight * rf, inside);
    }
    let w = weight * (1.0 - rf) * tint;
    if events < 8 && w.max_element() >= 2e-3 {
        let t_dir = refract(d, facing, eta).unwrap();
        l += (1.0 - rf) * tint * ball_radiance(p - facing * 1e-5, t_dir, r, n, tint, env, events, w.max_element(), !inside);
    }
    l
}

/// A glass ball, clear and tinted (`tint`, per surface crossing), against the exact trace.
#[test]
fn a_glass_ball_matches_an_exact_ray_trace_with_fresnel_and_tint() {
    for tint in [Vec3::ONE, Vec3::new(1.0, 0.6, 0.3)] {
        let desc = frame_from_lua(&format!(
            r#"local r = require("refrakt")
            local scene = r.scene{{
              camera = r.camera{{ position = {{0.4, 0.5, 2.4}}, target = {{0, 0, 0}}, fov = 24, size = {{64, 64}} }},
              environment = r.environment{{ preset = "sky" }},
              volume = {{ resolution = 128 }}, samples = 1,
            }}
            scene:add(r.node{{ name = "ball", shape = r.sphere{{ radius = 0.4 }}, material = r.glass{{ ior = 1.5, tint = {{{}, {}, {}}} }} }})
            return scene"#,
            tint.x, tint.y, tint.z
        ));
        let image = renderer().frame(&desc).unwrap();
        let beauty = layer(&image, "beauty");
        let env = |d: Vec3| desc.environment.radiance(d);
        let (mut errors, mut values, mut rim_reflection) = (Vec::new(), Vec::new(), 0.0f32);
        let (mut got_sum, mut exact_sum) = (Vec3::ZERO, Vec3::ZERO);
        for y in 0..desc.camera.height {
            for x in 0..desc.camera.width {
                let d = desc.camera.ray(x, y);
                let o = desc.camera.position;
                // Pixels whose ray passes inside the outline (the outline pixel itself is a
                // coin toss in f32 either way).
                let miss = (o - o.dot(d) * d).length();
                if miss > 0.4 * 0.97 {
                    continue;
                }
                let exact = ball_radiance(o, d, 0.4, 1.5, tint, &env, 0, 1.0, false);
                let got = rgb(beauty, (y * desc.camera.width + x) as usize);
                errors.push((got - exact).abs().element_sum() / 3.0);
                values.push(exact.element_sum() / 3.0);
                (got_sum, exact_sum) = (got_sum + got, exact_sum + exact);
                if miss > 0.4 * 0.9 {
                    // Near the rim reflection is strong (R → 1 at grazing incidence).
                    let p = o + (-o.dot(d) - (0.16 - miss * miss).sqrt()) * d;
                    rim_reflection = rim_reflection.max(fresnel_dielectric(-d.dot(p / 0.4), 1.5));
                }
            }
        }
        let (mae, level) = (mean(&errors), mean(&values));
        let colour = got_sum / exact_sum;
        eprintln!(
            "glass ball, tint {tint}: MAE {mae:.5} over {} pixels (mean radiance {level:.4}, {:.2} %); mean colour / exact {colour:.4}",
            errors.len(),
            100.0 * mae / level
        );
        assert!(rim_reflection > 0.2, "the test must include grazing pixels where reflection matters");
        assert!(mae < 0.01 * level, "MAE {mae} against a mean of {level}");
        assert!((colour - Vec3::ONE).abs().max_element() < 0.02, "the ball's colour per channel: {colour}");
    }
}

/// Photons through a tinted clear slab: each crossing passes `tint`, so the floor receives
/// (1 − R)² τ² / (1 − R²) per channel — the tint twice, internal reflections untinted.
#[test]
fn a_tinted_slab_passes_its_tint_once_per_surface() {
    let tint = Vec3::new(0.9, 0.6, 0.3);
    let desc = frame_from_lua(&format!(
        r#"local r = require("refrakt")
        local scene = r.scene{{ volume = {{ resolution = 32, min = {{-0.5, -0.3, -0.5}}, max = {{0.5, 0.3, 0.5}} }},
                               photons = 40000, camera = r.camera{{ size = {{8, 8}} }}, environment = r.environment{{ color = {{0, 0, 0}} }} }}
        scene:add(r.node{{ name = "pane", shape = r.box{{ size = {{3, 0.05, 3}} }},
                          material = r.glass{{ ior = 1.5, tint = {{{}, {}, {}}} }} }})
        scene:add(r.node{{ name = "floor", translation = {{0, -1, 0}}, shape = r.plane{{ size = {{4, 4}} }},
                          material = r.diffuse{{ color = {{1, 1, 1}} }} }})
        scene:add(r.node{{ name = "sun", light = r.sun{{ direction = {{0, -1, 0}}, intensity = 683, angular_diameter = 0 }} }})
        return scene"#,
        tint.x, tint.y, tint.z
    ));
    let mut r = renderer();
    r.frame(&desc).unwrap();
    let s = r.photon_stats().unwrap();
    let rf = fresnel_dielectric(1.0, 1.5) as f64;
    assert_received_per_channel(&s, "tinted slab", 0.02, |c| {
        let t = tint[c] as f64;
        (1.0 - rf).powi(2) * t * t / (1.0 - rf * rf)
    });
}

/// A ball's shadow on the floor under an oblique sun: its edge sits where the exact cylinder of
/// grazing rays meets the floor (within a quarter voxel), and the light just outside it is the
/// full direct light — no dark ring where a smoothed step used to block shadow rays.
#[test]
fn a_ball_shadow_edge_is_exact_and_has_no_dark_ring() {
    let radius = 0.3f32;
    let desc = frame_from_lua(
        r#"local r = require("refrakt")
        local scene = r.scene{
          camera = r.camera{ position = {1.4, 10, 0.3}, target = {1, -1, 0.3}, fov = 1.2, size = {128, 24} },
          environment = r.environment{ color = {0, 0, 0} },
          volume = { resolution = 64 }, photons = 0, samples = 1,
        }
        scene:add(r.node{ name = "ball", shape = r.sphere{ radius = 0.3 }, material = r.glass{ ior = 1.5 } })
        scene:add(r.node{ name = "floor", translation = {0, -1, 0}, shape = r.plane{ size = {6, 6} },
                          material = r.diffuse{ color = {1, 1, 1} } })
        scene:add(r.node{ name = "sun", light = r.sun{ direction = {1, -1, 0}, intensity = 1000, angular_diameter = 0 } })
        return scene"#,
    );
    let image = renderer().frame(&desc).unwrap();
    let direct = layer(&image, "direct");
    let h = desc.volume.voxel_size;
    // Lit floor: E cos 45° / π.
    let open = 1000.0 / 683.0 * std::f32::consts::FRAC_1_SQRT_2 / std::f32::consts::PI;
    // The shadow is the ellipse where the cylinder of radius R along the sun meets the floor:
    // centred at x = 1, semi-axes R/cos 45° (along x) and R (along z).
    let (mut inside_max, mut outside_min, mut ring) = (0.0f32, f32::MAX, f32::MAX);
    for y in 0..desc.camera.height {
        for x in 0..desc.camera.width {
            let p = floor_point(&desc, x, y, -1.0);
            let e = Vec2::new((p.x - 1.0) * std::f32::consts::FRAC_1_SQRT_2, p.z).length();
            let lit = rgb(direct, (y * desc.camera.width + x) as usize).x;
            if lit < 0.5 * open {
                inside_max = inside_max.max(e);
            } else {
                outside_min = outside_min.min(e);
            }
            if e > radius + 0.5 * h && e < radius + 3.0 * h {
                ring = ring.min(lit / open);
            }
        }
    }
    let edge = 0.5 * (inside_max + outside_min);
    eprintln!("shadow edge at {edge:.5} m (exact {radius}), {:.3} voxels off; light just outside the edge ≥ {ring:.4} of the open floor", (edge - radius).abs() / h);
    assert!(outside_min - inside_max < 0.25 * h, "the pixels must resolve a quarter voxel");
    assert!((edge - radius).abs() < 0.25 * h, "shadow edge {edge} vs {radius}");
    assert!((ring - 1.0).abs() < 0.005, "a dark ring outside the shadow: {ring}");
}

/// Which pixels' centre rays hit a triangle of the mesh — the silhouette rasterized from the
/// triangles themselves (on the CPU, through refrakt's BVH twin).
fn silhouette(desc: &refrakt::frame::FrameDesc, mesh: &refrakt::scene::MeshData, world: glam::Mat4) -> Vec<bool> {
    let triangles = mesh
        .triangles
        .iter()
        .enumerate()
        .map(|(k, t)| refrakt::bvh::Triangle { v: t.map(|i| world.transform_point3(mesh.positions[i as usize])), receiver: 0, index: k as u32 })
        .collect();
    let bvh = refrakt::bvh::Bvh::build(triangles);
    let (w, h) = (desc.camera.width, desc.camera.height);
    (0..w * h).map(|i| bvh.intersect(desc.camera.position, desc.camera.ray(i % w, i / w), 0.0, f32::MAX).is_some()).collect()
}

#[test]
fn bunny_alpha_is_the_silhouette_of_its_triangles() {
    let bunny = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/assets/bunny.obj");
    for eye in ["{0.2, 0.25, 1.6}", "{-1.5, 0.6, -0.4}"] {
        let source = format!(
            r#"local r = require("refrakt")
            local scene = r.scene{{
              camera = r.camera{{ position = {eye}, target = {{0, 0.1, 0}}, fov = 30, size = {{96, 96}} }},
              volume = {{ resolution = 128 }}, samples = 1,
            }}
            scene:add(r.node{{ name = "bunny", scale = {{4, 4, 4}}, shape = r.mesh{{ file = "{}" }}, material = r.glass{{ ior = 1.5 }} }})
            return scene"#,
            bunny.display()
        );
        let (_dir, path) = write_script("bunny.lua", &source);
        let host = refrakt::lua::ScriptHost::load(&path, &[bunny.parent().unwrap().to_path_buf()], &Default::default()).unwrap();
        host.update(0.0).unwrap();
        let desc = refrakt::scene::eval::evaluate(&host.scene().borrow(), 0.0, &Default::default()).unwrap();
        assert!(desc.meshes[0].sharp, "a closed glass mesh is a sharp interface");
        let image = renderer().frame(&desc).unwrap();
        let alpha: Vec<bool> = layer(&image, "beauty").data.chunks(4).map(|p| p[3] > 0.5).collect();
        let exact = silhouette(&desc, &desc.meshes[0].mesh, desc.meshes[0].world);
        let both = alpha.iter().zip(&exact).filter(|(a, b)| **a && **b).count();
        let either = alpha.iter().zip(&exact).filter(|(a, b)| **a || **b).count();
        let iou = both as f32 / either as f32;
        eprintln!("bunny from {eye}: alpha covers {} pixels, its triangles {}: IoU {iou:.4}", alpha.iter().filter(|a| **a).count(), exact.iter().filter(|a| **a).count());
        assert!(iou >= 0.97, "IoU {iou}");
    }
}
