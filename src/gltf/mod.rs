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
pub mod framing;
mod layers;
pub mod material;
pub mod mesh;
pub mod meshopt;
pub mod nodes;
pub mod player;
pub mod pointer;

use std::path::{Path, PathBuf};

use anyhow::{Result, anyhow, bail};
use glam::Vec3;

use crate::lua::sandbox::FileAccess;
use crate::scene::environment::{self, Environment, EnvironmentSource};
use crate::scene::{Fog, Node, Scene, Shared, VolumeSettings, by_name_or_index, shared};
use crate::warnings::{Collector, Warning};
pub use player::Player;

/// What to take from a file with several scenes or animations.
#[derive(Clone, Debug, Default)]
pub struct ImportOptions {
    /// `--scene NAME|INDEX`: the scene of that name, else of that index (default: the file's
    /// `scene`, else the first).
    pub scene: Option<String>,
    /// `--animation NAME|INDEX`: only the animation of that name, else of that index (default:
    /// all of them at once).
    pub animation: Option<String>,
    /// `--variant NAME|INDEX`: the KHR_materials_variants variant whose materials the meshes
    /// take (default: the primitives' own materials).
    pub variant: Option<String>,
    /// `--size WxH`: the image a file without a camera is framed for (its aspect ratio).
    pub size: Option<(u32, u32)>,
    /// `--environment` is given: a file without an environment is not lit by the studio preset
    /// (the command line's environment replaces the scene's when it is evaluated).
    pub environment_given: bool,
}

/// The scenes and animations a file has, by index, and which were taken — what `refrakt dump`
/// lists so unnamed ones can be chosen by index.
#[derive(Clone, Debug, Default)]
pub struct Catalog {
    pub scenes: Vec<Option<String>>,
    /// The imported scene (`None`: the file has no scenes, so every root node was taken).
    pub scene: Option<usize>,
    pub animations: Vec<Option<String>>,
    /// The animation that plays (`None`: all of them).
    pub animation: Option<usize>,
    /// KHR_materials_variants' variants, and the one taken.
    pub variants: Vec<Option<String>>,
    pub variant: Option<usize>,
}

/// A glTF scene made into refrakt nodes.
pub struct Import {
    /// The glTF scene's name, else the file's stem.
    pub name: String,
    pub roots: Vec<Shared<Node>>,
    /// refrakt's scene settings from `scenes[i].extras.refrakt`.
    pub settings: Settings,
    pub player: Player,
    pub catalog: Catalog,
    /// Things the user should hear about: ignored extensions, approximations (each once).
    pub warnings: Vec<Warning>,
}

/// Scene-wide settings a glTF scene may carry; each `None` leaves refrakt's default.
#[derive(Default)]
pub struct Settings {
    pub photons: Option<u32>,
    pub bounces: Option<u32>,
    pub bounce_photons: Option<u32>,
    pub samples: Option<u32>,
    pub shutter: Option<f32>,
    pub motion_steps: Option<u32>,
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
        if let Some(b) = self.bounces {
            scene.bounces = b;
        }
        if self.bounce_photons.is_some() {
            scene.bounce_photons = self.bounce_photons;
        }
        if let Some(s) = self.samples {
            scene.samples = s;
        }
        if let Some(s) = self.shutter {
            scene.shutter = s;
        }
        if let Some(n) = self.motion_steps {
            scene.motion_steps = n;
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
    s.contact = v.contact.unwrap_or(s.contact);
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
    let (json, pointers) = pointer::split(container.json, shown)?;
    let doc = document::parse(&json, shown)?;
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new(".")).to_path_buf();
    let at = buffers::Location { file: shown, dir: &dir, access };
    let mut buffers = buffers::load_buffers(&doc, container.bin, &at)?;
    let doc = meshopt::decompress(doc, &mut buffers, shown)?;
    let acc = accessor::Accessors { root: doc.as_json(), buffers: &buffers, file: shown };

    let mut warnings = Collector::new(shown);
    for e in document::ignored_extensions(&doc) {
        warnings.file_wide(format!("the glTF extension {e} is not supported by refrakt; what it adds is ignored"));
    }
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
    let variants: Vec<Option<&str>> = doc.variants().into_iter().flatten().map(|v| Some(v.name())).collect();
    let variant = match &opts.variant {
        Some(chosen) => Some(by_name_or_index(&variants, chosen).ok_or_else(|| {
            anyhow!("{shown}: there is no material variant called \"{chosen}\" and none of that index (variants: {})", catalog(&variants))
        })?),
        None => None,
    };
    let materials = material::Materials::new(&doc, &buffers, &at);
    let graph = nodes::build(&doc, &acc, materials, &roots, variant, &mut warnings)?;
    let clips = clips(&doc, &pointers, &acc, &graph, opts.animation.as_deref(), shown, &mut warnings)?;
    let animations: Vec<Option<&str>> = doc.animations().map(|a| a.name()).collect();
    let catalog = Catalog {
        scenes: doc.scenes().map(|s| s.name().map(str::to_string)).collect(),
        scene: scene.as_ref().map(|s| s.index()),
        animation: opts.animation.as_deref().and_then(|a| by_name_or_index(&animations, a)),
        animations: animations.iter().map(|a| a.map(str::to_string)).collect(),
        variants: variants.iter().map(|v| v.map(str::to_string)).collect(),
        variant,
    };
    let name = scene.and_then(|s| s.name().map(str::to_string)).unwrap_or_else(|| {
        path.file_stem().map_or_else(|| "gltf".to_string(), |s| s.to_string_lossy().to_string())
    });
    let player = Player::new(graph.nodes, clips, graph.weights, graph.deformables).with_animated(graph.animated);
    Ok(Import { name, roots: graph.roots, settings, player, catalog, warnings: warnings.into_warnings() })
}

/// §3.5.3: the scene `--scene` names (by name, else by index), else the file's `scene`, else
/// the first one.
fn choose_scene<'a>(doc: &'a gltf::Document, chosen: Option<&str>, file: &str) -> Result<Option<gltf::Scene<'a>>> {
    let Some(chosen) = chosen else { return Ok(doc.default_scene().or_else(|| doc.scenes().next())) };
    let names: Vec<Option<&str>> = doc.scenes().map(|s| s.name()).collect();
    match by_name_or_index(&names, chosen) {
        Some(i) => Ok(doc.scenes().nth(i)),
        None => bail!("{file}: there is no scene called \"{chosen}\" and no scene of that index (scenes: {})", catalog(&names)),
    }
}

/// `0 "Walk", 1 (unnamed)` — what `--scene` / `--animation` can name, for messages.
pub fn catalog(names: &[Option<&str>]) -> String {
    if names.is_empty() {
        return "none".into();
    }
    let items: Vec<String> =
        names.iter().enumerate().map(|(i, n)| n.map_or_else(|| format!("{i} (unnamed)"), |n| format!("{i} \"{n}\""))).collect();
    items.join(", ")
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
    pointers: &[pointer::PointerChannel],
    acc: &accessor::Accessors,
    graph: &nodes::Graph,
    name: Option<&str>,
    file: &str,
    warnings: &mut Collector,
) -> Result<Vec<animation::Clip>> {
    let chosen: Vec<gltf::Animation> = match name {
        Some(name) => {
            let names: Vec<Option<&str>> = doc.animations().map(|a| a.name()).collect();
            match by_name_or_index(&names, name) {
                Some(i) => doc.animations().skip(i).take(1).collect(),
                None => bail!("{file}: there is no animation called \"{name}\" and no animation of that index (animations: {})", catalog(&names)),
            }
        }
        None => doc.animations().collect(),
    };
    let counts = [doc.nodes().count(), doc.lights().map_or(0, |l| l.count()), doc.cameras().count(), doc.materials().count()];
    let clips = animation::read_clips(chosen, pointers, acc, counts, |n| graph.weights[n].len(), warnings)?;
    for message in overlaps(&clips) {
        warnings.file_wide(message);
    }
    Ok(clips)
}

/// One warning per pair of animations that drive the same properties (all play at once, and
/// the later one in the file wins), counting what they share.
fn overlaps(clips: &[animation::Clip]) -> Vec<String> {
    /// Two animations (earlier, later) that drive `shared` properties, the first on `node`.
    struct Overlap {
        clips: (usize, usize),
        shared: usize,
        node: usize,
        target: animation::Target,
    }
    let mut driven_by = std::collections::HashMap::new();
    let mut pairs: Vec<Overlap> = Vec::new();
    for (k, clip) in clips.iter().enumerate() {
        for c in &clip.channels {
            match driven_by.insert((c.node, c.target), k) {
                Some(first) if first != k => match pairs.iter_mut().find(|p| p.clips == (first, k)) {
                    Some(p) => p.shared += 1,
                    None => pairs.push(Overlap { clips: (first, k), shared: 1, node: c.node, target: c.target }),
                },
                _ => {}
            }
        }
    }
    pairs
        .into_iter()
        .map(|Overlap { clips: (a, b), shared: n, node, target }| {
            let more = if n > 1 { format!(" and {} more propert{}", n - 1, if n == 2 { "y" } else { "ies" }) } else { String::new() };
            format!(
                "animations \"{}\" and \"{}\" both drive the {} of {}[{node}]{more}; all animations play at once \
                 and the later wins (pick one with --animation NAME or INDEX)",
                clips[a].name,
                clips[b].name,
                target.plain(),
                target.owners()
            )
        })
        .collect()
}

/// `scenes[i].extras.refrakt`, with the environment image loaded.
fn settings(scene: &gltf::Scene, at: &buffers::Location, warnings: &mut Collector) -> Result<Settings> {
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
    Ok(Settings {
        photons: x.photons,
        bounces: x.bounces,
        bounce_photons: x.bounce_photons,
        samples: x.samples,
        shutter: x.shutter,
        motion_steps: x.motion_steps,
        volume: x.volume,
        environment,
        fog,
    })
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
    env.tilt = e.tilt.map_or(env.tilt, |q| glam::Quat::from_array(q).normalize());
    env.visible = e.visible.unwrap_or(env.visible);
    Ok(env)
}
