//! glTF 2.0 import: a `.gltf` (with external or embedded buffers) or `.glb` file becomes a
//! subtree of refrakt's scene graph — nodes, meshes, materials, cameras and lights — plus a
//! [`Player`] that animates it on the scene clock (translation, rotation, scale and morph
//! weights channels; skinned and morphed meshes deformed on the CPU). refrakt's own settings
//! travel in `extras.refrakt` (docs/gltf.md).
//!
//! Everything a file claims is checked against what it holds before it is used: a damaged or
//! hostile file gets a one-paragraph error naming the file and the part of it that is wrong.

pub mod accessor;
pub mod animation;
pub mod buffers;
pub mod document;
pub mod extras;
pub mod material;
pub mod mesh;
pub mod nodes;
pub mod player;

use std::path::{Path, PathBuf};

use anyhow::{Result, anyhow, bail};
use glam::Vec3;

use crate::lua::sandbox::FileAccess;
use crate::scene::environment::{self, Environment, EnvironmentSource};
use crate::scene::{Fog, Node, Scene, Shared, VolumeSettings, shared};
pub use player::Player;

/// What to take from a file with several scenes or animations.
#[derive(Clone, Debug, Default)]
pub struct ImportOptions {
    /// `--scene NAME`: the scene of that name (default: the file's `scene`, else the first).
    pub scene: Option<String>,
    /// `--animation NAME`: only the animation of that name (default: all of them at once).
    pub animation: Option<String>,
}

/// A glTF scene made into refrakt nodes.
pub struct Import {
    /// The glTF scene's name, else the file's stem.
    pub name: String,
    pub roots: Vec<Shared<Node>>,
    /// refrakt's scene settings from `scenes[i].extras.refrakt`.
    pub settings: Settings,
    pub player: Player,
    /// Things the user should hear about: ignored extensions, approximations.
    pub warnings: Vec<String>,
}

/// Scene-wide settings a glTF scene may carry; each `None` leaves refrakt's default.
#[derive(Default)]
pub struct Settings {
    pub photons: Option<u32>,
    pub samples: Option<u32>,
    pub volume: Option<extras::VolumeExtras>,
    pub environment: Option<Environment>,
    pub fog: Option<Fog>,
}

impl Settings {
    /// Puts the settings on `scene` (the volume field by field over its current settings).
    pub fn apply(&self, scene: &mut Scene) {
        if let Some(p) = self.photons {
            scene.photons = p;
        }
        if let Some(s) = self.samples {
            scene.samples = s;
        }
        if let Some(v) = &self.volume {
            let mut s = scene.volume.borrow_mut();
            apply_volume(&mut s, v);
        }
        if let Some(e) = &self.environment {
            scene.environment = shared(e.clone());
        }
        if let Some(f) = &self.fog {
            scene.fog = Some(shared(f.clone()));
        }
    }
}

fn apply_volume(s: &mut VolumeSettings, v: &extras::VolumeExtras) {
    s.resolution = v.resolution.unwrap_or(s.resolution);
    s.margin = v.margin.unwrap_or(s.margin);
    s.boundary = v.boundary.unwrap_or(s.boundary);
    s.step = v.step.unwrap_or(s.step);
    if let (Some(lo), Some(hi)) = (v.min, v.max) {
        s.bounds = Some((Vec3::from(lo), Vec3::from(hi)));
    }
}

/// Imports the glTF file at `path` (already resolved and allowed by `access`; `shown` is how
/// messages name it). Buffers and images it names are read through `access`, relative to the
/// file's folder.
pub fn import(path: &Path, shown: &str, access: &FileAccess, opts: &ImportOptions) -> Result<Import> {
    let bytes = std::fs::read(path).map_err(|e| anyhow!("cannot read the glTF file {shown}: {e}"))?;
    access.record(&path.canonicalize().unwrap_or_else(|_| path.to_path_buf()));
    let binary = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("glb"));
    let container = document::container(&bytes, shown, binary)?;
    let doc = document::parse(container.json, shown)?;
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new(".")).to_path_buf();
    let at = buffers::Location { file: shown, dir: &dir, access };
    let buffers = buffers::load_buffers(&doc, container.bin, &at)?;
    let acc = accessor::Accessors { root: doc.as_json(), buffers: &buffers, file: shown };

    let mut warnings: Vec<String> = document::ignored_extensions(&doc)
        .into_iter()
        .map(|e| format!("{shown}: the glTF extension {e} is not supported by refrakt; what it adds is ignored"))
        .collect();
    let scene = choose_scene(&doc, opts.scene.as_deref(), shown)?;
    let roots: Vec<usize> = match &scene {
        Some(s) => s.nodes().map(|n| n.index()).collect(),
        // §3.5.3: with no scene, nothing is required to render; refrakt takes every root node.
        None => root_nodes(&doc),
    };
    let settings = match &scene {
        Some(s) => settings(s, &at, &mut warnings)?,
        None => Settings::default(),
    };
    let materials = material::Materials::new(&doc, &buffers, &at);
    let graph = nodes::build(&doc, &acc, materials, &roots, &mut warnings)?;
    let clips = clips(&doc, &acc, &graph, opts.animation.as_deref(), shown, &mut warnings)?;
    let name = scene.and_then(|s| s.name().map(str::to_string)).unwrap_or_else(|| {
        path.file_stem().map_or_else(|| "gltf".to_string(), |s| s.to_string_lossy().to_string())
    });
    let player = Player::new(graph.nodes, clips, graph.weights, graph.deformables);
    Ok(Import { name, roots: graph.roots, settings, player, warnings })
}

/// §3.5.3: the scene named by `--scene`, else the file's `scene`, else the first one.
fn choose_scene<'a>(doc: &'a gltf::Document, name: Option<&str>, file: &str) -> Result<Option<gltf::Scene<'a>>> {
    let Some(name) = name else { return Ok(doc.default_scene().or_else(|| doc.scenes().next())) };
    if let Some(s) = doc.scenes().find(|s| s.name() == Some(name)) {
        return Ok(Some(s));
    }
    let names: Vec<String> = doc.scenes().map(|s| s.name().map_or_else(|| format!("(unnamed scenes[{}])", s.index()), |n| format!("\"{n}\""))).collect();
    bail!("{file}: there is no scene called \"{name}\" (scenes: {})", if names.is_empty() { "none".into() } else { names.join(", ") })
}

fn root_nodes(doc: &gltf::Document) -> Vec<usize> {
    let mut is_child = vec![false; doc.nodes().count()];
    for n in doc.nodes() {
        for c in n.children() {
            is_child[c.index()] = true;
        }
    }
    (0..is_child.len()).filter(|&i| !is_child[i]).collect()
}

/// The animations that play: the one named by `--animation`, else all of them (warning when
/// two of them drive the same property, where the later one wins).
fn clips(
    doc: &gltf::Document,
    acc: &accessor::Accessors,
    graph: &nodes::Graph,
    name: Option<&str>,
    file: &str,
    warnings: &mut Vec<String>,
) -> Result<Vec<animation::Clip>> {
    let chosen: Vec<gltf::Animation> = match name {
        Some(name) => {
            let hit: Vec<_> = doc.animations().filter(|a| a.name() == Some(name)).take(1).collect();
            if hit.is_empty() {
                let names: Vec<String> = doc.animations().map(|a| format!("\"{}\"", a.name().unwrap_or("(unnamed)"))).collect();
                bail!("{file}: there is no animation called \"{name}\" (animations: {})", if names.is_empty() { "none".into() } else { names.join(", ") });
            }
            hit
        }
        None => doc.animations().collect(),
    };
    let clips = animation::read_clips(chosen, acc, |n| graph.weights[n].len())?;
    let mut driven = std::collections::HashMap::new();
    for clip in &clips {
        for c in &clip.channels {
            if let Some(first) = driven.insert((c.node, c.target), clip.name.clone())
                && first != clip.name
            {
                warnings.push(format!(
                    "{file}: animations \"{first}\" and \"{}\" both drive the {:?} of nodes[{}]; all animations play \
                     at once and the later wins (pick one with --animation NAME)",
                    clip.name, c.target, c.node
                ));
            }
        }
    }
    Ok(clips)
}

/// `scenes[i].extras.refrakt`, with the environment image loaded.
fn settings(scene: &gltf::Scene, at: &buffers::Location, warnings: &mut Vec<String>) -> Result<Settings> {
    let Some(x) = extras::scene_extras(scene, at.file, warnings)? else { return Ok(Settings::default()) };
    let environment = match &x.environment {
        Some(e) => Some(environment_of(e, at)?),
        None => None,
    };
    let fog = x.fog.as_ref().map(|f| Fog {
        scattering: f.scattering.map_or(Fog::default().scattering, Vec3::from),
        absorption: f.absorption.map_or(Vec3::ZERO, Vec3::from),
        g: f.g.unwrap_or(0.0),
    });
    Ok(Settings { photons: x.photons, samples: x.samples, volume: x.volume, environment, fog })
}

fn environment_of(e: &extras::EnvironmentExtras, at: &buffers::Location) -> Result<Environment> {
    let mut env = Environment::default();
    if let Some(c) = e.color {
        env.source = EnvironmentSource::Color(Vec3::from(c));
    }
    if let Some(image) = &e.image {
        let path = at.access.resolve_in(at.dir, image).map_err(|m| anyhow!("{}: the environment image: {m}", at.file))?;
        let loaded = environment::load_image(&path).map_err(|e| anyhow!("{}: {e:#}", at.file))?;
        env.source = EnvironmentSource::Image { path: PathBuf::from(image), image: loaded.into() };
    }
    if let Some(p) = &e.preset {
        let image = environment::preset(p).map_err(|e| anyhow!("{}: environment.preset: {e}", at.file))?;
        env.source = EnvironmentSource::Preset { name: p.clone(), image };
    }
    env.intensity = e.intensity.unwrap_or(env.intensity);
    env.rotation = e.rotation.map_or(env.rotation, f32::to_radians);
    env.visible = e.visible.unwrap_or(env.visible);
    Ok(env)
}
