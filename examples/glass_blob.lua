-- A glass pebble made of triangles: a procedural mesh of 5120 triangles (a geodesic sphere
-- with a few smooth bumps), voxelized into the index volume every frame as it turns — the seed
-- configuration of the paper's demos (1024×576, 128³ volume). Render one frame with
--   refrakt render examples/glass_blob.lua
-- or the turn with --frames 0..47.
local r = require("refrakt")

local scene = r.scene{
  camera      = r.camera{ position = {0, 0.45, 2.6}, target = {0, 0, 0}, fov = 35, size = {1024, 576} },
  environment = r.environment{ preset = "studio" },
  volume      = { resolution = 128, margin = 0.05 },
}

local pebble = scene:add(r.node{
  name = "pebble",
  shape = r.blob{ radius = 0.45, bumps = 0.3, seed = 9 },         -- detail 16: 5120 triangles
  material = r.glass{ ior = 1.5, color = {0.75, 0.9, 0.85}, distance = 0.5 },
})

function update(scene, t)
  pebble.rotation = {0, 15 * t, 8}     -- degrees: one turn every 24 s
end

return scene
