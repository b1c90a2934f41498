//! Which stages a frame can skip because the GPU already holds their result.
//!
//! The volume stages (voxelize → gradient → octree) read only the volume box, the index fields,
//! the refractive meshes and the fog. The photon stages (photons → march → caustics) read, in
//! addition, the lights, the environment, the receivers, the photon budget and the render settings; what they
//! leave behind — the radiance grid and the caustic maps — does not depend on the camera. That
//! is the relighting idea of Sun et al. 2008: a new view of a lit scene costs only the view pass.
//!
//! Each group's inputs are kept as a key (cheap to hold: meshes and sampled fields are shared
//! `Arc`s) and compared by value with the next frame's, so a scene reloaded from an edited
//! script that evaluates to the same objects reuses them too. Objects enter a key without their
//! names and the script lines that made them: those are for messages, and change no voxel. Keys also hold the generations of
//! the GPU buffers the results live in, so a reallocation can never be mistaken for a hit.
//! Every stage is deterministic, so a frame that reuses a result is bit-identical to one that
//! recomputes it (`tests/watch.rs` checks this).

use crate::frame::{FieldDesc, FogDesc, FrameDesc, LightDesc, MeshInstance, Receiver, VolumeDesc};

use super::RenderSettings;

/// Everything the volume stages read.
#[derive(Clone, Debug, PartialEq)]
pub struct VolumeKey {
    grids_generation: u64,
    volume: VolumeDesc,
    fields: Vec<FieldDesc>,
    meshes: Vec<MeshInstance>,
    fog: Option<FogDesc>,
}

impl VolumeKey {
    pub fn of(desc: &FrameDesc, grids_generation: u64) -> Self {
        Self {
            grids_generation,
            volume: desc.volume,
            fields: desc.fields.iter().map(|f| FieldDesc { name: String::new(), ..f.clone() }).collect(),
            meshes: desc.meshes.iter().map(|m| MeshInstance { name: String::new(), origin: String::new(), ..m.clone() }).collect(),
            fog: desc.fog,
        }
    }
}

/// Everything the photon stages read besides the volume they travel through (the cache ties
/// photons to the volume they were traced in): the light sent in and where it lands.
#[derive(Clone, Debug, PartialEq)]
pub struct PhotonKey {
    /// Generations of the receivers' buffers and of the radiance grid, where results land.
    targets_generation: [u64; 2],
    lights: Vec<LightDesc>,
    /// The environment as a light: which image (by identity: images are shared, never
    /// mutated), its colour × intensity and its turn.
    environment: (ImageIdentity, [f32; 3], [f32; 4]),
    receivers: Vec<Receiver>,
    photons: u32,
    bounces: (u32, u32),
    settings: RenderSettings,
}

impl PhotonKey {
    pub fn of(desc: &FrameDesc, targets_generation: [u64; 2], settings: &RenderSettings) -> Self {
        Self {
            targets_generation,
            lights: desc.lights.iter().map(|l| LightDesc { name: String::new(), ..l.clone() }).collect(),
            environment: {
                let env = &desc.environment;
                (ImageIdentity(env.image().cloned()), super::env_light::scale(env).into(), env.turn().to_array())
            },
            receivers: desc.receivers.iter().map(|r| Receiver { name: String::new(), ..r.clone() }).collect(),
            photons: desc.photons,
            bounces: (desc.bounces, desc.bounce_photons),
            settings: settings.clone(),
        }
    }
}

/// An environment image compared by identity (held, so its address cannot be reused).
#[derive(Clone, Debug)]
struct ImageIdentity(Option<std::sync::Arc<crate::scene::EnvImage>>);

impl PartialEq for ImageIdentity {
    fn eq(&self, other: &Self) -> bool {
        match (&self.0, &other.0) {
            (Some(a), Some(b)) => std::sync::Arc::ptr_eq(a, b),
            (a, b) => a.is_none() && b.is_none(),
        }
    }
}

/// What the GPU holds from earlier frames.
#[derive(Default)]
pub struct StageCache {
    volume: Option<VolumeKey>,
    /// Counts the volumes built, so photons know which one they were traced through without
    /// comparing its inputs a second time.
    volume_serial: u64,
    photons: Option<(u64, PhotonKey)>,
}

/// Which groups of stages a frame takes from the cache.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct Reuse {
    pub volume: bool,
    pub photons: bool,
}

impl StageCache {
    pub fn reuse(&self, volume: &VolumeKey, photons: &PhotonKey) -> Reuse {
        let volume_hit = self.volume.as_ref() == Some(volume);
        let photons_hit = matches!(&self.photons, Some((serial, key)) if *serial == self.volume_serial && key == photons);
        Reuse { volume: volume_hit, photons: volume_hit && photons_hit }
    }

    /// A new volume is on the GPU (photons traced through the old one no longer apply).
    pub fn built_volume(&mut self, key: VolumeKey) {
        self.volume = Some(key);
        self.volume_serial += 1;
    }

    /// Photons were traced through the current volume.
    pub fn traced_photons(&mut self, key: PhotonKey) {
        self.photons = Some((self.volume_serial, key));
    }

    /// Forgets everything (new pipelines may compute differently).
    pub fn clear(&mut self) {
        *self = Self::default();
    }
}
