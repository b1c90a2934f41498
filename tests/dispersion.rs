//! Dispersion against closed forms: the index n(λ) of KHR_materials_dispersion, a ball lens's
//! focus per wavelength, a prism's minimum deviation per wavelength and where narrow bands of
//! its spectrum land on the floor, and white light staying white (and keeping its energy)
//! through clear dispersive glass.

mod common;

use common::*;
use glam::{DVec2, Mat3, Vec3};
use refrakt::cpu::spectrum::{self, LAMBDA_C, LAMBDA_D, LAMBDA_F};
use refrakt::gpu::types::ProbeRay;
use refrakt::pipeline::probe::ProbeOptions;

/// KHR_materials_dispersion's formula, written out here in f64.
fn khr_index(n_d: f64, abbe: f64, lambda: f64) -> f64 {
    (n_d + (n_d - 1.0) / abbe * (523655.0 / (lambda * lambda) - 1.5168)).max(1.0)
}

#[test]
fn the_cpu_index_is_the_khr_formula_at_the_fraunhofer_lines() {
    for (n_d, abbe) in [(1.5f32, 59.0f32), (1.5, 20.0), (2.42, 55.0), (1.33, 10.0)] {
        let dispersion = spectrum::dispersion_from_abbe(abbe);
        for lambda in [400.0f32, 486.1, 587.6, 656.3, 700.0] {
            let n = spectrum::ior_at(n_d, dispersion, lambda);
            let want = khr_index(n_d as f64, abbe as f64, lambda as f64);
            assert!((n as f64 - want).abs() < 2e-6, "n_d {n_d}, V_d {abbe}, {lambda} nm: {n} vs {want}");
        }
        // The formula's Abbe number is the one asked for, and n(587.6 nm) is n_d (to the
        // rounding of the spec's constants).
        let at = |l| spectrum::ior_at(n_d, dispersion, l) as f64;
        let v = (at(LAMBDA_D) - 1.0) / (at(LAMBDA_F) - at(LAMBDA_C));
        assert!((v / abbe as f64 - 1.0).abs() < 2e-3, "V_d {v} for {abbe}");
        assert!((at(LAMBDA_D) - n_d as f64).abs() < 1e-4 * (n_d as f64 - 1.0) * 20.0 / abbe as f64);
    }
    // No dispersion: the index itself, at every wavelength; and never below 1.
    assert_eq!(spectrum::ior_at(1.5, 0.0, 400.0), 1.5);
    assert_eq!(spectrum::ior_at(1.05, 30.0, 830.0), 1.0);
}

/// A triangular prism (apex angle 60°, side `side`) along z, its cross-section in the x-y plane
/// turned by `turn` radians, as Lua vertices and triangles.
fn prism_corners(side: f64, turn: f64) -> [DVec2; 3] {
    let h = side / 3f64.sqrt();
    let apex_up = [DVec2::new(0.0, h), DVec2::new(-side / 2.0, -h / 2.0), DVec2::new(side / 2.0, -h / 2.0)];
    apex_up.map(|p| DVec2::from_angle(turn).rotate(p))
}

fn prism_mesh(corners: &[DVec2; 3], length: f64) -> String {
    let v: Vec<String> = [-length / 2.0, length / 2.0]
        .iter()
        .flat_map(|&z| corners.iter().map(move |c| format!("{{{}, {}, {}}}", c.x, c.y, z)))
        .collect();
    // Both caps and the three sides (1-based), wound outward.
    let tris = "{1,3,2},{4,5,6},{1,2,5},{1,5,4},{2,3,6},{2,6,5},{3,1,4},{3,4,6}";
    format!("r.mesh{{ vertices = {{{}}}, triangles = {{{tris}}} }}", v.join(", "))
}

/// The minimum deviation of a prism of apex angle A and index n: 2·asin(n·sin(A/2)) − A.
fn minimum_deviation(n: f64, apex: f64) -> f64 {
    2.0 * (n * (apex / 2.0).sin()).asin() - apex
}

const PRISM_SIDE: f64 = 0.3;
const PRISM_TURN: f64 = -std::f64::consts::FRAC_PI_2;
const PRISM_DISPERSION: f32 = 2.0; // V_d = 10: a strongly dispersive flint, so bands separate at 32³.

/// The direction (in the x-y plane) that crosses the prism at minimum deviation for n.
fn minimum_deviation_direction(n: f64) -> DVec2 {
    DVec2::from_angle(PRISM_TURN + minimum_deviation(n, std::f64::consts::FRAC_PI_3) / 2.0)
}

#[test]
fn a_prism_deviates_each_wavelength_by_its_closed_form_minimum() {
    let corners = prism_corners(PRISM_SIDE, PRISM_TURN);
    let desc = frame_from_lua(&format!(
        r#"local r = require("refrakt")
        local scene = r.scene{{ volume = {{ resolution = 48 }} }}
        scene:add(r.node{{ name = "prism", shape = {}, material = r.glass{{ ior = 1.5, dispersion = {PRISM_DISPERSION} }} }})
        return scene"#,
        prism_mesh(&corners, 0.4)
    ));
    let mut r = renderer();
    r.build_volume(&desc).unwrap();
    let entrance_mid = (corners[0] + corners[1]) / 2.0;
    let mut last = f64::INFINITY;
    for lambda in [450.0f32, 550.0, 650.0] {
        let n = spectrum::ior_at(1.5, PRISM_DISPERSION, lambda) as f64;
        // Sweep the angle of incidence around the minimum; deviation = angle between in and out.
        let centre = minimum_deviation_direction(n);
        let angles: Vec<f64> = (-40..=40).map(|k| k as f64 * 0.25f64.to_radians()).collect();
        let rays: Vec<ProbeRay> = angles
            .iter()
            .map(|&a| {
                let d = DVec2::from_angle(a).rotate(centre);
                let o = entrance_mid - d * 0.5;
                // (At z = 0.12 the rays cross each side away from the diagonal splitting it into
                // two triangles, where a ray could slip between them.)
                ProbeRay { origin: [o.x as f32, o.y as f32, 0.12], dir: [d.x as f32, d.y as f32, 0.0], wavelength: lambda, ..Default::default() }
            })
            .collect();
        let out = r.probe(&rays, &ProbeOptions::endpoints(desc.volume.step, 100_000)).unwrap();
        let deviation = |i: usize| {
            let v = Vec3::from(out[2 * i + 1].v).normalize();
            let d = Vec3::from(rays[i].dir);
            d.dot(v).clamp(-1.0, 1.0).acos() as f64
        };
        let measured = (0..rays.len()).map(deviation).fold(f64::INFINITY, f64::min);
        let expected = minimum_deviation(n, std::f64::consts::FRAC_PI_3);
        eprintln!("{lambda} nm: n = {n:.5}, minimum deviation {:.4}° (closed form {:.4}°)", measured.to_degrees(), expected.to_degrees());
        // The sweep's 0.25° spacing leaves the minimum within 0.01° (it is flat there).
        assert!((measured - expected).abs().to_degrees() < 0.02, "{lambda} nm: {measured} vs {expected}");
        assert!(expected < last, "red must be deviated least");
        last = expected;
    }
}

/// Expected landing of a sun's parallel beam of direction d (x-y plane) through the prism on
/// the floor y = floor_y: every path split by Fresnel at each event (reflected and refracted,
/// weights R and 1 − R, the photons' choice in expectation), tracing those that met the glass.
fn beam_on_floor(corners: &[DVec2; 3], n: f64, d: DVec2, floor_y: f64) -> Vec<(f64, f64)> {
    let across = DVec2::new(-d.y, d.x);
    let mut out = Vec::new();
    let rays = 4000;
    for k in 0..rays {
        let s = (k as f64 + 0.5) / rays as f64 - 0.5;
        let o = across * (s * 0.5) - d * 1.0;
        trace_2d(corners, n, o, d, false, 1.0 / rays as f64, 0, floor_y, &mut out);
    }
    out
}

#[allow(clippy::too_many_arguments)]
fn trace_2d(c: &[DVec2; 3], n: f64, o: DVec2, d: DVec2, inside: bool, w: f64, events: u32, floor_y: f64, out: &mut Vec<(f64, f64)>) {
    // The nearest edge crossing.
    let mut best: Option<(f64, DVec2)> = None;
    for i in 0..3 {
        let (a, b) = (c[i], c[(i + 1) % 3]);
        let e = b - a;
        let den = d.perp_dot(e);
        if den.abs() < 1e-12 {
            continue;
        }
        let t = (a - o).perp_dot(e) / den;
        let u = (a - o).perp_dot(d) / den;
        if t > 1e-9 && (0.0..=1.0).contains(&u) && best.is_none_or(|(bt, _)| t < bt) {
            let centroid = (c[0] + c[1] + c[2]) / 3.0;
            let mut normal = DVec2::new(e.y, -e.x).normalize();
            if normal.dot(a - centroid) < 0.0 {
                normal = -normal;
            }
            best = Some((t, normal));
        }
    }
    let Some((t, outward)) = best else {
        if events > 0 && d.y < 0.0 {
            out.push((o.x + d.x * (floor_y - o.y) / d.y, w));
        }
        return;
    };
    if events >= 12 || w < 1e-7 {
        return;
    }
    let p = o + d * t;
    let facing = if d.dot(outward) < 0.0 { outward } else { -outward };
    let eta = if inside { 1.0 / n } else { n };
    let cos_i = -d.dot(facing);
    let r = refrakt::cpu::interface::fresnel_dielectric(cos_i as f32, eta as f32) as f64;
    let reflected = d + facing * (2.0 * cos_i);
    trace_2d(c, n, p + facing * 1e-9, reflected, inside, w * r, events + 1, floor_y, out);
    if r < 1.0 {
        let cos_t = (1.0 - (1.0 - cos_i * cos_i) / (eta * eta)).sqrt();
        let transmitted = (d / eta + facing * (cos_i / eta - cos_t)).normalize();
        trace_2d(c, n, p - facing * 1e-9, transmitted, !inside, w * (1.0 - r), events + 1, floor_y, out);
    }
}

fn weighted_mean(points: impl Iterator<Item = (f64, f64)>) -> f64 {
    let (sum, weight) = points.fold((0.0, 0.0), |(s, w), (x, pw)| (s + x * pw, w + pw));
    sum / weight
}

/// Luminance Y of a linear sRGB value of refrakt's spectral transport (its white point).
fn luminance(rgb: Vec3) -> f32 {
    let to_xyz = Mat3::from_cols_array_2d(&spectrum::XYZ_TO_RGB).transpose().inverse();
    (to_xyz * rgb).y
}

#[test]
fn narrow_bands_of_a_prisms_spectrum_land_where_snell_and_fresnel_put_them() {
    let corners = prism_corners(PRISM_SIDE, PRISM_TURN);
    let n_d = spectrum::ior_at(1.5, PRISM_DISPERSION, LAMBDA_D) as f64;
    let sun = minimum_deviation_direction(n_d);
    let floor_y = -0.5;
    let desc = frame_from_lua(&format!(
        r#"local r = require("refrakt")
        local scene = r.scene{{ volume = {{ resolution = 32 }}, photons = 120000,
                               camera = r.camera{{ size = {{8, 8}} }}, environment = r.environment{{ color = {{0, 0, 0}} }} }}
        scene:add(r.node{{ name = "floor", translation = {{0, {floor_y}, 0}}, shape = r.plane{{ size = {{2, 2}} }},
                          material = r.diffuse{{ color = {{1, 1, 1}} }} }})
        scene:add(r.node{{ name = "prism", shape = {}, material = r.glass{{ ior = 1.5, dispersion = {PRISM_DISPERSION} }} }})
        scene:add(r.node{{ name = "sun", light = r.sun{{ direction = {{{}, {}, 0}}, intensity = 1000, angular_diameter = 0 }} }})
        return scene"#,
        prism_mesh(&corners, 0.6),
        sun.x,
        sun.y
    ));
    let voxel = desc.volume.voxel_size as f64;
    // The window: around where the d line's main beam lands (Snell through two faces), which is
    // deviated back across the undeviated line. (The light entering through the base, which
    // faces the sun too, lands far on the other side.)
    let undeviated = |x: f64| x - (sun.x / sun.y) * floor_y;
    let main_beam = beam_on_floor(&corners, n_d, sun, floor_y).into_iter().filter(|&(x, w)| w > 0.5 / 4000.0 && undeviated(x) < 0.0);
    let centre = weighted_mean(main_beam);
    let window = |x: f64| (x - centre).abs() < 0.15;
    let mut r = renderer();
    let mut measured = Vec::new();
    for (lo, hi) in [(440.0f32, 460.0f32), (540.0, 560.0), (640.0, 660.0)] {
        r.settings.wavelength_band = Some((lo, hi));
        r.frame(&desc).unwrap();
        let (c, e) = chart(&r, 0, 2);
        let mut texels = Vec::new();
        for j in 0..c.height {
            for i in 0..c.width {
                // A floor chart's axes are (z, x): the two after y, cyclically.
                let p = texel_centre(&c, i, j);
                let (x, z) = (p.y as f64, p.x);
                let t = e[(i + c.width * j) as usize];
                if window(x) && z.abs() < 0.15 {
                    texels.push((x, luminance(Vec3::new(t[0], t[1], t[2])).max(0.0) as f64));
                }
            }
        }
        let got = weighted_mean(texels.into_iter());
        // The band's expectation: its wavelengths spread evenly, each traced exactly.
        let expected = weighted_mean((0..5).flat_map(|k| {
            let lambda = lo + (hi - lo) * (k as f32 + 0.5) / 5.0;
            let n = spectrum::ior_at(1.5, PRISM_DISPERSION, lambda) as f64;
            let weight = spectrum::cmf(lambda).y as f64;
            beam_on_floor(&corners, n, sun, floor_y).into_iter().filter(|&(x, _)| window(x)).map(move |(x, w)| (x, w * weight))
        }));
        eprintln!("band {lo}–{hi} nm: centroid x = {got:.4} m, Snell + Fresnel {expected:.4} m ({:.2} voxel apart)", (got - expected).abs() / voxel);
        assert!((got - expected).abs() < 0.25 * voxel, "band {lo}–{hi} nm lands at {got}, expected {expected} (voxel {voxel})");
        measured.push((got, expected));
    }
    // The spectrum spreads in order (blue, green, red), resolved apart, the way Snell says:
    // red, deviated least, lands nearest where undeviated light would (the sun's direction).
    let (blue, green, red) = (measured[0], measured[1], measured[2]);
    assert!((red.0 - blue.0).abs() > voxel, "the spectrum is resolved: {measured:?}");
    assert!((red.0 - green.0).signum() == (green.0 - blue.0).signum() && (red.0 - blue.0).signum() == (red.1 - blue.1).signum(), "{measured:?}");
    assert!(undeviated(red.0).abs() < undeviated(blue.0).abs(), "red is deviated least: {measured:?}");
}

/// A white sun over a clear glass ball (n_d 1.5, V_d 20 / `dispersion`) and a white floor.
fn white_ball(dispersion: f32, photons: u32) -> String {
    format!(
        r#"local r = require("refrakt")
        local scene = r.scene{{ volume = {{ resolution = 32 }}, photons = {photons},
                               camera = r.camera{{ size = {{8, 8}} }}, environment = r.environment{{ color = {{0, 0, 0}} }} }}
        scene:add(r.node{{ name = "floor", translation = {{0, -0.6, 0}}, shape = r.plane{{ size = {{3, 3}} }},
                          material = r.diffuse{{ color = {{1, 1, 1}} }} }})
        scene:add(r.node{{ name = "ball", shape = r.sphere{{ radius = 0.3 }}, material = r.glass{{ ior = 1.5, dispersion = {dispersion} }} }})
        scene:add(r.node{{ name = "sun", light = r.sun{{ direction = {{0.2, -1, 0.1}}, intensity = 1000 }} }})
        return scene"#
    )
}

/// The floor's caustic map under `white_ball` (irradiance per texel, rgb) and the photon stats.
fn white_ball_caustic(dispersion: f32, photons: u32) -> (refrakt::gpu::types::Chart, Vec<[f32; 4]>, refrakt::pipeline::march::PhotonStats) {
    let desc = frame_from_lua(&white_ball(dispersion, photons));
    let mut r = renderer();
    r.frame(&desc).unwrap();
    let (c, e) = chart(&r, 0, 2);
    (c, e, r.photon_stats().unwrap())
}

/// White light through clear dispersive glass onto a white floor: summed over the whole lit
/// patch, the caustic is neutral and carries the energy the same glass without dispersion does.
#[test]
fn white_light_through_dispersive_glass_stays_white_and_keeps_its_energy() {
    let total = |dispersion: f32| {
        let (c, e, stats) = white_ball_caustic(dispersion, 200_000);
        let area = (c.texel * c.texel) as f64;
        let sum = e.iter().fold([0f64; 3], |s, t| [s[0] + t[0] as f64 * area, s[1] + t[1] as f64 * area, s[2] + t[2] as f64 * area]);
        (sum, stats)
    };
    let (clear, _) = total(0.0);
    let (dispersive, stats) = total(1.0);
    eprintln!("caustic flux on the floor: without dispersion {clear:?} W, with (V_d = 20) {dispersive:?} W; photon stats {stats:?}");
    let mean = (dispersive[0] + dispersive[1] + dispersive[2]) / 3.0;
    for k in 0..3 {
        assert!((dispersive[k] / mean - 1.0).abs() < 0.01, "channel {k} of {dispersive:?} is not neutral within 1 %");
        assert!((dispersive[k] / clear[k] - 1.0).abs() < 0.01, "channel {k}: {} W vs {} W without dispersion", dispersive[k], clear[k]);
    }
}

/// A spectral photon carries one wavelength, so a dispersive caustic is noisier than a clear one
/// at equal photons: colour noise adds to the photons' own. Drawing each photon's wavelength
/// together with its place in its raster cell (photons.wgsl's `cell_sample`) keeps the photons
/// that reach one texel spread over the spectrum. Caustic RMSE (all three channels, against 16×
/// the photons) of the dispersive ball over that of the clear one, at 80k photons (~25 a cell):
/// 2.23 with the wavelength drawn apart from the place, 1.82 with both drawn together and
/// wavelengths drawn from pbrt's visible-wavelength density, 1.47 with both together and the
/// binned density that makes white light's rgb least noisy (`cpu::spectrum::wavelength_cdf`;
/// each figure measured with its shader). (At 20k photons, ~6 a cell, too few photons share a
/// cell for its run of R₃ to stratify: the first two were both 2.1.)
#[test]
fn spectral_photons_keep_the_caustics_colour_noise_low() {
    let n = 80_000;
    let noise = |dispersion: f32| {
        let (_, reference, _) = white_ball_caustic(dispersion, 16 * n);
        let (_, e, _) = white_ball_caustic(dispersion, n);
        let squares: f64 = e.iter().zip(&reference).map(|(a, b)| (0..3).map(|k| ((a[k] - b[k]) as f64).powi(2)).sum::<f64>()).sum();
        (squares / (3 * e.len()) as f64).sqrt()
    };
    let (clear, dispersive) = (noise(0.0), noise(1.0));
    eprintln!("caustic RMSE at {n} photons: clear {clear:.3} W/m², dispersive {dispersive:.3} W/m² ({:.2}×)", dispersive / clear);
    assert!(dispersive / clear < 1.65, "the dispersive caustic's noise is {:.2}× the clear one's", dispersive / clear);
}

#[test]
fn a_ball_lens_focuses_each_wavelength_at_its_closed_form_distance() {
    let (n_d, radius, dispersion) = (1.5f32, 0.4f32, 1.0f32);
    let desc = frame_from_lua(&format!(
        r#"local r = require("refrakt")
        local scene = r.scene{{ volume = {{ resolution = 64, margin = 0.05 }} }}
        scene:add(r.node{{ name = "ball", shape = r.sphere{{ radius = {radius} }}, material = r.glass{{ ior = {n_d}, dispersion = {dispersion} }} }})
        return scene"#
    ));
    let mut r = renderer();
    r.build_volume(&desc).unwrap();
    let voxel = desc.volume.voxel_size;
    let mut foci = Vec::new();
    for lambda in [450.0f32, 550.0, 650.0] {
        // Paraxial rays along +z at heights h; each crosses the axis at f(h) = f₀ + c·h²: fit f₀.
        let heights: Vec<f32> = (1..=8).map(|k| radius * 0.03 * k as f32).collect();
        let rays: Vec<ProbeRay> =
            heights.iter().map(|&h| ProbeRay { origin: [h, 0.0, -1.0], dir: [0.0, 0.0, 1.0], wavelength: lambda, ..Default::default() }).collect();
        let out = r.probe(&rays, &ProbeOptions::endpoints(desc.volume.step, 100_000)).unwrap();
        let (mut h2, mut focus) = (Vec::new(), Vec::new());
        for (i, h) in heights.iter().enumerate() {
            let (x, v) = (Vec3::from(out[2 * i + 1].x), Vec3::from(out[2 * i + 1].v).normalize());
            h2.push((h * h) as f64);
            focus.push((x.z - x.x / v.x * v.z) as f64);
        }
        let n = h2.len() as f64;
        let (mx, my) = (h2.iter().sum::<f64>() / n, focus.iter().sum::<f64>() / n);
        let slope = h2.iter().zip(&focus).map(|(a, b)| (a - mx) * (b - my)).sum::<f64>() / h2.iter().map(|a| (a - mx) * (a - mx)).sum::<f64>();
        let f0 = (my - slope * mx) as f32;
        let n_l = spectrum::ior_at(n_d, dispersion, lambda);
        let expected = n_l * radius / (2.0 * (n_l - 1.0));
        eprintln!("{lambda} nm: n = {n_l:.5}, focus {f0:.4} m from the centre, closed form {expected:.4} m (voxel {voxel:.4})");
        assert!((f0 - expected).abs() < voxel, "{lambda} nm: focus {f0} vs {expected} ± {voxel}");
        foci.push(f0);
    }
    assert!(foci[0] < foci[1] && foci[1] < foci[2], "blue focuses nearest: {foci:?}");
    assert!(foci[2] - foci[0] > voxel, "the bands' foci are resolved apart: {foci:?}");
}

#[test]
fn lua_glass_takes_an_abbe_number_or_khr_dispersion() {
    let desc = frame_from_lua(
        r#"local r = require("refrakt")
        local scene = r.scene{}
        local flint = r.glass{ ior = 1.6, abbe = 20 }
        assert(flint.dispersion == 1 and flint.abbe == 20)
        local crown = r.glass{ dispersion = 20 / 59 }
        assert(math.abs(crown.abbe - 59) < 1e-4)
        local clear = r.glass{}
        assert(clear.dispersion == 0 and clear.abbe == nil)
        clear.abbe = 40
        assert(clear.dispersion == 0.5)
        scene:add(r.node{ name = "a", shape = r.sphere{ radius = 0.2 }, material = flint })
        scene:add(r.node{ name = "b", translation = {1, 0, 0}, shape = r.luneburg{ radius = 0.2 }, material = clear })
        return scene"#,
    );
    assert_eq!(desc.fields[0].glass.dispersion, 1.0);
    let s = desc.spectrum();
    assert!(s.spectral && s.grid_dispersion == 0.5, "{s:?}");
    let limits = refrakt::lua::Limits::default();
    let both = load_error("local g = r.glass{ abbe = 30, dispersion = 0.5 }", &limits);
    assert!(both.contains("either abbe") && both.contains("scene.lua:3"), "{both}");
    let negative = load_error("local g = r.glass{ dispersion = -1 }", &limits);
    assert!(negative.contains("glass.dispersion") && negative.contains("20/V_d"), "{negative}");
    let tiny = load_error("local g = r.glass{ abbe = 0.5 }", &limits);
    assert!(tiny.contains("glass.abbe") && tiny.contains("Abbe number"), "{tiny}");
}

#[test]
fn gradient_index_media_with_different_dispersions_share_the_largest_with_a_warning() {
    let desc = frame_from_lua(
        r#"local r = require("refrakt")
        local scene = r.scene{}
        scene:add(r.node{ name = "one", shape = r.luneburg{ radius = 0.2 }, material = r.glass{ abbe = 40 } })
        scene:add(r.node{ name = "two", translation = {1, 0, 0}, shape = r.luneburg{ radius = 0.2 }, material = r.glass{ abbe = 20 } })
        return scene"#,
    );
    assert_eq!(desc.spectrum().grid_dispersion, 1.0);
    let w = desc.warnings();
    assert!(w.iter().any(|w| w.contains("share one dispersion") && w.contains("\"one\" 0.5")), "{w:?}");
    let plain = frame_from_lua(
        r#"local r = require("refrakt")
        local scene = r.scene{}
        scene:add(r.node{ name = "ball", shape = r.sphere{ radius = 0.2 }, material = r.glass{} })
        return scene"#,
    );
    assert!(!plain.spectrum().spectral, "no dispersion: RGB light");
}

/// A thin wedge of very dispersive glass (apex 20°, n_d 1.5, V_d 5) between the camera and a
/// white strip lit by a sun: each vertical edge of the strip, seen through the wedge, spreads
/// into a fringe, red deviated least. `WEDGE_SCENE` in Lua; the strip spans x ∈ [−0.8, 0.2] at
/// z = −1, the wedge's front face is z = 1 (x ∈ [−1, 1]), its back face runs from (1, 1) to
/// (−1, 1 − 2·tan 20°) in x-z.
const WEDGE_SCENE: &str = r#"local r = require("refrakt")
local t = math.tan(math.rad(20))
local section = { {-1, 1}, {1, 1}, {-1, 1 - 2 * t} }
local v = {}
for _, y in ipairs({-0.4, 0.4}) do for _, c in ipairs(section) do v[#v + 1] = {c[1], y, c[2]} end end
local wedge = r.mesh{ vertices = v, triangles = { {1,2,3}, {4,6,5}, {1,4,5}, {1,5,2}, {2,5,6}, {2,6,3}, {3,6,4}, {3,4,1} } }
local scene = r.scene{ camera = r.camera{ position = {0, 0, 4}, target = {0, 0, 0}, fov = 1, size = {256, 8} },
  environment = r.environment{ color = {0, 0, 0} }, volume = { resolution = 32 }, photons = 1000, samples = 32 }
scene:add(r.node{ name = "strip", translation = {-0.3, 0, -1}, rotation = {90, 0, 0}, shape = r.plane{ size = {1, 4} },
                  material = r.diffuse{ color = {1, 1, 1} } })
scene:add(r.node{ name = "wedge", shape = wedge, material = r.glass{ ior = 1.5, dispersion = 4 } })
scene:add(r.node{ name = "sun", light = r.sun{ direction = {-1, 0, -0.3}, intensity = 3000, angular_diameter = 0 } })
return scene"#;

/// The camera ray `d` from `o` through the wedge at index `n` to the strip's plane: the
/// transmittance of the two faces (Fresnel) if it lands on the strip, else 0.
fn through_wedge_onto_strip(o: Vec3, d: Vec3, n: f32) -> f32 {
    use refrakt::cpu::interface::{fresnel_dielectric, refract};
    let t = 20f32.to_radians().tan();
    // Front face z = 1, facing the camera.
    let p = o + d * ((1.0 - o.z) / d.z);
    if p.x.abs() > 1.0 || p.y.abs() > 0.4 {
        return 0.0;
    }
    let front = Vec3::Z;
    let cos_front = -d.dot(front);
    let inside = refract(d, front, n).unwrap();
    // Back face through (1, ·, 1), its outward normal ∝ (t, 0, −1) (x-z), facing away from the
    // glass: seen from inside, the normal that faces the ray is its negation.
    let back = Vec3::new(t, 0.0, -1.0).normalize();
    let q = p + inside * ((Vec3::new(1.0, 0.0, 1.0) - p).dot(back) / inside.dot(back));
    let Some(out) = refract(inside, -back, 1.0 / n) else { return 0.0 };
    let transmitted = (1.0 - fresnel_dielectric(cos_front, n)) * (1.0 - fresnel_dielectric(inside.dot(back), 1.0 / n));
    let s = q + out * ((-1.0 - q.z) / out.z);
    if (-0.8..=0.2).contains(&s.x) { transmitted } else { 0.0 }
}

/// `WEDGE_SCENE` rendered at `samples` per pixel against its closed form, over the strip's
/// fringes: (pixels in the fringes, RMS and worst error of the row means, RMS error a per-channel
/// index would have), all in units of the strip's white. The closed form traces each pixel's
/// sub-pixel positions as the view pass takes them (`view::sample_offset`, view.wgsl's r2(k))
/// through both faces for every other nm of 360–830, weighted by the colour matching functions; the
/// per-channel index takes n at the C, d and F lines for r, g and b.
fn wedge_fringes(samples: u32, rows: u32) -> (usize, f32, f32, f32) {
    // (The field of view grows with the rows, so a pixel stays ~1/8° tall and wide.)
    let desc = frame_from_lua(
        &WEDGE_SCENE
            .replace("samples = 32", &format!("samples = {samples}"))
            .replace("fov = 1, size = {256, 8}", &format!("fov = {}, size = {{256, {rows}}}", rows as f32 / 8.0)),
    );
    let mut r = renderer();
    let image = r.frame(&desc).unwrap();
    let beauty = image.layer("beauty").unwrap();
    let (w, h) = (desc.camera.width as usize, desc.camera.height as usize);
    let channels = beauty.channels.len();
    let rendered: Vec<Vec3> = (0..w)
        .map(|x| (0..h).map(|y| Vec3::from_slice(&beauty.data[channels * (x + w * y)..][..3])).sum::<Vec3>() / h as f32)
        .collect();

    // The strip's radiance: a white diffuse surface under the sun (lux → W/m², cos θ), ρ/π.
    let sun = Vec3::new(-1.0, 0.0, -0.3).normalize();
    let white = 3000.0 / refrakt::scene::light::LUMENS_PER_WATT * -sun.z / std::f32::consts::PI;
    // Camera sample k of pixel (x, y), as the view pass takes it.
    let camera = &desc.camera;
    let rays = |x: usize| -> Vec<Vec3> {
        let pixel = |y: usize, k: u32| glam::Vec2::new(x as f32, y as f32) + refrakt::pipeline::view::sample_offset(k);
        (0..h).flat_map(|y| (0..samples).map(move |k| camera.ray_through(pixel(y, k)))).collect()
    };
    let paths = (h as u32 * samples) as f32;
    let through = |d: Vec3, lambda: f32| through_wedge_onto_strip(desc.camera.position, d, spectrum::ior_at(1.5, 4.0, lambda));
    // Every other nm: the edges move smoothly with λ.
    let spectral: Vec<Vec3> = (0..w)
        .map(|x| {
            let xyz: Vec3 = rays(x).into_iter().flat_map(|d| (180..=415).map(move |l| (d, 2.0 * l as f32))).map(|(d, l)| 2.0 * spectrum::cmf(l) * through(d, l)).sum();
            spectrum::xyz_to_rgb(xyz * (white / (paths * spectrum::Y_INTEGRAL)))
        })
        .collect();
    let per_channel: Vec<Vec3> = (0..w)
        .map(|x| {
            let paths_of_x = rays(x);
            let channel = |l: f32| paths_of_x.iter().map(|&d| through(d, l)).sum::<f32>();
            Vec3::new(channel(LAMBDA_C), channel(LAMBDA_D), channel(LAMBDA_F)) * (white / paths)
        })
        .collect();

    // The fringes: pixels of the closed form that are neither black nor the strip's colour
    // through the glass (its middle pixel's).
    let lit: Vec<usize> = (0..w).filter(|&x| spectral[x].y > 0.5 * white).collect();
    let inside = spectral[lit[lit.len() / 2]];
    let fringe: Vec<usize> =
        (0..w).filter(|&x| spectral[x].abs().max_element() > 0.03 * white && (spectral[x] - inside).abs().max_element() > 0.03 * white).collect();
    let rms = |image: &[Vec3]| (fringe.iter().map(|&x| (image[x] - spectral[x]).length_squared() / 3.0).sum::<f32>() / fringe.len() as f32).sqrt() / white;
    let worst = fringe.iter().map(|&x| (rendered[x] - spectral[x]).abs().max_element()).fold(0.0, f32::max) / white;
    let (got, banded) = (rms(&rendered), rms(&per_channel));
    eprintln!("{samples} samples: fringes {} pixels; rendered vs the spectral closed form: RMS {got:.4}, worst {worst:.4} of the strip's white ({white:.4}); a per-channel index: RMS {banded:.4}", fringe.len());
    for &x in &fringe {
        eprintln!("  {x:3}: rendered {:.3?}  spectral {:.3?}  per-channel {:.3?}", rendered[x].to_array(), spectral[x].to_array(), per_channel[x].to_array());
    }
    (fringe.len(), got, worst, banded)
}

/// Camera samples through dispersive glass converge to the spectral integral, without the
/// banding of a per-channel index: `WEDGE_SCENE`'s fringes at 32 samples per pixel. Three sharp
/// copies of each edge (the per-channel index) are far outside the same bound.
#[test]
fn camera_rays_through_dispersive_glass_make_smooth_fringes_not_three_bands() {
    let (pixels, got, worst, banded) = wedge_fringes(32, 8);
    assert!(pixels >= 12, "each fringe must span several pixels: {pixels}");
    // (Measured on lavapipe: RMS 0.022, worst 0.13 at an edge pixel that only the red end of
    // the spectrum reaches; the per-channel index 0.28.)
    assert!(got < 0.04 && worst < 0.2, "rendered fringes: RMS {got}, worst {worst} of white");
    assert!(banded > 4.0 * 0.04, "the bound must tell a per-channel index apart: RMS {banded}");
}

/// One sample per pixel: where it meets dispersive glass it is traced at the pixel's companion
/// wavelength too (view::SPECTRAL_WAVELENGTHS_PER_PIXEL, in a thread of its own: view.wgsl's
/// `main_companions`), so the means of 64 rows still follow the spectral closed form.
#[test]
fn one_camera_sample_through_dispersive_glass_takes_several_wavelengths() {
    let (_, got, worst, banded) = wedge_fringes(1, 64);
    // (Measured on lavapipe: RMS 0.064, worst 0.19; with one wavelength per sample 0.139. With
    // pbrt's visible-wavelength density, before: 0.097, and 0.155 with one wavelength.)
    assert!(got < 0.09 && worst < 0.35, "rendered fringes: RMS {got}, worst {worst} of white");
    assert!(banded > 2.0 * 0.09, "the bound must tell a per-channel index apart: RMS {banded}");
}
