//! Mesh solids against closed forms: voxel volumes of meshes against their exact volumes,
//! under rotation, with holes, flipped and repeated triangles and thin walls; the band of
//! surface voxels separates inside from outside; only changed meshes are voxelized again.

mod common;

use std::path::PathBuf;
use std::sync::Arc;

use common::*;
use glam::{Quat, UVec3, Vec3};
use refrakt::frame::FrameDesc;
use refrakt::gpu::readback;
use refrakt::pipeline::Renderer;
use refrakt::pipeline::voxelize_mesh::FAR;
use refrakt::scene::eval::{EvalOptions, evaluate};
use refrakt::scene::{Glass, Material, MeshData, Node, Scene, Shape, Transform, mesh, obj, shared};

/// The seed assets, shared by every worktree and CI (not part of the project: see docs/testing.md).
fn asset(name: &str) -> MeshData {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/assets").join(name);
    obj::load(&path).unwrap_or_else(|e| panic!("{e:#} (the test meshes live in ../shared/assets)"))
}

/// One glass mesh (n = 2, so α = n − 1) placed by `transform`, in a volume of `resolution`
/// fitted to it, or the fixed box `bounds`. Its boundary is given (the default width, 3 voxels),
/// so a closed mesh is voxelized into n rather than becoming a sharp interface.
fn frame(mesh: MeshData, transform: Transform, resolution: u32, bounds: Option<(Vec3, Vec3)>) -> FrameDesc {
    let scene = Scene::default();
    scene.volume.borrow_mut().resolution = resolution;
    scene.volume.borrow_mut().bounds = bounds;
    let mut node = Node::new("solid");
    node.transform = transform;
    node.shape = Some(shared(Shape::Mesh { mesh: Arc::new(mesh), source: "test".into(), boundary: Some(3.0) }));
    node.material = Some(shared(Material::Glass(Glass { ior: 2.0, ..Default::default() })));
    let mut scene = scene;
    scene.roots.push(shared(node));
    evaluate(&scene, 0.0, &EvalOptions::default()).unwrap()
}

fn turned(rotation: Quat) -> Transform {
    Transform { rotation, ..Default::default() }
}

/// What the GPU made of the scene's first mesh: signed distances over its window, and n.
struct Solid {
    sd: Vec<f32>,
    window_dims: UVec3,
    n: Vec<f32>,
    voxel: f64,
}

impl Solid {
    fn of(r: &mut Renderer, desc: &FrameDesc) -> Self {
        r.build_volume(desc).unwrap();
        let sd = r.mesh_voxels().read_signed_distance(&r.ctx, 0).unwrap();
        let window_dims = r.mesh_voxels().window(0).unwrap().dims;
        let n = bytemuck::cast_slice(&readback::read_buffer(&r.ctx, &r.grids().unwrap().index_field).unwrap()).to_vec();
        Self { sd, window_dims, n, voxel: desc.volume.voxel_size as f64 }
    }

    /// Volume of the voxels whose centre is inside (m³).
    fn occupancy(&self) -> f64 {
        self.sd.iter().filter(|d| **d < 0.0).count() as f64 * self.voxel.powi(3)
    }

    /// ∫α dV of the smooth index (m³), with α = n − 1.
    fn smooth(&self) -> f64 {
        self.n.iter().map(|n| (*n - 1.0) as f64).sum::<f64>() * self.voxel.powi(3)
    }

    fn inside(&self, v: UVec3) -> bool {
        self.sd[(v.x + self.window_dims.x * (v.y + self.window_dims.y * v.z)) as usize] < 0.0
    }

    fn in_band(&self, v: UVec3) -> bool {
        self.sd[(v.x + self.window_dims.x * (v.y + self.window_dims.y * v.z)) as usize].abs() != FAR
    }

    /// Pairs of 26-neighbours that are both outside the band yet differ in inside/outside:
    /// leaks through the surface voxels. Zero means the band is 26-separating.
    fn leaks(&self) -> usize {
        let d = self.window_dims.as_ivec3();
        let mut leaks = 0;
        for z in 0..d.z {
            for y in 0..d.y {
                for x in 0..d.x {
                    let p = glam::IVec3::new(x, y, z);
                    if self.in_band(p.as_uvec3()) {
                        continue;
                    }
                    for o in (0..27).map(|k| glam::IVec3::new(k % 3 - 1, (k / 3) % 3 - 1, k / 9 - 1)) {
                        let q = p + o;
                        if q.cmpge(glam::IVec3::ZERO).all() && q.cmplt(d).all() && !self.in_band(q.as_uvec3())
                            && self.inside(p.as_uvec3()) != self.inside(q.as_uvec3())
                        {
                            leaks += 1;
                        }
                    }
                }
            }
        }
        leaks
    }
}

fn relative(a: f64, b: f64) -> f64 {
    (a - b).abs() / b
}

#[test]
fn sphere_and_box_volumes_converge_to_the_closed_form() {
    let mut r = renderer();
    let tilt = Quat::from_euler(glam::EulerRot::XYZ, 0.3, 0.5, 0.2);
    for (name, m) in [("sphere", mesh::icosphere(0.5, 5)), ("box", mesh::cuboid(Vec3::new(0.6, 0.4, 0.8)))] {
        let exact = m.signed_volume();
        let mut errors = Vec::new();
        for resolution in [32, 64, 128] {
            let s = Solid::of(&mut r, &frame(m.clone(), turned(tilt), resolution, None));
            let (occupancy, smooth) = (relative(s.occupancy(), exact), relative(s.smooth(), exact));
            eprintln!("{name} {resolution}³: occupancy {:+.3}%, smooth ∫α {:+.3}%", 100.0 * (s.occupancy() / exact - 1.0), 100.0 * (s.smooth() / exact - 1.0));
            errors.push((occupancy, smooth));
        }
        let (coarse, fine) = (errors[0], errors[2]);
        assert!(fine.0 < 0.01 && fine.1 < 0.01, "{name} at 128³ is off by more than 1%: {fine:?}");
        assert!(fine.0 < coarse.0 && fine.1 < coarse.1, "{name}: the error must shrink with resolution: {errors:?}");
    }
}

#[test]
fn bunny_volume_closed_and_with_holes() {
    let mut r = renderer();
    let closed = asset("bunny.obj");
    let exact = closed.signed_volume();
    let s = Solid::of(&mut r, &frame(closed, Transform::default(), 128, None));
    let (occupancy, smooth) = (s.occupancy() / exact - 1.0, s.smooth() / exact - 1.0);
    eprintln!("bunny 128³: occupancy {:+.3}%, smooth {:+.3}% of {exact:.4e} m³", 100.0 * occupancy, 100.0 * smooth);
    assert!(occupancy.abs() < 0.02 && smooth.abs() < 0.02);
    assert_eq!(s.leaks(), 0, "the closed bunny's surface band must be 26-separating");
    let open = Solid::of(&mut r, &frame(asset("bunny_open.obj"), Transform::default(), 128, None));
    let (occupancy, smooth) = (open.occupancy() / exact - 1.0, open.smooth() / exact - 1.0);
    eprintln!("open bunny 128³: occupancy {:+.3}%, smooth {:+.3}% of the closed bunny's volume", 100.0 * occupancy, 100.0 * smooth);
    assert!(occupancy.abs() < 0.05 && smooth.abs() < 0.05, "holes must neither empty nor flood the solid");
}

#[test]
fn rotation_keeps_the_volume() {
    let mut r = renderer();
    let bunny = asset("bunny.obj");
    let exact = bunny.signed_volume();
    let mut rng = Rng(0x7077);
    let mut volumes = Vec::new();
    for _ in 0..4 {
        let q = Quat::from_axis_angle(rng.unit_vector(), rng.range(0.0, std::f32::consts::TAU));
        let v = Solid::of(&mut r, &frame(bunny.clone(), turned(q), 80, None)).occupancy();
        eprintln!("bunny turned by {q}: {:+.3}%", 100.0 * (v / exact - 1.0));
        volumes.push(v);
    }
    let (lo, hi) = volumes.iter().fold((f64::MAX, 0.0f64), |(lo, hi), v| (lo.min(*v), hi.max(*v)));
    assert!((hi - lo) / exact < 0.01, "volumes under rotation spread by {:.3}%", 100.0 * (hi - lo) / exact);
}

/// A closed box of zero-thickness faces — the case where a surface voxelization that is not
/// 26-separating lets a flood fill leak — and a hollow box whose walls are thinner than a voxel.
#[test]
fn thin_walls_are_neither_hollow_nor_flooded() {
    let mut r = renderer();
    let q = Quat::from_euler(glam::EulerRot::XYZ, 0.4, 0.7, 0.1);
    let size = Vec3::new(0.7, 0.5, 0.6);
    let desc = frame(mesh::cuboid(size), turned(q), 40, None);
    let s = Solid::of(&mut r, &desc);
    // Away from the band every voxel is classified as the box says.
    let window_min = r.mesh_voxels().window(0).unwrap().min;
    let mut wrong = 0;
    for (i, d) in s.sd.iter().enumerate().filter(|(_, d)| d.abs() == FAR) {
        let v = UVec3::new(i as u32 % s.window_dims.x, (i as u32 / s.window_dims.x) % s.window_dims.y, i as u32 / (s.window_dims.x * s.window_dims.y));
        let local = q.inverse() * desc.volume.voxel_centre(window_min + v);
        let truly_inside = (local.abs() - 0.5 * size).max_element() < 0.0;
        wrong += usize::from(truly_inside != (*d < 0.0));
    }
    assert_eq!(wrong, 0, "voxels away from the surface classified against the box");
    assert_eq!(s.leaks(), 0, "the box's band must be 26-separating");

    // A glass tank: walls 0.4 voxel thick, the inner faces wound either way.
    let voxel = 1.0 / 40.0;
    let wall = 0.4 * voxel;
    for flip_inner in [false, true] {
        let mut tank = mesh::cuboid(Vec3::splat(0.8));
        let inner = mesh::cuboid(Vec3::splat(0.8 - 2.0 * wall));
        let base = tank.positions.len() as u32;
        tank.positions.extend(&inner.positions);
        tank.triangles.extend(inner.triangles.iter().map(|t| {
            let t = t.map(|i| i + base);
            if flip_inner { [t[0], t[2], t[1]] } else { t }
        }));
        let bounds = Some((Vec3::splat(-0.5), Vec3::splat(0.5)));
        let desc = frame(tank, turned(Quat::from_rotation_y(0.3)), 40, bounds);
        let s = Solid::of(&mut r, &desc);
        let inside_far = s.sd.iter().filter(|d| **d == -FAR).count();
        assert_eq!(inside_far, 0, "the tank's air must not be filled (flipped inner faces: {flip_inner})");
        assert_eq!(s.leaks(), 0, "the tank's walls must separate its air from the outside");
        // Every line of voxels through the tank meets glass in each wall: n rises on the way.
        let d = desc.volume.dims;
        for (y, z) in [(20, 20), (12, 25), (27, 14)] {
            let line: Vec<f32> = (0..d.x).map(|x| s.n[(x + d.x * (y + d.y * z)) as usize]).collect();
            let peak = line.iter().copied().fold(0.0, f32::max);
            assert!(peak > 1.25, "line (y {y}, z {z}) crosses the thin walls with n at most {peak}");
        }
    }
}

#[test]
fn holes_flips_and_repeats_give_the_documented_solid() {
    let mut r = renderer();
    let tilt = Quat::from_euler(glam::EulerRot::XYZ, 0.2, 0.9, 0.4);
    let bunny = asset("bunny.obj");
    let reference = Solid::of(&mut r, &frame(bunny.clone(), turned(tilt), 48, None));

    // Orientation is ignored: 30% of the triangles flipped give exactly the same solid.
    let mut flipped = bunny.clone();
    let mut rng = Rng(0xf1f);
    for t in &mut flipped.triangles {
        if rng.next_f32() < 0.3 {
            t.swap(1, 2);
        }
    }
    assert!(relative(flipped.signed_volume(), bunny.signed_volume()) > 0.1, "the flips must spoil the signed volume");
    let s = Solid::of(&mut r, &frame(flipped, turned(tilt), 48, None));
    assert_eq!(s.occupancy(), reference.occupancy(), "flipped triangles change which voxels are inside");
    let worst = s.sd.iter().zip(&reference.sd).map(|(a, b)| (a - b).abs()).fold(0.0, f32::max);
    assert!(worst < 1e-5, "flipped triangles change distances by {worst} voxels");

    // Triangles listed twice count once.
    let mut repeated = bunny.clone();
    let again: Vec<[u32; 3]> = repeated.triangles.iter().step_by(7).map(|t| [t[1], t[0], t[2]]).collect();
    repeated.triangles.extend(again);
    let s = Solid::of(&mut r, &frame(repeated, turned(tilt), 48, None));
    assert_eq!(s.sd, reference.sd, "repeated triangles change the solid");

    // A box without its top, a hole as large as a face. Turned, lines along all three axes
    // leave through the hole near it: such voxels count as outside, never the outside as inside.
    let closed = mesh::cuboid(Vec3::new(0.6, 0.5, 0.7));
    let mut open = closed.clone();
    open.triangles.retain(|t| t.iter().any(|&i| open.positions[i as usize].y < 0.0));
    assert_eq!(open.triangles.len(), 10);
    let a = Solid::of(&mut r, &frame(closed, turned(tilt), 40, None));
    let b = Solid::of(&mut r, &frame(open.clone(), turned(tilt), 40, None));
    let flooded = a.sd.iter().zip(&b.sd).filter(|(x, y)| **x > 0.0 && **y < 0.0).count();
    assert_eq!(flooded, 0, "the hole must not flood the outside");
    let lost = 1.0 - b.occupancy() / a.occupancy();
    eprintln!("box without its top, turned: {:.2}% of the closed box's voxels lost near the hole", 100.0 * lost);
    assert!(lost < 0.15, "the open box lost {:.1}% of its volume", 100.0 * lost);
    // Upright, the side faces close every line that crosses the hole: exactly the closed box.
    let a = Solid::of(&mut r, &frame(mesh::cuboid(Vec3::new(0.6, 0.5, 0.7)), Transform::default(), 40, None));
    let b = Solid::of(&mut r, &frame(open, Transform::default(), 40, None));
    let differ = a.sd.iter().zip(&b.sd).filter(|(x, y)| x.is_sign_negative() != y.is_sign_negative()).count();
    assert_eq!(differ, 0, "an upright open box must voxelize as the closed one");
}

/// A fixed volume, a still mesh and a moving one: the still one is voxelized once, and the
/// result equals a fresh voxelization.
#[test]
fn only_changed_meshes_are_voxelized_again() {
    let source = r#"local r = require("refrakt")
        local scene = r.scene{ volume = { resolution = 40, min = {-1, -1, -1}, max = {1, 1, 1} } }
        scene:add(r.node{ name = "still", translation = {-0.4, 0, 0}, shape = r.blob{ radius = 0.3, detail = 8 },
                          material = r.glass{ ior = 1.5 } })
        scene:add(r.node{ name = "moving", shape = r.torus{ major_radius = 0.3, minor_radius = 0.1 },
                          material = r.glass{ ior = 1.3 } })
        scene:add(r.node{ name = "growing", translation = {0, 0.6, 0}, shape = r.icosphere{ radius = 0.1, subdivisions = 2 },
                          material = r.glass{ ior = 1.4 } })
        function update(scene, t)
          scene:find("moving").translation = {0.4, 0.2 * t, 0}
          scene:find("growing").shape = r.icosphere{ radius = 0.1 + 0.05 * t, subdivisions = 2 }
        end
        return scene"#;
    let (_dir, path) = write_script("anim.lua", source);
    let host = load(&path);
    let at = |t: f64| {
        host.update(t).unwrap();
        evaluate(&host.scene().borrow(), t, &EvalOptions::default()).unwrap()
    };
    let mut r = renderer();
    let n_of = |r: &Renderer| -> Vec<u32> { bytemuck::cast_slice(&readback::read_buffer(&r.ctx, &r.grids().unwrap().index_field).unwrap()).to_vec() };
    r.build_volume(&at(0.0)).unwrap();
    assert_eq!((r.counters.meshes_voxelized, r.counters.meshes_reused), (3, 0));
    let frame1 = at(1.0);
    r.build_volume(&frame1).unwrap();
    assert_eq!((r.counters.meshes_voxelized, r.counters.meshes_reused), (5, 1), "only the moving and the growing mesh are redone");
    r.build_volume(&frame1).unwrap();
    assert_eq!((r.counters.meshes_voxelized, r.counters.meshes_reused), (5, 4), "an unchanged frame redoes nothing");
    let mut fresh = renderer();
    fresh.build_volume(&frame1).unwrap();
    assert_eq!(n_of(&r), n_of(&fresh), "reused solids must give the same volume, bit for bit");
}
