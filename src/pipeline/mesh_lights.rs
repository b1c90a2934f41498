//! Glowing meshes as lights: every receiver whose material emits (glTF's emissive ×
//! KHR_materials_emissive_strength, Lua's `emission`) is a light too, as in Cycles, where an
//! emission shader lights the scene — and so is glass that glows (a sharp glass mesh with
//! `Glass::emission`: a lamp's glowing shade), as a receiver of its glow in its place would. Its triangles go to the GPU in world space with their
//! share of its area (`LightTriangle::cdf`), so the view's shadow rays and the photons stage
//! pick a point uniformly over the surface (`shaders/shared/mesh_light.wgsl`).
//!
//! The mesh glows with the material's `emission × emission_strength` on both sides of each
//! triangle as Cycles' emission does — but a closed mesh (a bulb, a tube) only on its outer
//! side, its triangles wound outward: light from the inner side could only land on the mesh
//! itself, so its photons and shadow rays would be spent for nothing.
//!
//! An emission texture is a pattern in the light too (a screen, a neon sign, a stained-glass
//! shade): each triangle is cut into pieces of a few texels each (`pattern_pieces`), each piece
//! glowing with the texture's mean over it, and points are drawn by the pieces' power rather
//! than their area, so black texels cost no photon or shadow ray; each piece's `scale` weighs
//! what is drawn there against the light's mean radiance (`piece_scale`). A mesh without
//! texture coordinates glows with the texture's mean.

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
    /// built, and one whose patterned glows are cut into more pieces than that once they are:
    /// `Err` holds their count.
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
        let built = mesh_lights(glowing.iter().copied());
        if built.triangles.len() > max_triangles {
            return Err(built.triangles.len());
        }
        self.built = built;
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
        let mean_radiance = emitted_radiance(r);
        if mean_radiance.max_element() <= 0.0 {
            continue;
        }
        let first = out.triangles.len();
        let closed = r.mesh.is_closed();
        let Some(Glow { area, centroid, radiance }) = push_triangles(r, mean_radiance, closed, &mut out.triangles) else {
            out.triangles.truncate(first);
            continue;
        };
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

/// What `push_triangles` found of a glowing receiver: the area of what glows (a patterned glow's
/// black pieces left out), its area-weighted centroid and the mean radiance over it.
struct Glow {
    area: f32,
    centroid: Vec3,
    radiance: Vec3,
}

/// One piece of a glowing surface: a world-space triangle and the radiance it glows with.
struct Piece {
    corners: [Vec3; 3],
    radiance: Vec3,
}

/// How many texels of its emission texture a piece of a patterned glow covers, about: small
/// enough that a sign's letters cast their own light, large enough to keep the pieces few.
const TEXELS_PER_PIECE: f32 = 4.0;
/// The most pieces one triangle, and one glowing mesh, is cut into; past the mesh's budget every
/// triangle is cut more coarsely alike.
const MAX_PIECES_PER_SIDE: u32 = 64;
const MAX_PIECES_PER_MESH: u32 = 1 << 16;

/// Appends the receiver's world-space triangles — or on a patterned glow their pieces
/// (`pattern_pieces`) — wound outward where `closed` (by the sign of the volume they enclose,
/// which a mirroring transform turns), with their running share: of the area on a glow of one
/// radiance (`mean_radiance`: the emission × its texture's mean), of the power (area × the
/// radiance's channel sum) on a patterned one. None where the mesh has no area or glows nowhere.
fn push_triangles(r: &Receiver, mean_radiance: Vec3, closed: bool, out: &mut Vec<LightTriangle>) -> Option<Glow> {
    let world = world_positions(&r.mesh, r.world);
    let inward = closed && enclosed_volume(&world, &r.mesh.triangles) < 0.0;
    let pieces = pattern_pieces(r, &world, inward);
    let patterned = pieces.is_some();
    let pieces = pieces.unwrap_or_else(|| plain_pieces(r, &world, inward, mean_radiance));
    let (mut area, mut power, mut moment, mut glow) = (0.0f64, 0.0f64, glam::DVec3::ZERO, glam::DVec3::ZERO);
    let first = out.len();
    for p in &pieces {
        let [a, b, c] = p.corners;
        let (e1, e2) = (b - a, c - a);
        let piece_area = 0.5 * e1.cross(e2).length() as f64;
        area += piece_area;
        moment += piece_area * ((a + b + c) / 3.0).as_dvec3();
        glow += piece_area * p.radiance.as_dvec3();
        power += if patterned { piece_area * p.radiance.element_sum() as f64 } else { piece_area };
        out.push(LightTriangle { v0: a.into(), cdf: power as f32, e1: e1.into(), e2: e2.into(), scale: [1.0; 3], ..Default::default() });
    }
    if !(area > 0.0 && power > 0.0) {
        return None;
    }
    let radiance = (glow / area).as_vec3();
    for (t, p) in out[first..].iter_mut().zip(&pieces) {
        t.cdf = (t.cdf as f64 / power) as f32;
        if patterned {
            t.scale = piece_scale(p.radiance, radiance, power / area).into();
        }
    }
    if let Some(last) = out[first..].last_mut() {
        last.cdf = 1.0;
    }
    Some(Glow { area: area as f32, centroid: (moment / area).as_vec3(), radiance })
}

/// What a point of a piece of radiance L drawn by power (density Σ(L)/W per unit area, W the
/// glow's power Σ area·Σ(L)) weighs against the light's mean radiance L̄ drawn uniformly (density
/// 1/A): L/(Σ(L)/W) = scale · L̄ A, per channel — so the photons and shadow rays that multiply
/// L̄ A by it carry L over its density. `power_per_area` is W/A. 0 in a channel the glow lacks.
fn piece_scale(piece: Vec3, mean: Vec3, power_per_area: f64) -> Vec3 {
    let sum = piece.element_sum();
    Vec3::from_array(std::array::from_fn(|c| {
        if mean[c] > 0.0 && sum > 0.0 { (piece[c] as f64 * power_per_area / (sum as f64 * mean[c] as f64)) as f32 } else { 0.0 }
    }))
}

/// The receiver's triangles as pieces of one radiance, the degenerate ones left out.
fn plain_pieces(r: &Receiver, world: &[Vec3], inward: bool, radiance: Vec3) -> Vec<Piece> {
    r.mesh.triangles.iter().map(|t| oriented(world, t, inward)).filter(has_area).map(|corners| Piece { corners, radiance }).collect()
}

/// Whether a triangle has a finite area above 0.
fn has_area([a, b, c]: &[Vec3; 3]) -> bool {
    let twice = (*b - *a).cross(*c - *a).length();
    twice > 0.0 && twice.is_finite()
}

/// Triangle t's corner values (world positions, texture coordinates), its last two swapped where
/// `inward` (to wind it outward).
fn oriented<T: Copy>(values: &[T], t: &[u32; 3], inward: bool) -> [T; 3] {
    let [a, b, c] = t.map(|i| values[i as usize]);
    if inward { [a, c, b] } else { [a, b, c] }
}

/// A patterned glow's pieces: each triangle cut into n² equal triangles (n along each edge, so
/// each covers about `TEXELS_PER_PIECE` texels of the emission texture, at most
/// `MAX_PIECES_PER_SIDE`² and all together `MAX_PIECES_PER_MESH`), each glowing with the
/// emission times the texture's mean over it (four bilinear lookups: its centroid and halfway
/// from there to each corner), those that glow at all. None without an emission texture or
/// texture coordinates.
fn pattern_pieces(r: &Receiver, world: &[Vec3], inward: bool) -> Option<Vec<Piece>> {
    let texture = r.diffuse.emission_texture.as_ref()?;
    let uvs = r.mesh.uvs.as_ref()?;
    let texels = (texture.width * texture.height) as f32;
    let wanted: Vec<u32> = r.mesh.triangles.iter().map(|t| {
        let [a, b, c] = t.map(|i| uvs[i as usize]);
        let covered = 0.5 * (b - a).perp_dot(c - a).abs() * texels;
        ((covered / TEXELS_PER_PIECE).sqrt().ceil() as u32).clamp(1, MAX_PIECES_PER_SIDE)
    }).collect();
    let total: u64 = wanted.iter().map(|&n| (n * n) as u64).sum();
    let thin = if total > MAX_PIECES_PER_MESH as u64 { (MAX_PIECES_PER_MESH as f64 / total as f64).sqrt() } else { 1.0 };
    let emitted = r.diffuse.emitted();
    let mut pieces = Vec::new();
    for (t, &n) in r.mesh.triangles.iter().zip(&wanted) {
        let n = ((n as f64 * thin).floor() as u32).max(1);
        let corners = oriented(world, t, inward);
        let uv = oriented(uvs, t, inward);
        for bary in sub_triangles(n) {
            let at = |w: glam::Vec3| (corners[0] * w.x + corners[1] * w.y + corners[2] * w.z, uv[0] * w.x + uv[1] * w.y + uv[2] * w.z);
            let [(p0, t0), (p1, t1), (p2, t2)] = bary.map(at);
            if !has_area(&[p0, p1, p2]) {
                continue;
            }
            let centre = (t0 + t1 + t2) / 3.0;
            let mean = [centre, 0.5 * (centre + t0), 0.5 * (centre + t1), 0.5 * (centre + t2)].map(|uv| texture.sample(uv)).iter().sum::<Vec3>() / 4.0;
            let radiance = (emitted * mean).max(Vec3::ZERO);
            if radiance.max_element() > 0.0 {
                pieces.push(Piece { corners: [p0, p1, p2], radiance });
            }
        }
    }
    Some(pieces)
}

/// A triangle cut into n² equal triangles, as the barycentric weights of each one's corners
/// (wound as the triangle): n(n + 1)/2 upright and n(n − 1)/2 upside down.
fn sub_triangles(n: u32) -> impl Iterator<Item = [Vec3; 3]> {
    let at = move |i: u32, j: u32| {
        let (u, v) = (i as f32 / n as f32, j as f32 / n as f32);
        Vec3::new(1.0 - u - v, u, v)
    };
    (0..n).flat_map(move |j| (0..n - j).flat_map(move |i| {
        let up = [at(i, j), at(i + 1, j), at(i, j + 1)];
        let down = (i + j + 1 < n).then(|| [at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)]);
        std::iter::once(up).chain(down)
    }))
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

    /// A square (1 × 1 m, radiance 2 × its texture) whose emission texture is white on its left
    /// half (u < ½) and black on the right is cut into pieces on the left half alone, about
    /// `TEXELS_PER_PIECE` texels each, the light's area and mean radiance those of the half that
    /// glows; drawn by their power and weighed by their scale, they give the glow's power
    /// exactly: Σ P(piece) · scale · L̄ A = Σ area · L = 2 · ½ m² per channel (bilinear filtering
    /// blurs one texel's width at the edge: within 1/64).
    #[test]
    fn a_patterned_glow_is_cut_where_it_glows_and_keeps_its_power() {
        let mut texels = vec![[1.0, 1.0, 1.0, 1.0]; 64 * 4];
        for (i, t) in texels.iter_mut().enumerate() {
            if i % 64 >= 32 {
                *t = [0.0, 0.0, 0.0, 1.0];
            }
        }
        let texture = Arc::new(Texture2d { width: 64, height: 4, texels, wrap: [crate::scene::material::Wrap::Clamp; 2] });
        let diffuse = Diffuse { emission: Vec3::splat(2.0), emission_texture: Some(texture), ..Diffuse::pbr() };
        let lamp = Receiver { name: "sign".into(), mesh: Arc::new(plane(glam::Vec2::ONE)), world: glam::Mat4::IDENTITY, diffuse };
        let lit = mesh_lights(&[lamp]);
        let LightShape::Mesh { area, patterned: true, .. } = lit.lights[0].shape else { panic!("a patterned mesh light") };
        let pieces = &lit.triangles;
        assert!(pieces.len() >= 32 && pieces.len() <= 64, "{} pieces for 128 lit texels", pieces.len());
        assert!(pieces.iter().all(|t| t.v0[0] + (t.e1[0] + t.e2[0]) / 3.0 < 0.02), "a piece on the black half");
        let mut before = 0.0;
        let mut power = Vec3::ZERO;
        for t in pieces {
            power += (t.cdf - before) * Vec3::from(t.scale) * lit.lights[0].radiant * area;
            before = t.cdf;
        }
        assert!((power - Vec3::ONE).abs().max_element() < 1.0 / 64.0, "drawn power {power}, the glow's 1 W/sr·π per channel");
        assert!((area - 0.5).abs() < 1.0 / 32.0, "the glowing half's area {area}");
        assert!((lit.lights[0].radiant - Vec3::splat(2.0)).abs().max_element() < 1.0 / 16.0, "mean radiance {}", lit.lights[0].radiant);
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
