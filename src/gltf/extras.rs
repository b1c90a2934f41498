//! refrakt's settings carried in glTF `extras` (glTF 2.0 §3.12: "application-specific data"),
//! as the Blender add-on writes them (blender_addon/extras.py; schema in docs/gltf.md):
//!
//! - `scenes[i].extras.refrakt`: photons, samples, volume, environment, fog;
//! - `nodes[i].extras.refrakt`: an analytic index field instead of the node's mesh, or
//!   `{"role": "ignore"}`; `light_radius` and `light_visible` for the node's light; `light`, an area
//!   light KHR_lights_punctual has no type for (a `rect`: Blender's area lights);
//! - `materials[i].extras.refrakt`: absorption, scattering, g and boundary of the medium;
//! - `cameras[i].extras.refrakt`: a thin lens (aperture, focus, blades, blade_rotation).
//!
//! Unknown keys are skipped with a warning (a newer add-on may write more); values out of
//! range are errors naming the object and key.

use anyhow::{Result, anyhow, bail};
use glam::{Quat, Vec2, Vec3};
use serde::Deserialize;
use serde::de::DeserializeOwned;

use crate::scene::Lens;
use crate::warnings::Collector;

/// The `refrakt` object in an `extras`, parsed as `T`; `None` when there is none.
fn refrakt_object<T: DeserializeOwned>(
    extras: &gltf::json::Extras,
    file: &str,
    what: &str,
    known: &[&str],
    warnings: &mut Collector,
) -> Result<Option<T>> {
    let Some(raw) = extras else { return Ok(None) };
    let Ok(serde_json::Value::Object(all)) = serde_json::from_str::<serde_json::Value>(raw.get()) else { return Ok(None) };
    let Some(ours) = all.get("refrakt") else { return Ok(None) };
    let serde_json::Value::Object(fields) = ours else {
        bail!("{file}: {what}.extras.refrakt must be an object, got {ours}");
    };
    for key in fields.keys().filter(|k| !known.contains(&k.as_str())) {
        warnings.about(what, format!("extras.refrakt.{key} is not a refrakt setting (known: {}); skipped", known.join(", ")));
    }
    T::deserialize(ours).map(Some).map_err(|e| anyhow!("{file}: {what}.extras.refrakt: {e} (see docs/gltf.md for the schema)"))
}

fn check(ok: bool, file: &str, what: &str, key: &str, expected: &str) -> Result<()> {
    if ok { Ok(()) } else { bail!("{file}: {what}.extras.refrakt.{key} must be {expected}") }
}

fn non_negative(v: Option<[f32; 3]>) -> bool {
    v.is_none_or(|c| c.iter().all(|x| x.is_finite() && *x >= 0.0))
}

// ---------------------------------------------------------------------------------------------
// Scenes.

#[derive(Debug, Default, Deserialize)]
#[serde(default)]
pub struct VolumeExtras {
    pub resolution: Option<u32>,
    pub margin: Option<f32>,
    pub boundary: Option<f32>,
    pub step: Option<f32>,
    /// Metres (`VolumeSettings::contact`).
    pub contact: Option<f32>,
    pub min: Option<[f32; 3]>,
    pub max: Option<[f32; 3]>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(default)]
pub struct EnvironmentExtras {
    pub visible: Option<bool>,
    pub color: Option<[f32; 3]>,
    pub intensity: Option<f32>,
    /// An equirectangular .exr or .hdr, relative to the glTF file.
    pub image: Option<String>,
    /// Degrees about +Y.
    pub rotation: Option<f32>,
    /// A unit quaternion (x, y, z, w) turning the environment before `rotation` (Blender's
    /// Mapping node rotated about X or Y).
    pub tilt: Option<[f32; 4]>,
    /// A built-in environment (refrakt's own addition; the add-on does not write it).
    pub preset: Option<String>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(default)]
pub struct FogExtras {
    pub scattering: Option<[f32; 3]>,
    pub absorption: Option<[f32; 3]>,
    pub g: Option<f32>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(default)]
pub struct SceneExtras {
    pub photons: Option<u32>,
    pub bounces: Option<u32>,
    pub bounce_photons: Option<u32>,
    pub samples: Option<u32>,
    pub volume: Option<VolumeExtras>,
    pub environment: Option<EnvironmentExtras>,
    pub fog: Option<FogExtras>,
    pub shutter: Option<f32>,
    pub motion_steps: Option<u32>,
}

const SCENE_KEYS: &[&str] = &["photons", "bounces", "bounce_photons", "samples", "volume", "environment", "fog", "shutter", "motion_steps"];

pub fn scene_extras(scene: &gltf::Scene, file: &str, warnings: &mut Collector) -> Result<Option<SceneExtras>> {
    let what = format!("scenes[{}]", scene.index());
    let Some(s) = refrakt_object::<SceneExtras>(scene.extras(), file, &what, SCENE_KEYS, warnings)? else { return Ok(None) };
    check(s.photons.is_none_or(|p| p <= 1 << 30), file, &what, "photons", "from 0 to 2³⁰")?;
    check(s.bounce_photons.is_none_or(|p| p <= 1 << 30), file, &what, "bounce_photons", "from 0 to 2³⁰")?;
    check(s.bounces.is_none_or(|b| b <= crate::scene::MAX_BOUNCES), file, &what, "bounces", "from 0 to 1024")?;
    check(s.samples.is_none_or(|n| (1..=256).contains(&n)), file, &what, "samples", "from 1 to 256")?;
    check(s.shutter.is_none_or(|t| (0.0..=crate::scene::MotionBlur::MAX_SHUTTER).contains(&t)), file, &what, "shutter", "frames from 0 to 100")?;
    check(s.motion_steps.is_none_or(|n| (1..=crate::scene::MotionBlur::MAX_STEPS).contains(&n)), file, &what, "motion_steps", "from 1 to 64")?;
    if let Some(v) = &s.volume {
        check(v.resolution.is_none_or(|r| (8..=2048).contains(&r)), file, &what, "volume.resolution", "from 8 to 2048")?;
        check(v.margin.is_none_or(|m| m.is_finite() && m >= 0.0), file, &what, "volume.margin", "≥ 0 (metres)")?;
        check(v.boundary.is_none_or(|b| (0.0..=16.0).contains(&b)), file, &what, "volume.boundary", "from 0 to 16 (voxels)")?;
        check(v.step.is_none_or(|b| (0.01..=8.0).contains(&b)), file, &what, "volume.step", "from 0.01 to 8 (voxels)")?;
        check(v.contact.is_none_or(|c| c.is_finite() && c >= 0.0), file, &what, "volume.contact", "≥ 0 (metres)")?;
        check(v.min.is_some() == v.max.is_some(), file, &what, "volume.min", "given together with volume.max")?;
    }
    if let Some(e) = &s.environment {
        check(non_negative(e.color), file, &what, "environment.color", "three numbers ≥ 0")?;
        check(e.intensity.is_none_or(|i| i.is_finite() && i >= 0.0), file, &what, "environment.intensity", "a number ≥ 0")?;
        check(e.rotation.is_none_or(f32::is_finite), file, &what, "environment.rotation", "a number of degrees")?;
        let unit = |q: &[f32; 4]| q.iter().all(|c| c.is_finite()) && (Quat::from_array(*q).length() - 1.0).abs() < 1e-3;
        check(e.tilt.as_ref().is_none_or(unit), file, &what, "environment.tilt", "a unit quaternion [x, y, z, w]")?;
        let sources = [e.color.is_some(), e.image.is_some(), e.preset.is_some()].iter().filter(|x| **x).count();
        check(sources <= 1, file, &what, "environment", "one of color, image or preset")?;
    }
    if let Some(f) = &s.fog {
        check(non_negative(f.scattering) && non_negative(f.absorption), file, &what, "fog", "per-metre coefficients ≥ 0")?;
        check(f.g.is_none_or(|g| (-0.99..=0.99).contains(&g)), file, &what, "fog.g", "from −0.99 to 0.99")?;
    }
    Ok(Some(s))
}

// ---------------------------------------------------------------------------------------------
// Nodes.

#[derive(Debug, Default, Deserialize)]
#[serde(default)]
pub struct NodeExtras {
    pub role: Option<String>,
    pub field: Option<String>,
    pub radius: Option<f32>,
    pub size: Option<[f32; 3]>,
    pub ior: Option<f32>,
    pub gradient: Option<f32>,
    pub boundary: Option<f32>,
    /// The bulb radius of the node's point or spot light, metres (Blender's light radius).
    pub light_radius: Option<f32>,
    /// Whether the camera sees the node's point, spot or area light (Blender's Ray Visibility ▸
    /// Camera; refrakt's `visible`). Absent: not seen, as KHR_lights_punctual's points are not.
    pub light_visible: Option<bool>,
    /// A light of a kind KHR_lights_punctual lacks.
    pub light: Option<LightExtras>,
}

/// `nodes[i].extras.refrakt.light`: `{"type": "rect", "size": [w, h], "color": [r, g, b],
/// "intensity": nits}`, as Lua's `refrakt.rect` (in the node's local XY plane, emitting toward
/// its local −Z; intensity in nits, cd/m², as KHR_lights_punctual's photometric units); type
/// "disk": the ellipse of diameters w, h, as Lua's `refrakt.disk`.
#[derive(Debug, Default, Deserialize)]
#[serde(default)]
pub struct LightExtras {
    #[serde(rename = "type")]
    pub kind: Option<String>,
    pub size: Option<[f32; 2]>,
    pub color: Option<[f32; 3]>,
    pub intensity: Option<f32>,
    /// Keys refrakt does not know (warned about, as at the top level).
    #[serde(flatten)]
    pub unknown: std::collections::BTreeMap<String, serde_json::Value>,
}

/// An area light from a node's extras: a one-sided rectangle (refrakt's `rect`) or the ellipse
/// inscribed in it (`disk`).
#[derive(Clone, Debug, PartialEq)]
pub struct RectExtras {
    /// Metres, along the node's local X and Y.
    pub size: Vec2,
    /// A disk or ellipse of diameters `size`.
    pub round: bool,
    pub color: Vec3,
    /// Nits (cd/m²).
    pub intensity: f32,
}

/// What a node's extras say: its role, its light's radius and visibility, and an area light.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NodeSettings {
    pub role: Option<NodeRole>,
    pub light_radius: Option<f32>,
    pub light_visible: Option<bool>,
    pub rect: Option<RectExtras>,
}

/// What a node's extras make of it.
#[derive(Clone, Debug, PartialEq)]
pub enum NodeRole {
    /// Left out: the node keeps only its transform (its children stay).
    Ignore,
    /// An analytic index field replaces the node's mesh.
    Field(FieldExtras),
}

#[derive(Clone, Debug, PartialEq)]
pub struct FieldExtras {
    pub kind: FieldType,
    pub radius: f32,
    pub size: Vec3,
    pub ior: f32,
    pub gradient: f32,
    pub boundary: Option<f32>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FieldType {
    Luneburg,
    Sphere,
    Box,
    Slab,
}

const NODE_KEYS: &[&str] = &["role", "field", "radius", "size", "ior", "gradient", "boundary", "light_radius", "light_visible", "light"];
const LIGHT_KEYS: &[&str] = &["type", "size", "color", "intensity"];

pub fn node_settings(node: &gltf::Node, file: &str, warnings: &mut Collector) -> Result<NodeSettings> {
    let what = format!("nodes[{}]", node.index());
    let Some(n) = refrakt_object::<NodeExtras>(node.extras(), file, &what, NODE_KEYS, warnings)? else { return Ok(NodeSettings::default()) };
    let light_radius = n.light_radius;
    check(light_radius.is_none_or(|r| r.is_finite() && r >= 0.0), file, &what, "light_radius", "a number ≥ 0 (metres)")?;
    let rect = match &n.light {
        Some(l) => Some(rect_light(l, file, &what, warnings)?),
        None => None,
    };
    let light_visible = n.light_visible;
    Ok(NodeSettings { role: node_role(n, file, &what)?, light_radius, light_visible, rect })
}

fn rect_light(l: &LightExtras, file: &str, what: &str, warnings: &mut Collector) -> Result<RectExtras> {
    for key in l.unknown.keys() {
        warnings.about(what, format!("extras.refrakt.light.{key} is not a refrakt setting (known: {}); skipped", LIGHT_KEYS.join(", ")));
    }
    let round = match l.kind.as_deref() {
        Some("rect") => false,
        Some("disk") => true,
        Some(other) => bail!("{file}: {what}.extras.refrakt.light.type is \"{other}\"; refrakt reads \"rect\" and \"disk\" (point, spot and sun lights come through KHR_lights_punctual)"),
        None => bail!("{file}: {what}.extras.refrakt.light.type must be \"rect\" or \"disk\""),
    };
    let size = Vec2::from(l.size.unwrap_or([0.0; 2]));
    check(size.is_finite() && size.min_element() > 0.0, file, what, "light.size", "two numbers > 0 (metres)")?;
    check(non_negative(l.color), file, what, "light.color", "three numbers ≥ 0")?;
    let intensity = l.intensity.unwrap_or(1.0);
    check(intensity.is_finite() && intensity >= 0.0, file, what, "light.intensity", "a number ≥ 0 (nits)")?;
    Ok(RectExtras { size, round, color: Vec3::from(l.color.unwrap_or([1.0; 3])), intensity })
}

fn node_role(n: NodeExtras, file: &str, what: &str) -> Result<Option<NodeRole>> {
    match n.role.as_deref() {
        Some("ignore") => return Ok(Some(NodeRole::Ignore)),
        None | Some("field") => {}
        Some(other) => bail!("{file}: {what}.extras.refrakt.role is \"{other}\"; it can be \"ignore\" (or leave it out)"),
    }
    let Some(field) = n.field.as_deref() else { return Ok(None) };
    let kind = match field {
        "luneburg" => FieldType::Luneburg,
        "sphere" => FieldType::Sphere,
        "box" => FieldType::Box,
        "slab" => FieldType::Slab,
        other => bail!("{file}: {what}.extras.refrakt.field is \"{other}\"; refrakt knows luneburg, sphere, box and slab"),
    };
    let round = matches!(kind, FieldType::Luneburg | FieldType::Sphere);
    let radius = n.radius.unwrap_or(0.0);
    let size = Vec3::from(n.size.unwrap_or([0.0; 3]));
    if round {
        check(radius.is_finite() && radius > 0.0, file, what, "radius", "a number > 0 (metres)")?;
    } else {
        check(size.is_finite() && size.min_element() > 0.0, file, what, "size", "three numbers > 0 (metres)")?;
    }
    let ior = n.ior.unwrap_or(1.5);
    check((1.0..=4.0).contains(&ior), file, what, "ior", "from 1 to 4")?;
    let gradient = n.gradient.unwrap_or(0.0);
    check(gradient.is_finite(), file, what, "gradient", "a finite number (per metre)")?;
    check(n.boundary.is_none_or(|b| (0.0..=16.0).contains(&b)), file, what, "boundary", "from 0 to 16 (voxels)")?;
    Ok(Some(NodeRole::Field(FieldExtras { kind, radius, size, ior, gradient, boundary: n.boundary })))
}

// ---------------------------------------------------------------------------------------------
// Cameras.

/// A camera's thin lens, as Lua's `r.camera{ aperture, focus, blades, blade_rotation, shift }`
/// (metres, metres, a count, degrees, fractions of the frame's larger side).
#[derive(Debug, Default, Deserialize)]
#[serde(default)]
pub struct LensExtras {
    pub aperture: Option<f32>,
    pub focus: Option<f32>,
    pub blades: Option<u32>,
    pub blade_rotation: Option<f32>,
    pub shift: Option<[f32; 2]>,
}

const CAMERA_KEYS: &[&str] = &["aperture", "focus", "blades", "blade_rotation", "shift"];

/// The thin lens of glTF camera `camera` from its extras (a pinhole where there are none).
pub fn lens(camera: &gltf::Camera, file: &str, what: &str, warnings: &mut Collector) -> Result<Lens> {
    let mut lens = Lens::default();
    let Some(e) = refrakt_object::<LensExtras>(camera.extras(), file, what, CAMERA_KEYS, warnings)? else { return Ok(lens) };
    check(e.aperture.is_none_or(|a| (0.0..=Lens::MAX_APERTURE).contains(&a)), file, what, "aperture", "a diameter from 0 to 100 (metres)")?;
    check(e.focus.is_none_or(|f| f.is_finite() && f > 0.0), file, what, "focus", "a distance > 0 (metres)")?;
    check(e.blades.is_none_or(Lens::blades_are_valid), file, what, "blades", "0 (round) or 3 to 64")?;
    check(e.blade_rotation.is_none_or(f32::is_finite), file, what, "blade_rotation", "an angle in degrees")?;
    check(e.shift.is_none_or(|s| s.iter().all(|c| c.abs() <= Lens::MAX_SHIFT)), file, what, "shift", "a pair [x, y] from -10 to 10 (fractions of the frame's larger side)")?;
    lens.aperture = e.aperture.unwrap_or(0.0);
    lens.focus = e.focus;
    lens.blades = e.blades.unwrap_or(0);
    lens.blade_rotation = e.blade_rotation.unwrap_or(0.0).to_radians();
    lens.shift = e.shift.map_or(glam::Vec2::ZERO, glam::Vec2::from);
    Ok(lens)
}

// ---------------------------------------------------------------------------------------------
// Materials.

#[derive(Debug, Default, Deserialize)]
#[serde(default)]
pub struct MediumExtras {
    pub absorption: Option<[f32; 3]>,
    pub scattering: Option<[f32; 3]>,
    pub g: Option<f32>,
    pub boundary: Option<f32>,
    /// A thin sheet (true) or a solid (false), overriding what KHR_materials_volume says.
    pub thin: Option<bool>,
    /// Which medium holds where solids overlap (`Glass::priority`).
    pub priority: Option<i32>,
    /// Rough crossings keep the light masking takes (`Glass::multiscatter`).
    pub multiscatter: Option<bool>,
    /// The tint per surface where it is not the base colour, which then colours only the
    /// diffuse base and the metal (`Glass::base_color`): what the add-on writes for a
    /// Principled BSDF's glass, tinted by the root of its Base Color.
    pub tint: Option<[f32; 3]>,
}

const MATERIAL_KEYS: &[&str] = &["absorption", "scattering", "g", "boundary", "thin", "priority", "multiscatter", "tint"];

pub fn medium(material: &gltf::Material, file: &str, what: &str, warnings: &mut Collector) -> Result<Option<MediumExtras>> {
    let Some(m) = refrakt_object::<MediumExtras>(material.extras(), file, what, MATERIAL_KEYS, warnings)? else { return Ok(None) };
    check(non_negative(m.absorption), file, what, "absorption", "three numbers ≥ 0 (per metre)")?;
    check(non_negative(m.scattering), file, what, "scattering", "three numbers ≥ 0 (per metre)")?;
    check(m.g.is_none_or(|g| (-0.99..=0.99).contains(&g)), file, what, "g", "from −0.99 to 0.99")?;
    check(m.boundary.is_none_or(|b| (0.0..=16.0).contains(&b)), file, what, "boundary", "from 0 to 16 (voxels)")?;
    check(m.priority.is_none_or(|p| (-1000..=1000).contains(&p)), file, what, "priority", "a whole number from -1000 to 1000")?;
    check(m.tint.is_none_or(|t| t.iter().all(|c| (0.0..=1.0).contains(c))), file, what, "tint", "three numbers from 0 to 1 (the fraction passed per surface)")?;
    Ok(Some(m))
}

impl MediumExtras {
    /// Whether the medium absorbs or scatters at all.
    pub fn is_medium(&self) -> bool {
        [self.absorption, self.scattering].iter().flatten().any(|c| c.iter().any(|x| *x > 0.0))
    }
}
