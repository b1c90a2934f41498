//! The opaque receivers on the GPU: their triangles in a BVH, their albedo (and base color
//! texture), and the caustic charts refracted photons land in (`shaders/shared/receivers.wgsl`).
//!
//! A chart is a world-axis-aligned grid of texels over the triangles of one receiver whose
//! surfaces face one of the six axis directions, on one side (front faces, or back faces — the
//! inside of a room). Planes, boxes and walls map onto charts exactly; curved receivers are
//! split by the direction they face, like a cube map, so surfaces of one receiver that face the
//! same way and overlap in projection share texels (a documented limit, rare for floors and
//! walls). Charts are rebuilt only when the receivers change.
//!
//! The BVH also holds the triangles of sharp glass meshes (`pipeline::interfaces`), so one
//! closest-hit query finds the next surface of either kind and a shadow ray is stopped by both.

use std::collections::HashMap;
use std::sync::Arc;

use glam::{Vec2, Vec3};

use crate::bvh::{Bvh, MeshTrees, Placed, Triangle};
use crate::scene::{AlphaMode, Diffuse, MeshData, Texture2d, Wrap};
use super::resources::GrowableBuffer;
use crate::frame::{FrameDesc, Receiver};
use crate::gpu::GpuContext;
use super::interfaces::{self, GLASS_TEXTURES, GlassTextures, SharpTriangles};
use crate::gpu::types::{BvhNode, BvhTriangle, Chart, ReceiverGpu, interface_kind, receiver_flags, texel_encoding};

/// Texels along the longest side of one chart, at most.
pub const MAX_CHART_SIDE: f32 = 2048.0;
/// Texels over all charts, at most (16 bytes each in four buffers, 8 in a fifth). 7.5 Mi texels, so that an
/// atlas — with the percent or so that rounding chart sizes up may add — stays under the
/// 128 MiB one binding may hold on many adapters (lavapipe, WebGPU's defaults).
pub const MAX_ATLAS_TEXELS: f32 = 7.5 * 1024.0 * 1024.0;

/// Chart slot of a direction: 2·axis + (0 for +, 1 for −); dominant-axis ties resolve to x,
/// then y, exactly as `chart_for` in WGSL.
pub fn direction_slot(d: Vec3) -> usize {
    let a = d.abs();
    let axis = if a.x >= a.y && a.x >= a.z { 0 } else if a.y >= a.z { 1 } else { 2 };
    2 * axis + usize::from(d[axis] <= 0.0)
}

/// The two world axes a chart of `slot` spans.
fn chart_axes(slot: usize) -> (usize, usize) {
    let axis = (slot % 6) / 2;
    ((axis + 1) % 3, (axis + 2) % 3)
}

/// The world-space triangles of a receiver.
fn world_triangles(r: &Receiver, index: u32) -> Vec<Triangle> {
    let p: Vec<Vec3> = r.mesh.positions.iter().map(|v| r.world.transform_point3(*v)).collect();
    r.mesh
        .triangles
        .iter()
        .enumerate()
        .filter(|(_, t)| t.iter().all(|&i| (i as usize) < p.len()))
        .map(|(k, t)| Triangle { v: t.map(|i| p[i as usize]), receiver: index, index: k as u32 })
        .collect()
}

/// A receiver's textures in `ReceiverGpu`'s order, each with the encoding its texels take.
fn textures(d: &Diffuse) -> [(Option<&Arc<Texture2d>>, u32); 10] {
    use texel_encoding::{LINEAR, SRGB};
    [
        (d.texture.as_ref(), SRGB),
        (d.metallic_roughness_texture.as_ref(), LINEAR),
        (d.normal_texture.as_ref(), LINEAR),
        (d.occlusion_texture.as_ref(), LINEAR),
        (d.emission_texture.as_ref(), SRGB),
        (d.clearcoat_texture.as_ref(), LINEAR),
        (d.clearcoat_roughness_texture.as_ref(), LINEAR),
        (d.sheen_color_texture.as_ref(), SRGB),
        (d.sheen_roughness_texture.as_ref(), LINEAR),
        (d.clearcoat_normal_texture.as_ref(), LINEAR),
    ]
}

/// The texture coordinates of a receiver mesh, when it has a texture to use them for.
fn textured(r: &Receiver) -> Option<&[Vec2]> {
    let any = textures(&r.diffuse).iter().any(|(t, _)| t.is_some_and(|t| t.width > 0 && t.height > 0));
    any.then_some(())?;
    r.mesh.uvs.as_deref().filter(|uv| uv.len() == r.mesh.positions.len())
}

/// The unit tangent (toward +u) of a triangle and the sign that turns cross(n, tangent) into
/// the normal map's +Y (toward −v: glTF images have v down); zero where the UVs are degenerate.
fn triangle_tangent(p: [Vec3; 3], uv: [Vec2; 3]) -> [f32; 4] {
    let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
    let (d1, d2) = (uv[1] - uv[0], uv[2] - uv[0]);
    let det = d1.x * d2.y - d1.y * d2.x;
    if det.abs() < 1e-12 {
        return [0.0; 4];
    }
    let tangent = ((e1 * d2.y - e2 * d1.y) / det).normalize_or_zero();
    let toward_v = (e2 * d1.x - e1 * d2.x) / det;
    let n = e1.cross(e2);
    let sign = if n.cross(tangent).dot(toward_v) > 0.0 { -1.0 } else { 1.0 };
    tangent.extend(sign).to_array()
}

fn is_interface(t: &Triangle) -> bool {
    t.receiver & interface_kind::BIT != 0
}

/// Vec4s per BVH triangle in `triangle_uvs`.
pub const UV_VEC4S: usize = 3;

/// Per BVH triangle (in leaf order), its corners' texture coordinates and its tangent as three
/// vec4s: (uv₀, uv₁), (uv₂, 0, 0), (tangent, sign) (`triangle_tangent`); zeros for
/// untextured receivers and glass meshes without texture coordinates.
fn triangle_uvs(bvh: &Bvh, receivers: &[Receiver], interface_uvs: &[[Vec2; 3]]) -> Vec<[f32; 4]> {
    let mut out = Vec::with_capacity(UV_VEC4S * bvh.triangles.len());
    for t in &bvh.triangles {
        let corners = if is_interface(t) {
            Some(interface_uvs[t.index as usize])
        } else {
            let r = &receivers[t.receiver as usize];
            textured(r).map(|uv| r.mesh.triangles[t.index as usize].map(|i| uv[i as usize]))
        };
        let corners = corners.unwrap_or([Vec2::ZERO; 3]);
        out.push([corners[0].x, corners[0].y, corners[1].x, corners[1].y]);
        out.push([corners[2].x, corners[2].y, 0.0, 0.0]);
        out.push(triangle_tangent(t.v, corners));
    }
    out
}

/// Per BVH triangle (in leaf order), the unit shading normals at its three corners, one vec4
/// each: a sharp mesh's and a PBR receiver's shading normals (the mesh's [`Normals`]), a
/// Lambertian receiver's face normal (its light is the irradiance photons deposit on the
/// triangles themselves, which no shading normal enters).
///
/// [`Normals`]: crate::scene::Normals
fn triangle_normals(bvh: &Bvh, receivers: &[Receiver], interface_normals: &[[Vec3; 3]]) -> Vec<[f32; 4]> {
    let smooth: Vec<Option<Vec<[Vec3; 3]>>> = receivers
        .iter()
        .map(|r| {
            r.diffuse.is_pbr().then(|| {
                let to_world = glam::Mat3::from_mat4(r.world).inverse().transpose();
                let corners = r.mesh.corner_normals();
                corners.into_iter().map(|c| c.map(|n| (to_world * n).normalize_or_zero())).collect()
            })
        })
        .collect();
    bvh.triangles
        .iter()
        .flat_map(|t| {
            if is_interface(t) {
                return interface_normals[t.index as usize];
            }
            match &smooth[t.receiver as usize] {
                Some(corners) => corners[t.index as usize],
                None => [t.normal().normalize(); 3],
            }
        })
        .map(|n| n.extend(0.0).to_array())
        .collect()
}

/// Packs one texel for the GPU: RGB sRGB-encoded or linear, A linear, 8 bits each
/// (`unpack4x8unorm` in the view shader, then the inverse transfer function for sRGB).
fn pack_texel(c: [f32; 4], encoding: u32) -> u32 {
    let byte = |x: f32| (x.clamp(0.0, 1.0) * 255.0).round() as u32;
    let e = |x: f32| if encoding == texel_encoding::SRGB { byte(crate::output::png::srgb_encode(x)) } else { byte(x) };
    e(c[0]) | e(c[1]) << 8 | e(c[2]) << 16 | byte(c[3]) << 24
}

/// The receivers' and glass meshes' textures in one texel array; a texture shared by surfaces
/// (with the same encoding) is stored once. `reduced` holds the textures stored at a lower
/// resolution than their own (`fit_textures`).
#[derive(Default)]
struct TexelAtlas {
    texels: Vec<u32>,
    placed: Vec<(*const Texture2d, u32, u32)>,
    reduced: HashMap<*const Texture2d, Arc<Texture2d>>,
}

/// What `fit_textures` did: how many textures it reduced, and the texels before and after.
#[derive(Debug, Default, PartialEq)]
struct Fitted {
    reduced: usize,
    texels: u64,
    kept: u64,
}

/// Lower resolutions for the largest of `textures` (each with the number of encodings it is
/// stored in) until all their texels fit `max_texels`, one storage binding of the GPU: the
/// largest is halved (`Texture2d::halved`) until it is no longer the largest, and so on — so
/// the detail lost is the least, and small textures stay whole.
fn fit_textures(textures: &[(&Arc<Texture2d>, u64)], max_texels: u64) -> (HashMap<*const Texture2d, Arc<Texture2d>>, Fitted) {
    let size = |t: &Texture2d| t.width as u64 * t.height as u64;
    let mut current: Vec<(Arc<Texture2d>, u64)> = textures.iter().map(|(t, copies)| (Arc::clone(t), *copies)).collect();
    let texels: u64 = current.iter().map(|(t, c)| size(t) * c).sum();
    let mut total = texels;
    let mut reduced = HashMap::new();
    while total > max_texels {
        let Some(i) = (0..current.len()).max_by_key(|&i| size(&current[i].0)) else { break };
        let (t, copies) = &current[i];
        if size(t) <= 1 {
            break;
        }
        let half = Arc::new(t.halved());
        total -= (size(t) - size(&half)) * copies;
        reduced.insert(Arc::as_ptr(textures[i].0), half.clone());
        current[i].0 = half;
    }
    let fitted = Fitted { reduced: reduced.len(), texels, kept: total };
    (reduced, fitted)
}

impl TexelAtlas {
    /// (first texel, width, height, encoding); zeros for none.
    fn place(&mut self, texture: Option<&Arc<Texture2d>>, encoding: u32) -> [u32; 4] {
        let Some(t) = texture.filter(|t| t.width > 0 && t.height > 0) else { return [0; 4] };
        let key = Arc::as_ptr(t);
        let t = self.reduced.get(&key).unwrap_or(t);
        let start = match self.placed.iter().find(|(p, e, _)| std::ptr::eq(*p, key) && *e == encoding) {
            Some(&(_, _, start)) => start,
            None => {
                let start = self.texels.len() as u32;
                self.texels.extend(t.texels.iter().map(|&c| pack_texel(c, encoding)));
                self.placed.push((key, encoding, start));
                start
            }
        };
        [start, t.width, t.height, encoding | wrap_bits(t.wrap)]
    }
}

/// A texture's wrap modes in `texel_encoding`'s bits.
fn wrap_bits(wrap: [Wrap; 2]) -> u32 {
    use texel_encoding::{WRAP_CLAMP, WRAP_MIRROR, WRAP_REPEAT, WRAP_U_SHIFT, WRAP_V_SHIFT};
    let mode = |w: Wrap| match w {
        Wrap::Repeat => WRAP_REPEAT,
        Wrap::Clamp => WRAP_CLAMP,
        Wrap::Mirror => WRAP_MIRROR,
    };
    mode(wrap[0]) << WRAP_U_SHIFT | mode(wrap[1]) << WRAP_V_SHIFT
}

/// A receiver's material as the GPU reads it (charts filled in by `layout`).
fn receiver_gpu(r: &Receiver, atlas: &mut TexelAtlas) -> ReceiverGpu {
    let d = &r.diffuse;
    // Without UVs a texture cannot be looked up: the factors alone shade the surface.
    let mut tex = textures(d).map(|(t, e)| if textured(r).is_some() { atlas.place(t, e) } else { [0; 4] });
    let mut flags = 0;
    if d.is_pbr() {
        flags |= receiver_flags::PBR;
    } else {
        tex[2] = [0; 4]; // (no normal map without the PBR path; is_pbr says there is none)
    }
    flags |= match d.alpha_mode {
        AlphaMode::Opaque => 0,
        AlphaMode::Mask => receiver_flags::MASK,
        AlphaMode::Blend => receiver_flags::BLEND,
    };
    let glowing = d.emitted().max_element() > 0.0;
    let (glow_area, glow_side) = super::mesh_lights::glow_measure(&r.mesh, r.world, d.emitted(), d.emission_texture.is_some(), glowing && r.mesh.is_closed());
    ReceiverGpu {
        albedo: d.color.into(),
        alpha: d.alpha,
        emission: d.emitted().into(),
        metallic: d.metallic,
        roughness: d.roughness,
        specular: d.specular,
        alpha_cutoff: d.alpha_cutoff,
        flags,
        normal_scale: d.normal_scale,
        occlusion_strength: d.occlusion_strength,
        clearcoat: d.clearcoat,
        clearcoat_roughness: d.clearcoat_roughness,
        sheen_color: d.sheen_color.into(),
        sheen_roughness: d.sheen_roughness,
        base_texture: tex[0],
        metallic_roughness_texture: tex[1],
        normal_texture: tex[2],
        occlusion_texture: tex[3],
        emission_texture: tex[4],
        clearcoat_texture: tex[5],
        clearcoat_roughness_texture: tex[6],
        sheen_color_texture: tex[7],
        sheen_roughness_texture: tex[8],
        clearcoat_normal_texture: tex[9],
        clearcoat_normal_scale: d.clearcoat_normal_scale,
        glow_area,
        glow_side,
        ..Default::default()
    }
}


/// A sharp glass mesh's textures (`Glass::textures`) with the encoding each is stored in: the
/// roughness (the metallic-roughness texture's green channel), the normal map, the transmission
/// and the specular factor are stored linear; the tint (base colour), the glow (emissive) and
/// the specular colour sRGB-encoded, as a receiver's colours are.
fn glass_texture_encodings(t: &GlassTextures) -> [(Option<&Arc<Texture2d>>, u32); GLASS_TEXTURES] {
    use texel_encoding::{LINEAR, SRGB};
    [
        (t[0].as_ref(), LINEAR),
        (t[1].as_ref(), SRGB),
        (t[2].as_ref(), SRGB),
        (t[3].as_ref(), LINEAR),
        (t[4].as_ref(), LINEAR),
        (t[5].as_ref(), LINEAR),
        (t[6].as_ref(), SRGB),
    ]
}

/// Every texture the atlas will hold, fitted to `max_texels` (`fit_textures`), warning when
/// any had to be reduced.
fn fitted_atlas(receivers: &[Receiver], glass_textures: &[GlassTextures], max_texels: u64) -> HashMap<*const Texture2d, Arc<Texture2d>> {
    let mut stored: Vec<(&Arc<Texture2d>, u32)> = Vec::new();
    let used = receivers.iter().filter(|r| textured(r).is_some()).flat_map(|r| textures(&r.diffuse));
    let glass = glass_textures.iter().flat_map(glass_texture_encodings);
    for (t, encoding) in used.chain(glass) {
        if let Some(t) = t.filter(|t| !stored.iter().any(|(s, e)| Arc::ptr_eq(s, t) && *e == encoding)) {
            stored.push((t, encoding));
        }
    }
    let mut copies: Vec<(&Arc<Texture2d>, u64)> = Vec::new();
    for (t, _) in stored {
        match copies.iter_mut().find(|(s, _)| Arc::ptr_eq(s, t)) {
            Some((_, n)) => *n += 1,
            None => copies.push((t, 1)),
        }
    }
    let (reduced, fitted) = fit_textures(&copies, max_texels);
    if fitted.reduced > 0 {
        crate::warnings::say_plain(&format!(
            "the scene's textures hold {} Mi texels and one buffer of this GPU {} Mi; refrakt stores the {} largest at a lower \
             resolution ({} Mi texels in all)",
            fitted.texels >> 20,
            max_texels >> 20,
            fitted.reduced,
            fitted.kept >> 20
        ));
    }
    reduced
}

/// CPU-side layout of the receivers: what goes into the GPU buffers.
pub struct ReceiverLayout {
    pub bvh: Bvh,
    pub receivers: Vec<ReceiverGpu>,
    pub charts: Vec<Chart>,
    pub texels: u32,
    /// The indirect maps' charts, one per caustic chart and over the same surface, coarser
    /// (`indirect_charts`); stored after the caustic charts, from `indirect_chart_base`.
    pub indirect_charts: Vec<Chart>,
    pub indirect_texels: u32,
    /// `UV_VEC4S` vec4 of texture coordinates and tangent per BVH triangle (see `triangle_uvs`).
    pub triangle_uvs: Vec<[f32; 4]>,
    /// Three vec4 of corner normals per BVH triangle (see `triangle_normals`).
    pub triangle_normals: Vec<[f32; 4]>,
    /// Every texture's texels, 8-bit packed (`pack_texel`), one after another.
    pub albedo_texels: Vec<u32>,
    /// Each sharp glass mesh's (roughness, tint, emission) textures in `albedo_texels` (for
    /// `interfaces::table`).
    pub interface_textures: Vec<[[u32; 4]; GLASS_TEXTURES]>,
}

/// Texels along the longest side of an indirect chart, at most: bounced light is smooth, and the
/// adaptive filter's widest footprint (`caustics::MAX_RADIUS` = 64 texels) should reach across a
/// good part of a wall where few bounce photons land.
pub const INDIRECT_CHART_SIDE: u32 = 256;

/// The indirect maps' charts: each caustic chart's surface at a texel of a whole multiple of its
/// own, so that no side exceeds `INDIRECT_CHART_SIDE` texels (charts already that small stay as
/// they are). Returns them and their texel count.
pub fn indirect_charts(charts: &[Chart]) -> (Vec<Chart>, u32) {
    let mut offset = 0;
    let coarse = charts
        .iter()
        .map(|c| {
            let k = c.width.max(c.height).div_ceil(INDIRECT_CHART_SIDE).max(1);
            let (width, height) = (c.width.div_ceil(k), c.height.div_ceil(k));
            let chart = Chart { texel: c.texel * k as f32, width, height, offset, ..*c };
            offset += width * height;
            chart
        })
        .collect();
    (coarse, offset)
}

/// Where the indirect charts start in the charts buffer: past the caustic charts, at a whole
/// 256 bytes (the most any adapter asks a binding's offset to be aligned to), so the caustics
/// stage can bind them alone.
pub fn indirect_chart_base(charts: usize) -> u32 {
    let per_block = 256 / std::mem::size_of::<Chart>();
    charts.div_ceil(per_block).max(1) as u32 * per_block as u32
}

/// Lays out BVH and charts; `texel` is the wanted texel size (metres), grown where a chart or
/// the whole atlas would be too large. `interfaces` are the sharp meshes' triangles, corner
/// normals, texture coordinates and textures (`interfaces::triangles`): they join the BVH and
/// the texel atlas but get no charts. Each mesh's tree is taken from `trees` when it only moved
/// (and left there for the next layout).
/// `max_texels` is what one storage binding holds: textures beyond it are stored at a lower
/// resolution, with a warning (`fit_textures`).
pub fn layout(receivers: &[Receiver], interfaces: SharpTriangles, texel: f32, max_texels: u64, trees: &mut MeshTrees) -> ReceiverLayout {
    let mut meshes = Vec::with_capacity(receivers.len() + interfaces.meshes.len());
    // (receiver, slot) → bounds in the chart's two axes.
    let mut extents: Vec<[Option<(Vec2, Vec2)>; 12]> = vec![[None; 12]; receivers.len()];
    for (i, r) in receivers.iter().enumerate() {
        let mut triangles = world_triangles(r, i as u32);
        triangles.retain(|t| {
            let n = t.normal();
            n.is_finite() && n.length_squared() > 0.0
        });
        for t in &triangles {
            let n = t.normal();
            for slot in [direction_slot(n), 6 + direction_slot(-n)] {
                let (u, v) = chart_axes(slot);
                for p in t.v {
                    let q = Vec2::new(p[u], p[v]);
                    let e = extents[i][slot].get_or_insert((q, q));
                    *e = (e.0.min(q), e.1.max(q));
                }
            }
        }
        meshes.push(Placed { mesh: Arc::as_ptr(&r.mesh) as usize, triangles });
    }
    let SharpTriangles { meshes: interface_meshes, normals: interface_normals, uvs: interface_uvs, textures: glass_textures } = interfaces;
    meshes.extend(interface_meshes);
    let bvh = Bvh::build_placed(meshes, trees);
    // Grow the texel where one chart would be too long, then every chart's by one factor if the
    // atlas is too big (growing only the wanted size would not shrink charts already capped).
    let base = texel.max(1e-6);
    let capped = |lo: Vec2, hi: Vec2| base.max((hi - lo).max_element() / MAX_CHART_SIDE);
    let total: f32 = extents
        .iter()
        .flatten()
        .flatten()
        .map(|&(lo, hi)| ((hi - lo) / capped(lo, hi) + 2.0).ceil().element_product())
        .sum();
    let shrink = if total > MAX_ATLAS_TEXELS { (total / MAX_ATLAS_TEXELS).sqrt() * 1.01 } else { 1.0 };
    let texel_for = |lo: Vec2, hi: Vec2| capped(lo, hi) * shrink;
    let mut charts = Vec::new();
    let mut table = Vec::with_capacity(receivers.len());
    let mut offset = 0u32;
    let mut atlas = TexelAtlas::default();
    atlas.reduced = fitted_atlas(receivers, &glass_textures, max_texels);
    for (i, r) in receivers.iter().enumerate() {
        let mut slots = [-1i32; 12];
        for (slot, e) in extents[i].iter().enumerate() {
            let Some((lo, hi)) = *e else { continue };
            let t = texel_for(lo, hi);
            // One texel of margin on each side: deposits at the edge stay inside.
            let size = ((hi - lo) / t + 2.0).ceil().as_uvec2().max(glam::UVec2::ONE);
            slots[slot] = charts.len() as i32;
            charts.push(Chart {
                origin: (lo - Vec2::splat(t)).into(),
                texel: t,
                axis: (slot % 6) as u32,
                width: size.x,
                height: size.y,
                offset,
                _pad0: 0,
            });
            offset += size.x * size.y;
        }
        table.push(ReceiverGpu {
            charts_a: slots[0..4].try_into().expect("4"),
            charts_b: slots[4..8].try_into().expect("4"),
            charts_c: slots[8..12].try_into().expect("4"),
            ..receiver_gpu(r, &mut atlas)
        });
    }
    let interface_textures = glass_textures.iter().map(|t| glass_texture_encodings(t).map(|(t, encoding)| atlas.place(t, encoding))).collect();
    let triangle_uvs = triangle_uvs(&bvh, receivers, &interface_uvs);
    let triangle_normals = triangle_normals(&bvh, receivers, &interface_normals);
    let (indirect_charts, indirect_texels) = indirect_charts(&charts);
    ReceiverLayout {
        bvh,
        receivers: table,
        charts,
        texels: offset,
        indirect_charts,
        indirect_texels,
        triangle_uvs,
        triangle_normals,
        albedo_texels: atlas.texels,
        interface_textures,
    }
}

/// The receivers' GPU buffers and the caustic maps sized by their charts. Buffers only grow:
/// moving receivers re-upload, they do not reallocate.
pub struct Receivers {
    pub bvh_nodes: GrowableBuffer,
    pub bvh_triangles: GrowableBuffer,
    pub receivers: GrowableBuffer,
    pub charts: GrowableBuffer,
    /// Texture coordinates of the BVH triangles (view and march stages).
    pub triangle_uvs: GrowableBuffer,
    /// Corner normals of the BVH triangles (interfaces' shading normals).
    pub triangle_normals: GrowableBuffer,
    /// The sharp interfaces' records (`pipeline::interfaces::table`), written every frame.
    pub interfaces: GrowableBuffer,
    /// The rough glass albedo table (`rough_albedo`), constant: what `cross_interface` reads
    /// beside `interfaces` (view, march and probe stages).
    pub rough_albedo: wgpu::Buffer,
    /// Every receiver's and glass mesh's texture, 8-bit packed (view and march stages).
    pub albedo_texels: GrowableBuffer,
    /// 4 u32 per texel: photon count, flux r, g, b (fixed point), written by the march stage.
    pub caustic_atlas: GrowableBuffer,
    /// Summed-area table of the atlas, then of each footprint level (caustics stage).
    pub caustic_sat: GrowableBuffer,
    /// What the caustics stage's tables sum: the deposits, then one level's share (16 B/texel).
    pub caustic_layer: GrowableBuffer,
    /// Each texel's filter footprint: two adjacent levels and the blend (8 B/texel).
    pub caustic_footprint: GrowableBuffer,
    /// Filtered irradiance per texel (caustics stage → view stage).
    pub caustic_irradiance: GrowableBuffer,
    /// The indirect maps (bounced light), laid out as the caustic maps: bounce photons'
    /// deposits (march stage), and their filtered irradiance (caustics stage → view stage).
    pub indirect_atlas: GrowableBuffer,
    pub indirect_irradiance: GrowableBuffer,
    /// Photons each chart received this frame (caustics stage: charts without any skip their
    /// filter levels).
    pub chart_photons: GrowableBuffer,
    pub layout: ReceiverLayout,
    /// Each mesh's BVH from the last layout, refitted when the mesh only moved.
    trees: MeshTrees,
    /// Changes when a buffer was reallocated (consumers rebind).
    pub generation: u64,
    key: Option<(Vec<ReceiverKey>, Vec<interfaces::MeshKey>)>,
}

/// What identifies a receiver: its mesh, placement and material. The key holds the mesh (and
/// the material its textures), so no other can take its address while the layout is kept;
/// they compare by pointer first, then by data (a procedural plane, box or sphere is made
/// afresh at every evaluation and still keeps its layout while its parameters do).
type ReceiverKey = (Arc<MeshData>, glam::Mat4, Diffuse);

/// What identifies the receivers of a frame.
fn key_of(desc: &FrameDesc, texel: f32) -> Vec<ReceiverKey> {
    let mut key: Vec<_> = desc
        .receivers
        .iter()
        .map(|r| (r.mesh.clone(), r.world, r.diffuse.clone()))
        .collect();
    key.push((Arc::default(), glam::Mat4::from_scale(Vec3::splat(texel)), Diffuse::default()));
    key
}

impl Receivers {
    /// The chart texel for a frame: half a voxel of the volume, where caustics are sharpest.
    pub fn texel_for(desc: &FrameDesc) -> f32 {
        0.5 * desc.volume.voxel_size
    }

    pub fn new(device: &wgpu::Device) -> Self {
        let buffer = |label| GrowableBuffer::new(device, label, 64);
        Self {
            bvh_nodes: buffer("bvh nodes"),
            bvh_triangles: buffer("bvh triangles"),
            receivers: buffer("receivers"),
            charts: buffer("charts"),
            triangle_uvs: buffer("triangle uvs"),
            triangle_normals: buffer("triangle normals"),
            interfaces: buffer("interfaces"),
            rough_albedo: super::rough_albedo::buffer(device),
            albedo_texels: buffer("albedo texels"),
            caustic_atlas: buffer("caustic atlas"),
            caustic_sat: buffer("caustic sat"),
            caustic_layer: buffer("caustic layer"),
            caustic_footprint: buffer("caustic footprint"),
            caustic_irradiance: buffer("caustic irradiance"),
            indirect_atlas: buffer("indirect atlas"),
            indirect_irradiance: buffer("indirect irradiance"),
            chart_photons: buffer("chart photons"),
            layout: layout(&[], Default::default(), 1.0, u64::MAX, &mut MeshTrees::default()),
            trees: MeshTrees::default(),
            generation: super::resources::next_generation(),
            key: None,
        }
    }

    /// Uploads this frame's receivers if they changed; true if they did.
    pub fn update(&mut self, ctx: &GpuContext, desc: &FrameDesc) -> bool {
        let texel = Self::texel_for(desc);
        let key = (key_of(desc, texel), interfaces::mesh_key(desc));
        let changed = self.key.as_ref() != Some(&key);
        if changed {
            // Texels are 4 bytes; one binding must hold them all.
            let max_texels = ctx.limits.max_storage_buffer_binding_size.min(ctx.limits.max_buffer_size) / 4;
            self.layout = layout(&desc.receivers, interfaces::triangles(desc), texel, max_texels, &mut self.trees);
        }
        // (Written every frame: a glass's index or tint animates without a new layout.)
        let table = interfaces::table(desc, &self.layout.interface_textures);
        if self.interfaces.write(ctx, bytemuck::cast_slice(&table)) {
            self.generation = super::resources::next_generation();
        }
        if !changed {
            return false;
        }
        let mut nodes = self.layout.bvh.nodes.clone();
        if self.layout.bvh.triangles.is_empty() {
            nodes = vec![BvhNode::default()]; // first = 0, count = 0: the empty tree
        }
        let triangles: Vec<BvhTriangle> = self.layout.bvh.gpu_triangles();
        let texel_bytes = self.layout.texels.max(1) as u64 * 16;
        let mut grown = self.bvh_nodes.write(ctx, bytemuck::cast_slice(&nodes));
        grown |= self.bvh_triangles.write(ctx, bytemuck::cast_slice(&triangles));
        // Empty arrays still bind a buffer of at least one element.
        let table = if self.layout.receivers.is_empty() { vec![ReceiverGpu::default()] } else { self.layout.receivers.clone() };
        grown |= self.receivers.write(ctx, bytemuck::cast_slice(&table));
        // The caustic charts, then the indirect ones from `indirect_chart_base`.
        let mut charts = self.layout.charts.clone();
        charts.resize(indirect_chart_base(charts.len()) as usize, Chart::default());
        charts.extend_from_slice(&self.layout.indirect_charts);
        grown |= self.charts.write(ctx, bytemuck::cast_slice(&charts));
        let uvs = if self.layout.triangle_uvs.is_empty() { vec![[0.0f32; 4]] } else { self.layout.triangle_uvs.clone() };
        grown |= self.triangle_uvs.write(ctx, bytemuck::cast_slice(&uvs));
        let normals = if self.layout.triangle_normals.is_empty() { vec![[0.0f32; 4]] } else { self.layout.triangle_normals.clone() };
        grown |= self.triangle_normals.write(ctx, bytemuck::cast_slice(&normals));
        let texels = if self.layout.albedo_texels.is_empty() { vec![0u32] } else { self.layout.albedo_texels.clone() };
        grown |= self.albedo_texels.write(ctx, bytemuck::cast_slice(&texels));
        grown |= self.caustic_atlas.reserve(ctx, texel_bytes);
        grown |= self.caustic_sat.reserve(ctx, texel_bytes);
        grown |= self.caustic_layer.reserve(ctx, texel_bytes);
        grown |= self.caustic_footprint.reserve(ctx, texel_bytes / 2);
        grown |= self.caustic_irradiance.reserve(ctx, texel_bytes);
        let indirect_bytes = self.layout.indirect_texels.max(1) as u64 * 16;
        grown |= self.indirect_atlas.reserve(ctx, indirect_bytes);
        grown |= self.indirect_irradiance.reserve(ctx, indirect_bytes);
        grown |= self.chart_photons.reserve(ctx, self.layout.charts.len().max(1) as u64 * 4);
        if grown {
            self.generation = super::resources::next_generation();
        }
        self.key = Some(key);
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::mesh;

    fn receiver(m: crate::scene::MeshData, world: glam::Mat4) -> Receiver {
        Receiver { name: "r".into(), mesh: Arc::new(m), world, diffuse: Diffuse::default() }
    }

    #[test]
    fn a_floor_gets_one_chart_per_side_a_box_twelve() {
        let floor = receiver(mesh::plane(Vec2::new(4.0, 2.0)), glam::Mat4::IDENTITY);
        let l = layout(&[floor], Default::default(), 0.01, u64::MAX, &mut MeshTrees::default());
        // Top (+Y front) and bottom (the back of the same triangles, facing −Y).
        assert_eq!(l.charts.len(), 2);
        let top = &l.charts[l.receivers[0].charts_a[2] as usize];
        assert_eq!(top.axis, 2);
        // A +Y chart spans (z, x): 2 m and 4 m at 1 cm, plus a texel of margin on each side.
        assert_eq!((top.width, top.height), (202, 402));
        let cube = receiver(mesh::cuboid(Vec3::ONE), glam::Mat4::IDENTITY);
        assert_eq!(layout(&[cube], Default::default(), 0.01, u64::MAX, &mut MeshTrees::default()).charts.len(), 12);
    }

    /// The indirect charts cover the caustic charts' surfaces at a whole multiple of their texel,
    /// at most INDIRECT_CHART_SIDE a side, packed one after another; small charts stay as they are.
    #[test]
    fn indirect_charts_cover_the_same_surface_coarser() {
        let floor = receiver(mesh::plane(Vec2::new(4.0, 2.0)), glam::Mat4::IDENTITY);
        let l = layout(&[floor], Default::default(), 0.01, u64::MAX, &mut MeshTrees::default());
        let (fine, coarse) = (&l.charts[0], &l.indirect_charts[0]);
        // 402 texels along the long side: 2 to 1, 201 × 101.
        assert_eq!((coarse.width, coarse.height, coarse.texel), (101, 201, 0.02));
        assert_eq!(coarse.origin, fine.origin);
        assert!(coarse.width as f32 * coarse.texel >= fine.width as f32 * fine.texel);
        assert_eq!(l.indirect_charts[1].offset, 101 * 201);
        assert_eq!(l.indirect_texels, 2 * 101 * 201);
        let small = layout(&[receiver(mesh::plane(Vec2::ONE), glam::Mat4::IDENTITY)], Default::default(), 0.01, u64::MAX, &mut MeshTrees::default());
        assert_eq!((small.indirect_charts[0].width, small.indirect_charts[0].texel), (small.charts[0].width, 0.01));
        // The indirect charts start at a whole 256 bytes (8 charts of 32 bytes).
        assert_eq!((indirect_chart_base(0), indirect_chart_base(2), indirect_chart_base(9)), (8, 8, 16));
    }

    /// A script's `r.plane` floor is a new mesh at every evaluation: the same size keeps the
    /// layout's key (the meshes compare by data), a new size changes it, and the key holds the
    /// mesh it was built from, so no later mesh can reuse its address and pass for it.
    #[test]
    fn a_procedural_floor_made_afresh_keeps_its_layout_while_its_size_does() {
        let dir = tempfile::tempdir().unwrap();
        let script = dir.path().join("floor.lua");
        std::fs::write(&script, r#"local r = require("refrakt")
local scene = r.scene{ camera = r.camera{ position = {0, 1, 3}, target = {0, 0, 0}, size = {8, 8} } }
local floor = r.plane{ size = {1, 1} }
scene:add(r.node{ shape = floor, material = r.diffuse{ color = {0.5, 0.5, 0.5} } })
function update(scene, t) floor.size = {1 + math.floor(t), 1} end
return scene
"#).unwrap();
        let mut source = crate::render::SceneSource::load(&script, &[], &Default::default()).unwrap();
        let mut key_at = |t| key_of(&source.frame_desc(t, &Default::default()).unwrap(), 0.01);
        let (first, again, wider) = (key_at(0.0), key_at(0.5), key_at(1.0));
        assert!(!Arc::ptr_eq(&first[0].0, &again[0].0), "each evaluation makes its plane afresh");
        assert!(first == again, "the same plane keeps its layout");
        assert!(first != wider, "a wider plane gets a new one");
        assert_eq!(Arc::strong_count(&first[0].0), 1, "the key alone holds the first frame's mesh");
    }

    #[test]
    fn slots_match_the_dominant_axis() {
        assert_eq!(direction_slot(Vec3::new(0.1, 0.9, 0.2)), 2);
        assert_eq!(direction_slot(Vec3::new(0.1, -0.9, 0.2)), 3);
        assert_eq!(direction_slot(Vec3::new(-0.7, 0.1, 0.7)), 1, "ties go to x");
    }

    /// Textures beyond one binding: the largest is halved until the rest fit, small ones stay
    /// whole, and the layout stores (and names) the reduced one.
    #[test]
    fn textures_beyond_a_binding_are_stored_at_a_lower_resolution() {
        let texture = |side: u32| {
            Arc::new(Texture2d { width: side, height: side, texels: vec![[0.5, 0.5, 0.5, 1.0]; (side * side) as usize], wrap: Default::default() })
        };
        let (big, small) = (texture(64), texture(16));
        let (reduced, fitted) = fit_textures(&[(&big, 1), (&small, 1)], 1500);
        assert_eq!(fitted, Fitted { reduced: 1, texels: 64 * 64 + 16 * 16, kept: 32 * 32 + 16 * 16 });
        assert_eq!(reduced[&Arc::as_ptr(&big)].width, 32);
        assert!(!reduced.contains_key(&Arc::as_ptr(&small)));
        let (none, _) = fit_textures(&[(&big, 2)], 2 * 64 * 64);
        assert!(none.is_empty(), "what fits is kept whole");
        // Two copies (two encodings) count twice: 2 × 32² = 2048 > 1500 → 16².
        let (twice, fitted) = fit_textures(&[(&big, 2)], 1500);
        assert_eq!((twice[&Arc::as_ptr(&big)].width, fitted.kept), (16, 2 * 16 * 16));
        let mut plane = mesh::plane(Vec2::ONE);
        plane.uvs = Some(vec![Vec2::ZERO; plane.positions.len()]);
        let mut floor = receiver(plane, glam::Mat4::IDENTITY);
        floor.diffuse.texture = Some(big.clone());
        let l = layout(&[floor], Default::default(), 0.01, 1500, &mut MeshTrees::default());
        assert_eq!(l.albedo_texels.len(), 32 * 32);
        assert_eq!(l.receivers[0].base_texture[1..3], [32, 32]);
    }

    #[test]
    fn huge_receivers_are_capped() {
        let floor = receiver(mesh::plane(Vec2::new(1000.0, 1000.0)), glam::Mat4::IDENTITY);
        let l = layout(&[floor], Default::default(), 0.001, u64::MAX, &mut MeshTrees::default());
        assert!(l.texels as f32 <= MAX_ATLAS_TEXELS * 1.01, "{} texels", l.texels);
        assert!(l.charts.iter().all(|c| c.width as f32 <= MAX_CHART_SIDE + 3.0));
    }
}
