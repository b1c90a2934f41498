-- A scene split over modules: materials come from lib/materials.lua, animation rigs from
-- lib/rigs.lua. Five pieces stand on a turning shelf (a parent node), each bobbing a little.
--
--   refrakt render examples/gallery.lua                 # a still at t = 0
--   refrakt render examples/gallery.lua --frames 1..96  # one turn of the shelf
local r = require("refrakt")
local materials = require("lib.materials")
local rigs = require("lib.rigs")

local scene = r.scene{
  camera      = r.camera{ position = {0, 1.3, 2.7}, target = {0, -0.05, 0}, fov = 40, size = {1024, 576} },
  environment = r.environment{ preset = "studio" },
  volume      = { resolution = 128 },
}

-- The shelf turns; its children are placed on a circle in its frame and turn with it.
local shelf = scene:add(r.node{ name = "shelf" })
local pieces = {
  { name = "water",   shape = r.box{ size = {0.4, 0.4, 0.4} },     material = materials.water },
  { name = "crown",   shape = r.sphere{ radius = 0.27 },           material = materials.crown },
  { name = "amber",   shape = r.sphere{ radius = 0.27 },           material = materials.amber },
  { name = "emerald", shape = r.box{ size = {0.3, 0.45, 0.3} },    material = materials.emerald },
  { name = "lens",    shape = r.luneburg{ radius = 0.3 } },
}
local bobs = {}
for i, piece in ipairs(pieces) do
  local angle = 360 * (i - 1) / #pieces
  piece.translation = r.axis_angle({0, 1, 0}, angle) * {0, 0, 0.8}
  piece.rotation = {0, angle, 0}
  local node = shelf:add(r.node(piece))
  bobs[#bobs + 1] = rigs.bob(node, 0.06, 2, i / #pieces)
end

local pose = rigs.all{ rigs.turntable(shelf, 4), rigs.all(bobs) }
function update(scene, t)
  pose(t)
end

return scene
