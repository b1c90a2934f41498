-- Benchmark "seed": the configuration of the paper's seed implementation — a ~5k-triangle glass
-- object at 1024×576 with a 128³ volume and 70k photons — with the object and the light moving,
-- so every stage runs every frame. The mesh is a procedural pebble unless `--mesh` names an OBJ.
-- "seed-dispersion" is the same scene with dispersive glass (Abbe number 20): spectral photons
-- and camera samples. "seed-sunny" is lit by its environment alone (the "sunny" sky, turning):
-- the sky's photons and shadow rays instead of the spot's.
local r = require("refrakt")
local mesh_file = "@MESH@"
local lit_by_sky = @SKY@

local scene = r.scene{
  camera      = r.camera{ position = {0, 0.32, 0.75}, target = {0, 0.03, 0}, fov = 35, size = {1024, 576} },
  environment = lit_by_sky and r.environment{ preset = "sunny", intensity = 0.5 } or r.environment{ preset = "studio", intensity = 0.4 },
  -- A fixed box, so the moving object is re-voxelized in place.
  volume      = { resolution = 128, min = {-0.18, -0.09, -0.18}, max = {0.18, 0.2, 0.18} },
  photons     = 70000,
  samples     = 1,
}

local shape
if mesh_file ~= "" then
  -- smooth: the Stanford bunny's OBJ carries no normals (flat faces as it is); the paper's is smooth.
  shape = r.mesh{ file = mesh_file, smooth = 30 }
else
  shape = r.blob{ radius = 0.07, detail = @DETAIL@ }
end
-- The object turns about its own vertical axis; a mesh from a file is centred on it first.
local object = scene:add(r.node{ name = "object" })
local glass = object:add(r.node{ shape = shape, material = r.glass{ ior = 1.5, absorption = {0.6, 0.3, 0.0}@GLASS@ } })
if mesh_file ~= "" then
  -- The Stanford bunny (../shared/assets/bunny.obj) stands on the floor, centred.
  glass.translation = {0.017, -0.1133, 0.002}
end
scene:add(r.node{ name = "floor", translation = {0, -0.08, 0}, shape = r.plane{ size = {1.5, 1.5} },
                  material = r.diffuse{ color = {0.8, 0.8, 0.8} } })
if not lit_by_sky then
  scene:add(r.node{ name = "key", translation = {0.3, 0.6, 0.2},
                    light = r.spot{ target = {0, 0, 0}, intensity = 600, angle = 25, blend = 0.2 } })
end

function update(scene, t)
  scene:find("object").rotation = {0, 40 * t, 0}
  if lit_by_sky then
    scene.environment.rotation = 30 * t
  else
    scene:find("key").translation = {0.6 * math.cos(0.5 * t), 0.6, 0.6 * math.sin(0.5 * t)}
  end
end

return scene
