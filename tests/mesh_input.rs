//! Meshes from scripts and files: the constructors, and bad input — a missing or malformed
//! file, an empty mesh, a NaN vertex, degenerate triangles, a mesh larger than the volume —
//! each giving one clear message naming the script's line, or the documented result.

mod common;

use std::path::PathBuf;

use common::*;
use refrakt::lua::{Limits, ScriptHost};
use refrakt::pipeline::voxelize_mesh::FAR;

fn assets() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/assets")
}

/// The error a script stops with (it must stop), one paragraph.
fn script_error(source: &str) -> String {
    let (_dir, path) = write_script("scene.lua", source);
    match ScriptHost::load(&path, &[], &Limits::default()) {
        Ok(_) => panic!("the script should fail:\n{source}"),
        Err(e) => {
            let msg = format!("{e:#}");
            assert!(!msg.contains('\n'), "one paragraph: {msg}");
            msg
        }
    }
}

fn with_node(shape: &str) -> String {
    format!(
        "local r = require(\"refrakt\")\nlocal scene = r.scene{{}}\nscene:add(r.node{{ shape = {shape}, material = r.glass{{}} }})\nreturn scene\n"
    )
}

#[test]
fn mesh_files_load_below_the_scene_folder_or_an_allowed_one() {
    let e = script_error(&with_node("r.mesh{ file = \"missing.obj\" }"));
    assert!(e.contains("scene.lua:3:") && e.contains("cannot open \"missing.obj\""), "{e}");
    let bunny = assets().join("bunny.obj");
    let e = script_error(&with_node(&format!("r.mesh{{ file = {:?} }}", bunny.display().to_string())));
    assert!(e.contains("outside the scene's folder") && e.contains("--allow-read"), "{e}");

    let (_dir, path) = write_script(
        "scene.lua",
        &format!(
            "local r = require(\"refrakt\")\nlocal s = r.scene{{}}\nlocal m = r.mesh{{ file = {:?} }}\n\
             assert(m.triangles == 5000 and m.source:find(\"bunny\"))\ns:add(r.node{{ shape = m, material = r.glass{{}} }})\nreturn s\n",
            bunny.display().to_string()
        ),
    );
    let host = ScriptHost::load(&path, &[assets()], &Limits::default()).unwrap_or_else(|e| panic!("{e:#}"));
    assert!(host.files_read().iter().any(|p| p.ends_with("bunny.obj")), "the mesh is recorded for `refrakt watch`");
}

#[test]
fn malformed_obj_files_are_named_with_what_is_wrong() {
    let dir = tempfile::tempdir().unwrap();
    for (file, text, expected) in [
        ("nan.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n", "vertex 2 is (NaN, 0, 0), not a finite point"),
        ("points.obj", "v 0 0 0\nv 1 0 0\n", "has no faces"),
        ("garbage.obj", "v 0 zero 0\nf 1 2 3\n", "not a valid OBJ file"),
        ("flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n", "zero area"),
    ] {
        std::fs::write(dir.path().join(file), text).unwrap();
        let script = dir.path().join("scene.lua");
        std::fs::write(&script, with_node(&format!("r.mesh{{ file = \"{file}\" }}"))).unwrap();
        let e = format!("{:#}", ScriptHost::load(&script, &[], &Limits::default()).err().expect("must fail"));
        assert!(e.contains("scene.lua:3:") && e.contains(file) && e.contains(expected), "{file}: {e}");
    }
}

#[test]
fn meshes_from_tables_are_checked() {
    let cases = [
        ("r.mesh{ vertices = {}, triangles = {} }", "the mesh is empty"),
        ("r.mesh{ vertices = {{0, 0, 0}, {0/0, 1, 0}, {1, 0, 0}}, triangles = {{1, 2, 3}} }", "mesh.vertices[2] must be"),
        ("r.mesh{ vertices = {{0, 0, 0}, {0, 1, 0}, {1, 0, 0}}, triangles = {{1, 2, 4}} }", "mesh.triangles[1] must be a whole number from 1 to 3"),
        ("r.mesh{ vertices = {{0, 0, 0}, {0, 1, 0}, {1, 0, 0}}, triangles = {{1, 2}} }", "must list three vertex numbers"),
        ("r.mesh{ vertices = {{0, 0, 0}, {1, 1, 1}, {2, 2, 2}}, triangles = {{1, 2, 3}, {1, 1, 2}} }", "zero area"),
        ("r.mesh{ file = \"a.obj\", vertices = {} }", "either a file or vertices and triangles"),
        ("r.mesh{}", "mesh needs a file"),
        ("r.torus{ major_radius = 0.5, minor_raduis = 0.1 }", "did you mean minor_radius?"),
        ("r.torus{ major_radius = 0.2, minor_radius = 0.3 }", "must be smaller than torus.major_radius"),
        ("r.cylinder{ radius = 0.2 }", "cylinder needs a field \"height\""),
        ("r.icosphere{ radius = 0.2, subdivisions = 9 }", "icosphere.subdivisions must be a whole number from 0 to 7"),
        ("r.blob{ radius = 0.2, bumps = 2 }", "blob.bumps must be a relative height from 0 to 0.5"),
        ("r.lathe{ profile = {{0, 0}} }", "at least two points"),
        ("r.lathe{ profile = {{-1, 0}, {1, 1}} }", "lathe.profile[1] must be a point {radius, height} with radius ≥ 0"),
        ("r.lathe{ profile = {{0, 0}, {0, 1}} }", "does the profile enclose an area?"),
        ("r.cube{ size = {1, 1, 1}, boundary = 40 }", "mesh.boundary must be a width in voxels from 0 to 16"),
    ];
    for (shape, expected) in cases {
        let e = script_error(&with_node(shape));
        assert!(e.contains("scene.lua:3:") && e.contains(expected), "{shape}: {e}");
    }
    let e = script_error("local r = require(\"refrakt\")\nlocal home = r.getenv(\"HOME\")\n");
    assert!(e.contains("scene.lua:2:") && e.contains("only variables whose names start with REFRAKT_"), "{e}");
}

#[test]
fn every_primitive_makes_a_closed_solid() {
    let desc = frame_from_lua(
        r#"local r = require("refrakt")
        local scene = r.scene{}
        local shapes = {
          r.icosphere{ radius = 0.2 }, r.cube{ size = {0.3, 0.2, 0.1} }, r.cylinder{ radius = 0.1, height = 0.3 },
          r.torus{ major_radius = 0.2, minor_radius = 0.05 }, r.blob{ radius = 0.2 },
          r.lathe{ profile = {{0, 0}, {0.1, 0.05}, {0.05, 0.2}, {0, 0.2}}, segments = 32 },
          r.mesh{ vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, triangles = {{1, 3, 2}, {1, 2, 4}, {1, 4, 3}, {2, 3, 4}} },
        }
        for i, s in ipairs(shapes) do
          scene:add(r.node{ translation = {i, 0, 0}, shape = s, material = r.glass{} })
        end
        assert(shapes[5].triangles == 5120 and shapes[1].source == "icosphere")
        return scene"#,
    );
    for m in &desc.meshes {
        assert!(m.mesh.signed_volume() > 0.0, "{}: outward and closed", m.name);
    }
    assert_eq!(desc.meshes.len(), 7);
}

#[test]
fn degenerate_triangles_are_ignored_and_big_meshes_clipped() {
    // A tetrahedron, and the same with collapsed and collinear triangles added.
    let tetra = "vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0.5, 0, 0}}";
    let faces = "{1, 3, 2}, {1, 2, 4}, {1, 4, 3}, {2, 3, 4}";
    let scene = |triangles: &str| {
        format!(
            "local r = require(\"refrakt\")\nlocal scene = r.scene{{ volume = {{ resolution = 24 }} }}\n\
             scene:add(r.node{{ shape = r.mesh{{ {tetra}, triangles = {{{triangles}}} }}, material = r.glass{{}} }})\nreturn scene\n"
        )
    };
    let mut r = renderer();
    r.build_volume(&frame_from_lua(&scene(faces))).unwrap();
    let clean = r.mesh_voxels().read_signed_distance(&r.ctx, 0).unwrap();
    r.build_volume(&frame_from_lua(&scene(&format!("{faces}, {{1, 1, 2}}, {{1, 5, 2}}, {{3, 3, 3}}")))).unwrap();
    let with_degenerate = r.mesh_voxels().read_signed_distance(&r.ctx, 0).unwrap();
    assert_eq!(clean, with_degenerate, "degenerate triangles add no surface");

    // A sphere much larger than the fixed volume: the volume is wholly inside the glass.
    let desc = frame_from_lua(
        r#"local r = require("refrakt")
        local scene = r.scene{ volume = { resolution = 16, min = {-0.1, -0.1, -0.1}, max = {0.1, 0.1, 0.1} } }
        scene:add(r.node{ shape = r.icosphere{ radius = 50, subdivisions = 3 }, material = r.glass{ ior = 1.5 } })
        return scene"#,
    );
    r.build_volume(&desc).unwrap();
    let sd = r.mesh_voxels().read_signed_distance(&r.ctx, 0).unwrap();
    assert_eq!(sd.len() as u64, desc.volume.voxel_count(), "the window is the whole volume");
    assert!(sd.iter().all(|d| *d == -FAR), "every voxel of the volume is deep inside the glass");
}

#[test]
fn meshes_take_the_volume_default_or_their_own_boundary() {
    let desc = frame_from_lua(
        r#"local r = require("refrakt")
        local scene = r.scene{ volume = { resolution = 32, boundary = 2 } }
        scene:add(r.node{ shape = r.icosphere{ radius = 0.3 }, material = r.glass{ ior = 1, absorption = {1, 1, 1} } })
        scene:add(r.node{ translation = {1, 0, 0}, shape = r.icosphere{ radius = 0.3, boundary = 0 }, material = r.glass{} })
        scene:add(r.node{ translation = {-1, 0, 0}, shape = r.icosphere{ radius = 0.3 }, material = r.glass{} })
        return scene"#,
    );
    let h = desc.volume.voxel_size;
    // A medium that does not refract takes the volume's default; a boundary set by the script
    // keeps the smooth step; refracting glass with neither is a sharp interface, voxelized only
    // to mark where it is.
    assert!((desc.meshes[0].boundary - 2.0 * h).abs() < 1e-6 && !desc.meshes[0].sharp);
    assert!(desc.meshes[1].boundary == 0.0 && !desc.meshes[1].sharp);
    let mark = refrakt::pipeline::interfaces::MARK_WIDTH_VOXELS * h;
    assert!((desc.meshes[2].boundary - mark).abs() < 1e-6 && desc.meshes[2].sharp);
}

#[test]
fn mesh_examples_load() {
    for (name, triangles) in [("glass_blob.lua", 5120), ("wine_glass.lua", 3840)] {
        let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples").join(name);
        let host = ScriptHost::load(&path, &[], &Limits::default()).unwrap_or_else(|e| panic!("{e:#}"));
        host.update(1.0).unwrap();
        let desc = refrakt::scene::eval::evaluate(&host.scene().borrow(), 1.0, &Default::default()).unwrap();
        assert_eq!(desc.meshes.len(), 1, "{name}");
        assert_eq!(desc.meshes[0].mesh.triangles.len(), triangles, "{name}");
        assert_eq!((desc.camera.width, desc.camera.height, desc.volume.dims.max_element()), (1024, 576, if name == "glass_blob.lua" { 128 } else { 192 }));
    }
    // Without the bunny, its example renders a stand-in (and says where to get the bunny);
    // asked for one it cannot read, it stops and says why.
    let bunny_lua = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples/bunny.lua");
    if std::env::var_os("REFRAKT_BUNNY").is_none() && !bunny_lua.with_file_name("bunny.obj").exists() {
        let host = ScriptHost::load(&bunny_lua, &[], &Limits::default()).unwrap_or_else(|e| panic!("{e:#}"));
        let desc = refrakt::scene::eval::evaluate(&host.scene().borrow(), 0.0, &Default::default()).unwrap();
        assert_eq!(desc.meshes[0].mesh.triangles.len(), 5120, "the stand-in pebble");
    }
    let source = std::fs::read_to_string(&bunny_lua).unwrap().replace("r.getenv(\"REFRAKT_BUNNY\")", "\"missing/bunny.obj\"");
    let e = script_error(&source);
    assert!(e.contains("cannot open \"missing/bunny.obj\"") && e.contains("REFRAKT_BUNNY=/path/to/bunny.obj") && e.contains("--allow-read"), "{e}");
}

/// `smooth` on every mesh constructor and `normals` (and `uvs`) on a mesh given by its vertices:
/// what each shades with, and one clear message for each mistake.
#[test]
fn smooth_and_normals_choose_how_a_mesh_is_shaded() {
    use refrakt::scene::{Normals, Shape};
    let source = "local r = require(\"refrakt\")\nlocal s = r.scene{}\n\
        local tri = { vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, triangles = {{1, 3, 2}, {1, 2, 4}, {1, 4, 3}, {2, 3, 4}} }\n\
        for name, shape in pairs{ ball = r.icosphere{ radius = 1 }, faceted = r.icosphere{ radius = 1, smooth = false },\n\
          rounded = r.cube{ size = {1, 1, 1}, smooth = true }, wide = r.cylinder{ radius = 1, height = 1, smooth = 89.5 },\n\
          given = r.mesh{ vertices = tri.vertices, triangles = tri.triangles, normals = {{-1, -1, -1}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}},\n\
                          uvs = {{0, 0}, {2, 0}, {0, 2}, {0.5, 0.5}} },\n\
          bare = r.mesh(tri) } do\n\
          s:add(r.node{ name = name, shape = shape, material = r.glass{} })\n\
        end\nreturn s\n";
    let (_dir, path) = write_script("scene.lua", source);
    let host = ScriptHost::load(&path, &[], &Limits::default()).unwrap_or_else(|e| panic!("{e:#}"));
    let normals = |name: &str| match &*host.scene().borrow().find(name).unwrap().borrow().shape.as_ref().unwrap().borrow() {
        Shape::Mesh { mesh, .. } => mesh.normals.clone(),
        other => panic!("{other:?}"),
    };
    assert_eq!(normals("ball"), Normals::Crease(30.0), "procedural shapes are smooth below 30°, as before");
    assert_eq!(normals("faceted"), Normals::Flat);
    assert_eq!(normals("rounded"), Normals::Crease(30.0));
    assert_eq!(normals("wide"), Normals::Crease(89.5));
    assert_eq!(normals("bare"), Normals::Flat, "a mesh without normals is flat, as glTF and Blender's OBJ import");
    let Normals::Authored(given) = normals("given") else { panic!() };
    assert_eq!(given[1], glam::Vec3::X);
    let uvs = |name: &str| match &*host.scene().borrow().find(name).unwrap().borrow().shape.as_ref().unwrap().borrow() {
        Shape::Mesh { mesh, .. } => mesh.uvs.clone(),
        other => panic!("{other:?}"),
    };
    assert_eq!(uvs("given").unwrap()[1], glam::Vec2::new(2.0, 0.0));
    assert_eq!(uvs("bare"), None);

    for (shape, expected) in [
        ("r.icosphere{ radius = 1, smooth = 200 }", "icosphere.smooth must be a crease angle in degrees from 0 to 180, or true (30°) or false (flat)"),
        ("r.icosphere{ radius = 1, smooth = \"yes\" }", "icosphere.smooth must be a crease angle"),
        ("r.mesh{ vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, triangles = {{1, 2, 3}}, normals = {{0, 0, 1}} }", "mesh.normals lists 1 normals for 3 vertices"),
        ("r.mesh{ vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, triangles = {{1, 2, 3}}, normals = {{0, 0, 1}, {0, 0, 1}, {0, 0}} }", "normals[3]"),
        ("r.mesh{ file = \"a.obj\", normals = {} }", "either a file or vertices and triangles (and normals, uvs)"),
        ("r.mesh{ vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, triangles = {{1, 2, 3}}, uvs = {{0, 0}, {1, 0}} }", "mesh.uvs lists 2 texture coordinates for 3 vertices"),
        ("r.mesh{ vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, triangles = {{1, 2, 3}}, uvs = {{0, 0}, {1, 0}, {0, 0/0}} }", "uvs[3]"),
        ("r.icosphere{ radius = 1, smoth = 30 }", "smooth"),
    ] {
        let e = script_error(&with_node(shape));
        assert!(e.contains("scene.lua:3:") && e.contains(expected), "{shape}: {e}");
    }
}
