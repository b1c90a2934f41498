//! Lights, in the units of glTF's KHR_lights_punctual so Blender scenes carry over: candela for
//! point and spot lights, lux for the sun. Internally refrakt works in Blender's radiometric
//! units (W/sr, W/m², radiance in W/(m²·sr)): photometric values are divided by 683 lm/W, as
//! Blender's glTF importer does, so a frame composites over a Blender render at the same scale.

use glam::{Vec2, Vec3};

/// Luminous efficacy used to turn lumens into watts (the peak of the photopic curve).
pub const LUMENS_PER_WATT: f32 = 683.0;

#[derive(Clone, Debug, PartialEq)]
pub enum LightKind {
    /// Emits equally in all directions from the node's origin.
    Point,
    /// A cone along the node's local −Z (or toward `target`): full intensity within
    /// `angle · (1 − blend)`, falling smoothly to zero at `angle` (half-angle, radians).
    Spot { angle: f32, blend: f32 },
    /// Parallel light along the node's local −Z (or `direction`), from a disc of
    /// `angular_diameter` radians (0: perfectly parallel).
    Sun { angular_diameter: f32 },
    /// A one-sided rectangle of `size` in the node's local XY plane, emitting toward −Z — or,
    /// `round`, the ellipse inscribed in it (a disk when its sides are equal: Lua's `disk`).
    Rect { size: Vec2, round: bool },
}

#[derive(Clone, Debug, PartialEq)]
pub struct Light {
    pub kind: LightKind,
    /// Linear RGB, multiplies the intensity.
    pub color: Vec3,
    /// Candela (point, spot), lux (sun), or nits (rect: luminance of the emitting surface).
    pub intensity: f32,
    /// World-space aim overriding the node's orientation (spot: a point to aim at).
    pub target: Option<Vec3>,
    /// World-space direction the light travels (sun), overriding the node's orientation.
    pub direction: Option<Vec3>,
    /// Radius of a point or spot light's bulb, metres (Blender's light radius): its soft
    /// shadows, and the sphere glass shows of it. Its photons still leave from its centre.
    pub radius: f32,
    /// The camera sees the bulb (a point or spot light's sphere of `radius`) or the panel (rect,
    /// disk) directly, as Blender's *Ray Visibility ▸ Camera*: a softbox in the frame shows as
    /// the bright surface it is. Glass shows every light with a size, whatever this says; a sun
    /// is never seen directly (Cycles' neither).
    pub visible: bool,
}

/// A point or spot light's radius unless set (Blender's default is 0.1 m; a smaller bulb keeps
/// highlights crisp).
pub const DEFAULT_LIGHT_RADIUS: f32 = 0.05;

impl Light {
    pub fn new(kind: LightKind) -> Self {
        Self { kind, color: Vec3::ONE, intensity: 1.0, target: None, direction: None, radius: DEFAULT_LIGHT_RADIUS, visible: false }
    }
}
