//! Thin sheets and rough glass: a pane passes the thin-slab fraction of the light, tinted, and
//! bends nothing; a frosted surface (GGX roughness) widens a caustic monotonically, converges
//! with samples in the view, and at roughness 0 is exactly the polished surface.

mod common;

use common::*;
use common::gltf_builder::{frame_of_glb, tetrahedron_of};
use glam::{Mat4, Vec3};
use refrakt::cpu::interface::reflect;
use refrakt::output::{Image, Layer};

fn rgb(layer: &Layer, i: usize) -> Vec3 {
    let c = layer.channels.len();
    Vec3::new(layer.data[c * i], layer.data[c * i + 1], layer.data[c * i + 2])
}

fn beauty(image: &Image) -> &Layer {
    image.layer("beauty").expect("a beauty layer")
}

/// The exact incoherent thin slab of index 1.5 at incidence θᵢ, from Fresnel's equations in his
/// own angle form (Born & Wolf §1.5.3), written out here rather than taken from refrakt: per
/// polarization R_s = sin²(θᵢ − θₜ)/sin²(θᵢ + θₜ), R_p = tan²(θᵢ − θₜ)/tan²(θᵢ + θₜ), each summed
/// over the pane's inner reflections to 2R/(1 + R), then averaged.
fn thin_slab_reflectance(theta_i: f32) -> f32 {
    let (rs, rp) = polarized_reflectances(theta_i);
    let sum = |r: f32| 2.0 * r / (1.0 + r);
    0.5 * (sum(rs) + sum(rp))
}

/// Fresnel's reflectances of glass (n = 1.5) for s and p light at incidence θᵢ.
fn polarized_reflectances(theta_i: f32) -> (f32, f32) {
    if theta_i < 1e-3 {
        return (0.04, 0.04); // ((n − 1)/(n + 1))², both polarizations alike
    }
    let theta_t = (theta_i.sin() / 1.5).asin();
    let rs = ((theta_i - theta_t).sin() / (theta_i + theta_t).sin()).powi(2);
    let rp = ((theta_i - theta_t).tan() / (theta_i + theta_t).tan()).powi(2);
    (rs, rp)
}

/// The wrong thin slab the issue found: 2R/(1 + R) of the polarizations' averaged R.
fn averaged_thin_slab_reflectance(theta_i: f32) -> f32 {
    let (rs, rp) = polarized_reflectances(theta_i);
    let r = 0.5 * (rs + rp);
    2.0 * r / (1.0 + r)
}

/// A square pane (a quad, two triangles) of side `size` in its local xy plane, as Lua.
fn pane_mesh(size: f32) -> String {
    let h = size / 2.0;
    format!("r.mesh{{ vertices = {{{{-{h}, -{h}, 0}}, {{{h}, -{h}, 0}}, {{{h}, {h}, 0}}, {{-{h}, {h}, 0}}}}, triangles = {{{{1, 2, 3}}, {{1, 3, 4}}}} }}")
}

/// Sunlight through a tinted thin pane 1 m above the floor, at 0° and 60° from its normal: the
/// patch of light it casts gets E cos θ · tint · (1 − R_thin) (R_thin: the thin slab at θ, each
/// polarization's reflections summed; glTF's thin-walled transmission tints once), per channel, in
/// absolute terms, within 1 %. The light passes the polished sheet as shadow rays (direct light:
/// exact, noise-free), not as photons: the caustic there is none, so nothing counts twice.
/// A pane of index 1 (a gel, a coloured film) reflects nothing and passes E cos θ · tint.
#[test]
fn a_thin_pane_casts_the_thin_slab_fraction_of_sunlight_tinted_once() {
    let tint = Vec3::new(0.9, 0.6, 0.3);
    for (degrees, ior) in [(0.0f32, 1.5f32), (60.0, 1.5), (60.0, 1.0)] {
        let (s, c) = degrees.to_radians().sin_cos();
        // The patch lies tan θ beyond the pane's foot, along x; an orthographic camera just under
        // the pane looks straight down at its middle (its rays start below the pane).
        let x = degrees.to_radians().tan();
        let desc = frame_from_lua(&format!(
            r#"local r = require("refrakt")
            local scene = r.scene{{ volume = {{ resolution = 32 }}, photons = 100000, samples = 4,
                                    environment = r.environment{{ color = {{0, 0, 0}} }},
                                    camera = r.camera{{ position = {{{x}, -0.2, 0}}, target = {{{x}, -1, 0}}, up = {{0, 0, -1}}, orthographic = 0.5, size = {{8, 8}} }} }}
            scene:add(r.node{{ name = "floor", translation = {{0, -1, 0}}, shape = r.plane{{ size = {{6, 6}} }},
                              material = r.diffuse{{ color = {{1, 1, 1}} }} }})
            scene:add(r.node{{ name = "pane", rotation = {{-90, 0, 0}}, shape = {},
                              material = r.glass{{ ior = {ior}, thin = true, tint = {{{}, {}, {}}} }} }})
            scene:add(r.node{{ name = "sun", light = r.sun{{ direction = {{{s}, {}, 0}}, intensity = 683, angular_diameter = 0 }} }})
            return scene"#,
            pane_mesh(1.0),
            tint.x,
            tint.y,
            tint.z,
            -c
        ));
        assert!(desc.meshes[0].thin && desc.meshes[0].sharp);
        let image = renderer().frame(&desc).unwrap();
        let layer_mean = |name: &str| {
            let l = image.layer(name).unwrap();
            let n = l.data.len() / l.channels.len();
            (0..n).map(|i| rgb(l, i)).sum::<Vec3>() / n as f32
        };
        // 683 lux is 1 W/m² across the beam; a white floor shows E/π.
        let (direct, caustic) = (layer_mean("direct") * std::f32::consts::PI, layer_mean("caustic") * std::f32::consts::PI);
        let passed = if ior == 1.0 { 1.0 } else { 1.0 - thin_slab_reflectance(degrees.to_radians()) };
        for k in 0..3 {
            let expected = c * tint[k] * passed;
            eprintln!("thin pane of index {ior} at {degrees}°, channel {k}: patch irradiance {:.4} W/m² (caustic {:.5}), E cos θ · tint · (1 − R_thin) = {expected:.4}", direct[k], caustic[k]);
            assert!((direct[k] / expected - 1.0).abs() < 0.01, "{degrees}°, channel {k}: {} vs {expected}", direct[k]);
            assert!(caustic[k] < 1e-3 * expected, "{degrees}°, channel {k}: the pane's light counted again as caustic ({})", caustic[k]);
        }
    }
}

/// π × the mean radiance a camera looking straight down sees of a thin pane (index 1.5, `glass`:
/// the rest of its fields) 1 m over a white floor, in a sun straight overhead (E = 1 W/m²) and a
/// black sky. `texture`: an RGBA texel for a 2 × 2 texture the fields may name as "t.png".
fn pane_over_a_floor(glass: &str, texture: Option<[u8; 4]>) -> Vec3 {
    let script = format!(
        r#"local r = require("refrakt")
        local scene = r.scene{{ volume = {{ resolution = 24 }}, photons = 20000, samples = 1, bounces = 0,
                                environment = r.environment{{ color = {{0, 0, 0}} }},
                                camera = r.camera{{ position = {{0, 0.5, 0}}, target = {{0, -1, 0}}, up = {{0, 0, -1}}, orthographic = 0.3, size = {{8, 8}} }} }}
        scene:add(r.node{{ name = "floor", translation = {{0, -1, 0}}, shape = r.plane{{ size = {{4, 4}} }},
                          material = r.diffuse{{ color = {{1, 1, 1}} }} }})
        scene:add(r.node{{ name = "pane", shape = r.plane{{ size = {{1, 1}} }}, material = r.glass{{ ior = 1.5, {glass} }} }})
        scene:add(r.node{{ name = "sun", light = r.sun{{ direction = {{0, -1, 0}}, intensity = 683, angular_diameter = 0 }} }})
        return scene"#
    );
    let (dir, path) = write_script("scene.lua", &script);
    if let Some(texel) = texture {
        image::RgbaImage::from_pixel(2, 2, image::Rgba(texel)).save(dir.path().join("t.png")).unwrap();
    }
    let host = load(&path);
    host.update(0.0).unwrap();
    let desc = refrakt::scene::eval::evaluate(&host.scene().borrow(), 0.0, &Default::default()).unwrap();
    assert!(desc.meshes[0].thin && desc.meshes[0].sharp && desc.warnings().is_empty(), "{:?}", desc.warnings());
    let image = renderer().frame(&desc).unwrap();
    let l = beauty(&image);
    let n = l.data.len() / l.channels.len();
    (0..n).map(|i| rgb(l, i)).sum::<Vec3>() / n as f32 * std::f32::consts::PI
}

/// A partly transmissive pane (glTF's transmissionFactor t, or its transmission texture) over a
/// white floor in the sun (`pane_over_a_floor`): of the light its surface does not reflect, t
/// passes and 1 − t meets its diffuse base of the base colour (the tint), so each pixel is
/// (1 − R)(1 − t)·tint·E/π from the base plus what is seen through it, (1 − R)·t·tint × the floor
/// beneath, lit through the pane by E (1 − R)·t·tint — in all, π L = (1 − R)(1 − t)·tint +
/// (1 − R)² t²·tint², R = R_thin(0°), per channel within 1 %. The factor and a texture of the
/// same value (64/255, its red channel) give the same. With the factor, the base has a colour of
/// its own (`base_color`, a Principled BSDF's Base Color whose glass is tinted by its root): the
/// base term takes it, the rest the tint.
#[test]
fn a_partly_transmissive_pane_shows_its_diffuse_base_and_passes_the_rest() {
    let tint = Vec3::new(1.0, 0.5, 0.25);
    let passed = 1.0 - thin_slab_reflectance(0.0);
    let own_base = Vec3::new(0.3, 0.9, 0.6);
    for (factor, texel, base) in [(0.25f32, None, own_base), (1.0, Some([64u8, 0, 0, 255]), tint)] {
        let texture = texel.map_or("", |_| r#", transmission_texture = "t.png""#);
        let base_field = if base == tint { String::new() } else { format!(", base_color = {{{}, {}, {}}}", base.x, base.y, base.z) };
        let seen = pane_over_a_floor(&format!("thin = true, tint = {{{}, {}, {}}}, transmission = {factor}{texture}{base_field}", tint.x, tint.y, tint.z), texel);
        let t = texel.map_or(factor, |v| factor * v[0] as f32 / 255.0);
        for k in 0..3 {
            let expected = passed * (1.0 - t) * base[k] + passed * passed * t * t * tint[k] * tint[k];
            eprintln!("pane of transmission {t:.4}, channel {k}: π L = {:.4}, expected {expected:.4} (its base {:.4})", seen[k], passed * (1.0 - t) * base[k]);
            assert!((seen[k] / expected - 1.0).abs() < 0.01, "transmission {t}, channel {k}: {} vs {expected}", seen[k]);
        }
    }
}

/// A glass's `base_color` reads back as its tint until set (glTF's one base colour is both),
/// is its own once set, and must be a fraction per channel.
#[test]
fn a_glass_base_colour_is_its_tint_until_set() {
    let desc = frame_from_lua(
        r#"local r = require("refrakt")
        local g = r.glass{ tint = {0.5, 0.25, 1} }
        assert(g.base_color[1] == 0.5 and g.base_color[2] == 0.25 and g.base_color[3] == 1)
        g.base_color = {0.75, 0.5, 0}
        assert(g.base_color[1] == 0.75 and g.tint[1] == 0.5)
        local scene = r.scene{}
        scene:add(r.node{ name = "b", shape = r.sphere{ radius = 0.2 }, material = g })
        return scene"#,
    );
    assert_eq!((desc.fields[0].glass.base_color, desc.fields[0].glass.tint), (Some(Vec3::new(0.75, 0.5, 0.0)), Vec3::new(0.5, 0.25, 1.0)));
    let error = load_error("local g = require('refrakt').glass{ base_color = {2, 0, 0} }", &Default::default());
    assert!(error.contains("glass.base_color") && error.contains("from 0 to 1"), "{error}");
}

/// Alpha on a thin pane over a white floor in the sun (`pane_over_a_floor`): where it is there
/// by the fraction a (BLEND), it passes P = a (1 − R)·tint + (1 − a) of the light — to the floor
/// (shadow rays) and from the floor back up to the camera — so π L = P²; MASK cuts it away where
/// the base colour texture's alpha is below the cutoff (π L = 1, the open floor) and keeps it
/// whole above (a = 1). Per channel within 1 %.
#[test]
fn alpha_cuts_a_thin_pane_away_or_blends_it() {
    let tint = Vec3::new(1.0, 0.5, 0.25);
    let r = thin_slab_reflectance(0.0);
    let fields = format!("thin = true, tint = {{{}, {}, {}}}", tint.x, tint.y, tint.z);
    for (extra, texel, a) in [
        (r#", alpha = 0.4, alpha_mode = "BLEND""#, None, 0.4f32),
        (r#", alpha_mode = "MASK", tint_texture = "t.png""#, Some([255u8, 255, 255, 100]), 0.0),
        (r#", alpha_mode = "MASK", tint_texture = "t.png""#, Some([255u8, 255, 255, 200]), 1.0),
    ] {
        let seen = pane_over_a_floor(&format!("{fields}{extra}"), texel);
        for k in 0..3 {
            let p = a * (1.0 - r) * tint[k] + 1.0 - a;
            eprintln!("pane{extra} (texel {texel:?}), channel {k}: π L = {:.4}, expected P² = {:.4}", seen[k], p * p);
            assert!((seen[k] / (p * p) - 1.0).abs() < 0.01, "{extra} {texel:?}, channel {k}: {} vs {}", seen[k], p * p);
        }
    }
}

/// Tinted glass of index 1 — KHR_materials_transmission with an index of 1, a coloured gel block —
/// bends and reflects nothing but tints at each surface it is crossed at, as glTF says: a closed
/// block (an analytic box, a mesh cube) in a uniform white sky, seen straight down through its
/// top and bottom, shows tint² per channel (within 1 %).
#[test]
fn tinted_glass_of_index_1_tints_each_surface_it_is_crossed_at() {
    let tint = Vec3::new(0.9, 0.6, 0.3);
    for shape in ["r.box{ size = {1, 0.2, 1} }", "r.cube{ size = {1, 0.2, 1} }"] {
        let desc = frame_from_lua(&format!(
            r#"local r = require("refrakt")
            local scene = r.scene{{ volume = {{ resolution = 16 }}, photons = 1000, samples = 1, bounces = 0,
                                    environment = r.environment{{ color = {{1, 1, 1}} }},
                                    camera = r.camera{{ position = {{0, 0.5, 0}}, target = {{0, -1, 0}}, up = {{0, 0, -1}}, orthographic = 0.3, size = {{8, 8}} }} }}
            scene:add(r.node{{ name = "gel", shape = {shape}, material = r.glass{{ ior = 1.0, tint = {{{}, {}, {}}} }} }})
            return scene"#,
            tint.x, tint.y, tint.z
        ));
        assert!(desc.fields.iter().all(|f| f.sharp) && desc.meshes.iter().all(|m| m.sharp && !m.thin), "{shape}: a sharp solid");
        let image = renderer().frame(&desc).unwrap();
        let l = beauty(&image);
        let n = l.data.len() / l.channels.len();
        let seen = (0..n).map(|i| rgb(l, i)).sum::<Vec3>() / n as f32;
        for k in 0..3 {
            let expected = tint[k] * tint[k];
            eprintln!("{shape} of index 1, channel {k}: L = {:.4}, expected tint² = {expected:.4}", seen[k]);
            assert!((seen[k] / expected - 1.0).abs() < 0.01, "{shape}, channel {k}: {} vs {expected}", seen[k]);
        }
    }
}

/// Metal on glass (glTF's metallic on a transmissive material): a thin pane in a uniform white
/// sky, seen straight down, shows what it reflects and what it passes of the sky: the metal
/// part m reflects Schlick's F from the base colour, at normal incidence the base colour b
/// itself, and passes nothing; the glass part reflects R and passes (1 − R)·c, c the tint — so
/// L = (1 − m) R + m b + (1 − m)(1 − R) c, per channel within 1 % (all metal: L = b). Half metal
/// has a base colour of its own (`base_color`); all metal, glTF's one base colour (b = c).
#[test]
fn metal_on_a_pane_reflects_its_base_colour_and_passes_nothing() {
    let tint = Vec3::new(1.0, 0.5, 0.25);
    let r = thin_slab_reflectance(0.0);
    for (m, base) in [(0.5f32, Vec3::new(0.3, 0.9, 0.6)), (1.0, tint)] {
        let seen = pane_in_a_white_sky(&format!(
            "tint = {{{}, {}, {}}}, metallic = {m}, base_color = {{{}, {}, {}}}",
            tint.x, tint.y, tint.z, base.x, base.y, base.z
        ));
        for k in 0..3 {
            let expected = (1.0 - m) * r + m * base[k] + (1.0 - m) * (1.0 - r) * tint[k];
            eprintln!("pane of metallic {m}, channel {k}: L = {:.4}, expected {expected:.4}", seen[k]);
            assert!((seen[k] / expected - 1.0).abs() < 0.01, "metallic {m}, channel {k}: {} vs {expected}", seen[k]);
        }
    }
}

/// The mean radiance a camera looking straight down sees of a thin pane (index 1.5, `glass`:
/// the rest of its fields) in a uniform white sky of radiance 1.
fn pane_in_a_white_sky(glass: &str) -> Vec3 {
    let desc = frame_from_lua(&format!(
        r#"local r = require("refrakt")
        local scene = r.scene{{ volume = {{ resolution = 16 }}, photons = 1000, samples = 1, bounces = 0,
                                environment = r.environment{{ color = {{1, 1, 1}} }},
                                camera = r.camera{{ position = {{0, 0.5, 0}}, target = {{0, -1, 0}}, up = {{0, 0, -1}}, orthographic = 0.3, size = {{8, 8}} }} }}
        scene:add(r.node{{ name = "pane", shape = r.plane{{ size = {{1, 1}} }}, material = r.glass{{ ior = 1.5, thin = true, {glass} }} }})
        return scene"#
    ));
    let image = renderer().frame(&desc).unwrap();
    let l = beauty(&image);
    let n = l.data.len() / l.channels.len();
    (0..n).map(|i| rgb(l, i)).sum::<Vec3>() / n as f32
}

/// KHR_materials_specular on a pane (`Glass::specular`) seen from straight above in a uniform
/// white sky: each surface reflects R′ = factor · min(F₀ · colour, 1) at normal incidence (F₀ =
/// 0.04 for n = 1.5), the sheet 2R′/(1 + R′) per channel, and passes the rest tinted, so
/// L = R_sheet + (1 − R_sheet)·tint per channel within 1 % — a factor 0 reflects nothing and
/// shows the tint alone; a colour above 1 raises F₀ (10 × 0.04 = 0.4 in red). The same pane
/// without the layer reflects 0.077 in every channel, which the bound tells apart.
#[test]
fn a_specular_layer_reshapes_a_panes_reflection_and_passes_the_rest() {
    let tint = Vec3::new(0.5, 0.5, 0.25);
    for (factor, colour) in [(0.0f32, Vec3::ONE), (0.8, Vec3::new(10.0, 1.0, 0.0))] {
        let seen = pane_in_a_white_sky(&format!(
            "tint = {{{}, {}, {}}}, specular = {factor}, specular_color = {{{}, {}, {}}}",
            tint.x, tint.y, tint.z, colour.x, colour.y, colour.z
        ));
        for k in 0..3 {
            let surface = factor * (0.04 * colour[k]).min(1.0);
            let sheet = 2.0 * surface / (1.0 + surface);
            let expected = sheet + (1.0 - sheet) * tint[k];
            eprintln!("pane of specular {factor} × {colour}, channel {k}: L = {:.4}, expected {expected:.4} (R_sheet {sheet:.4})", seen[k]);
            assert!((seen[k] / expected - 1.0).abs() < 0.01, "specular {factor}, channel {k}: {} vs {expected}", seen[k]);
        }
    }
}

/// A tilted pane in front of a dim striped wall (the issue's bright sky over a dim ground), seen
/// by the camera: every pixel through it is what the same pixel shows without the pane, times
/// tint · (1 − R_thin(θ)), plus R_thin(θ) of the sky in the mirror direction — tinted at 35°,
/// clear at 55°, where summing the averaged Fresnel instead of each polarization's reflects
/// 0.008 more of the sky: about 5 % of what the pane shows over the dim wall, past the 1 % bound.
/// A sheet that displaced the stripes (as a refracting slab would) or reflected a single
/// surface's Fresnel fails it. (The wall and stripes glow rather than reflect: the sky lights the
/// scene, and the pane shades the wall from part of it, which is not what this test measures.)
/// A tinted pane of index 1 (a gel) shows what lies behind it times its tint, and reflects nothing.
#[test]
fn a_thin_pane_bends_nothing_and_reflects_a_thin_slabs_fresnel() {
    for (angle, tint, ior) in [(35.0f32, Vec3::new(0.9, 0.7, 0.5), 1.5f32), (55.0, Vec3::ONE, 1.5), (35.0, Vec3::new(0.3, 0.8, 1.0), 1.0)] {
        pane_against_the_exact_thin_slab(angle, tint, ior);
    }
}

fn pane_against_the_exact_thin_slab(angle: f32, tint: Vec3, ior: f32) {
    let scene = |with_pane: bool| {
        let pane = if with_pane {
            format!(
                r#"scene:add(r.node{{ name = "pane", translation = {{0, 0.2, 0}}, rotation = {{0, {angle}, 0}}, shape = {},
                                    material = r.glass{{ ior = {ior}, thin = true, tint = {{{}, {}, {}}} }} }})"#,
                pane_mesh(1.2),
                tint.x,
                tint.y,
                tint.z
            )
        } else {
            String::new()
        };
        frame_from_lua(&format!(
            r#"local r = require("refrakt")
            local scene = r.scene{{
              camera = r.camera{{ position = {{0, 0.2, 2.5}}, target = {{0, 0.2, 0}}, fov = 20, size = {{48, 48}} }},
              environment = r.environment{{ preset = "sky" }},
              volume = {{ resolution = 32, min = {{-1, -0.8, -0.8}}, max = {{1, 1.2, 0.8}} }}, samples = 1, photons = 0,
            }}
            scene:add(r.node{{ name = "wall", translation = {{0, 0, -1.5}}, shape = r.box{{ size = {{4, 4, 0.1}} }},
                              material = r.diffuse{{ color = {{0, 0, 0}}, emission = {{0.03, 0.03, 0.03}} }} }})
            for i = -3, 3 do
              scene:add(r.node{{ name = "stripe" .. i, translation = {{0.2 * i, 0, -1.4}}, shape = r.box{{ size = {{0.07, 3, 0.05}} }},
                                material = r.diffuse{{ color = {{0, 0, 0}}, emission = {{0.5, 0.5, 0.5}} }} }})
            end
            {pane}
            return scene"#
        ))
    };
    let (with, without) = (scene(true), scene(false));
    let mut r = renderer();
    let seen = r.frame(&with).unwrap();
    let bare = r.frame(&without).unwrap();
    // The pane's plane and extent in the world.
    let world = Mat4::from_translation(Vec3::new(0.0, 0.2, 0.0)) * Mat4::from_rotation_y(angle.to_radians());
    let normal = world.transform_vector3(Vec3::Z);
    let (mut errors, mut values, mut stripes, mut averaged_errors) = (Vec::new(), Vec::new(), 0, Vec::new());
    for y in 0..with.camera.height {
        for x in 0..with.camera.width {
            let (o, d) = (with.camera.position, with.camera.ray(x, y));
            let t = (Vec3::new(0.0, 0.2, 0.0) - o).dot(normal) / d.dot(normal);
            let local = world.inverse().transform_point3(o + t * d);
            if local.x.abs().max(local.y.abs()) > 0.6 * 0.95 {
                continue; // off the pane, or on its outline
            }
            let i = (y * with.camera.width + x) as usize;
            let behind = rgb(beauty(&bare), i);
            let theta = d.dot(normal).abs().min(1.0).acos();
            let slab = |r_thin: f32| tint * (1.0 - r_thin) * behind + r_thin * with.environment.radiance(reflect(d, normal));
            let exact = slab(if ior == 1.0 { 0.0 } else { thin_slab_reflectance(theta) });
            let got = rgb(beauty(&seen), i);
            errors.push((got - exact).abs().element_sum() / 3.0);
            averaged_errors.push((slab(averaged_thin_slab_reflectance(theta)) - exact).abs().element_sum() / 3.0);
            values.push(exact.element_sum() / 3.0);
            stripes += usize::from(behind.x > 0.2);
        }
    }
    let (mae, level) = (mean(&errors), mean(&values));
    eprintln!("thin pane of index {ior} at {angle}°, tint {tint}: MAE {mae:.5} over {} pixels ({stripes} on stripes), mean radiance {level:.4}; the averaged-R slab would be off by {:.5}", errors.len(), mean(&averaged_errors));
    assert!(errors.len() > 300 && stripes > 30, "the pane must cover the stripes: {} pixels, {stripes} on stripes", errors.len());
    assert!(mae < 0.012 && mae < 0.01 * level, "{angle}°: MAE {mae} against a mean of {level}");
    if angle > 50.0 {
        assert!(mean(&averaged_errors) > 0.01 * level, "the scene must tell the averaged-R slab from the exact one");
    }
}

/// A small glass block (0.4 × 0.1 × 0.4 m) 1 m above the floor under a vertical sun, at
/// roughness 0 (the `glass` default, bit for bit), 0.25, 0.5 and 0.75: the share of its caustic's
/// power inside the block's own square falls with each step (the patch's edges blur wider), and
/// the light it carries falls slowly (microfacet shadowing and steeper reflection: ≤ 15% up to 0.5).
#[test]
fn rough_glass_widens_a_suns_caustic_monotonically() {
    let spot = |roughness: Option<f32>| {
        let material = match roughness {
            Some(a) => format!("r.glass{{ ior = 1.5, roughness = {a} }}"),
            None => "r.glass{ ior = 1.5 }".to_string(),
        };
        let desc = frame_from_lua(&format!(
            r#"local r = require("refrakt")
            local scene = r.scene{{ volume = {{ resolution = 32 }}, photons = 60000, camera = r.camera{{ size = {{8, 8}} }} }}
            scene:add(r.node{{ name = "floor", translation = {{0, -1, 0}}, shape = r.plane{{ size = {{4, 4}} }},
                              material = r.diffuse{{ color = {{1, 1, 1}} }} }})
            scene:add(r.node{{ name = "block", shape = r.box{{ size = {{0.4, 0.1, 0.4}} }}, material = {material} }})
            scene:add(r.node{{ name = "sun", light = r.sun{{ direction = {{0, -1, 0}}, intensity = 683, angular_diameter = 0 }} }})
            return scene"#
        ));
        let mut r = renderer();
        r.frame(&desc).unwrap();
        let (c, e) = chart(&r, 0, 2);
        let (mut flux, mut inside) = (0.0f64, 0.0f64);
        for j in 0..c.height {
            for i in 0..c.width {
                let power = e[(i + c.width * j) as usize][1] as f64 * (c.texel * c.texel) as f64;
                flux += power;
                if texel_centre(&c, i, j).abs().max_element() < 0.2 {
                    inside += power;
                }
            }
        }
        (e, inside / flux, flux)
    };
    let (polished, share0, flux0) = spot(None);
    let (zero, _, _) = spot(Some(0.0));
    assert!(polished == zero, "roughness 0 is the polished surface, bit for bit");
    eprintln!("roughness 0: {share0:.4} of the caustic's power inside the block's square, flux {flux0:.4} W");
    let mut last = share0;
    for a in [0.25f32, 0.5, 0.75] {
        let (_, share, flux) = spot(Some(a));
        eprintln!("roughness {a}: {share:.4} inside the square, flux {flux:.4} W ({:.3} of polished)", flux / flux0);
        assert!(share < last - 0.01, "roughness {a}: {share} of the power inside, after {last}");
        // Single-scattering microfacets lose what their facets shadow (Smith's G₁), and steep
        // facets reflect more: little at moderate roughness, much near 1.
        assert!(flux < flux0 && (a > 0.5 || flux / flux0 > 0.85), "roughness {a}: flux {flux} vs {flux0}");
        last = share;
    }
}

/// A frosted ball in the view converges with samples: its error against a 32-sample image falls
/// as 1/√N does from 4 to 16 samples (by √(4 + 1/2)/√(1 + 1/2) = 1.73 with the reference's own
/// noise), and the same samples render the same image twice.
#[test]
fn a_frosted_ball_converges_with_samples() {
    let render = |samples: u32| {
        let desc = frame_from_lua(&format!(
            r#"local r = require("refrakt")
            local scene = r.scene{{
              camera = r.camera{{ position = {{0, 0.2, 2}}, target = {{0, 0, 0}}, fov = 26, size = {{24, 24}} }},
              environment = r.environment{{ preset = "sky" }}, volume = {{ resolution = 32 }}, samples = {samples},
            }}
            scene:add(r.node{{ name = "ball", shape = r.sphere{{ radius = 0.4 }}, material = r.glass{{ ior = 1.5, roughness = 0.3 }} }})
            return scene"#
        ));
        let image = renderer().frame(&desc).unwrap();
        beauty(&image).data.clone()
    };
    let reference = render(32);
    let error = |v: &[f32]| mean(&v.iter().zip(&reference).map(|(a, b)| (a - b).abs()).collect::<Vec<_>>());
    let (four, sixteen) = (render(4), render(16));
    let (e4, e16) = (error(&four), error(&sixteen));
    eprintln!("frosted ball: mean |error| against 32 samples: {e4:.5} at 4 samples, {e16:.5} at 16 ({:.2}×)", e4 / e16);
    assert!(e4 > 0.0 && e4 / e16 > 1.4, "4 samples {e4}, 16 samples {e16}");
    assert!(render(4) == four, "deterministic: the same samples give the same image");
}

/// The furnace: clear glass of any roughness in a uniform environment of radiance 1, with
/// nothing else in the scene, neither absorbs nor emits, so every pixel must show radiance 1 —
/// through it, off it, and after any number of bounces inside. A single GGX microfacet crossing
/// loses the light its masking term blocks (at roughness 1, 14 % at each entry and about half at
/// each exit: at roughness 0.5 the ball rendered at 0.875 before); divided by the surface's albedo E
/// (`pipeline::rough_albedo`) it keeps it. A solid ball and a thin sheet (a pane facing the
/// camera), each at roughness 0.5 and 1, within 3 % over the glass (the table's and the branches'
/// truncation).
#[test]
fn rough_glass_in_a_uniform_environment_keeps_its_energy() {
    let mut r = renderer();
    for (shape, thin) in [("r.sphere{ radius = 0.4 }", false), ("r.box{ size = {0.8, 0.8, 0.01} }", true)] {
        for roughness in [0.5, 1.0] {
            let desc = frame_from_lua(&format!(
                r#"local r = require("refrakt")
                local scene = r.scene{{
                  camera = r.camera{{ position = {{0, 0, 2}}, target = {{0, 0, 0}}, fov = 20, size = {{24, 24}} }},
                  environment = r.environment{{ color = {{1, 1, 1}} }}, volume = {{ resolution = 32 }}, samples = 16,
                }}
                scene:add(r.node{{ name = "glass", shape = {shape}, material = r.glass{{ ior = 1.5, roughness = {roughness}, thin = {thin} }} }})
                return scene"#
            ));
            let image = r.frame(&desc).unwrap();
            let layer = beauty(&image);
            // The pixels within the glass's outline (a ball of 0.4 and a 0.8 pane at 2 m, 20°).
            let inside: Vec<f32> = (0..24 * 24)
                .filter(|&i| ((i % 24) as f32 - 11.5).hypot((i / 24) as f32 - 11.5) < 8.0)
                .map(|i| rgb(layer, i).dot(Vec3::splat(1.0 / 3.0)))
                .collect();
            let m = mean(&inside);
            eprintln!("{} of roughness {roughness} in a furnace: mean radiance {m:.4} over {} pixels", if thin { "thin pane" } else { "ball" }, inside.len());
            assert!((m - 1.0).abs() < 0.03, "{shape} roughness {roughness}: {m}");
        }
    }
}

/// The sun's glint on frosted glass, against the microfacet closed form: a rough (α = 0.25)
/// glass slab whose inside absorbs everything, under a sun 30° from the mirror direction, seen
/// from far off (every pixel at one angle) against a black sky. Its radiance is
/// E ⟨F(v·m) D(m) G₁(v) G₁(l) / 4 cos θ_v⟩ over the sun's disc (m the half vector of the view
/// direction v and the sun's l; E in W/m²) — the model whose directions the crossing samples —
/// divided by the surface's single-scattering albedo at v (by a fine quadrature of its own,
/// `rough_albedo::single_scattering_albedo`: the energy the crossing keeps from masking). A
/// sun of no size is found only by sampling the sun at the crossing; a sun 10° across by both
/// strategies, each weighted by the balance heuristic: either weight wrong and the glint is off.
/// With `multiscatter = false` (single-scattering GGX) the same without the division (2 % less
/// here). Half metal (`metallic = 0.5`, base colour (1, 0.5, 0.2)): F per channel is
/// ½ F_glass + ½ Schlick(base, v·m), the glass's and the metal's at the half vector of each
/// direction over the disc — the split of the light sampled at the crossing is taken at its own
/// facet. Within 0.5 % per channel at 64 samples.
#[test]
fn a_suns_glint_on_frosted_glass_matches_the_microfacet_closed_form() {
    use refrakt::cpu::interface::{fresnel_dielectric, ggx_distribution, smith_g1};
    let (roughness, n_up) = (0.5f32, Vec3::Y);
    let alpha = roughness * roughness;
    let v = Vec3::new(0.0, 1.0, 1.0).normalize();
    // The sun 30° from the mirror direction of v (turned about x), 15° above the horizon.
    let mirror = Vec3::new(0.0, v.y, -v.z);
    let sun = (glam::Quat::from_rotation_x(-30f32.to_radians()) * mirror).normalize();
    // Multiscatter (the default) keeps what masking takes: the closed form ÷ the albedo E.
    let albedo = refrakt::pipeline::rough_albedo::single_scattering_albedo(v.dot(n_up), roughness, 1.5, false, 256);
    let base = Vec3::new(1.0, 0.5, 0.2);
    let glint = |l: Vec3, multiscatter: bool, metallic: f32| {
        let m = (v + l).normalize();
        let schlick = base + (Vec3::ONE - base) * (1.0 - v.dot(m)).powi(5);
        let f = Vec3::splat(fresnel_dielectric(v.dot(m), 1.5)).lerp(schlick, metallic);
        let kept = if multiscatter { 1.0 / albedo } else { 1.0 };
        kept * f * ggx_distribution(m.dot(n_up), alpha) * smith_g1(v.dot(n_up), alpha) * smith_g1(l.dot(n_up), alpha) / (4.0 * v.dot(n_up))
    };
    for (diameter, multiscatter, metallic) in [(0.0f32, true, 0.0f32), (10.0, true, 0.0), (10.0, false, 0.0), (10.0, true, 0.5)] {
        // The disc's mean by a polar grid of equal solid angles.
        let half = (0.5 * diameter).to_radians();
        let (right, up) = (sun.cross(Vec3::X).normalize(), Vec3::X);
        let mut expected = glam::DVec3::ZERO;
        let (rings, spokes) = if diameter > 0.0 { (64, 64) } else { (1, 1) };
        for i in 0..rings {
            let cos_t = 1.0 - (i as f32 + 0.5) / rings as f32 * (1.0 - half.cos());
            let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
            for j in 0..spokes {
                let phi = std::f32::consts::TAU * (j as f32 + 0.5) / spokes as f32;
                let l = (sun * cos_t + (right * phi.cos() + up * phi.sin()) * sin_t).normalize();
                expected += glint(l, multiscatter, metallic).as_dvec3() / (rings * spokes) as f64;
            }
        }
        let eye = v * 40.0;
        let desc = frame_from_lua(&format!(
            r#"local r = require("refrakt")
            local scene = r.scene{{ camera = r.camera{{ position = {{{}, {}, {}}}, target = {{0, 0, 0}}, fov = 0.5, size = {{8, 8}} }},
                                   environment = r.environment{{ color = {{0, 0, 0}} }}, photons = 0, samples = 64, volume = {{ resolution = 16 }} }}
            scene:add(r.node{{ name = "slab", translation = {{0, -0.1, 0}}, shape = r.box{{ size = {{2, 0.2, 2}} }},
                              material = r.glass{{ ior = 1.5, roughness = {roughness}, absorption = {{1000, 1000, 1000}}, multiscatter = {multiscatter},
                                                  metallic = {metallic}, base_color = {{{}, {}, {}}} }} }})
            scene:add(r.node{{ name = "sun", light = r.sun{{ direction = {{{}, {}, {}}}, intensity = 683, angular_diameter = {diameter} }} }})
            return scene"#,
            eye.x, eye.y, eye.z, base.x, base.y, base.z, -sun.x, -sun.y, -sun.z
        ));
        let image = renderer().frame(&desc).unwrap();
        let layer = beauty(&image);
        let got = (0..64).map(|i| rgb(layer, i).as_dvec3()).sum::<glam::DVec3>() / 64.0;
        for k in 0..3 {
            eprintln!(
                "glint of a sun {diameter}° across on frosted glass (multiscatter {multiscatter}, metallic {metallic}), channel {k}: {:.5} W/m²/sr, closed form {:.5} ({:+.2} %)",
                got[k],
                expected[k],
                100.0 * (got[k] / expected[k] - 1.0)
            );
            assert!((got[k] / expected[k] - 1.0).abs() < 0.005, "sun {diameter}°, multiscatter {multiscatter}, metallic {metallic}, channel {k}: {} vs {}", got[k], expected[k]);
        }
    }
}

/// A softbox and a bulb in glass: a disk light (radiance L, 5° across at 20 m) seen in a slab's
/// surface (inside absorbing), as in the glint test above. Polished, with the disk on the mirror
/// direction: every pixel sees L · F(θ_v) (to 0.1 %). Frosted (roughness 0.5), the disk 30° off
/// the mirror direction: L ∫ F D G₁(v) G₁(l) / (4 cos θ_v) / E dω over the disk, dω = cos θ_l dA / d²;
/// and a bulb (a point light of radius R, radiance I / π R²) in its place, over the cone it
/// fills; and a glowing square (side 2R, a two-sided mesh of radiance L, and the same as a
/// glowing thin glass pane) over its area — each light found by both strategies (sampled at
/// the crossing, and by the branches' own directions), each by the balance heuristic: within
/// 1 % at 64 samples. (Before, an area light did not show in glass at all, a bulb in frosted
/// glass only by the branches, and a glowing mesh only by the branches.)
#[test]
fn a_softbox_a_bulb_and_a_glowing_square_are_seen_in_polished_and_frosted_glass() {
    use refrakt::cpu::interface::{fresnel_dielectric, ggx_distribution, smith_g1};
    use std::f32::consts::{PI, TAU};
    let v = Vec3::new(0.0, 1.0, 1.0).normalize();
    let mirror = Vec3::new(0.0, v.y, -v.z);
    let (distance, radius) = (20.0f32, 20.0 * 5f32.to_radians().tan());
    let (roughness, alpha) = (0.5f32, 0.25f32);
    let albedo = refrakt::pipeline::rough_albedo::single_scattering_albedo(v.y, roughness, 1.5, false, 256);
    // f cos θ_l of the frosted surface, kept from masking (÷ E).
    let glint = |l: Vec3| {
        let m = (v + l).normalize();
        (fresnel_dielectric(v.dot(m), 1.5) * ggx_distribution(m.y, alpha) * smith_g1(v.y, alpha) * smith_g1(l.y, alpha) / (4.0 * v.y * albedo)) as f64
    };
    let off_mirror = (glam::Quat::from_rotation_x(-30f32.to_radians()) * mirror).normalize();
    let (right, up) = (off_mirror.cross(Vec3::X).normalize(), Vec3::X);
    let (rings, spokes) = (64, 64);
    // Over the disk by rings of equal area, dω = cos θ_l dA / d².
    let mut over_disk = 0.0f64;
    // Over the bulb's cone (sin α = R/d) by rings of equal solid angle.
    let mut over_cone = 0.0f64;
    // Over the square of side 2R by a grid of equal areas.
    let mut over_square = 0.0f64;
    let square_point = |i: usize, j: usize| {
        let at = |k: usize| radius * (2.0 * (k as f32 + 0.5) / rings as f32 - 1.0);
        off_mirror * distance + right * at(i) + up * at(j)
    };
    let cos_cone = (1.0 - (radius / distance).powi(2)).sqrt();
    for i in 0..rings {
        let r = radius * ((i as f32 + 0.5) / rings as f32).sqrt();
        let cos_t = 1.0 - (i as f32 + 0.5) / rings as f32 * (1.0 - cos_cone);
        let sin_t = (1.0 - cos_t * cos_t).sqrt();
        for j in 0..spokes {
            let around = |phi: f32| right * phi.cos() + up * phi.sin();
            let phi = TAU * (j as f32 + 0.5) / spokes as f32;
            let q = off_mirror * distance + around(phi) * r;
            let d_omega = q.normalize().dot(off_mirror) / q.length_squared() * (PI * radius * radius / (rings * spokes) as f32);
            over_disk += glint(q.normalize()) * d_omega as f64;
            let w = (off_mirror * cos_t + around(phi) * sin_t).normalize();
            over_cone += glint(w) * (TAU * (1.0 - cos_cone) / (rings * spokes) as f32) as f64;
            let q = square_point(i, j);
            let d_omega = q.normalize().dot(off_mirror) / q.length_squared() * (4.0 * radius * radius / (rings * spokes) as f32);
            over_square += glint(q.normalize()) * d_omega as f64;
        }
    }
    // Each light as the node that holds it, at `toward`'s distance.
    let at = |toward: Vec3| {
        let c = toward * distance;
        format!("translation = {{{}, {}, {}}}", c.x, c.y, c.z)
    };
    let disk = |toward: Vec3| format!("{}, light = r.disk{{ size = {{{d}, {d}}}, intensity = 683, target = {{0, 0, 0}} }}", at(toward), d = 2.0 * radius);
    // A bulb of radiance 1: I = π R² W/sr, × 683 cd.
    let bulb = format!("{}, light = r.point{{ radius = {radius}, intensity = {} }}", at(off_mirror), 683.0 * PI * radius * radius);
    // The square as a mesh in world space, glowing with radiance 1.
    let corners = [(0, 0), (rings - 1, 0), (rings - 1, rings - 1), (0, rings - 1)].map(|(i, j)| {
        let q = square_point(i, j) + (square_point(i, j) - off_mirror * distance) / (rings - 1) as f32;
        format!("{{{}, {}, {}}}", q.x, q.y, q.z)
    });
    let square = |material: &str| format!("shape = r.mesh{{ vertices = {{{}}}, triangles = {{{{1, 2, 3}}, {{1, 3, 4}}}} }}, material = {material}", corners.join(", "));
    let cases = [
        ("a softbox in polished glass", 0.0, disk(mirror), fresnel_dielectric(v.y, 1.5) as f64, 0.001),
        ("a softbox in frosted glass", roughness, disk(off_mirror), over_disk, 0.01),
        ("a bulb in frosted glass", roughness, bulb, over_cone, 0.01),
        ("a glowing square in frosted glass", roughness, square("r.pbr{ color = {0, 0, 0}, emission = {1, 1, 1} }"), over_square, 0.01),
        ("a glowing glass pane in frosted glass", roughness, square("r.glass{ ior = 1.5, thin = true, emission = {1, 1, 1} }"), over_square, 0.01),
    ];
    for (what, roughness, node, expected, bound) in cases {
        let eye = v * 40.0;
        let desc = frame_from_lua(&format!(
            r#"local r = require("refrakt")
            local scene = r.scene{{ camera = r.camera{{ position = {{{}, {}, {}}}, target = {{0, 0, 0}}, fov = 0.5, size = {{8, 8}} }},
                                   environment = r.environment{{ color = {{0, 0, 0}} }}, photons = 0, samples = 64, volume = {{ resolution = 16 }} }}
            scene:add(r.node{{ name = "slab", translation = {{0, -0.1, 0}}, shape = r.box{{ size = {{2, 0.2, 2}} }},
                              material = r.glass{{ ior = 1.5, roughness = {roughness}, absorption = {{1000, 1000, 1000}} }} }})
            scene:add(r.node{{ name = "light", {node} }})
            return scene"#,
            eye.x, eye.y, eye.z
        ));
        let image = renderer().frame(&desc).unwrap();
        let layer = beauty(&image);
        let got = (0..64).map(|i| rgb(layer, i).x as f64).sum::<f64>() / 64.0;
        eprintln!("{what}: {got:.6} W/m²/sr, closed form {expected:.6} ({:+.2} %)", 100.0 * (got / expected - 1.0));
        assert!((got / expected - 1.0).abs() < bound, "{what}: {got} vs {expected}");
    }
}

/// How a glass mesh is read when its material does not say: a flat open mesh is a sheet, a
/// curved open one a voxelized solid, each with a warning that names it and says how to choose;
/// `thin` chosen explicitly is obeyed without a word.
#[test]
fn open_glass_meshes_are_guessed_with_a_warning_and_thin_decides() {
    // An open box (five faces): curved, in the sense of not flat.
    let cup = "r.mesh{ vertices = {{-1,-1,-1},{1,-1,-1},{1,1,-1},{-1,1,-1},{-1,-1,1},{1,-1,1},{1,1,1},{-1,1,1}}, \
               triangles = {{1,2,3},{1,3,4},{1,2,6},{1,6,5},{2,3,7},{2,7,6},{3,4,8},{3,8,7},{4,1,5},{4,5,8}} }";
    let desc = |pane_thin: &str, cup_thin: &str| {
        frame_from_lua(&format!(
            r#"local r = require("refrakt")
            local scene = r.scene{{ camera = r.camera{{ size = {{8, 8}} }} }}
            scene:add(r.node{{ name = "pane", shape = {}, material = r.glass{{ ior = 1.5 {pane_thin} }} }})
            scene:add(r.node{{ name = "cup", translation = {{3, 0, 0}}, shape = {cup}, material = r.glass{{ ior = 1.5 {cup_thin} }} }})
            return scene"#,
            pane_mesh(1.0)
        ))
    };
    let guessed = desc("", "");
    let (pane, cup_mesh) = (&guessed.meshes[0], &guessed.meshes[1]);
    assert!(pane.thin && pane.sharp && pane.guessed);
    assert!(!cup_mesh.thin && !cup_mesh.sharp && cup_mesh.guessed, "an open curved mesh stays a voxelized solid");
    let warnings = guessed.warnings();
    assert!(warnings.iter().any(|w| w.contains("\"pane\" is flat: rendered as a thin sheet") && w.contains("thin = true")), "{warnings:?}");
    assert!(warnings.iter().any(|w| w.contains("\"cup\" is open: rendered as the solid") && w.contains("thin = true")), "{warnings:?}");
    assert!(warnings.iter().all(|w| !w.contains("outside the volume box")), "the fitted box holds the glass: {warnings:?}");
    let chosen = desc(", thin = false", ", thin = true");
    assert!(!chosen.meshes[0].sharp && chosen.meshes[1].thin && chosen.meshes[1].sharp);
    assert!(chosen.warnings().iter().all(|w| !w.contains("glass mesh")), "{:?}", chosen.warnings());
}

/// Sharp glass that reaches outside a script's fixed volume box is named in a warning: light
/// meeting it out there is not refracted.
#[test]
fn glass_outside_a_fixed_volume_box_is_warned_about() {
    let desc = frame_from_lua(
        r#"local r = require("refrakt")
        local scene = r.scene{ camera = r.camera{ size = {8, 8} }, volume = { resolution = 16, min = {-0.5, -0.3, -0.5}, max = {0.5, 0.3, 0.5} } }
        scene:add(r.node{ name = "slab", shape = r.box{ size = {3, 0.1, 3} }, material = r.glass{ ior = 1.5 } })
        scene:add(r.node{ name = "pebble", shape = r.sphere{ radius = 0.1 }, material = r.glass{ ior = 1.5 } })
        return scene"#,
    );
    let named: Vec<String> = desc.warnings().into_iter().filter(|w| w.contains("outside the volume box")).collect();
    assert_eq!(named.len(), 1, "{named:?}");
    assert!(named[0].starts_with("glass \"slab\" reaches outside the volume box"), "{}", named[0]);
}

/// `multiscatter` (single-scattering GGX when false) is read from Lua and from a glTF material's
/// `extras.refrakt.multiscatter`, reaches the interface record as its flag, and a non-boolean
/// is refused with where it was.
#[test]
fn multiscatter_is_read_from_lua_and_gltf() {
    use refrakt::gpu::types::interface_kind::SINGLE_SCATTERING;
    let desc = frame_from_lua(
        r#"local r = require("refrakt")
        local scene = r.scene{}
        local g = r.glass{ roughness = 0.5, multiscatter = false }
        assert(g.multiscatter == false and r.glass{}.multiscatter == true)
        scene:add(r.node{ name = "ball", shape = r.sphere{ radius = 0.2 }, material = g })
        scene:add(r.node{ name = "box", translation = {1, 0, 0}, shape = r.box{ size = {0.2, 0.2, 0.2} }, material = r.glass{ roughness = 0.5 } })
        return scene"#,
    );
    let kinds: Vec<u32> = refrakt::pipeline::interfaces::table(&desc, &[]).iter().map(|i| i.kind & SINGLE_SCATTERING).collect();
    assert_eq!(kinds, [SINGLE_SCATTERING, 0, 0], "the ball's record, the box's, the end of the list");
    let error = load_error("local g = require('refrakt').glass{ multiscatter = 1 }", &Default::default());
    assert!(error.contains("multiscatter") && error.contains("scene.lua:"), "{error}");

    let (mut g, frosted, _) = tetrahedron_of(
        serde_json::json!({ "name": "Frosted", "extras": { "refrakt": { "multiscatter": false } },
            "pbrMetallicRoughness": { "metallicFactor": 0.0, "roughnessFactor": 0.5 }, "extensions": { "KHR_materials_transmission": { "transmissionFactor": 1.0 } } }),
        &["KHR_materials_transmission"],
    );
    let dir = tempfile::tempdir().unwrap();
    let desc = frame_of_glb(&g, &dir.path().join("drop.glb")).unwrap();
    assert!(!desc.meshes[0].glass.multiscatter);
    g.json["materials"][frosted]["extras"]["refrakt"]["multiscatter"] = serde_json::json!("no");
    let error = frame_of_glb(&g, &dir.path().join("bad.glb")).err().unwrap();
    assert!(format!("{error:#}").contains("\"Frosted\".extras.refrakt: invalid type: string \"no\", expected a boolean"), "{error:#}");
}

#[test]
fn a_tint_that_cannot_apply_to_an_analytic_shape_is_warned_about() {
    let desc = frame_from_lua(
        r#"local r = require("refrakt")
        local scene = r.scene{ camera = r.camera{ size = {8, 8} } }
        scene:add(r.node{ name = "air", shape = r.sphere{ radius = 0.1 }, material = r.glass{ ior = 1.0, tint = {1, 0.5, 0.5} } })
        scene:add(r.node{ name = "soft", translation = {0.3, 0, 0}, shape = r.sphere{ radius = 0.1, boundary = 2 }, material = r.glass{ tint = {1, 0.5, 0.5} } })
        scene:add(r.node{ name = "clear", translation = {-0.3, 0, 0}, shape = r.box{ size = {0.1, 0.1, 0.1} }, material = r.glass{ tint = {1, 0.5, 0.5} } })
        scene:add(r.node{ name = "film", translation = {0, 0.3, 0}, shape = r.sphere{ radius = 0.1 }, material = r.glass{ ior = 1.0, thin = true, tint = {1, 0.5, 0.5} } })
        scene:add(r.node{ name = "gel", translation = {0, -0.3, 0}, shape = r.mesh{ vertices = {{0, 0, 0}, {0.1, 0, 0}, {0, 0.1, 0}}, triangles = {{1, 2, 3}} },
                          material = r.glass{ ior = 1.0, tint = {1, 0.5, 0.5} } })
        scene:add(r.node{ name = "lump", translation = {0.3, 0.3, 0}, shape = r.icosphere{ radius = 0.1 }, material = r.glass{ ior = 1.0, tint = {1, 0.5, 0.5} } })
        scene:add(r.node{ name = "scrap", translation = {0, -0.6, 0}, shape = r.mesh{ vertices = {{0, 0, 0}, {0.1, 0, 0}, {0, 0.1, 0}}, triangles = {{1, 2, 3}} },
                          material = r.glass{ ior = 1.0, thin = false, tint = {1, 0.5, 0.5} } })
        return scene"#,
    );
    let said: Vec<String> = desc.warnings().into_iter().filter(|w| w.contains("its tint is not applied")).collect();
    assert_eq!(said.len(), 1, "{said:?}");
    assert!(said[0].starts_with("glass \"soft\" is a smooth index field"), "{}", said[0]);
    // Tinted glass of index 1 is sharp and keeps its tint, as glTF tints at each surface: a sheet
    // or shell (a gel, a film), a sphere, a closed mesh. Only a solid without an inside (an open
    // mesh that is not a sheet) is air, and said to be.
    let field = |name: &str| desc.fields.iter().find(|f| f.name == name).unwrap();
    assert!(field("film").sharp && field("film").thin, "a tinted shell of index 1 is a sharp sheet");
    assert!(field("air").sharp && !field("air").thin, "a tinted ball of index 1 is a sharp solid");
    let mesh = |name: &str| desc.meshes.iter().find(|m| m.name == name).unwrap();
    assert!(mesh("gel").sharp && mesh("gel").thin, "a flat tinted mesh of index 1 is a sharp sheet");
    assert!(mesh("lump").sharp && !mesh("lump").thin, "a closed tinted mesh of index 1 is a sharp solid");
    assert!(!mesh("scrap").sharp);
    let air: Vec<String> = desc.warnings().into_iter().filter(|w| w.contains("renders it as air")).collect();
    assert!(air.len() == 1 && air[0].contains("\"scrap\"") && air[0].contains("thin = true"), "{air:?}");
}

/// A lamp in a thin glass shade: a point light (1 W/sr) at the centre of a thin, tinted glass
/// sphere (r = 0.25 m) 1 m over a white floor, the floor seen from under the shade. Each shadow
/// ray leaves the shade square to it, so the floor's direct light is the unshaded irradiance
/// h/d³ × the thin slab's transmittance at normal incidence (1 − 2R/(1 + R), R = 0.04) × the
/// tint (±2 %, per channel). What the shade reflects inside bounces across it and leaves
/// through the far side, tinted on its way out: photons, the caustic layer. Tinting only what
/// passes, the shade lets out t of the light in all (T·t/(1 − R_thin) = t), so direct +
/// caustic = t × the unshaded irradiance (±3 %). And the bulb shows through the shade, and in
/// its inner reflections.
#[test]
fn a_lamp_in_a_thin_tinted_shade_lights_the_floor_through_it() {
    let tint = Vec3::new(0.9, 0.6, 0.3);
    // The lamp in its shade, 1 m up, in a scene of these settings.
    let lamp_in = |settings: &str| {
        frame_from_lua(&format!(
            r#"local r = require("refrakt")
            local scene = r.scene{{ {settings}, environment = r.environment{{ color = {{0, 0, 0}} }} }}
            scene:add(r.node{{ name = "shade", translation = {{0, 1, 0}}, shape = r.sphere{{ radius = 0.25 }},
                              material = r.glass{{ ior = 1.5, thin = true, tint = {{{}, {}, {}}} }} }})
            scene:add(r.node{{ name = "lamp", translation = {{0, 1, 0}}, light = r.point{{ intensity = 683 }} }})
            scene:add(r.node{{ name = "floor", shape = r.plane{{ size = {{6, 6}} }}, material = r.diffuse{{ color = {{1, 1, 1}} }} }})
            return scene"#,
            tint.x, tint.y, tint.z
        ))
    };
    let desc = lamp_in(
        "volume = { resolution = 32 }, photons = 400000, samples = 4, bounces = 0, \
         camera = r.camera{ position = {0, 0.5, 0}, target = {0, 0, 0}, up = {0, 0, -1}, orthographic = 1, size = {8, 8} }",
    );
    let image = renderer().frame(&desc).unwrap();
    let layer_mean = |name: &str| {
        let l = image.layer(name).unwrap();
        let n = l.data.len() / l.channels.len();
        (0..n).map(|i| rgb(l, i)).sum::<Vec3>() / n as f32
    };
    // The unshaded irradiance h/d³ over the 1 m square the camera sees, 64 points a pixel.
    let unshaded = (0..64 * 64)
        .map(|k| {
            let (x, z) = (((k % 64) as f32 + 0.5) / 64.0 - 0.5, ((k / 64) as f32 + 0.5) / 64.0 - 0.5);
            1.0 / (1.0 + x * x + z * z).powf(1.5)
        })
        .sum::<f32>()
        / (64.0 * 64.0);
    // A white floor shows E/π.
    let (direct, caustic) = (layer_mean("direct") * std::f32::consts::PI, layer_mean("caustic") * std::f32::consts::PI);
    let passed = 1.0 - thin_slab_reflectance(0.0);
    for k in 0..3 {
        let (expected_direct, expected_all) = (unshaded * passed * tint[k], unshaded * tint[k]);
        eprintln!(
            "lamp in a thin shade, channel {k}: direct {:.4} vs {expected_direct:.4} W/m² ({:+.2} %); direct + caustic {:.4} vs {expected_all:.4} ({:+.2} %)",
            direct[k],
            100.0 * (direct[k] / expected_direct - 1.0),
            direct[k] + caustic[k],
            100.0 * ((direct[k] + caustic[k]) / expected_all - 1.0)
        );
        assert!((direct[k] / expected_direct - 1.0).abs() < 0.02, "channel {k}: direct {} vs {expected_direct}", direct[k]);
        assert!(((direct[k] + caustic[k]) / expected_all - 1.0).abs() < 0.03, "channel {k}: all {} vs {expected_all}", direct[k] + caustic[k]);
    }
    // The bulb (r = 5 cm, radiance I / π r²) seen through the shade's near side, square to it:
    // L · (1 − R_thin) · tint, and again in the far side's reflection, and in the near side's
    // reflection of that (a light is no surface: the view goes on past it, as Cycles'), R_thin
    // and R_thin² of it; the next, R_thin³ (5e-4), falls below the branches' least weight. In
    // every pixel of a narrow view, to 0.1 %. It was black: the lights a view ray passes were
    // looked for only where it met a receiver or left the scene.
    let desc = lamp_in("volume = { resolution = 16 }, photons = 0, samples = 1, camera = r.camera{ position = {0, 1, 5}, target = {0, 1, 0}, fov = 0.5, size = {8, 8} }");
    let image = renderer().frame(&desc).unwrap();
    let r_thin = thin_slab_reflectance(0.0);
    let bulb = 1.0 / (std::f32::consts::PI * 0.05 * 0.05) * passed * tint * (1.0 + r_thin + r_thin * r_thin);
    for i in 0..64 {
        let got = rgb(beauty(&image), i);
        assert!((got / bulb - Vec3::ONE).abs().max_element() < 1e-3, "pixel {i}: {got} vs {bulb}");
    }
}

/// Glowing glass (glTF's emissive on a transmissive material, Lua `glass.emission` ×
/// `emission_strength`): a thin pane
/// and a solid ball of emission E in front of a black sky show E exactly where the camera sees
/// them square on — the pane once (either side of a sheet), the ball at its front only (its
/// back, met from inside, does not add) — and the glTF importer reads emissiveFactor ×
/// emissive strength and the emissive texture. (Before, the glow was not rendered at all.)
#[test]
fn glowing_glass_shows_its_emission_from_its_front() {
    let glow = Vec3::new(0.5, 0.25, 0.125);
    for (what, shape, thin) in [("a thin pane", pane_mesh(1.0), "true"), ("a solid ball", "r.sphere{ radius = 0.5 }".to_string(), "false")] {
        let desc = frame_from_lua(&format!(
            r#"local r = require("refrakt")
            local scene = r.scene{{ volume = {{ resolution = 16 }}, photons = 0, samples = 1, environment = r.environment{{ color = {{0, 0, 0}} }},
                                    camera = r.camera{{ position = {{0, 0, 5}}, target = {{0, 0, 0}}, fov = 1, size = {{8, 8}} }} }}
            scene:add(r.node{{ name = "glow", shape = {shape}, material = r.glass{{ ior = 1.5, thin = {thin}, emission = {{{}, {}, {}}}, emission_strength = 0.5 }} }})
            return scene"#,
            2.0 * glow.x, 2.0 * glow.y, 2.0 * glow.z
        ));
        let image = renderer().frame(&desc).unwrap();
        for i in 0..64 {
            let got = rgb(beauty(&image), i);
            assert!((got / glow - Vec3::ONE).abs().max_element() < 1e-4, "{what}, pixel {i}: {got} vs {glow}");
        }
    }
    let (g, _, _) = tetrahedron_of(
        serde_json::json!({ "name": "Shade", "emissiveFactor": [1.0, 0.5, 0.25], "pbrMetallicRoughness": { "metallicFactor": 0.0 },
            "extensions": { "KHR_materials_transmission": { "transmissionFactor": 1.0 }, "KHR_materials_emissive_strength": { "emissiveStrength": 4.0 } } }),
        &["KHR_materials_transmission", "KHR_materials_emissive_strength"],
    );
    let dir = tempfile::tempdir().unwrap();
    let desc = frame_of_glb(&g, &dir.path().join("shade.glb")).unwrap();
    let glass = &desc.meshes[0].glass;
    assert_eq!((glass.emission, glass.emission_strength, glass.emitted()), (Vec3::new(1.0, 0.5, 0.25), 4.0, Vec3::new(4.0, 2.0, 1.0)));
}

/// A real file: Khronos' TransmissionRoughnessTest (tests/data/khronos, CC BY 4.0, Ed Mackey /
/// AGI 2021), a board of 5 mm glass tiles in front of a patterned backdrop, one row per index
/// (2.42, 1.76, 1.5, 1.33, 1.0) and one column per roughness, smooth to rough, set by each row's
/// `metallicRoughnessTexture`. Through a tile, the backdrop's pattern is what stays sharp: its
/// correlation with the backdrop seen without the glass falls column by column as the texture's
/// roughness grows, and stays high along the index-1.0 row, where microfacets bend nothing (and
/// the row's tint still colours what passes). With
/// the textures dropped, every tile takes the factor 1 and all frost alike (as they did before
/// refrakt read roughness textures on glass).
#[test]
fn khronos_transmission_roughness_test_frosts_column_by_column() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/khronos/TransmissionRoughnessTest.glb");
    let scene = refrakt::render::GltfScene::load(&path, &[], &Default::default()).unwrap();
    // The board, from the file's default view at 512×288: 9 × 5 tiles of ~13 × 12 pixels.
    let opts = refrakt::scene::eval::EvalOptions {
        size: Some((512, 288)),
        region: Some(refrakt::scene::eval::Region { origin: (212, 100), size: (136, 72) }),
        photons: Some(20_000),
        samples: Some(16),
        resolution: Some(64),
        ..Default::default()
    };
    let tiles = refrakt::scene::eval::evaluate(&scene.scene, 0.0, &opts).unwrap();
    let mut untextured = tiles.clone();
    untextured.meshes.iter_mut().for_each(|m| m.glass.roughness_texture = None);
    let mut backdrop = tiles.clone();
    backdrop.meshes.clear();
    let mut r = renderer();
    let mut colours = |desc| {
        let image = r.frame(desc).unwrap();
        let layer = beauty(&image);
        (0..layer.data.len() / layer.channels.len()).map(|i| rgb(layer, i)).collect::<Vec<Vec3>>()
    };
    let luminance = |c: &[Vec3]| c.iter().map(|c| c.dot(Vec3::new(0.2126, 0.7152, 0.0722))).collect::<Vec<f32>>();
    let backdrop_colours = colours(&backdrop);
    let behind = luminance(&backdrop_colours);
    // Each tile's correlation, row by row: tiles of 13.2 × 12.5 pixels from (9, 9) in the region
    // (the file is fixed, and so is its default view), two pixels in from their edges.
    let correlations = |through: &[f32]| -> Vec<Vec<f32>> {
        let tile = |row: usize, col: usize| {
            let (x, y) = (9.0 + 13.2 * col as f32, 9.0 + 12.5 * row as f32);
            let (xs, ys) = (x as usize + 2..(x + 13.2) as usize - 2, y as usize + 2..(y + 12.5) as usize - 2);
            let (a, b): (Vec<f32>, Vec<f32>) = ys.flat_map(|y| xs.clone().map(move |x| y * 136 + x)).map(|i| (through[i], behind[i])).unzip();
            correlation(&a, &b)
        };
        (0..5).map(|row| (0..9).map(|col| tile(row, col)).collect()).collect()
    };
    let tile_colours = colours(&tiles);
    let rows = correlations(&luminance(&tile_colours));
    for (row, ior) in rows.iter().zip(["2.42", "1.76", "1.5", "1.33", "1.0"]) {
        eprintln!("index {ior:>4}: {}", row.iter().map(|c| format!("{c:5.2}")).collect::<Vec<_>>().join(" "));
    }
    for row in &rows[..4] {
        assert!(mean(&row[..2]) > 0.65, "the smoothest tiles show the backdrop: {row:?}");
        assert!(mean(&row[4..]) < 0.15 && row[4..].iter().all(|c| c.abs() < 0.35), "the rougher half frosts it away: {row:?}");
    }
    // (Above 0.7, not 1: the backdrop behind a solid tile is lit by photons through it, which
    // shadow rays do not carry, at 20 000 photons.)
    assert!(rows[4].iter().all(|&c| c > 0.7), "index 1.0 bends no ray, whatever its roughness: {:?}", rows[4]);
    // Glass of index 1 still tints at each surface (KHR_materials_transmission): through the
    // row's tiles (base colour 0.5, 0.7, 0.9; two crossings, no Fresnel at index 1) the backdrop's
    // blue-to-red balance grows by at least (0.9 / 0.5)² = 3.24 (more where the backdrop is lit
    // through the tiles too; as air it stayed 1).
    let row_sum = |c: &[Vec3]| (0..9).flat_map(|col| {
        let (x, y) = ((9.0 + 13.2 * col as f32) as usize, (9.0 + 12.5 * 4.0) as usize);
        (y + 2..y + 10).flat_map(move |y| (x + 2..x + 11).map(move |x| y * 136 + x))
    }).map(|i| c[i]).sum::<Vec3>();
    let (through, bare) = (row_sum(&tile_colours), row_sum(&backdrop_colours));
    let balance = (through.z / through.x) / (bare.z / bare.x);
    eprintln!("index 1.0: the backdrop's blue-to-red balance through the tiles × {balance:.3} (tint² 3.24)");
    assert!(balance > 0.9 * 3.24, "{balance}");
    assert!(tiles.warnings().iter().all(|w| !w.contains("as air")), "{:?}", tiles.warnings());
    // Without its textures every tile takes the roughness factor, 1: all alike frosted.
    let flat = correlations(&luminance(&colours(&untextured)));
    eprintln!("without the textures, the smoothest columns: {:?}", flat[..4].iter().map(|row| mean(&row[..2])).collect::<Vec<_>>());
    assert!(flat[..4].iter().all(|row| mean(&row[..2]) < 0.3), "{flat:?}");
}
