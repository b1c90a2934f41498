//! Sharp interfaces (`shaders/shared/interface.wgsl`): the surfaces of constant-index objects,
//! where rays and photons refract and reflect once, by Snell's law and the Fresnel equations,
//! at the exact surface — instead of bending across the paper's smoothed step of n, whose width
//! blurs shadows, widens alpha and misplaces caustic energy by a voxel or two.
//!
//! Glass spheres and boxes are analytic: each is one [`Interface`] record the shaders intersect
//! in its local frame. Closed glass meshes are triangles in the receivers' BVH, marked with
//! `interface_kind::BIT | index`, with shading normals per corner; their record carries the
//! medium (index, tint, absorption), and a textured glass's texture coordinates go with its
//! triangles, its textures in the receivers' texel atlas. Which objects are sharp is decided in
//! `scene::eval`.

use std::sync::Arc;

use glam::{Mat3, Vec2, Vec3};

use crate::bvh::{Placed, Triangle};
use crate::scene::{AlphaMode, Glass, MeshData, Texture2d};
use crate::frame::{FieldDesc, FieldKind, FrameDesc, MeshInstance};
use crate::gpu::types::{Interface, interface_kind};

/// The coverage band a sharp object is voxelized with, in voxels. Its n stays out of the grid;
/// the band only marks the voxels it touches for the photon raster (`voxelize.wgsl`): coverage
/// is above zero where the signed distance is below half of it, 0.875 voxel — every voxel whose
/// cube the solid reaches (half a voxel's diagonal is 0.866).
pub const MARK_WIDTH_VOXELS: f32 = 1.75;

/// The textures a glass mesh's surface may carry, in the interface record's order: roughness,
/// tint, emission, normal map, transmission (`scene::Glass::textures`).
pub const GLASS_TEXTURES: usize = 7;
pub type GlassTextures = [Option<Arc<Texture2d>>; GLASS_TEXTURES];


/// The sharp objects of a frame as interface records: the analytic ones first, then the
/// meshes, then one `NONE` record that ends the analytic list even when there is no mesh.
/// `textures`: each sharp mesh's textures (`GlassTextures`) in the texel atlas
/// (`receivers::layout`; zeros for none). Each solid gets its rank among the overlapping
/// (`ranks`) and the contact distance where another solid's box comes that close to its own
/// (elsewhere 0: no crossing searches for a partner that cannot be there).
pub fn table(desc: &FrameDesc, textures: &[[[u32; 4]; GLASS_TEXTURES]]) -> Vec<Interface> {
    let analytic = desc.fields.iter().filter(|f| f.sharp).map(analytic_record);
    let meshes = sharp_meshes(desc).enumerate().map(|(j, m)| {
        // (Every frame: a sharp mesh is a sheet or a closed solid, so `thin` says which.)
        let (glow_area, glow_side) = super::mesh_lights::glow_measure(&m.mesh, m.world, m.glass.emitted(), m.glass.emission_texture.is_some(), !m.thin);
        let texture = |k: usize| textures.get(j).map_or([0; 4], |t| t[k]);
        let surface = surface_record(&m.glass, m.thin);
        Interface {
            world_to_local: m.world.inverse().to_cols_array_2d(),
            kind: interface_kind::MESH | surface.kind,
            roughness_texture: texture(0),
            tint_texture: texture(1),
            emission_texture: texture(2),
            normal_texture: texture(3),
            transmission_texture: texture(4),
            specular_texture: texture(5),
            specular_color_texture: texture(6),
            glow_area,
            glow_side,
            ..surface
        }
    });
    let mut table: Vec<Interface> = analytic.chain(meshes).collect();
    let solids = solids(desc);
    let contact = desc.volume.contact;
    for (i, (record, rank)) in table.iter_mut().zip(ranks(&solids)).enumerate() {
        record.rank = rank;
        record.contact = if has_neighbour(&solids, i, contact) { contact } else { 0.0 };
    }
    table.push(Interface::default());
    table
}

/// What decides which medium holds where sharp objects overlap, per interface in table order.
struct Solid {
    /// Not a thin sheet: it has an inside.
    solid: bool,
    priority: i32,
    /// Its world box.
    bounds: (Vec3, Vec3),
}

impl Solid {
    fn size(&self) -> f32 {
        (self.bounds.1 - self.bounds.0).element_product()
    }
}

fn solids(desc: &FrameDesc) -> Vec<Solid> {
    let analytic = desc.fields.iter().filter(|f| f.sharp).map(|f| Solid { solid: !f.thin, priority: f.glass.priority, bounds: f.bounds });
    let meshes = sharp_meshes(desc).map(|m| Solid { solid: !m.thin, priority: m.glass.priority, bounds: m.bounds });
    analytic.chain(meshes).collect()
}

/// Whether solid i has another solid's box within `contact` of its own: only then can a
/// surface of another lie that close to one of its own.
fn has_neighbour(solids: &[Solid], i: usize, contact: f32) -> bool {
    let (lo, hi) = solids[i].bounds;
    let (lo, hi) = (lo - Vec3::splat(contact), hi + Vec3::splat(contact));
    solids[i].solid
        && contact > 0.0
        && solids.iter().enumerate().any(|(j, s)| j != i && s.solid && s.bounds.0.cmple(hi).all() && s.bounds.1.cmpge(lo).all())
}

/// Each solid's rank (1 = holds least; thin sheets 0): by priority, higher first, then the
/// smaller object — a liquid modelled into its glass's wall is liquid there, ice in water is
/// ice — then the later in the table, so no two share one.
fn ranks(solids: &[Solid]) -> Vec<u32> {
    let mut order: Vec<usize> = (0..solids.len()).filter(|&i| solids[i].solid).collect();
    order.sort_by(|&a, &b| {
        let (sa, sb) = (&solids[a], &solids[b]);
        sa.priority.cmp(&sb.priority).then(sb.size().total_cmp(&sa.size())).then(a.cmp(&b))
    });
    let mut ranks = vec![0; solids.len()];
    for (rank, i) in order.into_iter().enumerate() {
        ranks[i] = rank as u32 + 1;
    }
    ranks
}

fn analytic_record(f: &FieldDesc) -> Interface {
    let kind = match f.kind {
        FieldKind::Sphere => interface_kind::SPHERE,
        FieldKind::Box => interface_kind::BOX,
        _ => unreachable!("only spheres and boxes are sharp (scene::eval::is_sharp)"),
    };
    let surface = surface_record(&f.glass, f.thin);
    Interface { world_to_local: f.world_to_local.to_cols_array_2d(), half_size: f.half_size.into(), kind: kind | surface.kind, ..surface }
}

/// What a sharp object's glass says of its surface and the medium behind it, as one record:
/// the part analytic shapes and meshes share (their shape, placement and textures are theirs).
fn surface_record(glass: &Glass, thin: bool) -> Interface {
    Interface {
        kind: thin_bit(thin) | single_scattering_bit(glass.multiscatter) | alpha_bits(thin, glass.alpha_mode),
        tint: glass.tint.into(),
        ior: glass.ior,
        absorption: glass.absorption.into(),
        roughness: glass.roughness,
        dispersion: glass.dispersion,
        emission: glass.emitted().into(),
        normal_scale: glass.normal_scale,
        transmission: glass.transmission,
        alpha: glass.alpha,
        alpha_cutoff: glass.alpha_cutoff,
        metallic: glass.metallic,
        base_color: glass.base().into(),
        specular: glass.specular,
        specular_color: glass.specular_color.into(),
        ..Default::default()
    }
}

fn thin_bit(thin: bool) -> u32 {
    if thin { interface_kind::THIN } else { 0 }
}

/// A sheet's alpha mode; a solid's alpha is not read (`FrameDesc::warnings` says so).
fn alpha_bits(thin: bool, mode: AlphaMode) -> u32 {
    match mode {
        AlphaMode::Mask if thin => interface_kind::ALPHA_MASK,
        AlphaMode::Blend if thin => interface_kind::ALPHA_BLEND,
        _ => 0,
    }
}

fn single_scattering_bit(multiscatter: bool) -> u32 {
    if multiscatter { 0 } else { interface_kind::SINGLE_SCATTERING }
}

fn sharp_meshes(desc: &FrameDesc) -> impl Iterator<Item = &MeshInstance> {
    desc.meshes.iter().filter(|m| m.sharp)
}

/// The sharp meshes' part of the BVH and what its triangles carry.
#[derive(Default)]
pub struct SharpTriangles {
    /// World-space triangles, a list per mesh (`receiver` = BIT | interface index, `index` =
    /// where their corners are in `normals` and `uvs`).
    pub meshes: Vec<Placed>,
    /// Corner shading normals, world space.
    pub normals: Vec<[Vec3; 3]>,
    /// Corner texture coordinates (zeros on a mesh without them).
    pub uvs: Vec<[Vec2; 3]>,
    /// Each sharp mesh's textures, where it has texture coordinates.
    pub textures: Vec<GlassTextures>,
}

pub fn triangles(desc: &FrameDesc) -> SharpTriangles {
    let first = desc.fields.iter().filter(|f| f.sharp).count() as u32;
    let mut out = SharpTriangles::default();
    for (j, m) in sharp_meshes(desc).enumerate() {
        let mut triangles = Vec::with_capacity(m.mesh.triangles.len());
        let normal_to_world = Mat3::from_mat4(m.world).inverse().transpose();
        let positions: Vec<Vec3> = m.mesh.positions.iter().map(|p| m.world.transform_point3(*p)).collect();
        let facts = MeshData::glass_facts(&m.mesh);
        for (t, n) in m.mesh.triangles.iter().zip(&facts.corner_normals) {
            triangles.push(Triangle {
                v: t.map(|i| positions[i as usize]),
                receiver: interface_kind::BIT | (first + j as u32),
                index: out.normals.len() as u32,
            });
            out.normals.push(n.map(|v| (normal_to_world * v).normalize_or_zero()));
            out.uvs.push(m.mesh.uvs.as_ref().map_or([Vec2::ZERO; 3], |uv| t.map(|i| uv[i as usize])));
        }
        let textured = m.mesh.uvs.is_some();
        let texture = |t: &Option<Arc<Texture2d>>| t.clone().filter(|_| textured);
        out.textures.push(m.glass.textures().map(texture));
        out.meshes.push(Placed { mesh: Arc::as_ptr(&m.mesh) as usize, triangles });
    }
    out
}

/// The sharp interfaces whose solid contains `p` (thin sheets contain nothing), outermost first (by the size of their boxes),
/// packed as the shaders' media stack (`shared/interface.wgsl`): interface index + 1 in 16 bits,
/// two to a word, at most four. Lights and the camera inside glass start their paths with it.
pub fn media_at(desc: &FrameDesc, p: Vec3) -> [u32; 2] {
    let analytic = desc.fields.iter().filter(|f| f.sharp).map(|f| (f.bounds, !f.thin && field_contains(f, p)));
    // (The box first: the crossing count walks every triangle, and this runs every frame.)
    let in_box = |(lo, hi): (Vec3, Vec3)| p.cmpge(lo).all() && p.cmple(hi).all();
    let meshes = sharp_meshes(desc).map(|m| (m.bounds, !m.thin && in_box(m.bounds) && m.mesh.encloses(m.world, p)));
    let mut around: Vec<(f32, u32)> = analytic
        .chain(meshes)
        .enumerate()
        .filter(|(_, (_, inside))| *inside)
        .map(|(i, ((lo, hi), _))| (-(hi - lo).element_product(), i as u32))
        .collect();
    around.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut words = [0u32; 2];
    for (slot, (_, i)) in around.iter().take(4).enumerate() {
        words[slot / 2] |= ((i + 1) & 0xffff) << (16 * (slot % 2));
    }
    words
}

fn field_contains(f: &FieldDesc, p: Vec3) -> bool {
    let q = f.world_to_local.transform_point3(p);
    match f.kind {
        FieldKind::Sphere => q.length() < f.half_size.x,
        _ => q.abs().cmplt(f.half_size).all(),
    }
}


/// A sharp mesh, its placement, and its textures: held (so no other can take their addresses
/// while a layout built from them is kept), compared by pointer first, then by data.
pub type MeshKey = (Arc<MeshData>, glam::Mat4, [Option<Arc<Texture2d>>; GLASS_TEXTURES]);

/// What identifies the sharp meshes' triangles and textures (so the BVH and the texel atlas
/// are rebuilt when one moves or another texture takes its place).
pub fn mesh_key(desc: &FrameDesc) -> Vec<MeshKey> {
    sharp_meshes(desc).map(|m| (m.mesh.clone(), m.world, m.glass.textures().map(Clone::clone))).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::mesh;

    #[test]
    fn the_higher_priority_then_the_smaller_solid_holds_and_sheets_have_no_rank() {
        let cube = |side: f32| (Vec3::ZERO, Vec3::splat(side));
        let solid = |priority, side| Solid { solid: true, priority, bounds: cube(side) };
        let glass = solid(0, 2.0);
        let water = solid(0, 1.8);
        let ice = solid(0, 0.4);
        let pane = Solid { solid: false, priority: 9, bounds: cube(0.2) };
        assert_eq!(ranks(&[glass, water, ice, pane]), [1, 2, 3, 0], "the smaller holds");
        let (glass, water) = (solid(1, 8.0), solid(0, 6.0));
        assert_eq!(ranks(&[glass, water]), [2, 1], "priority first");
        assert_eq!(ranks(&[solid(0, 1.0), solid(0, 1.0)]), [1, 2], "ties: the later");
    }

    #[test]
    fn only_solids_whose_boxes_come_within_the_contact_distance_search_for_partners() {
        let at = |x: f32, thin: bool| Solid { solid: !thin, priority: 0, bounds: (Vec3::new(x, 0.0, 0.0), Vec3::new(x + 1.0, 1.0, 1.0)) };
        let solids = [at(0.0, false), at(1.0005, false), at(3.0, false), at(4.0, true)];
        let searching: Vec<bool> = (0..4).map(|i| has_neighbour(&solids, i, 0.001)).collect();
        assert_eq!(searching, [true, true, false, false], "the pair 0.5 mm apart; a lone solid and a sheet never");
        assert!(!has_neighbour(&solids, 0, 0.0), "contact 0 turns it off");
    }

    #[test]
    fn smooth_normals_follow_a_sphere_and_keep_a_cubes_edges() {
        let ball = mesh::icosphere(1.0, 3);
        for (t, n) in ball.triangles.iter().zip(ball.corner_normals()) {
            for (i, n) in t.iter().zip(n) {
                // On a unit sphere the true normal is the position.
                assert!(n.dot(ball.positions[*i as usize].normalize()) > 0.9995);
            }
        }
        // Smoothed below 30°: a cube's 90° edges stay sharp.
        let cube = MeshData { normals: crate::scene::Normals::Crease(30.0), ..mesh::cuboid(Vec3::ONE) };
        for (t, n) in cube.triangles.iter().zip(cube.corner_normals()) {
            let [a, b, c] = t.map(|i| cube.positions[i as usize]);
            let face = (b - a).cross(c - a).normalize();
            assert!(n.iter().all(|v| v.dot(face) > 0.9999), "a cube's faces stay flat");
        }
        assert!(ball.is_closed() && cube.is_closed());
        assert!(!mesh::plane(glam::Vec2::ONE).is_closed());
    }
}
