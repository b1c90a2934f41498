//! Glowing meshes as lights: every receiver whose material emits (glTF's emissive ×
//! KHR_materials_emissive_strength, Lua's `emission`) is a light too, as in Cycles, where an
//! emission shader lights the scene — and so is glass that glows (a sharp glass mesh with
//! `Glass::emission`: a lamp's glowing shade), as a receiver of its glow in its place would. Its triangles go to the GPU in world space with their
//! share of its area (`LightTriangle::cdf`), so the view's shadow rays and the photons stage
//! pick a point uniformly over the surface (`shaders/shared/mesh_light.wgsl`).
//!
//! The mesh glows with one radiance, the material's `emission × emission_strength` times the
//! mean of its emission texture, on both sides of each triangle as Cycles' emission does — but
//! a closed mesh (a bulb, a tube) only on its outer side, its triangles wound outward: light
//! from the inner side could only land on the mesh itself, so its photons and shadow rays would
//! be spent for nothing. A texture's pattern shows on the surface itself, not in the light it
//! casts.

use std::sync::Arc;

use glam::Vec3;

use crate::frame::{LightDesc, LightShape, MeshInstance, Receiver};
use crate::scene::mesh::MeshData;
use crate::scene::Texture2d;
use crate::gpu::types::LightTriangle;

/// The frame's glowing meshes: one light per emissive receiver, and their triangles.
#[derive(Debug, Default)]
pub struct MeshLights {
    pub lights: Vec<LightDesc>,
    pub triangles: Vec<LightTriangle>,
}

/// What identifies a glowing receiver's light: its mesh, placement, emission and emission
/// texture (shared data compares by pointer first, then by data: a procedural lamp made afresh
/// at every evaluation keeps its light while its parameters do).
fn key_of(r: &Receiver) -> (&Arc<MeshData>, glam::Mat4, Vec3, &Option<Arc<Texture2d>>) {
    (&r.mesh, r.world, r.diffuse.emitted(), &r.diffuse.emission_texture)
}

/// The glowing meshes of the frames so far, built again only when a glowing receiver's mesh,
/// placement or emission changes (an animation's glass moving under a still lamp keeps them).
#[derive(Debug, Default)]
pub struct GlowingMeshes {
    /// The glowing receivers they were built from (what `key_of` compares the next frame's with).
    built_from: Vec<Receiver>,
    pub built: MeshLights,
    /// Whether the last [`update`](Self::update) built them anew (their triangles need uploading).
    pub changed: bool,
}

impl GlowingMeshes {
    /// Brings the glowing meshes up to this frame's receivers and glass. A frame whose glowing
    /// meshes have more than `max_triangles` triangles in all is refused before anything is
    /// built: `Err` holds their count.
    pub fn update(&mut self, receivers: &[Receiver], glass: &[MeshInstance], max_triangles: usize) -> Result<(), usize> {
        let glowing_glass: Vec<Receiver> = glass.iter().filter_map(glow_of_glass).collect();
        let glowing: Vec<&Receiver> =
            receivers.iter().filter(|r| r.diffuse.emitted().max_element() > 0.0).chain(&glowing_glass).collect();
        self.changed = !glowing.iter().map(|r| key_of(r)).eq(self.built_from.iter().map(key_of));
        if !self.changed {
            return Ok(());
        }
        let count: usize = glowing.iter().map(|r| r.mesh.triangles.len()).sum();
        if count > max_triangles {
            return Err(count);
        }
        self.built = mesh_lights(glowing.iter().copied());
        self.built_from = glowing.into_iter().cloned().collect();
        Ok(())
    }
}

/// A sharp glass mesh's glow as the receiver that would give it off: the same mesh in the same
/// place, black but for its emission (and emission texture) where its alpha leaves it (a sheet
/// glows where it is there, as the view shows it: by its mean coverage, as a texture lights by
/// its mean). None where the glass does not glow (or is a voxelized solid, whose surface the
/// view does not meet and so shows no glow).
fn glow_of_glass(m: &MeshInstance) -> Option<Receiver> {
    let g = &m.glass;
    let coverage = g.mean_coverage(m.thin);
    (m.sharp && coverage > 0.0 && g.emitted().max_element() > 0.0).then(|| Receiver {
        name: m.name.clone(),
        mesh: m.mesh.clone(),
        world: m.world,
        diffuse: crate::scene::material::Diffuse {
            color: Vec3::ZERO,
            emission: g.emission * coverage,
            emission_strength: g.emission_strength,
            emission_texture: g.emission_texture.clone(),
            ..crate::scene::material::Diffuse::pbr()
        },
    })
}

/// Every receiver given that glows, as a light over its world-space triangles (degenerate ones
/// left out). A receiver without emission, or without area, gives none.
pub fn mesh_lights<'a>(receivers: impl IntoIterator<Item = &'a Receiver>) -> MeshLights {
    let mut out = MeshLights::default();
    for r in receivers {
        let radiance = emitted_radiance(r);
        if radiance.max_element() <= 0.0 {
            continue;
        }
        let first = out.triangles.len();
        let closed = r.mesh.is_closed();
        let (area, centroid) = push_triangles(r, closed, &mut out.triangles);
        if area <= 0.0 {
            out.triangles.truncate(first);
            continue;
        }
        out.lights.push(LightDesc {
            name: r.name.clone(),
            shape: LightShape::Mesh {
                first: first as u32,
                count: (out.triangles.len() - first) as u32,
                area,
                closed,
                outside: just_outside(&out.triangles[first]),
                patterned: r.diffuse.emission_texture.is_some(),
            },
            position: centroid,
            direction: Vec3::NEG_Y,
            right: Vec3::X,
            up: Vec3::Z,
            radiant: radiance,
            radius: 0.0,
            // The camera sees the glowing mesh itself.
            visible: false,
        });
    }
    out
}

/// What the view needs to weigh a glowing mesh's glow that a branch leaving rough glass finds
/// against the same light drawn at that crossing (`lights_through_rough`, by the balance
/// heuristic): its world area and the side its light is drawn on — 0 both (an open mesh), +1 the
/// side its triangles' normals point to, −1 the other (a `closed` mesh glows on its outer side,
/// `push_triangles`). (0, 0) where it does not glow, or glows through a texture (`patterned`:
/// its light is drawn by the texture's mean, so the branches keep all of what they see).
pub fn glow_measure(mesh: &MeshData, world: glam::Mat4, emission: Vec3, patterned: bool, closed: bool) -> (f32, f32) {
    if emission.max_element() <= 0.0 || patterned {
        return (0.0, 0.0);
    }
    let corners = world_positions(mesh, world);
    let area: f64 = mesh.triangles.iter().map(|t| {
        let [a, b, c] = t.map(|i| corners[i as usize].as_dvec3());
        0.5 * (b - a).cross(c - a).length()
    }).sum();
    let side = if !closed { 0.0 } else if enclosed_volume(&corners, &mesh.triangles) >= 0.0 { 1.0 } else { -1.0 };
    (area as f32, side)
}

/// A mesh's vertices in world space.
fn world_positions(mesh: &MeshData, world: glam::Mat4) -> Vec<Vec3> {
    mesh.positions.iter().map(|p| world.transform_point3(*p)).collect()
}

/// Six times the volume the triangles enclose, signed: positive where their normals (by their
/// winding) point outward — which a mirroring transform turns.
fn enclosed_volume(corners: &[Vec3], triangles: &[[u32; 3]]) -> f64 {
    triangles.iter().map(|t| {
        let [a, b, c] = t.map(|i| corners[i as usize].as_dvec3());
        a.dot(b.cross(c))
    }).sum()
}

/// A point 0.1 mm off triangle t's centre on the side its cross product points to (a closed
/// mesh's outer side: `push_triangles` winds them outward), as far as the photons stage lifts
/// the photons it starts on a glowing mesh.
fn just_outside(t: &LightTriangle) -> Vec3 {
    let (v0, e1, e2) = (Vec3::from(t.v0), Vec3::from(t.e1), Vec3::from(t.e2));
    v0 + (e1 + e2) / 3.0 + e1.cross(e2).normalize() * 1e-4
}

/// The radiance a receiver glows with (W·m⁻²·sr⁻¹): its emission at full texture times the
/// texture's mean.
fn emitted_radiance(r: &Receiver) -> Vec3 {
    let d = &r.diffuse;
    let texture_mean = d.emission_texture.as_ref().map_or(Vec3::ONE, |t| {
        let sum: Vec3 = t.texels.iter().map(|c| Vec3::new(c[0], c[1], c[2])).sum();
        sum / t.texels.len().max(1) as f32
    });
    (d.emitted() * texture_mean).max(Vec3::ZERO)
}

/// Appends the receiver's world-space triangles with their running area fraction — wound
/// outward where `closed` (by the sign of the volume they enclose, which a mirroring transform
/// turns) — and returns the mesh's area and its area-weighted centroid.
fn push_triangles(r: &Receiver, closed: bool, out: &mut Vec<LightTriangle>) -> (f32, Vec3) {
    let world = world_positions(&r.mesh, r.world);
    let corners = |t: &[u32; 3]| t.map(|i| world[i as usize]);
    let inward = closed && enclosed_volume(&world, &r.mesh.triangles) < 0.0;
    let first = out.len();
    let (mut area, mut moment) = (0.0f64, glam::DVec3::ZERO);
    for t in &r.mesh.triangles {
        let [a, mut b, mut c] = corners(t);
        if inward {
            std::mem::swap(&mut b, &mut c);
        }
        let (e1, e2) = (b - a, c - a);
        let twice = e1.cross(e2).length();
        if !(twice > 0.0 && twice.is_finite()) {
            continue;
        }
        area += 0.5 * twice as f64;
        moment += (0.5 * twice as f64) * ((a + b + c) / 3.0).as_dvec3();
        out.push(LightTriangle { v0: a.into(), cdf: area as f32, e1: e1.into(), e2: e2.into(), ..Default::default() });
    }
    for t in &mut out[first..] {
        t.cdf = (t.cdf as f64 / area) as f32;
    }
    if let Some(last) = out[first..].last_mut() {
        last.cdf = 1.0;
    }
    (area as f32, if area > 0.0 { (moment / area).as_vec3() } else { Vec3::ZERO })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::material::Diffuse;
    use crate::scene::mesh::{MeshData, plane};
    use std::sync::Arc;

    fn receiver(mesh: MeshData, emission: Vec3, world: glam::Mat4) -> Receiver {
        let diffuse = Diffuse { emission, ..Diffuse::pbr() };
        Receiver { name: "lamp".into(), mesh: Arc::new(mesh), world, diffuse }
    }

    #[test]
    fn only_glowing_receivers_are_lights_with_their_world_area() {
        let world = glam::Mat4::from_scale_rotation_translation(Vec3::new(2.0, 1.0, 3.0), glam::Quat::IDENTITY, Vec3::new(0.0, 1.0, 0.0));
        let lit = mesh_lights(&[receiver(plane(glam::Vec2::ONE), Vec3::ZERO, world), receiver(plane(glam::Vec2::ONE), Vec3::new(1.0, 2.0, 3.0), world)]);
        assert_eq!(lit.lights.len(), 1);
        let LightShape::Mesh { first, count, area, .. } = lit.lights[0].shape else { panic!("a mesh light") };
        assert_eq!((first, count), (0, 2));
        assert!((area - 6.0).abs() < 1e-5, "area {area}");
        assert_eq!(lit.lights[0].radiant, Vec3::new(1.0, 2.0, 3.0));
        assert!((lit.lights[0].position - Vec3::Y).length() < 1e-5);
    }

    /// A closed mesh glows on its outer side: its triangles face away from its centre, even
    /// through a mirroring transform; an open one is marked two-sided.
    /// A glowing sheet lights the scene by the part of it its alpha leaves: a BLEND sheet of
    /// alpha ¼ with a texture half transparent gives ⅛ of its glow, a MASK sheet cut below ½ a
    /// half, an all-cut sheet none; a solid ignores alpha.
    #[test]
    fn a_glowing_sheet_lights_by_the_part_its_alpha_leaves() {
        let half_clear = Arc::new(crate::scene::Texture2d { width: 2, height: 1, texels: vec![[1.0, 1.0, 1.0, 1.0], [1.0, 1.0, 1.0, 0.0]], wrap: Default::default() });
        let sheet = |alpha_mode, alpha, thin| {
            let glass = crate::scene::Glass { emission: Vec3::ONE, alpha_mode, alpha, tint_texture: Some(half_clear.clone()), ..Default::default() };
            MeshInstance { name: "shade".into(), origin: String::new(), mesh: Arc::new(plane(glam::Vec2::ONE)), world: glam::Mat4::IDENTITY, glass,
                boundary: 0.0, bounds: (Vec3::ZERO, Vec3::ONE), sharp: true, thin, guessed: false }
        };
        let glow = |m: MeshInstance| glow_of_glass(&m).map(|r| r.diffuse.emission.x);
        use crate::scene::AlphaMode::{Blend, Mask, Opaque};
        assert_eq!(glow(sheet(Blend, 0.25, true)), Some(0.125));
        assert_eq!(glow(sheet(Mask, 1.0, true)), Some(0.5));
        assert_eq!(glow(sheet(Mask, 0.25, true)), None, "cut away everywhere");
        assert_eq!(glow(sheet(Opaque, 0.25, true)), Some(1.0));
        assert_eq!(glow(sheet(Blend, 0.25, false)), Some(1.0), "a solid is all there");
    }

    #[test]
    fn a_closed_mesh_is_wound_outward() {
        let mirror = glam::Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0));
        for world in [glam::Mat4::IDENTITY, mirror] {
            let lit = mesh_lights(&[receiver(crate::scene::mesh::cuboid(Vec3::ONE), Vec3::ONE, world)]);
            assert!(matches!(lit.lights[0].shape, LightShape::Mesh { closed: true, .. }));
            for t in &lit.triangles {
                let (v0, e1, e2) = (Vec3::from(t.v0), Vec3::from(t.e1), Vec3::from(t.e2));
                assert!(e1.cross(e2).dot(v0 + (e1 + e2) / 3.0) > 0.0, "a triangle faces inward");
            }
        }
        let open = mesh_lights(&[receiver(plane(glam::Vec2::ONE), Vec3::ONE, glam::Mat4::IDENTITY)]);
        assert!(matches!(open.lights[0].shape, LightShape::Mesh { closed: false, .. }));
    }

    /// Triangles of unequal area get their share: a uniform number lands in each in proportion.
    #[test]
    fn the_cdf_follows_area_and_ends_at_one() {
        let mesh = MeshData {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Z, Vec3::new(3.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 1.0)],
            triangles: vec![[0, 2, 1], [1, 0, 0], [0, 4, 3]],
            uvs: None,
            normals: Default::default(),
        };
        let lit = mesh_lights(&[receiver(mesh, Vec3::ONE, glam::Mat4::IDENTITY)]);
        let cdf: Vec<f32> = lit.triangles.iter().map(|t| t.cdf).collect();
        assert_eq!(cdf.len(), 2, "the degenerate triangle is left out");
        assert!((cdf[0] - 0.25).abs() < 1e-6 && cdf[1] == 1.0, "{cdf:?}");
    }

    /// Built once while nothing glowing changes; built again when a lamp moves; refused, before
    /// anything is built, when its triangles exceed the cap.
    #[test]
    fn glowing_meshes_are_built_again_only_when_they_change() {
        let lamp = receiver(crate::scene::mesh::cuboid(Vec3::ONE), Vec3::ONE, glam::Mat4::IDENTITY);
        let dark = receiver(plane(glam::Vec2::ONE), Vec3::ZERO, glam::Mat4::IDENTITY);
        let mut glowing = GlowingMeshes::default();
        glowing.update(&[lamp.clone(), dark.clone()], &[], 12).unwrap();
        assert!(glowing.changed && glowing.built.lights.len() == 1);
        let moved_dark = Receiver { world: glam::Mat4::from_translation(Vec3::X), ..dark };
        glowing.update(&[lamp.clone(), moved_dark.clone()], &[], 12).unwrap();
        assert!(!glowing.changed, "a receiver that does not glow moved");
        let moved = Receiver { world: glam::Mat4::from_translation(Vec3::Y), ..lamp };
        glowing.update(&[moved.clone(), moved_dark], &[], 12).unwrap();
        assert!(glowing.changed && (glowing.built.lights[0].position - Vec3::Y).length() < 1e-5);
        assert_eq!(GlowingMeshes::default().update(&[moved], &[], 11), Err(12));
    }
}
