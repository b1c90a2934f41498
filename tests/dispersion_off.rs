//! No dispersion ⇒ the images of today. The references in `tests/data/dispersion/` were written
//! by this test (`REFRAKT_WRITE_REFERENCE=1`) on the code before dispersion existed (commit
//! aead4a8, lavapipe; the caustic chart again at 12121ff, after fixed-point deposits began to
//! round with a dither, still before dispersion was merged, and once more when the caustic filter
//! began to spread each texel's deposits over its own footprint — the photon statistics stayed
//! identical, the chart's sum fell 2.7 % to what its photons brought — and when the filter's three
//! smallest levels became one pass that sums in floating point instead of rounding each level's
//! layer to fixed point: statistics identical, chart sum within 5e-6, no texel off by more than
//! 1.3e-5 of the brightest; and the view's beauty once more when the studio preset began to be
//! evaluated per ray, its floor filtered over each pixel's cone — with the old image lookup kept,
//! the view differed from its reference by at most 0.0028, in the preset's re-made texels; and
//! once more when the camera's image became a window on the image plane (lens shift, regions:
//! `CameraDesc::image_window`), which rounds the camera rays' directions differently in their last
//! bits — 1232 of 3840 values moved, by at most 0.0026, at the glass's silhouettes; and once
//! more when the grids' textures got spare texels off powers of two (`frame::texture_dims`),
//! which rounds the texture coordinates differently in their last bits — 235 of 3840 values
//! moved, by at most 0.0011), so a change that alters the non-dispersive path — a spectral photon, a wavelength-dependent index where none was asked
//! for — fails here bit for bit.
//!
//! The scenes avoid receivers' shading and fog on purpose (other work changes those): the view
//! scene is glass (a sharp ball, a gradient-index Luneburg lens) against the environment, the
//! photon scene is compared by its filtered caustic irradiance and its exact photon statistics.

mod common;

use std::path::PathBuf;

use common::*;

fn reference(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/dispersion").join(name)
}

/// Compares `values` with the stored reference bit for bit (or writes it, when asked).
fn same_as_reference(name: &str, values: &[f32]) {
    let path = reference(name);
    if std::env::var_os("REFRAKT_WRITE_REFERENCE").is_some() {
        std::fs::write(&path, bytemuck::cast_slice(values)).unwrap();
        return;
    }
    let stored: Vec<f32> = bytemuck::cast_slice(&std::fs::read(&path).unwrap()).to_vec();
    assert_eq!(stored.len(), values.len(), "{name}: the reference has another size");
    let differing = stored.iter().zip(values).filter(|(a, b)| a.to_bits() != b.to_bits()).count();
    let worst = stored.iter().zip(values).map(|(a, b)| (a - b).abs()).fold(0.0, f32::max);
    assert_eq!(differing, 0, "{name}: {differing} of {} values differ from the pre-dispersion render (largest difference {worst})", values.len());
}

const GLASS: &str = r#"
scene:add(r.node{ name = "ball", translation = {0.35, 0, 0}, shape = r.sphere{ radius = 0.3 },
                  material = r.glass{ ior = 1.5, tint = {0.9, 1.0, 0.95} } })
scene:add(r.node{ name = "lens", translation = {-0.35, 0, 0}, shape = r.luneburg{ radius = 0.3 } })
"#;

/// MATERIAL is substituted: "" (no dispersion) or `, dispersion = 0` / `, abbe = 0` spelled out.
fn view_scene(extra: &str) -> String {
    format!(
        r#"local r = require("refrakt")
        local scene = r.scene{{
          camera = r.camera{{ position = {{0, 0.4, 2.2}}, target = {{0, 0, 0}}, fov = 40, size = {{40, 24}} }},
          environment = r.environment{{ preset = "studio" }},
          volume = {{ resolution = 32 }}, photons = 0, samples = 2,
        }}
        {}
        return scene"#,
        GLASS.replace("ior = 1.5,", &format!("ior = 1.5{extra},"))
    )
}

fn photon_scene(extra: &str) -> String {
    format!(
        r#"local r = require("refrakt")
        local scene = r.scene{{
          camera = r.camera{{ position = {{0, 2, 2}}, target = {{0, -0.5, 0}}, fov = 40, size = {{16, 16}} }},
          environment = r.environment{{ color = {{0, 0, 0}} }},
          volume = {{ resolution = 24 }}, photons = 20000, samples = 1,
        }}
        scene:add(r.node{{ name = "floor", translation = {{0, -0.6, 0}}, shape = r.plane{{ size = {{1.6, 1.6}} }},
                          material = r.diffuse{{ color = {{0.8, 0.8, 0.8}} }} }})
        scene:add(r.node{{ name = "ball", shape = r.sphere{{ radius = 0.25 }}, material = r.glass{{ ior = 1.5{extra} }} }})
        scene:add(r.node{{ name = "sun", light = r.sun{{ direction = {{0.3, -1, 0.2}}, intensity = 1000, color = {{1, 0.9, 0.7}} }} }})
        return scene"#
    )
}

fn view_beauty(extra: &str) -> Vec<f32> {
    let desc = frame_from_lua(&view_scene(extra));
    let image = renderer().frame(&desc).unwrap();
    image.layer("beauty").map(|l| l.data.clone()).or_else(|| image.layers.first().map(|l| l.data.clone())).unwrap()
}

fn caustics_and_stats(extra: &str) -> Vec<f32> {
    let desc = frame_from_lua(&photon_scene(extra));
    let mut r = renderer();
    r.frame(&desc).unwrap();
    let (_, texels) = chart(&r, 0, 2);
    let stats = r.photon_stats().unwrap();
    let mut values: Vec<f32> = texels.iter().flatten().copied().collect();
    for s in [stats.emitted, stats.received, stats.caustic, stats.escaped] {
        values.extend(s.map(|w| w as f32));
    }
    values
}

#[test]
fn without_dispersion_glass_renders_as_before_dispersion_existed() {
    same_as_reference("view_beauty.f32", &view_beauty(""));
}

#[test]
fn without_dispersion_photons_land_as_before_dispersion_existed() {
    same_as_reference("caustic_chart.f32", &caustics_and_stats(""));
}
