//! Wavefront OBJ meshes (`tobj`): every object and group of the file merged into one mesh,
//! polygons fanned into triangles, materials ignored (refrakt's material comes from the script).

use std::path::Path;

use anyhow::{Result, anyhow, bail};
use glam::Vec3;

use super::MeshData;

/// Reads the OBJ file at `path` into one mesh and checks it (see [`MeshData::check`]).
pub fn load(path: &Path) -> Result<MeshData> {
    let shown = path.display();
    let file = std::fs::File::open(path).map_err(|e| anyhow!("cannot open the mesh {shown}: {e}"))?;
    let options = tobj::LoadOptions { triangulate: true, ignore_points: true, ignore_lines: true, ..Default::default() };
    // Materials are not read: the scene script gives the glass its index and color, and a
    // missing .mtl next to a downloaded model is no reason to fail.
    let (models, _) = tobj::load_obj_buf(&mut std::io::BufReader::new(file), &options, |_| {
        Err(tobj::LoadError::GenericFailure)
    })
    .map_err(|e| anyhow!("{shown} is not a valid OBJ file ({e}); export it again as triangles or polygons"))?;
    let mut mesh = MeshData::default();
    for model in &models {
        let base = mesh.positions.len() as u32;
        mesh.positions.extend(model.mesh.positions.chunks_exact(3).map(|p| Vec3::new(p[0], p[1], p[2])));
        mesh.triangles.extend(model.mesh.indices.chunks_exact(3).map(|t| [base + t[0], base + t[1], base + t[2]]));
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
