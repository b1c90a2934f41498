//! KHR_animation_pointer: animation channels aimed at a property by a JSON pointer
//! (`/extensions/KHR_lights_punctual/lights/0/intensity`) instead of a node's transform —
//! Blender's exporter writes them for animated light power and colour, camera lenses and
//! material values. The gltf crate cannot read such a channel (it has no node), so they are
//! taken out of the JSON before it parses (`split`) and read here; the properties refrakt
//! animates are resolved to a [`Target`], the others said once and left at the file's value.

use std::borrow::Cow;

use anyhow::{Result, anyhow};
use glam::{Vec2, Vec3, Vec4};
use serde_json::Value;

use super::animation::Target;
use crate::scene::{Camera, Lens, Light, LightKind, Material};

/// A channel of animation `animation` that drives what `pointer` names, by its sampler.
#[derive(Clone, Debug, PartialEq)]
pub struct PointerChannel {
    pub animation: usize,
    pub sampler: usize,
    pub pointer: String,
}

/// What a light's animation pointer can drive (KHR_lights_punctual).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum LightProperty {
    Color,
    Intensity,
    InnerCone,
    OuterCone,
    /// A point or spot light's bulb radius, metres (`extras.refrakt.radius` on the light: the
    /// animated twin of its node's `light_radius`, which KHR_lights_punctual has no field for).
    Radius,
    /// An area light's size [w, h], metres (its node's `extras.refrakt.light.size`).
    Size,
}

/// What a camera's animation pointer can drive.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CameraProperty {
    /// perspective.yfov, radians.
    Yfov,
    /// orthographic.ymag: half the view's height.
    Ymag,
    /// perspective.znear or orthographic.znear: where camera rays start (`Camera::clip_start`).
    Znear,
    /// The thin lens of `extras.refrakt` (extras.rs, `lens`), which glTF has no field for: the
    /// aperture's diameter and the focus distance, metres, and the lens shift [x, y] — a
    /// focus pull, an iris, a shift keyed in Blender (the add-on writes these channels).
    Aperture,
    Focus,
    Shift,
}

/// What a material's animation pointer can drive.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MaterialProperty {
    BaseColor,
    Metallic,
    Roughness,
    Emissive,
    EmissiveStrength,
    AlphaCutoff,
    /// KHR_materials_ior's index of a glass: an index keyed in Blender (a liquid that thickens,
    /// a lens that changes).
    Ior,
    /// KHR_materials_dispersion's 20/V_d of a glass.
    Dispersion,
    /// KHR_materials_specular's factor (a receiver's and a glass's) and colour (a glass's):
    /// Blender writes them for a keyed Specular IOR Level and Tint.
    Specular,
    SpecularColor,
}

/// The JSON without its pointer channels (the original bytes when it has none), and those
/// channels.
pub fn split<'a>(json_text: &'a [u8], file: &str) -> Result<(Cow<'a, [u8]>, Vec<PointerChannel>)> {
    // Most files have none: only they are parsed twice.
    if !json_text.windows(21).any(|w| w == b"KHR_animation_pointer") {
        return Ok((Cow::Borrowed(json_text), Vec::new()));
    }
    let mut root: Value = serde_json::from_slice(json_text).map_err(|e| anyhow!("{file}: the glTF JSON cannot be read: {e} (is the file complete? re-export it)"))?;
    let mut found = Vec::new();
    if let Some(animations) = root.get_mut("animations").and_then(Value::as_array_mut) {
        for (a, animation) in animations.iter_mut().enumerate() {
            let Some(channels) = animation.get_mut("channels").and_then(Value::as_array_mut) else { continue };
            channels.retain(|c| {
                let target = &c["target"];
                if target["path"] != "pointer" {
                    return true;
                }
                let pointer = target["extensions"]["KHR_animation_pointer"]["pointer"].as_str().unwrap_or_default().to_string();
                let sampler = c["sampler"].as_u64().map_or(usize::MAX, |s| s as usize);
                found.push(PointerChannel { animation: a, sampler, pointer });
                false
            });
        }
    }
    let text = serde_json::to_vec(&root).map_err(|e| anyhow!("{file}: {e}"))?;
    Ok((Cow::Owned(text), found))
}

/// The target and the index of the node, light, camera or material `pointer` names, if
/// refrakt animates that property.
pub fn resolve(pointer: &str) -> Option<(Target, usize)> {
    let parts: Vec<&str> = pointer.strip_prefix('/')?.split('/').collect();
    let index = |s: &str| s.parse::<usize>().ok();
    Some(match parts.as_slice() {
        ["nodes", i, "translation"] => (Target::Translation, index(i)?),
        ["nodes", i, "rotation"] => (Target::Rotation, index(i)?),
        ["nodes", i, "scale"] => (Target::Scale, index(i)?),
        ["nodes", i, "weights"] => (Target::Weights, index(i)?),
        ["extensions", "KHR_lights_punctual", "lights", i, rest @ ..] => {
            let p = match rest {
                ["color"] => LightProperty::Color,
                ["intensity"] => LightProperty::Intensity,
                ["spot", "innerConeAngle"] => LightProperty::InnerCone,
                ["spot", "outerConeAngle"] => LightProperty::OuterCone,
                ["extras", "refrakt", "radius"] => LightProperty::Radius,
                _ => return None,
            };
            (Target::Light(p), index(i)?)
        }
        // An area light lives in its node's extras (KHR_lights_punctual has none).
        ["nodes", i, "extras", "refrakt", "light", leaf] => {
            let p = match *leaf {
                "color" => LightProperty::Color,
                "intensity" => LightProperty::Intensity,
                "size" => LightProperty::Size,
                _ => return None,
            };
            (Target::AreaLight(p), index(i)?)
        }
        ["cameras", i, "perspective", "yfov"] => (Target::Camera(CameraProperty::Yfov), index(i)?),
        ["cameras", i, "orthographic", "ymag"] => (Target::Camera(CameraProperty::Ymag), index(i)?),
        ["cameras", i, "perspective" | "orthographic", "znear"] => (Target::Camera(CameraProperty::Znear), index(i)?),
        ["cameras", i, "extras", "refrakt", lens] => {
            let p = match *lens {
                "aperture" => CameraProperty::Aperture,
                "focus" => CameraProperty::Focus,
                "shift" => CameraProperty::Shift,
                _ => return None,
            };
            (Target::Camera(p), index(i)?)
        }
        ["materials", i, rest @ ..] => {
            let p = match rest {
                ["pbrMetallicRoughness", "baseColorFactor"] => MaterialProperty::BaseColor,
                ["pbrMetallicRoughness", "metallicFactor"] => MaterialProperty::Metallic,
                ["pbrMetallicRoughness", "roughnessFactor"] => MaterialProperty::Roughness,
                ["emissiveFactor"] => MaterialProperty::Emissive,
                ["extensions", "KHR_materials_emissive_strength", "emissiveStrength"] => MaterialProperty::EmissiveStrength,
                ["alphaCutoff"] => MaterialProperty::AlphaCutoff,
                ["extensions", "KHR_materials_ior", "ior"] => MaterialProperty::Ior,
                ["extensions", "KHR_materials_dispersion", "dispersion"] => MaterialProperty::Dispersion,
                ["extensions", "KHR_materials_specular", "specularFactor"] => MaterialProperty::Specular,
                ["extensions", "KHR_materials_specular", "specularColorFactor"] => MaterialProperty::SpecularColor,
                _ => return None,
            };
            (Target::Material(p), index(i)?)
        }
        _ => return None,
    })
}

/// How many numbers a value of `target` has.
pub fn width(target: Target) -> usize {
    match target {
        Target::Light(LightProperty::Color) | Target::AreaLight(LightProperty::Color) | Target::Material(MaterialProperty::Emissive) => 3,
        Target::AreaLight(LightProperty::Size) => 2,
        Target::Material(MaterialProperty::BaseColor) => 4,
        Target::Camera(CameraProperty::Shift) => 2,
        _ => 1,
    }
}

/// The smallest side an animated area light is held at, metres (the add-on's `MIN_SIZE`).
const MIN_AREA_LIGHT_SIZE: f32 = 1e-4;

/// Sets a light's animated property (negative values held at 0; cone angles kept ordered as
/// KHR_lights_punctual requires).
pub fn apply_light(light: &mut Light, p: LightProperty, v: &[f32]) {
    match p {
        LightProperty::Color => light.color = Vec3::from_slice(v).max(Vec3::ZERO),
        LightProperty::Intensity => light.intensity = v[0].max(0.0),
        LightProperty::Radius => light.radius = v[0].max(0.0),
        LightProperty::Size => {
            if let LightKind::Rect { size, .. } = &mut light.kind {
                // (A vanishing rect keeps a size, as the still extras require one > 0.)
                *size = Vec2::from_slice(v).max(Vec2::splat(MIN_AREA_LIGHT_SIZE));
            }
        }
        LightProperty::InnerCone | LightProperty::OuterCone => {
            let LightKind::Spot { angle, blend } = &mut light.kind else { return };
            // refrakt's spot is full inside angle·(1 − blend) (nodes.rs: the import).
            let (mut inner, mut outer) = (*angle * (1.0 - *blend), *angle);
            match p {
                LightProperty::InnerCone => inner = v[0],
                _ => outer = v[0],
            }
            let outer = outer.clamp(1e-4, std::f32::consts::FRAC_PI_2);
            *angle = outer;
            *blend = 1.0 - inner.clamp(0.0, outer) / outer;
        }
    }
}

pub fn apply_camera(camera: &mut Camera, p: CameraProperty, v: &[f32]) {
    match p {
        CameraProperty::Yfov => camera.fov_y = v[0].clamp(1e-4, std::f32::consts::PI - 1e-4),
        CameraProperty::Ymag => {
            if camera.orthographic.is_some() {
                camera.orthographic = Some(2.0 * v[0].abs().max(1e-6));
            }
        }
        CameraProperty::Znear => camera.clip_start = v[0].clamp(0.0, Camera::MAX_CLIP_START),
        // Held within what the still extras accept (extras.rs, `lens`).
        CameraProperty::Aperture => camera.lens.aperture = v[0].clamp(0.0, Lens::MAX_APERTURE),
        CameraProperty::Focus => camera.lens.focus = Some(v[0].max(Lens::MIN_FOCUS)),
        CameraProperty::Shift => camera.lens.shift = Vec2::from_slice(v).clamp(Vec2::splat(-Lens::MAX_SHIFT), Vec2::splat(Lens::MAX_SHIFT)),
    }
}

/// Sets a material's animated factor, held within what the import accepts: a receiver's, or a
/// glass's tint and alpha, metallic, roughness, emission, alpha cutoff, index (1 to 4),
/// dispersion (0 to 20) and specular factor (0 to 1) and colour (≥ 0); what a material does not
/// have (a receiver's index or specular colour) is left alone.
pub fn apply_material(material: &mut Material, p: MaterialProperty, v: &[f32]) {
    let unit = |x: f32| x.clamp(0.0, 1.0);
    match material {
        Material::Diffuse(d) => match p {
            MaterialProperty::BaseColor => {
                let c = Vec4::from_slice(v).clamp(Vec4::ZERO, Vec4::ONE);
                (d.color, d.alpha) = (c.truncate(), c.w);
            }
            MaterialProperty::Metallic => d.metallic = unit(v[0]),
            MaterialProperty::Roughness => d.roughness = unit(v[0]),
            MaterialProperty::Emissive => d.emission = Vec3::from_slice(v).max(Vec3::ZERO),
            MaterialProperty::EmissiveStrength => d.emission_strength = v[0].max(0.0),
            MaterialProperty::AlphaCutoff => d.alpha_cutoff = unit(v[0]),
            MaterialProperty::Specular => d.specular = unit(v[0]),
            MaterialProperty::Ior | MaterialProperty::Dispersion | MaterialProperty::SpecularColor => {}
        },
        Material::Glass(g) => match p {
            MaterialProperty::BaseColor => {
                let c = Vec4::from_slice(v).clamp(Vec4::ZERO, Vec4::ONE);
                (g.tint, g.alpha) = (c.truncate(), c.w);
            }
            MaterialProperty::Metallic => g.metallic = unit(v[0]),
            MaterialProperty::Roughness => g.roughness = unit(v[0]),
            MaterialProperty::Emissive => g.emission = Vec3::from_slice(v).max(Vec3::ZERO),
            MaterialProperty::EmissiveStrength => g.emission_strength = v[0].max(0.0),
            MaterialProperty::AlphaCutoff => g.alpha_cutoff = unit(v[0]),
            MaterialProperty::Ior => g.ior = v[0].clamp(1.0, 4.0),
            MaterialProperty::Dispersion => g.dispersion = v[0].clamp(0.0, 20.0),
            MaterialProperty::Specular => g.specular = unit(v[0]),
            MaterialProperty::SpecularColor => g.specular_color = Vec3::from_slice(v).max(Vec3::ZERO),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pointers_resolve_to_what_refrakt_animates_and_only_that() {
        assert_eq!(resolve("/extensions/KHR_lights_punctual/lights/2/intensity"), Some((Target::Light(LightProperty::Intensity), 2)));
        assert_eq!(resolve("/extensions/KHR_lights_punctual/lights/0/spot/outerConeAngle"), Some((Target::Light(LightProperty::OuterCone), 0)));
        assert_eq!(resolve("/cameras/1/perspective/yfov"), Some((Target::Camera(CameraProperty::Yfov), 1)));
        assert_eq!(resolve("/cameras/0/perspective/znear"), Some((Target::Camera(CameraProperty::Znear), 0)));
        assert_eq!(resolve("/cameras/1/orthographic/znear"), Some((Target::Camera(CameraProperty::Znear), 1)));
        assert_eq!(resolve("/materials/3/pbrMetallicRoughness/baseColorFactor"), Some((Target::Material(MaterialProperty::BaseColor), 3)));
        assert_eq!(resolve("/nodes/4/translation"), Some((Target::Translation, 4)));
        assert_eq!(resolve("/cameras/0/extras/refrakt/focus"), Some((Target::Camera(CameraProperty::Focus), 0)));
        assert_eq!(resolve("/cameras/2/extras/refrakt/shift"), Some((Target::Camera(CameraProperty::Shift), 2)));
        assert_eq!(resolve("/extensions/KHR_lights_punctual/lights/1/extras/refrakt/radius"), Some((Target::Light(LightProperty::Radius), 1)));
        assert_eq!(resolve("/nodes/7/extras/refrakt/light/size"), Some((Target::AreaLight(LightProperty::Size), 7)));
        assert_eq!(resolve("/nodes/7/extras/refrakt/light/intensity"), Some((Target::AreaLight(LightProperty::Intensity), 7)));
        assert_eq!(resolve("/materials/1/extensions/KHR_materials_ior/ior"), Some((Target::Material(MaterialProperty::Ior), 1)));
        assert_eq!(resolve("/materials/0/extensions/KHR_materials_dispersion/dispersion"), Some((Target::Material(MaterialProperty::Dispersion), 0)));
        assert_eq!(resolve("/materials/2/extensions/KHR_materials_specular/specularFactor"), Some((Target::Material(MaterialProperty::Specular), 2)));
        assert_eq!(resolve("/materials/2/extensions/KHR_materials_specular/specularColorFactor"), Some((Target::Material(MaterialProperty::SpecularColor), 2)));
        for unread in ["/extensions/KHR_lights_punctual/lights/0/range", "/cameras/0/perspective/zfar", "/cameras/0/extras/refrakt/blades", "/cameras/0/extras/other/focus", "/materials/x/alphaCutoff", "nodes/0/scale", ""] {
            assert_eq!(resolve(unread), None, "{unread}");
        }
    }

    #[test]
    fn spot_cones_stay_ordered() {
        let mut l = Light::new(LightKind::Spot { angle: 0.8, blend: 0.5 });
        apply_light(&mut l, LightProperty::InnerCone, &[0.2]);
        let LightKind::Spot { angle, blend } = l.kind else { panic!() };
        assert!((angle - 0.8).abs() < 1e-6 && (angle * (1.0 - blend) - 0.2).abs() < 1e-6);
        // An outer cone animated inside the inner one takes the inner one with it.
        apply_light(&mut l, LightProperty::OuterCone, &[0.1]);
        let LightKind::Spot { angle, blend } = l.kind else { panic!() };
        assert!((angle - 0.1).abs() < 1e-6 && blend.abs() < 1e-6);
    }

    #[test]
    fn an_animated_index_and_dispersion_stay_within_what_the_import_accepts() {
        let mut m = Material::Glass(Default::default());
        apply_material(&mut m, MaterialProperty::Ior, &[0.5]);
        apply_material(&mut m, MaterialProperty::Dispersion, &[40.0]);
        let Material::Glass(g) = &m else { unreachable!() };
        assert_eq!((g.ior, g.dispersion), (1.0, 20.0));
        apply_material(&mut m, MaterialProperty::Ior, &[1.33]);
        let Material::Glass(g) = &m else { unreachable!() };
        assert_eq!(g.ior, 1.33);
    }

    /// A glass's animated base colour is its tint and (on a sheet) its alpha, as the still import
    /// reads them; its metallic and alpha cutoff animate too, each held to 0–1.
    #[test]
    fn an_animated_glass_surface_animates_what_the_still_import_reads() {
        let mut m = Material::Glass(Default::default());
        apply_material(&mut m, MaterialProperty::BaseColor, &[0.5, 2.0, 0.25, 0.4]);
        apply_material(&mut m, MaterialProperty::Metallic, &[1.5]);
        apply_material(&mut m, MaterialProperty::AlphaCutoff, &[0.25]);
        apply_material(&mut m, MaterialProperty::Specular, &[-0.5]);
        apply_material(&mut m, MaterialProperty::SpecularColor, &[2.0, -1.0, 0.5]);
        let Material::Glass(g) = &m else { unreachable!() };
        assert_eq!((g.tint, g.alpha, g.metallic, g.alpha_cutoff), (Vec3::new(0.5, 1.0, 0.25), 0.4, 1.0, 0.25));
        assert_eq!((g.specular, g.specular_color), (0.0, Vec3::new(2.0, 0.0, 0.5)), "the factor held to 0–1, the colour to ≥ 0");
        let mut receiver = Material::Diffuse(Default::default());
        apply_material(&mut receiver, MaterialProperty::Specular, &[0.25]);
        assert!(matches!(receiver, Material::Diffuse(d) if d.specular == 0.25));
    }

    #[test]
    fn an_animated_lens_stays_within_what_the_extras_accept() {
        let mut c = Camera::default();
        apply_camera(&mut c, CameraProperty::Aperture, &[250.0]);
        apply_camera(&mut c, CameraProperty::Focus, &[-1.0]);
        apply_camera(&mut c, CameraProperty::Shift, &[0.25, -40.0]);
        assert_eq!((c.lens.aperture, c.lens.focus, c.lens.shift), (Lens::MAX_APERTURE, Some(Lens::MIN_FOCUS), Vec2::new(0.25, -Lens::MAX_SHIFT)));
        apply_camera(&mut c, CameraProperty::Focus, &[3.5]);
        assert_eq!(c.lens.focus, Some(3.5));
    }

    #[test]
    fn split_takes_out_pointer_channels_only() {
        let json = br#"{"animations":[{"channels":[{"sampler":0,"target":{"node":0,"path":"translation"}},
            {"sampler":1,"target":{"path":"pointer","extensions":{"KHR_animation_pointer":{"pointer":"/cameras/0/perspective/yfov"}}}}],
            "samplers":[]}]}"#;
        let (text, found) = split(json, "a.gltf").unwrap();
        assert_eq!(found, vec![PointerChannel { animation: 0, sampler: 1, pointer: "/cameras/0/perspective/yfov".into() }]);
        let left: Value = serde_json::from_slice(&text).unwrap();
        assert_eq!(left["animations"][0]["channels"].as_array().unwrap().len(), 1);
        assert!(matches!(split(b"{}", "a.gltf").unwrap().0, Cow::Borrowed(_)));
    }
}
