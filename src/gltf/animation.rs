//! Keyframe animation (glTF 2.0 §3.11 and Appendix C, "Interpolation"): samplers that turn a
//! time into a value by STEP, LINEAR (spherical linear for rotations) or CUBICSPLINE (cubic
//! Hermite with the keyframe's tangents) interpolation, and channels that aim them at a node's
//! translation, rotation, scale or morph weights — or, through KHR_animation_pointer
//! (`super::pointer`), at a light's, camera's or material's property.
//!
//! Time is the scene clock in seconds, which is the file's own time unit. Before the first
//! keyframe a sampler holds its first value, after the last its last value (no looping).

use anyhow::{Result, anyhow, bail};
use glam::{Quat, Vec3, Vec4};
use gltf::animation::{Interpolation, Property};

use super::accessor::Accessors;
use super::pointer::{self, CameraProperty, LightProperty, MaterialProperty, PointerChannel};
use crate::warnings::Collector;

/// One sampler's keyframes: `times` and, per keyframe, `width` values — or 3·`width` for
/// CUBICSPLINE, stored as (in-tangent aₖ, value vₖ, out-tangent bₖ).
#[derive(Clone, Debug)]
pub struct Sampler {
    pub interpolation: Interpolation,
    pub times: Vec<f32>,
    pub values: Vec<f32>,
    pub width: usize,
    /// Whether the values are unit quaternions (LINEAR is then a slerp, CUBICSPLINE normalized).
    pub rotation: bool,
}

impl Sampler {
    fn stride(&self) -> usize {
        if self.interpolation == Interpolation::CubicSpline { 3 * self.width } else { self.width }
    }

    /// The value (the vₖ part for CUBICSPLINE) of keyframe `k`.
    fn value(&self, k: usize) -> &[f32] {
        let at = k * self.stride() + if self.interpolation == Interpolation::CubicSpline { self.width } else { 0 };
        &self.values[at..at + self.width]
    }

    fn in_tangent(&self, k: usize) -> &[f32] {
        &self.values[k * self.stride()..][..self.width]
    }

    fn out_tangent(&self, k: usize) -> &[f32] {
        &self.values[k * self.stride() + 2 * self.width..][..self.width]
    }

    /// The sampled value at time `t` (seconds), written to `out` (`width` values).
    pub fn sample(&self, t: f32, out: &mut [f32]) {
        let last = self.times.len() - 1;
        // k: the last keyframe at or before t.
        let k = self.times.partition_point(|&x| x <= t);
        if k == 0 || k > last || self.interpolation == Interpolation::Step {
            out.copy_from_slice(self.value(k.saturating_sub(1).min(last)));
            return;
        }
        let k = k - 1;
        let td = self.times[k + 1] - self.times[k];
        let u = (t - self.times[k]) / td;
        match self.interpolation {
            Interpolation::Linear if self.rotation => {
                let q = slerp(Vec4::from_slice(self.value(k)), Vec4::from_slice(self.value(k + 1)), u);
                out.copy_from_slice(&q.to_array());
            }
            Interpolation::Linear => {
                for (i, o) in out.iter_mut().enumerate() {
                    *o = self.value(k)[i] * (1.0 - u) + self.value(k + 1)[i] * u;
                }
            }
            Interpolation::CubicSpline => {
                // Appendix C.3: p(t) = (2t³ − 3t² + 1)vₖ + t_d(t³ − 2t² + t)bₖ + (−2t³ + 3t²)vₖ₊₁ + t_d(t³ − t²)aₖ₊₁,
                // the tangents scaled by the keyframe interval t_d.
                let (u2, u3) = (u * u, u * u * u);
                let (h00, h10, h01, h11) = (2.0 * u3 - 3.0 * u2 + 1.0, u3 - 2.0 * u2 + u, -2.0 * u3 + 3.0 * u2, u3 - u2);
                let (v0, b0, v1, a1) = (self.value(k), self.out_tangent(k), self.value(k + 1), self.in_tangent(k + 1));
                for (i, o) in out.iter_mut().enumerate() {
                    *o = h00 * v0[i] + td * h10 * b0[i] + h01 * v1[i] + td * h11 * a1[i];
                }
                if self.rotation {
                    // "When interpolating rotations, the result MUST be normalized."
                    let q = Vec4::from_slice(out).normalize_or(Vec4::W);
                    out.copy_from_slice(&q.to_array());
                }
            }
            Interpolation::Step => unreachable!("handled above"),
        }
    }
}

/// Appendix C.2: spherical linear interpolation of unit quaternions along the shorter arc,
///   a = arccos|q₀·q₁|, s = sign(q₀·q₁), q = sin(a(1−u))/sin(a) q₀ + s sin(a u)/sin(a) q₁,
/// falling back to a normalized lerp where the two are too close for sin(a) to divide by.
pub fn slerp(q0: Vec4, q1: Vec4, u: f32) -> Vec4 {
    let d = q0.dot(q1);
    let s = if d < 0.0 { -1.0 } else { 1.0 };
    let a = d.abs().min(1.0).acos();
    if a < 1e-4 {
        return (q0 * (1.0 - u) + q1 * s * u).normalize_or(Vec4::W);
    }
    let sa = a.sin();
    q0 * ((a * (1.0 - u)).sin() / sa) + q1 * (s * (a * u).sin() / sa)
}

/// What a channel drives.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Target {
    Translation,
    Rotation,
    Scale,
    Weights,
    Light(LightProperty),
    /// An area light from a node's extras: the channel's index is the node's.
    AreaLight(LightProperty),
    Camera(CameraProperty),
    Material(MaterialProperty),
}

impl Target {
    /// The property in words, for messages.
    pub fn plain(self) -> &'static str {
        match self {
            Target::Translation => "translation",
            Target::Rotation => "rotation",
            Target::Scale => "scale",
            Target::Weights => "morph weights",
            Target::Light(_) | Target::AreaLight(_) => "light",
            Target::Camera(_) => "camera",
            Target::Material(_) => "material",
        }
    }

    /// The array whose element `Channel::node` indexes, for messages.
    pub fn owners(self) -> &'static str {
        match self {
            Target::Light(_) => "lights",
            Target::Camera(_) => "cameras",
            Target::Material(_) => "materials",
            _ => "nodes",
        }
    }
}

#[derive(Clone, Debug)]
pub struct Channel {
    /// The node — or for a light, camera or material target, the light, camera or material —
    /// the channel drives, by its glTF index.
    pub node: usize,
    pub target: Target,
    pub sampler: usize,
}

/// One named animation of the file.
#[derive(Clone, Debug)]
pub struct Clip {
    pub name: String,
    pub samplers: Vec<Sampler>,
    pub channels: Vec<Channel>,
}

/// A value a channel produced at some time, for the node (light, camera, material) it targets.
pub enum Pose<'a> {
    Translation(Vec3),
    Rotation(Quat),
    Scale(Vec3),
    Weights(&'a [f32]),
    /// A light's, camera's or material's property (the target says which).
    Property(Target, &'a [f32]),
}

impl Clip {
    /// Samples every channel at `t`; `apply` receives (node, value).
    pub fn sample(&self, t: f32, scratch: &mut Vec<f32>, mut apply: impl FnMut(usize, Pose)) {
        for c in &self.channels {
            let s = &self.samplers[c.sampler];
            scratch.resize(s.width, 0.0);
            s.sample(t, scratch);
            let v = &scratch[..];
            let pose = match c.target {
                Target::Translation => Pose::Translation(Vec3::from_slice(v)),
                Target::Rotation => Pose::Rotation(Quat::from_vec4(Vec4::from_slice(v).normalize_or(Vec4::W))),
                Target::Scale => Pose::Scale(Vec3::from_slice(v)),
                Target::Weights => Pose::Weights(v),
                other => Pose::Property(other, v),
            };
            apply(c.node, pose);
        }
    }

    /// The time of the last keyframe of any channel, seconds.
    pub fn duration(&self) -> f32 {
        self.samplers.iter().filter_map(|s| s.times.last().copied()).fold(0.0, f32::max)
    }
}

/// Reads the given animations, with their animation-pointer channels (those whose pointer names
/// a property refrakt does not animate are said once and skipped). `morph_targets(node)` is the
/// number of morph targets of the mesh on glTF node `node` (the width of its weights channels);
/// `counts` how many (nodes, lights, cameras, materials) the file has.
pub fn read_clips(
    animations: Vec<gltf::Animation>,
    pointers: &[PointerChannel],
    acc: &Accessors,
    counts: [usize; 4],
    morph_targets: impl Fn(usize) -> usize,
    warnings: &mut Collector,
) -> Result<Vec<Clip>> {
    animations
        .into_iter()
        .map(|a| {
            let name = a.name().map_or_else(|| format!("animation {}", a.index()), str::to_string);
            let what = format!("animations[{}] \"{name}\"", a.index());
            let mut samplers: Vec<Option<Sampler>> = vec![None; a.samplers().count()];
            let mut channels = Vec::new();
            let plain = a.channels().map(|c| {
                let target = match c.target().property() {
                    Property::Translation => Target::Translation,
                    Property::Rotation => Target::Rotation,
                    Property::Scale => Target::Scale,
                    Property::MorphTargetWeights => Target::Weights,
                };
                Ok((c.target().node().index(), target, c.sampler()))
            });
            let mut unread = Vec::new();
            let pointed = pointers.iter().filter(|p| p.animation == a.index()).filter_map(|p| {
                let Some((target, index)) = pointer::resolve(&p.pointer) else {
                    unread.push(p.pointer.clone());
                    return None;
                };
                let owners = [("nodes", counts[0]), ("lights", counts[1]), ("cameras", counts[2]), ("materials", counts[3])];
                let count = owners.iter().find(|(name, _)| *name == target.owners()).map_or(0, |o| o.1);
                Some(match a.samplers().nth(p.sampler) {
                    _ if index >= count => Err(anyhow!("{}: {what}: the animation pointer {} names {}[{index}], which does not exist", acc.file, p.pointer, target.owners())),
                    Some(s) => Ok((index, target, s)),
                    None => Err(anyhow!("{}: {what}: the channel for {} names sampler {}, which does not exist", acc.file, p.pointer, p.sampler)),
                })
            });
            for c in plain.chain(pointed).collect::<Result<Vec<_>>>()? {
                let (node, target, s) = c;
                let width = match target {
                    Target::Rotation => 4,
                    Target::Weights => morph_targets(node),
                    Target::Translation | Target::Scale => 3,
                    other => pointer::width(other),
                };
                let swhat = format!("{what} samplers[{}]", s.index());
                let sampler = read_sampler(&s, acc, &swhat, width, target)?;
                match &samplers[s.index()] {
                    Some(other) if other.width != sampler.width || other.rotation != sampler.rotation => {
                        bail!("{}: {swhat} drives channels of different kinds; give each its own sampler", acc.file)
                    }
                    _ => samplers[s.index()] = Some(sampler),
                }
                channels.push(Channel { node, target, sampler: s.index() });
            }
            if !unread.is_empty() {
                warnings.about(
                    format!("{what} ({})", unread.join(", ")),
                    "animates properties through KHR_animation_pointer that refrakt does not animate; they keep the file's values",
                );
            }
            // Samplers no channel uses are kept as placeholders so channel indices stay valid.
            let samplers = samplers
                .into_iter()
                .map(|s| s.unwrap_or(Sampler { interpolation: Interpolation::Step, times: vec![0.0], values: vec![], width: 0, rotation: false }))
                .collect();
            Ok(Clip { name, samplers, channels })
        })
        .collect()
}

fn read_sampler(s: &gltf::animation::Sampler, acc: &Accessors, what: &str, width: usize, target: Target) -> Result<Sampler> {
    let times = acc.floats_of(s.input().index(), &format!("{what} input"), 1)?.values;
    let values = acc.floats(s.output().index(), &format!("{what} output"))?.values;
    let interpolation = s.interpolation();
    let err = |m: String| anyhow!("{}: {what}: {m}; fix the animation and re-export", acc.file);
    if times.is_empty() {
        return Err(err("it has no keyframes".into()));
    }
    if let Some(i) = times.iter().position(|t| !t.is_finite()) {
        return Err(err(format!("keyframe {i} has the time {}, not a finite number of seconds", times[i])));
    }
    if let Some(i) = times.windows(2).position(|w| w[1] <= w[0]) {
        return Err(err(format!("keyframe times must increase, but keyframe {} is at {} s after {} s", i + 1, times[i + 1], times[i])));
    }
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        return Err(err(format!("output value {i} is {}; keyframe values must be finite numbers", values[i])));
    }
    let per_key = if interpolation == Interpolation::CubicSpline { 3 } else { 1 };
    // Weights channels take their width from the data when the node has no morph targets.
    let width = if target == Target::Weights && width == 0 { values.len() / (times.len() * per_key).max(1) } else { width };
    if width == 0 || values.len() != times.len() * per_key * width {
        return Err(err(format!(
            "{} keyframes need {} output values ({per_key} × {width} each), but the output has {}",
            times.len(),
            times.len() * per_key * width.max(1),
            values.len()
        )));
    }
    let sampler = Sampler { interpolation, times, values, width, rotation: target == Target::Rotation };
    if sampler.rotation
        && let Some(k) = (0..sampler.times.len()).find(|&k| Vec4::from_slice(sampler.value(k)).length() < 1e-6)
    {
        return Err(err(format!("keyframe {k} has a zero-length rotation quaternion")));
    }
    Ok(sampler)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sampler(interpolation: Interpolation, times: &[f32], values: &[f32], width: usize) -> Sampler {
        Sampler { interpolation, times: times.to_vec(), values: values.to_vec(), width, rotation: false }
    }

    #[test]
    fn times_outside_the_keyframes_hold_the_end_values() {
        let s = sampler(Interpolation::Linear, &[1.0, 2.0], &[10.0, 20.0], 1);
        let mut out = [0.0];
        for (t, want) in [(0.0, 10.0), (1.0, 10.0), (1.5, 15.0), (2.0, 20.0), (9.0, 20.0)] {
            s.sample(t, &mut out);
            assert_eq!(out[0], want, "t = {t}");
        }
    }

    #[test]
    fn slerp_takes_the_shorter_arc() {
        let a = Vec4::new(0.0, 0.0, 0.0, 1.0);
        let b = -Vec4::from(Quat::from_rotation_y(0.5).to_array());
        let mid = Quat::from_vec4(slerp(a, b, 0.5));
        assert!(1.0 - mid.dot(Quat::from_rotation_y(0.25)) < 1e-6, "{mid:?}");
    }
}
