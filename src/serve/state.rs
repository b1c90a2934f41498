//! The one truth of a `refrakt serve` session: what every page shows ([`PageState`]: the
//! camera, the light edits, the time, the `refrakt.param` values, the layer and display), the
//! names the scene defines (edits of other names are refused, so nothing a page sends can grow
//! the server's maps), and the undo history of the scene edits.
//!
//! Pages send edits; the server merges each into this state and echoes the whole state to every
//! page ([`StateMessage`]), so two pages, or a page reloaded, show what the frame shows. The
//! renderer and the encoder read their parts of it ([`PageState::view`], `display`).

use std::collections::{BTreeMap, BTreeSet};
use std::time::{Duration, Instant};

use serde::Serialize;

use super::protocol::{CameraPose, ClientMessage, Display, LightEdit, SceneInfo, ViewState};

/// The scene edits of a state: camera, lights, params.
type Edits = (Option<CameraPose>, BTreeMap<String, LightEdit>, BTreeMap<String, f64>);

/// What every page shows.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct PageState {
    /// `None`: the scene's own camera.
    pub camera: Option<CameraPose>,
    pub lights: BTreeMap<String, LightEdit>,
    /// Seconds on the scene clock.
    pub time: f64,
    pub params: BTreeMap<String, f64>,
    pub display: Display,
}

impl PageState {
    /// What the renderer renders of this state; `input`: the id of the newest edit in it.
    pub fn view(&self, input: u64, revision: u64) -> ViewState {
        ViewState {
            revision,
            camera: self.camera,
            lights: self.lights.clone(),
            time: self.time,
            all_layers: self.display.layer.needs_all_layers(),
            params: self.params.clone(),
            input,
        }
    }

    /// The scene edits (what undo steps through and "copy scene edits as Lua" exports).
    fn edits(&self) -> Edits {
        (self.camera, self.lights.clone(), self.params.clone())
    }

    fn restore(&mut self, (camera, lights, params): Edits) {
        (self.camera, self.lights, self.params) = (camera, lights, params);
    }
}

/// The names a scene defines: edits of others are refused.
#[derive(Clone, Debug, Default)]
pub struct SceneNames {
    pub lights: BTreeSet<String>,
    /// Each `refrakt.param`'s range.
    pub params: BTreeMap<String, (f64, f64)>,
}

impl SceneNames {
    pub fn of(info: &SceneInfo) -> Self {
        Self { lights: info.lights.iter().map(|l| l.name.clone()).collect(), params: info.params.iter().map(|p| (p.name.clone(), (p.min, p.max))).collect() }
    }
}

/// Undo steps kept.
const HISTORY: usize = 100;
/// Edits of one thing closer together than this are one undo step (a drag is one gesture).
const GESTURE: Duration = Duration::from_millis(800);

/// The state as pages see it, with what made its last change.
#[derive(Clone, Debug, Serialize)]
pub struct StateMessage {
    #[serde(flatten)]
    pub state: PageState,
    /// Counts the changes.
    pub revision: u64,
    /// The connection whose edit made the last change (0: the server), and the edit's id.
    pub by: u64,
    pub id: u64,
    pub can_undo: bool,
    pub can_redo: bool,
}

/// The session's truth and its history.
pub struct Truth {
    pub state: PageState,
    pub revision: u64,
    pub by: u64,
    pub id: u64,
    /// The newest edit id of any page (the frame header's `input`).
    pub input: u64,
    names: Option<SceneNames>,
    past: Vec<Edits>,
    future: Vec<Edits>,
    /// What the last edit changed and when: edits of the same thing soon after join its step.
    gesture: Option<(String, Instant)>,
}

impl Truth {
    pub fn new(state: PageState) -> Self {
        Self { state, revision: 0, by: 0, id: 0, input: 0, names: None, past: Vec::new(), future: Vec::new(), gesture: None }
    }

    pub fn message(&self) -> StateMessage {
        StateMessage { state: self.state.clone(), revision: self.revision, by: self.by, id: self.id, can_undo: !self.past.is_empty(), can_redo: !self.future.is_empty() }
    }

    /// A scene (re)loaded: its names are now the ones edits may use; edits of names it no longer
    /// has are dropped. Returns whether the state changed.
    pub fn scene_loaded(&mut self, info: &SceneInfo) -> bool {
        let names = SceneNames::of(info);
        let before = self.state.clone();
        self.state.lights.retain(|name, _| names.lights.contains(name));
        self.state.params.retain(|name, _| names.params.contains_key(name));
        self.names = Some(names);
        let changed = before != self.state;
        if changed {
            self.changed(0, 0);
        }
        changed
    }

    /// Merges one checked message from connection `by` (`Hdr` is not a state change); the
    /// reason when it cannot be taken.
    pub fn apply(&mut self, message: &ClientMessage, by: u64) -> Result<(), String> {
        let id = message.id();
        match message {
            ClientMessage::Camera { camera, .. } => {
                self.checkpoint("camera");
                self.state.camera = *camera;
            }
            ClientMessage::Light { name, edit, reset, .. } => {
                self.names()?.lights.get(name).ok_or_else(|| format!("light {name:?}: the scene has no light of that name"))?;
                self.checkpoint(&format!("light:{name}"));
                if *reset {
                    self.state.lights.remove(name);
                } else {
                    let e = self.state.lights.entry(name.clone()).or_default();
                    e.position = edit.position.or(e.position);
                    e.direction = edit.direction.or(e.direction);
                    e.intensity = edit.intensity.or(e.intensity);
                    e.color = edit.color.or(e.color);
                }
            }
            ClientMessage::Param { name, value, .. } => {
                let range = *self.names()?.params.get(name).ok_or_else(|| format!("param {name:?}: the scene has no param of that name"))?;
                self.checkpoint(&format!("param:{name}"));
                self.state.params.insert(name.clone(), value.clamp(range.0, range.1)); // as the script's r.param clamps
            }
            ClientMessage::Time { time, .. } => self.state.time = *time,
            ClientMessage::Display { display, .. } => self.state.display = *display,
            ClientMessage::Undo => self.step(true)?,
            ClientMessage::Redo => self.step(false)?,
            ClientMessage::Hdr { .. } | ClientMessage::Lua => return Ok(()),
        }
        if id != 0 && !matches!(message, ClientMessage::Display { .. }) {
            self.input = id; // what the renderer renders changed (a display change re-encodes)
        }
        self.changed(by, id);
        Ok(())
    }

    /// The loaded scene's names.
    fn names(&self) -> Result<&SceneNames, String> {
        self.names.as_ref().ok_or_else(|| "the scene has not loaded yet".to_string())
    }

    /// Before an edit of `what`: a new undo step, unless it continues the last edit's gesture.
    fn checkpoint(&mut self, what: &str) {
        let now = Instant::now();
        let continues = self.gesture.as_ref().is_some_and(|(w, at)| w == what && now - *at < GESTURE);
        self.gesture = Some((what.to_string(), now));
        if continues {
            return;
        }
        self.past.push(self.state.edits());
        if self.past.len() > HISTORY {
            self.past.remove(0);
        }
        self.future.clear();
    }

    /// Undo (`back`) or redo one step.
    fn step(&mut self, back: bool) -> Result<(), String> {
        let (from, to) = if back { (&mut self.past, &mut self.future) } else { (&mut self.future, &mut self.past) };
        let snapshot = from.pop().ok_or(if back { "nothing to undo" } else { "nothing to redo" })?;
        to.push(self.state.edits());
        self.state.restore(snapshot);
        self.gesture = None;
        Ok(())
    }

    fn changed(&mut self, by: u64, id: u64) {
        self.revision += 1;
        (self.by, self.id) = (by, id);
    }

    /// The scene edits as Lua, for the page's "copy scene edits as Lua" (`info`: the scene as
    /// loaded, for the camera's image size and the lights' kinds).
    pub fn edits_lua(&self, info: &SceneInfo) -> String {
        edits_lua(&self.state, info)
    }
}

/// A number as Lua source, to 4 decimals.
fn round(x: f32) -> f64 {
    (x as f64 * 1e4).round() / 1e4
}

/// A camera's lens as `r.camera` fields after a comma: the thin lens where it has an aperture,
/// the shift where there is one.
fn lens_fields(l: &crate::serve::protocol::LensInfo) -> String {
    let mut out = String::new();
    if l.aperture > 0.0 {
        out += &format!(", aperture = {}, focus = {}, blades = {}, blade_rotation = {}", round(l.aperture), round(l.focus), l.blades, round(l.blade_rotation));
    }
    if l.shift != [0.0; 2] {
        out += &format!(", shift = {{{}, {}}}", round(l.shift[0]), round(l.shift[1]));
    }
    out
}

fn lua_vec(v: [f32; 3]) -> String {
    format!("{{{}, {}, {}}}", round(v[0]), round(v[1]), round(v[2]))
}

/// The edits as Lua lines to paste into the script after its lights are added (`scene:find`
/// and the fields the API has; a spot's or area light's new direction as its `target`, a metre
/// ahead), with the params' values as comments (a param's value is its declaration's default). Positions are the nodes' translations: exact
/// for lights on top-level nodes. A colour is written with its brightest channel 1 (the page's
/// colour keeps the light's power, as the scene's colour does when its brightest channel is 1).
pub fn edits_lua(state: &PageState, info: &SceneInfo) -> String {
    let mut out = vec![format!("-- refrakt serve: the page's edits of {}", info.name)];
    if let Some(c) = &state.camera {
        // The page orbits with the scene's lens as it is (its focus distance and shift too).
        let lens = info.lens.map_or(String::new(), |l| lens_fields(&l));
        out.push(format!(
            "scene.camera = r.camera{{ position = {}, target = {}, fov = {}, size = {{{}, {}}}{lens} }}",
            lua_vec(c.position),
            lua_vec(c.target),
            round(c.fov),
            info.size[0],
            info.size[1]
        ));
    }
    for (name, edit) in &state.lights {
        let Some(light) = info.lights.iter().find(|l| &l.name == name) else { continue };
        let node = format!("scene:find({name:?})");
        let position = edit.position.unwrap_or(light.position);
        if let Some(p) = edit.position {
            out.push(format!("{node}.translation = {}", lua_vec(p)));
        }
        if let Some(d) = edit.direction {
            let d = glam::Vec3::from(d).normalize_or_zero();
            out.push(match light.kind {
                "sun" => format!("{node}.light.direction = {}", lua_vec(d.into())),
                "point" => continue,
                _ => format!("{node}.light.target = {}", lua_vec((glam::Vec3::from(position) + d).into())),
            });
        }
        if let Some(k) = edit.intensity {
            out.push(format!("{node}.light.intensity = {node}.light.intensity * {}", round(k)));
        }
        if let Some(c) = edit.color {
            let c = glam::Vec3::from(c);
            let c = if c.max_element() > 0.0 { c / c.max_element() } else { c };
            out.push(format!("{node}.light.color = {}", lua_vec(c.into())));
        }
    }
    for (name, value) in &state.params {
        out.push(format!("-- r.param {name:?}: {value} on the page (make it the default to keep it)"));
    }
    out.join("\n")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::serve::protocol::LightInfo;

    fn info() -> SceneInfo {
        SceneInfo {
            name: "scene.lua".into(),
            camera: CameraPose { position: [0.0, 0.5, 3.0], target: [0.0; 3], fov: 35.0 },
            size: [64, 36],
            lights: vec![LightInfo { name: "key".into(), kind: "spot", position: [0.0, 2.0, 0.0], direction: [0.0, -1.0, 0.0], color: [1.0; 3] }],
            animated: false,
            duration: None,
            fps: 24.0,
            params: vec![crate::lua::params::Param { name: "red".into(), value: 0.2, default: 0.2, min: 0.0, max: 1.0, step: 0.01 }],
            focus: [0.0; 3],
            lens: Some(crate::serve::protocol::LensInfo { aperture: 0.02, focus: 2.5, blades: 6, blade_rotation: 15.0, shift: [0.1, -0.05] }),
        }
    }

    fn camera(x: f32) -> ClientMessage {
        ClientMessage::Camera { id: 1, camera: Some(CameraPose { position: [x, 0.5, 3.0], target: [0.0; 3], fov: 35.0 }) }
    }

    #[test]
    fn names_the_scene_lacks_are_refused_and_a_reload_drops_them() {
        let mut t = Truth::new(PageState::default());
        let light = |name: &str| ClientMessage::Light { id: 2, name: name.into(), edit: LightEdit { intensity: Some(2.0), ..Default::default() }, reset: false };
        assert!(t.apply(&light("key"), 1).unwrap_err().contains("not loaded"));
        t.scene_loaded(&info());
        t.apply(&light("key"), 1).unwrap();
        for i in 0..20_000 {
            assert!(t.apply(&light(&format!("nope{i}")), 1).is_err());
        }
        assert_eq!(t.state.lights.len(), 1);
        let param = |v| ClientMessage::Param { id: 3, name: "red".into(), value: v };
        t.apply(&param(0.5), 1).unwrap();
        t.apply(&param(1.5), 1).unwrap();
        assert_eq!(t.state.params["red"], 1.0, "clamped to its range, as r.param clamps");
        assert!(t.apply(&ClientMessage::Param { id: 3, name: "blue".into(), value: 0.5 }, 1).is_err());
        let mut other = info();
        other.lights.clear();
        other.params.clear();
        assert!(t.scene_loaded(&other));
        assert!(t.state.lights.is_empty() && t.state.params.is_empty());
    }

    #[test]
    fn undo_steps_back_over_gestures_and_redo_forward() {
        let mut t = Truth::new(PageState::default());
        t.scene_loaded(&info());
        t.apply(&camera(1.0), 1).unwrap();
        t.apply(&camera(1.5), 1).unwrap(); // the same drag
        t.gesture = None; // …a pause
        t.apply(&camera(2.0), 2).unwrap();
        let x = |t: &Truth| t.state.camera.map(|c| c.position[0]);
        assert_eq!(x(&t), Some(2.0));
        t.apply(&ClientMessage::Undo, 1).unwrap();
        assert_eq!(x(&t), Some(1.5));
        t.apply(&ClientMessage::Undo, 1).unwrap();
        assert_eq!(x(&t), None, "back to the scene's camera");
        assert!(t.apply(&ClientMessage::Undo, 1).is_err());
        t.apply(&ClientMessage::Redo, 1).unwrap();
        assert_eq!(x(&t), Some(1.5));
        assert!(t.message().can_redo && t.message().can_undo);
        // Time and display are not scene edits: undo passes them by.
        t.apply(&ClientMessage::Time { id: 0, time: 3.0 }, 1).unwrap();
        t.apply(&ClientMessage::Undo, 1).unwrap();
        assert_eq!((x(&t), t.state.time), (None, 3.0));
    }

    #[test]
    fn the_edits_as_lua_run_on_the_scene_they_came_from() {
        let mut t = Truth::new(PageState::default());
        t.scene_loaded(&info());
        t.apply(&camera(1.0), 1).unwrap();
        let edit = LightEdit { position: Some([0.5, 2.0, 0.25]), direction: Some([0.0, -1.0, 0.0]), intensity: Some(1.5), color: Some([1.0, 0.5, 0.25]) };
        t.apply(&ClientMessage::Light { id: 2, name: "key".into(), edit, reset: false }, 1).unwrap();
        t.apply(&ClientMessage::Param { id: 3, name: "red".into(), value: 0.5 }, 1).unwrap();
        let lua = t.edits_lua(&info());
        assert!(lua.contains(r#"scene:find("key").translation = {0.5, 2, 0.25}"#), "{lua}");
        assert!(lua.contains(r#"-- r.param "red": 0.5 on the page"#), "{lua}");
        let script = |edits: &str| {
            format!(
                "local r = require('refrakt')\nlocal scene = r.scene{{ camera = r.camera{{ position = {{0, 0.5, 3}}, target = {{0, 0, 0}}, size = {{64, 36}} }} }}\n\
                 scene:add(r.node{{ name = 'key', translation = {{0, 2, 0}}, light = r.spot{{ target = {{0, 0, 0}}, intensity = 100, color = {{0.2, 1, 0.2}} }} }})\n{edits}\nreturn scene\n"
            )
        };
        let dir = tempfile::tempdir().unwrap();
        let desc = |name: &str, source: String| {
            let path = dir.path().join(name);
            std::fs::write(&path, source).unwrap();
            let mut scene = crate::render::SceneOptions::for_bench(&Default::default(), &[]).load(&path).unwrap_or_else(|e| panic!("{e:#}"));
            scene.frame_desc(0.0, &Default::default()).unwrap()
        };
        let (base, edited) = (desc("base.lua", script("")), desc("edited.lua", script(&lua)));
        assert_eq!(edited.camera.position, glam::Vec3::new(1.0, 0.5, 3.0));
        let c = &edited.camera;
        assert_eq!((c.aperture, c.focus, c.blades, c.shift), (0.02, 2.5, 6, glam::Vec2::new(0.1, -0.05)), "the lens is kept: {lua}");
        let mut served = base.lights[0].clone();
        edit.apply(&mut served); // what the server renders
        let light = &edited.lights[0];
        assert_eq!(light.position, served.position);
        assert!(light.direction.distance(served.direction) < 1e-6, "{:?} vs {:?}", light.direction, served.direction);
        assert!((light.radiant - served.radiant).abs().max_element() < 1e-4 * served.radiant.max_element(), "{:?} vs {:?}", light.radiant, served.radiant);
    }
}
