//! Wavefront OBJ meshes (`tobj`): every object and group of the file merged into one mesh,
//! polygons fanned into triangles, its `vn` normals as the shading normals (flat where the file
//! has none, as Blender imports it), materials ignored (refrakt's material comes from the script).

use std::path::Path;

use anyhow::{Result, anyhow, bail};
use glam::Vec3;

use super::{MeshData, Normals};

/// Reads the OBJ file at `path` into one mesh and checks it (see [`MeshData::check`]).
pub fn load(path: &Path) -> Result<MeshData> {
    let shown = path.display();
    let file = std::fs::File::open(path).map_err(|e| anyhow!("cannot open the mesh {shown}: {e}"))?;
    // One index per vertex: a corner's position and normal come from one vertex (tobj splits a
    // position that has several normals — a crease — into several vertices, which the closed-
    // surface checks weld back by position).
    let options = tobj::LoadOptions { triangulate: true, single_index: true, ignore_points: true, ignore_lines: true };
    // Materials are not read: the scene script gives the glass its index and color, and a
    // missing .mtl next to a downloaded model is no reason to fail.
    let (models, _) = tobj::load_obj_buf(&mut std::io::BufReader::new(file), &options, |_| {
        Err(tobj::LoadError::GenericFailure)
    })
    .map_err(|e| anyhow!("{shown} is not a valid OBJ file ({e}); export it again as triangles or polygons"))?;
    let mut mesh = MeshData::default();
    let mut normals = Vec::new();
    for model in &models {
        let base = mesh.positions.len() as u32;
        let vertices = model.mesh.positions.len() / 3;
        mesh.positions.extend(model.mesh.positions.chunks_exact(3).map(Vec3::from_slice));
        mesh.triangles.extend(model.mesh.indices.chunks_exact(3).map(|t| [base + t[0], base + t[1], base + t[2]]));
        // A group without `vn` gets zero normals: its triangles are shaded flat.
        match model.mesh.normals.chunks_exact(3).map(Vec3::from_slice).collect::<Vec<_>>() {
            given if given.len() == vertices => normals.extend(given),
            _ => normals.extend(std::iter::repeat_n(Vec3::ZERO, vertices)),
        }
    }
    if normals.iter().any(|n| *n != Vec3::ZERO) {
        mesh.normals = Normals::Authored(normals);
    }
    if mesh.triangles.is_empty() {
        bail!("{shown} has no faces ({} vertices, no triangles or polygons); a glass mesh needs a surface", mesh.positions.len());
    }
    mesh.check().map_err(|e| anyhow!("{shown}: {e}"))?;
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(text: &str) -> tempfile::NamedTempFile {
        let f = tempfile::Builder::new().suffix(".obj").tempfile().unwrap();
        std::fs::write(f.path(), text).unwrap();
        f
    }

    #[test]
    fn loads_quads_and_groups_as_triangles() {
        let f = write("o a\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\no b\nv 0 0 1\nv 1 0 1\nv 0 1 1\nf 5 6 7\n");
        let m = load(f.path()).unwrap();
        assert_eq!(m.triangles.len(), 3);
        assert_eq!(m.positions.len(), 7);
        assert_eq!(m.triangles[2], [4, 5, 6]);
    }

    #[test]
    fn vn_normals_shade_the_mesh_and_a_file_without_them_is_flat() {
        // A square pyramid's two slopes, each corner with a normal of its own (a crease at the
        // ridge: the ridge's position has two normals), and a triangle of a group without `vn`.
        let f = write(
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 0 0 1\nvn 0 0 2\nvn 0.6 0 0.8\n\
             f 1//1 2//2 3//1\nf 2//2 4//2 3//1\no bare\nf 1 2 5\n",
        );
        let m = load(f.path()).unwrap();
        assert_eq!(m.triangles.len(), 3);
        let corners = m.corner_normals();
        assert_eq!(corners[0], [Vec3::Z, Vec3::new(0.6, 0.0, 0.8), Vec3::Z], "vn as given, normalized");
        // The triangle without normals: its own face normal (−Y for corners 1, 2, 5) at each corner.
        assert_eq!(corners[2], [Vec3::NEG_Y; 3]);
        let flat = load(write("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").path()).unwrap();
        assert_eq!(flat.normals, Normals::Flat);
    }

    #[test]
    fn bad_files_say_what_is_wrong() {
        let missing = load(Path::new("/nonexistent/bunny.obj")).unwrap_err().to_string();
        assert!(missing.contains("cannot open the mesh /nonexistent/bunny.obj"), "{missing}");
        let empty = write("v 0 0 0\nv 1 0 0\n");
        assert!(load(empty.path()).unwrap_err().to_string().contains("has no faces"));
        let nan = write("v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n");
        let e = load(nan.path()).unwrap_err().to_string();
        assert!(e.contains("vertex 2 is (NaN, 0, 0)"), "{e}");
        let garbage = write("v 0 zero 0\nf 1 2 3\n");
        assert!(load(garbage.path()).unwrap_err().to_string().contains("not a valid OBJ file"));
    }
}
