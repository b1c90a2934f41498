//! Mesh primitives (glTF 2.0 §3.7.2) as refrakt triangle meshes: positions, triangles (from
//! TRIANGLES, TRIANGLE_STRIP or TRIANGLE_FAN), normals (flat where NORMAL is absent, as §3.7.2.1
//! requires), texture coordinates for a textured receiver, and what deforms them — morph target
//! displacements (§3.7.2.2) and skin influences (§3.7.3.3).

use std::sync::Arc;

use anyhow::{Result, bail};
use glam::{Vec2, Vec3};
use gltf::Semantic;
use gltf::mesh::Mode;

use super::accessor::Accessors;
use super::material::UvMap;
use crate::scene::{MeshData, Normals};

/// Up to 4·n joints per vertex, with their weights (JOINTS_0/WEIGHTS_0, JOINTS_1/WEIGHTS_1, …).
#[derive(Clone, Debug, Default)]
pub struct Influences {
    pub per_vertex: usize,
    pub joints: Vec<u32>,
    pub weights: Vec<f32>,
}

/// One primitive, ready to place on a node.
#[derive(Clone, Debug)]
pub struct Part {
    pub primitive: usize,
    pub material: Option<usize>,
    /// The rest shape (morph weights 0, no skin).
    pub rest: Arc<MeshData>,
    /// Per morph target, a displacement per vertex.
    pub targets: Vec<Vec<Vec3>>,
    /// Per morph target, a normal displacement per vertex (empty where the primitive has no
    /// NORMAL; zeros for a target without one).
    pub normal_targets: Vec<Vec<Vec3>>,
    pub influences: Option<Influences>,
}

/// The mesh's primitives; `uv_map(material)` says which TEXCOORD_n a material samples and how
/// it transforms them.
pub fn read_mesh(mesh: &gltf::Mesh, acc: &Accessors, variant: Option<usize>, uv_map: impl Fn(Option<usize>) -> Option<UvMap>) -> Result<Vec<Part>> {
    mesh.primitives()
        .map(|p| {
            let what = format!("meshes[{}]{} primitives[{}]", mesh.index(), quoted(mesh.name()), p.index());
            let material = material_of(&p, variant);
            Ok(Part { material, ..read_primitive(&p, acc, &what, uv_map(material))? })
        })
        .collect()
}

/// KHR_materials_variants: the material a primitive takes in `variant` (an index into the
/// file's variants) — the mapping that lists it, else the primitive's own material, as the
/// extension says for variants a primitive does not map.
pub fn material_of(p: &gltf::Primitive, variant: Option<usize>) -> Option<usize> {
    let mapped = variant.and_then(|v| p.mappings().find(|m| m.variants().contains(&(v as u32))));
    match mapped {
        Some(m) => Some(m.material().index().unwrap_or(0)),
        None => p.material().index(),
    }
}

pub fn quoted(name: Option<&str>) -> String {
    name.map_or(String::new(), |n| format!(" \"{n}\""))
}

fn read_primitive(p: &gltf::Primitive, acc: &Accessors, what: &str, uv_map: Option<UvMap>) -> Result<Part> {
    let Some(position) = p.get(&Semantic::Positions) else {
        bail!("{}: {what} has no POSITION attribute; every primitive refrakt reads needs one", acc.file);
    };
    let positions: Vec<Vec3> = vec3s(acc, position.index(), &format!("{what} POSITION"))?;
    if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
        bail!("{}: {what}: vertex {i} has a NaN or infinite POSITION; fix the mesh and re-export", acc.file);
    }
    let n = positions.len();
    let order = match p.indices() {
        Some(a) => {
            let indices = acc.uints(a.index(), &format!("{what} indices"), 1)?;
            if let Some(bad) = indices.iter().find(|&&i| i as usize >= n) {
                bail!("{}: {what}: index {bad} names a vertex, but POSITION has only {n}; re-export the mesh", acc.file);
            }
            indices
        }
        None => (0..n as u32).collect(),
    };
    let triangles = triangles(p.mode(), &order).map_err(|m| anyhow::anyhow!("{}: {what}: {m}", acc.file))?;
    let uvs = match uv_map.and_then(|m| p.get(&Semantic::TexCoords(m.set)).map(|a| (m, a))) {
        Some((m, a)) => {
            let uvs = same_count(acc, vec2s(acc, a.index(), &format!("{what} TEXCOORD_{}", m.set))?, n, what, "TEXCOORD")?;
            Some(uvs.into_iter().map(|uv| m.transform.transform_point2(uv)).collect())
        }
        None => None,
    };
    let normals = match p.get(&Semantic::Normals) {
        Some(a) => Normals::Authored(same_count(acc, vec3s(acc, a.index(), &format!("{what} NORMAL"))?, n, what, "NORMAL")?),
        None => Normals::Flat,
    };
    let displacements = |attribute: &str, of: for<'b> fn(&gltf::mesh::MorphTarget<'b>) -> Option<gltf::Accessor<'b>>| {
        p.morph_targets()
            .enumerate()
            .map(|(k, t)| match of(&t) {
                Some(a) => same_count(acc, vec3s(acc, a.index(), &format!("{what} targets[{k}] {attribute}"))?, n, what, "morph target"),
                None => Ok(vec![Vec3::ZERO; n]),
            })
            .collect::<Result<Vec<_>>>()
    };
    let targets = displacements("POSITION", |t| t.positions())?;
    let normal_targets = if matches!(normals, Normals::Authored(_)) { displacements("NORMAL", |t| t.normals())? } else { Vec::new() };
    Ok(Part {
        primitive: p.index(),
        material: p.material().index(),
        rest: Arc::new(MeshData { positions, triangles, uvs, normals }),
        targets,
        normal_targets,
        influences: influences(p, acc, what, n)?,
    })
}

fn same_count<T>(acc: &Accessors, v: Vec<T>, n: usize, what: &str, attribute: &str) -> Result<Vec<T>> {
    if v.len() != n {
        bail!("{}: {what}: {attribute} has {} elements, POSITION has {n}; every attribute needs one per vertex", acc.file, v.len());
    }
    Ok(v)
}

fn vec3s(acc: &Accessors, index: usize, what: &str) -> Result<Vec<Vec3>> {
    Ok(acc.floats_of(index, what, 3)?.values.chunks_exact(3).map(Vec3::from_slice).collect())
}

fn vec2s(acc: &Accessors, index: usize, what: &str) -> Result<Vec<Vec2>> {
    Ok(acc.floats_of(index, what, 2)?.values.chunks_exact(2).map(Vec2::from_slice).collect())
}

/// §3.7.2.1 "Topology types": the triangles a primitive's vertex order describes.
fn triangles(mode: Mode, v: &[u32]) -> Result<Vec<[u32; 3]>, String> {
    match mode {
        Mode::Triangles if v.len().is_multiple_of(3) => Ok(v.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect()),
        Mode::Triangles => Err(format!("{} indices do not make whole triangles (TRIANGLES needs a multiple of 3)", v.len())),
        // pᵢ = {vᵢ, vᵢ₊₍₁₊ᵢ mod 2₎, vᵢ₊₍₂₋ᵢ mod 2₎}: every other triangle flipped to keep the winding.
        Mode::TriangleStrip => Ok((0..v.len().saturating_sub(2))
            .map(|i| [v[i], v[i + 1 + i % 2], v[i + 2 - i % 2]])
            .collect()),
        // pᵢ = {vᵢ₊₁, vᵢ₊₂, v₀}.
        Mode::TriangleFan => Ok((0..v.len().saturating_sub(2)).map(|i| [v[i + 1], v[i + 2], v[0]]).collect()),
        other => Err(format!(
            "its mode is {other:?}; refrakt reads triangle meshes only (TRIANGLES, TRIANGLE_STRIP, TRIANGLE_FAN), so points \
             and lines cannot be glass or receivers (remove the primitive or turn it into faces)"
        )),
    }
}

/// Why a triangle mesh encloses no volume, if it does not: an open surface (edges that belong to
/// one triangle only, once vertices at the same position are taken as one, as UV seams split
/// them) or a closed one with no thickness (a sheet modelled double-sided). refrakt voxelizes
/// the solid a transmissive mesh encloses, so such glass shows nothing.
pub fn encloses_no_volume(mesh: &MeshData) -> Option<String> {
    let open = mesh.welded_edge_counts(&mesh.triangles).values().filter(|&&n| n == 1).count();
    if open > 0 {
        return Some(format!("it is an open surface ({open} edges belong to one triangle only)"));
    }
    let (lo, hi) = mesh.bounds()?;
    let size = (hi - lo).length() as f64;
    // Closed: the divergence theorem's volume is that of the solid, whatever the origin.
    if mesh.signed_volume().abs() <= 1e-6 * size * size * size {
        return Some("it is closed but flat (it encloses no volume)".into());
    }
    None
}

/// JOINTS_n / WEIGHTS_n pairs, all sets the primitive has.
fn influences(p: &gltf::Primitive, acc: &Accessors, what: &str, n: usize) -> Result<Option<Influences>> {
    let mut inf = Influences::default();
    for set in 0.. {
        let (Some(j), Some(w)) = (p.get(&Semantic::Joints(set)), p.get(&Semantic::Weights(set))) else { break };
        let joints = acc.uints(j.index(), &format!("{what} JOINTS_{set}"), 4)?;
        let weights = acc.floats_of(w.index(), &format!("{what} WEIGHTS_{set}"), 4)?.values;
        if joints.len() != 4 * n || weights.len() != 4 * n {
            bail!("{}: {what}: JOINTS_{set} and WEIGHTS_{set} need one element per vertex ({n})", acc.file);
        }
        if weights.iter().any(|w| !w.is_finite()) {
            bail!("{}: {what}: WEIGHTS_{set} holds NaN or infinite weights; re-export the skin", acc.file);
        }
        inf.per_vertex += 4;
        interleave(&mut inf.joints, &joints, set as usize, n);
        interleave(&mut inf.weights, &weights, set as usize, n);
    }
    Ok((inf.per_vertex > 0).then_some(inf))
}

/// Appends a set of 4 values per vertex to `all`, which holds `set` sets per vertex so far.
fn interleave<T: Copy>(all: &mut Vec<T>, next: &[T], set: usize, n: usize) {
    let old = std::mem::take(all);
    all.reserve(old.len() + next.len());
    for v in 0..n {
        all.extend_from_slice(&old[v * 4 * set..(v + 1) * 4 * set]);
        all.extend_from_slice(&next[v * 4..(v + 1) * 4]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strips_and_fans_keep_the_winding() {
        assert_eq!(triangles(Mode::TriangleStrip, &[0, 1, 2, 3]).unwrap(), vec![[0, 1, 2], [1, 3, 2]]);
        assert_eq!(triangles(Mode::TriangleFan, &[0, 1, 2, 3]).unwrap(), vec![[1, 2, 0], [2, 3, 0]]);
        assert!(triangles(Mode::Lines, &[0, 1]).unwrap_err().contains("Lines"));
        assert!(triangles(Mode::Triangles, &[0, 1]).is_err());
    }

    #[test]
    fn sheets_enclose_no_volume_and_solids_with_split_vertices_do() {
        let quad = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 0.0, 1.0), Vec3::Z];
        let mesh = |positions: Vec<Vec3>, triangles: Vec<[u32; 3]>| MeshData { positions, triangles, ..Default::default() };
        let single = mesh(quad.to_vec(), vec![[0, 1, 2], [0, 2, 3]]);
        assert!(encloses_no_volume(&single).unwrap().contains("open surface (4 edges"));
        let double_sided = mesh(quad.to_vec(), vec![[0, 1, 2], [0, 2, 3], [0, 2, 1], [0, 3, 2]]);
        assert!(encloses_no_volume(&double_sided).unwrap().contains("flat"));
        // A tetrahedron whose every triangle has vertices of its own (as UV seams split them).
        let corners = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
        let faces = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
        let positions: Vec<Vec3> = faces.iter().flat_map(|f| f.map(|i| corners[i])).collect();
        let split = mesh(positions, (0..4).map(|k| [3 * k, 3 * k + 1, 3 * k + 2]).collect());
        assert_eq!(encloses_no_volume(&split), None);
    }

    #[test]
    fn influence_sets_interleave_per_vertex() {
        let mut all = Vec::new();
        interleave(&mut all, &[1, 1, 1, 1, 2, 2, 2, 2], 0, 2);
        interleave(&mut all, &[3, 3, 3, 3, 4, 4, 4, 4], 1, 2);
        assert_eq!(all, vec![1, 1, 1, 1, 3, 3, 3, 3, 2, 2, 2, 2, 4, 4, 4, 4]);
    }
}
