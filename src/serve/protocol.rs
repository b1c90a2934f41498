//! What the page and the server say to each other over the WebSocket.
//!
//! - **Page → server**: JSON text messages ([`ClientMessage`]), each an edit of the session's
//!   state ([`ViewState`]): the camera, a light, the time, the layer shown, exposure and tone
//!   mapping, or a request for the next frame's HDR data. An edit may carry an `id`; the frame
//!   rendered from a state echoes the id of the newest edit in it (`input`), so a client can tell
//!   when its last move is on screen.
//! - **Server → page**: JSON text events (`scene`: the scene's camera, lights and clock after
//!   each load; `error`: a Lua, shader or asset error, with file:line, the last good frame staying
//!   on screen; `ok`: the error is fixed) and binary frames: a little-endian `u32` header length,
//!   the JSON [`FrameHeader`], then the payload — JPEG strips of rows, one after another (the
//!   header's `strips` say where each goes), or (`kind: "hdr"`) the layer's linear `f32` values,
//!   `channels` per pixel, rows top to bottom.

use std::collections::BTreeMap;

use glam::{Quat, Vec3};
use serde::{Deserialize, Serialize};

use crate::frame::{CameraDesc, FrameDesc, LightDesc, LightShape};
use crate::output::png::ToneMap;
use crate::scene::look_rotation;

/// Largest WebSocket message the server reads from a page, bytes.
pub const MAX_MESSAGE_BYTES: usize = 16 * 1024;

/// A camera placed by the page: where it is, what it looks at, its vertical field of view.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CameraPose {
    pub position: [f32; 3],
    pub target: [f32; 3],
    /// Degrees.
    pub fov: f32,
}

/// The page's changes to one light; what is left out stays as the scene says.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LightEdit {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position: Option<[f32; 3]>,
    /// The direction the light travels (spot axis, sun direction, rect normal).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub direction: Option<[f32; 3]>,
    /// Times the scene's intensity.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub intensity: Option<f32>,
    /// Linear RGB, replacing the scene's colour (its brightest channel keeps the power).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub color: Option<[f32; 3]>,
}

/// Which layer the page shows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LayerChoice {
    #[default]
    Beauty,
    Caustic,
    Direct,
    Indirect,
    Volume,
    Depth,
    Alpha,
}

impl LayerChoice {
    /// Whether the frame needs every layer read back (the beauty pass alone is a fifth of that).
    pub fn needs_all_layers(self) -> bool {
        !matches!(self, LayerChoice::Beauty | LayerChoice::Alpha)
    }
}

/// How a frame is shown: the display transform, applied by the encoder (no re-render).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Display {
    pub layer: LayerChoice,
    /// Stops.
    pub exposure: f32,
    pub tonemap: ToneMap,
    /// JPEG quality, 1 to 100.
    pub quality: u8,
}

impl Default for Display {
    fn default() -> Self {
        Self { layer: LayerChoice::Beauty, exposure: 0.0, tonemap: ToneMap::Neutral, quality: 85 }
    }
}

/// What the renderer renders: the page's edits on top of the scene at a time.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ViewState {
    /// `None`: the scene's own camera.
    pub camera: Option<CameraPose>,
    pub lights: BTreeMap<String, LightEdit>,
    /// Seconds on the scene clock.
    pub time: f64,
    pub all_layers: bool,
    /// Values of the script's `refrakt.param`s set by the page (a change reloads the script).
    pub params: BTreeMap<String, f64>,
    /// The id of the newest edit in this state.
    pub input: u64,
    /// The session state's revision this is.
    pub revision: u64,
}

/// A message from the page.
#[derive(Clone, Debug, Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub enum ClientMessage {
    /// Place the camera (`null`: back to the scene's).
    Camera {
        #[serde(default)]
        id: u64,
        camera: Option<CameraPose>,
    },
    /// Edit a light by its node name (`reset`: forget the page's edits of it).
    Light {
        #[serde(default)]
        id: u64,
        name: String,
        #[serde(flatten)]
        edit: LightEdit,
        #[serde(default)]
        reset: bool,
    },
    /// Set a `refrakt.param` of the script (it is run again with the value).
    Param {
        #[serde(default)]
        id: u64,
        name: String,
        value: f64,
    },
    /// Show the scene at this time, seconds.
    Time {
        #[serde(default)]
        id: u64,
        time: f64,
    },
    /// Change how frames are shown.
    Display {
        #[serde(default)]
        id: u64,
        #[serde(flatten)]
        display: Display,
    },
    /// Send the shown frame's layer as linear floats, of `region` (x, y, width, height in
    /// pixels; the whole frame when left out), to this page alone.
    Hdr {
        #[serde(default)]
        region: Option<[u32; 4]>,
    },
    /// Step back over the last scene edit (camera, light, param): one gesture at a time.
    Undo,
    Redo,
    /// Send this page the scene edits as Lua (a `lua` event).
    Lua,
}

impl ClientMessage {
    /// The edit's id (0 when it has none).
    pub fn id(&self) -> u64 {
        match self {
            ClientMessage::Camera { id, .. }
            | ClientMessage::Light { id, .. }
            | ClientMessage::Param { id, .. }
            | ClientMessage::Time { id, .. }
            | ClientMessage::Display { id, .. } => *id,
            ClientMessage::Hdr { .. } | ClientMessage::Undo | ClientMessage::Redo | ClientMessage::Lua => 0,
        }
    }

    /// Checks the numbers a page sent: finite, and in range where a range applies.
    pub fn check(&self) -> Result<(), String> {
        let finite = |v: &[f32]| v.iter().all(|x| x.is_finite());
        match self {
            ClientMessage::Camera { camera: Some(c), .. } => {
                if !finite(&c.position) || !finite(&c.target) || !(1.0..=170.0).contains(&c.fov) {
                    return Err("camera: position and target must be finite and fov from 1 to 170 degrees".into());
                }
                if Vec3::from(c.position).distance(Vec3::from(c.target)) < 1e-6 {
                    return Err("camera: position and target are the same point".into());
                }
            }
            ClientMessage::Light { name, edit, .. } => {
                let ok = edit.position.is_none_or(|p| finite(&p))
                    && edit.direction.is_none_or(|d| finite(&d) && Vec3::from(d).length() > 1e-6)
                    && edit.intensity.is_none_or(|i| i.is_finite() && (0.0..=1e6).contains(&i))
                    && edit.color.is_none_or(|c| finite(&c) && c.iter().all(|&x| (0.0..=1e3).contains(&x)));
                if !ok || name.len() > 256 {
                    return Err(format!("light {name:?}: position and direction must be finite, intensity from 0 to 1e6, colour channels from 0 to 1000"));
                }
            }
            ClientMessage::Param { name, value, .. } if !value.is_finite() || name.is_empty() || name.len() > 64 => {
                return Err("param: a name of 1 to 64 characters and a finite value".into());
            }
            ClientMessage::Time { time, .. } if !time.is_finite() => return Err("time must be finite".into()),
            ClientMessage::Display { display, .. } if !display.exposure.is_finite() || !(1..=100).contains(&display.quality) => {
                return Err("display: exposure must be finite and quality from 1 to 100".into());
            }
            ClientMessage::Hdr { region: Some([_, _, w, h]) } if *w == 0 || *h == 0 => return Err("hdr: an empty region".into()),
            _ => {}
        }
        Ok(())
    }
}

impl CameraPose {
    /// The pose of a scene camera: its target is on its axis, at the distance of `focus`'s
    /// projection (at least 0.1 m).
    pub fn of(camera: &CameraDesc, focus: Vec3) -> Self {
        let forward = camera.forward();
        let distance = (focus - camera.position).dot(forward).max(0.1);
        Self { position: camera.position.into(), target: (camera.position + distance * forward).into(), fov: camera.fov_y.to_degrees() }
    }

    /// Puts this pose on `camera` (the image size stays), oriented as `r.camera{target=…}` is.
    pub fn apply(&self, camera: &mut CameraDesc) {
        let (position, target) = (Vec3::from(self.position), Vec3::from(self.target));
        camera.position = position;
        camera.orientation = look_rotation((target - position).normalize_or(Vec3::NEG_Z), Vec3::Y);
        camera.fov_y = self.fov.to_radians();
    }
}

impl LightEdit {
    pub fn apply(&self, light: &mut LightDesc) {
        if let Some(p) = self.position {
            light.position = p.into();
        }
        if let Some(d) = self.direction {
            let d = Vec3::from(d).normalize();
            let turn = Quat::from_rotation_arc(light.direction, d);
            (light.direction, light.right, light.up) = (d, turn * light.right, turn * light.up);
        }
        let power = light.radiant.max_element();
        if let Some(c) = self.color {
            let c = Vec3::from(c);
            light.radiant = if c.max_element() > 0.0 { c / c.max_element() * power } else { Vec3::ZERO };
        }
        if let Some(k) = self.intensity {
            light.radiant *= k;
        }
    }
}

impl ViewState {
    /// Applies the state's edits to a frame of the scene.
    pub fn apply(&self, desc: &mut FrameDesc) {
        if let Some(pose) = &self.camera {
            pose.apply(&mut desc.camera);
        }
        for light in &mut desc.lights {
            if let Some(edit) = self.lights.get(&light.name) {
                edit.apply(light);
            }
        }
    }
}

/// A light as the page is told of it.
#[derive(Clone, Debug, Serialize)]
pub struct LightInfo {
    pub name: String,
    pub kind: &'static str,
    pub position: [f32; 3],
    pub direction: [f32; 3],
    /// Linear RGB of the scene's colour, brightest channel 1.
    pub color: [f32; 3],
}

impl LightInfo {
    pub fn of(light: &LightDesc) -> Self {
        let kind = match light.shape {
            LightShape::Point => "point",
            LightShape::Spot { .. } => "spot",
            LightShape::Sun { .. } => "sun",
            LightShape::Rect { round: false, .. } => "rect",
            LightShape::Rect { round: true, .. } => "disk",
            LightShape::Mesh { .. } => "mesh",
        };
        let max = light.radiant.max_element();
        let color = if max > 0.0 { light.radiant / max } else { Vec3::ONE };
        Self { name: light.name.clone(), kind, position: light.position.into(), direction: light.direction.into(), color: color.into() }
    }
}

/// The `scene` event: what the page needs to draw its controls.
#[derive(Clone, Debug, Serialize)]
pub struct SceneInfo {
    pub name: String,
    pub camera: CameraPose,
    pub size: [u32; 2],
    pub lights: Vec<LightInfo>,
    pub animated: bool,
    /// The animation's length, seconds: the scene's `duration`, else its glTF clips' (`None`:
    /// not known; the page's time slider then spans 10 s).
    pub duration: Option<f64>,
    pub fps: f64,
    /// The script's `refrakt.param`s, with the values in use.
    pub params: Vec<crate::lua::params::Param>,
    /// The centre of the volume box: what the page orbits around first.
    pub focus: [f32; 3],
    /// The camera's thin lens, where it has one (kept as the page orbits).
    pub lens: Option<LensInfo>,
}

/// A camera's thin lens and lens shift as the page is told of them (`r.camera`'s fields and
/// units).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct LensInfo {
    pub aperture: f32,
    pub focus: f32,
    pub blades: u32,
    /// Degrees.
    pub blade_rotation: f32,
    /// Fractions of the frame's larger side.
    pub shift: [f32; 2],
}

impl LensInfo {
    pub fn of(camera: &CameraDesc) -> Option<Self> {
        (camera.aperture > 0.0 || camera.shift != glam::Vec2::ZERO).then(|| Self {
            aperture: camera.aperture,
            focus: camera.focus,
            blades: camera.blades,
            blade_rotation: camera.blade_rotation.to_degrees(),
            shift: camera.shift.into(),
        })
    }
}

/// Where a frame's time went, milliseconds (GPU stages from timestamp queries where the
/// adapter has them).
#[derive(Clone, Debug, Default, Serialize)]
pub struct FrameTimes {
    /// Evaluating the scene (Lua `update`, the frame description).
    pub scene_ms: f64,
    /// From submission until the GPU finished.
    pub render_ms: f64,
    /// Copying the image back to the host.
    pub readback_ms: f64,
    /// Display transform and JPEG encoding.
    pub encode_ms: f64,
    pub gpu: Vec<(String, f64)>,
}

/// The JSON header of a binary frame message.
#[derive(Clone, Debug, Serialize)]
pub struct FrameHeader {
    /// `"jpeg"` or `"hdr"`.
    pub kind: &'static str,
    /// Rendered frames so far (a re-encode of the same frame keeps its number).
    pub frame: u64,
    /// The id of the newest page edit this frame shows.
    pub input: u64,
    pub width: u32,
    pub height: u32,
    pub layer: LayerChoice,
    /// Values per pixel of an `hdr` payload.
    pub channels: u32,
    /// A `jpeg` payload's strips, one after another: (first row, rows, bytes) each.
    pub strips: Vec<[u32; 3]>,
    /// An `hdr` payload's pixels: (x, y, width, height) of the frame.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub region: Option<[u32; 4]>,
    /// Camera rays per pixel so far (a still view refines: it rises frame by frame).
    pub samples: u32,
    /// The revision of the session's state the frame shows ([`super::state::StateMessage`]).
    pub revision: u64,
    pub time: f64,
    /// Which stages were taken from the frame before: `volume`, `photons`.
    pub reused: crate::pipeline::reuse::Reuse,
    pub times: FrameTimes,
    /// When the frame was ready to send, microseconds since the Unix epoch (delivery time is
    /// the receiver's clock minus this, on one machine).
    pub ready_us: u64,
}

/// A header and its payload as one binary message.
pub fn frame_message(header: &FrameHeader, payload: &[u8]) -> Vec<u8> {
    let json = serde_json::to_vec(header).unwrap_or_default();
    let mut out = Vec::with_capacity(4 + json.len() + payload.len());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(&json);
    out.extend_from_slice(payload);
    out
}

/// Splits a binary frame message into its JSON header and payload.
pub fn split_frame_message(bytes: &[u8]) -> Option<(serde_json::Value, &[u8])> {
    let len = u32::from_le_bytes(bytes.get(..4)?.try_into().ok()?) as usize;
    let header = serde_json::from_slice(bytes.get(4..4 + len)?).ok()?;
    Some((header, &bytes[4 + len..]))
}
