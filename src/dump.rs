//! `refrakt dump`: the evaluated scene of each frame as one JSON document per line — node world
//! matrices, the camera, lights in their photometric and radiometric units, materials,
//! refractive meshes and the volume box — for Lua and glTF scenes alike, without a GPU. It is
//! what the Blender add-on's round-trip tests read (schema in docs/gltf.md).

use std::collections::HashMap;
use std::io::Write;
use std::path::Path;
use std::rc::Rc;

use anyhow::{Result, anyhow};
use glam::{Mat4, Vec3};
use serde_json::{Value, json};

use crate::frame::{FrameDesc, LightDesc};
use crate::lua::objects::decimal;
use crate::gltf::Catalog;
use crate::render::{RenderOptions, SceneSource, frame_time};
use crate::scene::eval::{camera_nodes, placed_nodes};
use crate::scene::{EnvironmentSource, LightKind, Material, Scene};

fn vec3(v: Vec3) -> Value {
    json!([v.x, v.y, v.z])
}

fn matrix(m: &Mat4) -> Value {
    json!(m.to_cols_array())
}

/// The JSON document of one evaluated frame (`frame`: its number, `None` for a still).
pub fn frame_json(scene: &Scene, desc: &FrameDesc, frame: Option<i64>) -> Result<Value> {
    let placed = placed_nodes(scene);
    // Materials in the order nodes first use them, each once (they are shared objects).
    let mut material_index: HashMap<*const std::cell::RefCell<Material>, usize> = HashMap::new();
    let mut materials = Vec::new();
    let nodes: Vec<Value> = placed
        .iter()
        .map(|p| {
            let node = p.node.borrow();
            let material = node.material.as_ref().map(|m| {
                *material_index.entry(Rc::as_ptr(m)).or_insert_with(|| {
                    materials.push(material_json(&m.borrow()));
                    materials.len() - 1
                })
            });
            json!({
                "name": node.name,
                "world": matrix(&p.world),
                "material": material,
                "shape": node.shape.as_ref().map(|s| s.borrow().kind_name()),
                "light": node.light.is_some(),
                "camera": node.camera.is_some(),
            })
        })
        .collect();
    let cameras: Vec<Value> =
        camera_nodes(&placed).iter().enumerate().map(|(i, p)| json!({ "index": i, "node": p.node.borrow().name })).collect();
    let light_nodes: Vec<_> = placed.iter().filter(|p| p.node.borrow().light.is_some()).collect();
    if light_nodes.len() != desc.lights.len() {
        return Err(anyhow!("internal error: {} light nodes but {} lights in the frame", light_nodes.len(), desc.lights.len()));
    }
    let lights: Vec<Value> = light_nodes
        .iter()
        .zip(&desc.lights)
        .map(|(p, d)| light_json(&p.node.borrow().light.as_ref().expect("filtered above").borrow(), d))
        .collect();
    let c = &desc.camera;
    let meshes: Vec<Value> = desc
        .meshes
        .iter()
        .map(|m| {
            let (lo, hi) = m.mesh.bounds().unwrap_or_default();
            json!({ "node": m.name, "vertices": m.mesh.positions.len(), "triangles": m.mesh.triangles.len(),
                    "local_min": vec3(lo), "local_max": vec3(hi), "world": matrix(&m.world) })
        })
        .collect();
    let env = &desc.environment;
    let (env_kind, env_name) = match &env.source {
        EnvironmentSource::Color(_) => ("color", String::new()),
        EnvironmentSource::Image { path, .. } => ("image", path.display().to_string()),
        EnvironmentSource::Preset { name, .. } => ("preset", name.clone()),
    };
    Ok(json!({
        "frame": frame,
        "time": desc.time,
        "nodes": nodes,
        "camera": {
            "position": vec3(c.position),
            "forward": vec3(c.forward()),
            "up": vec3(c.orientation * Vec3::Y),
            "yfov": c.fov_y,
            "orthographic": c.orthographic,
            "size": [c.width, c.height],
            "clip_start": c.clip_start,
            "region": c.crop.map(|r| json!({ "frame": [r.frame.0, r.frame.1], "origin": [r.origin.0, r.origin.1] })),
            "lens": { "aperture": c.aperture, "focus": c.focus, "blades": c.blades, "blade_rotation": c.blade_rotation.to_degrees(), "shift": [c.shift.x, c.shift.y] },
        },
        "cameras": cameras,
        "lights": lights,
        "materials": materials,
        "meshes": meshes,
        "fields": desc.fields.iter().map(|f| json!({ "node": f.name, "ior": f.ior })).collect::<Vec<_>>(),
        "receivers": desc.receivers.iter().map(|r| r.name.clone()).collect::<Vec<_>>(),
        "environment": { "kind": env_kind, "source": env_name, "intensity": env.intensity,
                         "rotation": env.rotation, "tilt": env.tilt.to_array(), "visible": env.visible },
        "fog": desc.fog.map(|f| json!({ "scattering": vec3(f.scattering), "absorption": vec3(f.absorption), "g": f.g })),
        "photons": desc.photons,
        "samples": desc.samples,
        "motion_blur": desc.motion_blur.map(|m| json!({ "shutter": m.shutter, "steps": m.steps })),
        "volume": {
            "dims": [desc.volume.dims.x, desc.volume.dims.y, desc.volume.dims.z],
            "min": vec3(desc.volume.min),
            "max": vec3(desc.volume.max()),
            "voxel_size": desc.volume.voxel_size,
        },
    }))
}

fn material_json(m: &Material) -> Value {
    let size = |t: &Option<std::sync::Arc<crate::scene::Texture2d>>| t.as_ref().map(|t| [t.width, t.height]);
    match m {
        Material::Glass(g) => json!({ "kind": "glass", "ior": g.ior, "absorption": vec3(g.absorption),
                                      "scattering": vec3(g.scattering), "g": g.g, "tint": vec3(g.tint), "roughness": g.roughness,
                                      "roughness_texture": size(&g.roughness_texture), "tint_texture": size(&g.tint_texture),
                                      "multiscatter": g.multiscatter, "emission": vec3(g.emission), "emission_strength": g.emission_strength, "emission_texture": size(&g.emission_texture),
                                      "normal_texture": size(&g.normal_texture), "normal_scale": g.normal_scale,
                                      "transmission": g.transmission, "transmission_texture": size(&g.transmission_texture),
                                      "alpha": g.alpha, "alpha_mode": g.alpha_mode.name(), "alpha_cutoff": g.alpha_cutoff, "metallic": g.metallic,
                                      "base_color": vec3(g.base()), "specular": g.specular, "specular_color": vec3(g.specular_color),
                                      "specular_texture": size(&g.specular_texture), "specular_color_texture": size(&g.specular_color_texture) }),
        Material::Diffuse(d) => {
            json!({ "kind": "diffuse", "color": vec3(d.color), "texture": size(&d.texture),
                    "metallic": d.metallic, "roughness": d.roughness, "specular": d.specular,
                    "alpha": d.alpha, "alpha_mode": d.alpha_mode.name(), "alpha_cutoff": d.alpha_cutoff,
                    "emission": vec3(d.emitted()),
                    "metallic_roughness_texture": size(&d.metallic_roughness_texture), "normal_texture": size(&d.normal_texture),
                    "occlusion_texture": size(&d.occlusion_texture), "emission_texture": size(&d.emission_texture),
                    "clearcoat": d.clearcoat, "clearcoat_roughness": d.clearcoat_roughness,
                    "sheen_color": vec3(d.sheen_color), "sheen_roughness": d.sheen_roughness })
        }
    }
}

/// A light as authored (kind, photometric intensity and its unit, cone angles) and as the
/// frame has it (world position and direction, radiometric `radiant`).
fn light_json(l: &crate::scene::Light, d: &LightDesc) -> Value {
    let (kind, unit) = match l.kind {
        LightKind::Point => ("point", "cd"),
        LightKind::Spot { .. } => ("spot", "cd"),
        LightKind::Sun { .. } => ("sun", "lx"),
        LightKind::Rect { round: false, .. } => ("rect", "nit"),
        LightKind::Rect { round: true, .. } => ("disk", "nit"),
    };
    let mut v = json!({
        "node": d.name, "kind": kind, "unit": unit, "intensity": l.intensity, "color": vec3(l.color),
        "radiant": vec3(d.radiant), "position": vec3(d.position), "direction": vec3(d.direction),
        "visible": d.visible,
    });
    match l.kind {
        LightKind::Spot { angle, blend } => {
            v["outer_cone_angle"] = json!(angle);
            v["inner_cone_angle"] = json!(angle * (1.0 - blend));
            v["radius"] = json!(l.radius);
        }
        LightKind::Sun { angular_diameter } => v["angular_diameter"] = json!(angular_diameter),
        LightKind::Rect { size, .. } => v["size"] = json!([size.x, size.y]),
        LightKind::Point => v["radius"] = json!(l.radius),
    }
    v
}

/// A glTF file's scenes and animations by index and name, and which are taken: what
/// `--scene` and `--animation` can name (unnamed ones by index).
fn catalog_json(c: &Catalog) -> Value {
    let list = |names: &[Option<String>], taken: &dyn Fn(usize) -> bool| -> Vec<Value> {
        names.iter().enumerate().map(|(i, n)| json!({ "index": i, "name": n, "chosen": taken(i) })).collect()
    };
    json!({
        "scenes": list(&c.scenes, &|i| c.scene == Some(i)),
        "animations": list(&c.animations, &|i| c.animation.is_none_or(|a| a == i)),
        "variants": list(&c.variants, &|i| c.variant == Some(i)),
    })
}

/// Numbers that are f32 values (all but the time) written as the shortest decimal that reads
/// back as the same f32: 0.7, not 0.699999988079071; and −0 as 0 (e.g. the absorption
/// −ln(1) / d of a channel that absorbs nothing).
fn shorten(v: &mut Value) {
    match v {
        Value::Number(n) if n.is_f64() => {
            let x = n.as_f64().unwrap_or_default();
            if (x as f32) as f64 == x {
                *v = json!(decimal(if x == 0.0 { 0.0 } else { x as f32 }));
            }
        }
        Value::Array(items) => items.iter_mut().for_each(shorten),
        Value::Object(fields) => fields.values_mut().for_each(shorten),
        _ => {}
    }
}

/// Loads the scene and writes one line of JSON per frame (or one for a still) to `out`.
pub fn run(scene_path: &Path, opts: &RenderOptions, out: &mut impl Write) -> Result<()> {
    let mut source = opts.scene.load(scene_path)?;
    let frames: Vec<Option<i64>> = match opts.frames {
        Some(r) => (r.first..=r.last).map(Some).collect(),
        None => vec![None],
    };
    for frame in frames {
        let t = frame_time(frame, opts);
        let desc = source.frame_desc(t, &opts.scene.eval).map_err(|e| match frame {
            Some(k) => anyhow!("frame {k} (t = {t:.4} s): {e:#}"),
            None => e,
        })?;
        let mut doc = source.with_scene(|scene| frame_json(scene, &desc, frame))?;
        if let SceneSource::Gltf(g) = &source {
            doc["gltf"] = catalog_json(&g.catalog);
        }
        shorten(&mut doc);
        match writeln!(out, "{}", serde_json::to_string(&doc)?) {
            // A reader that has seen enough (`refrakt dump … | head -1`) is not an error.
            Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => return Ok(()),
            other => other?,
        }
    }
    match out.flush() {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(e.into()),
        _ => Ok(()),
    }
}
