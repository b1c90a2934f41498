-- A white room lit through its window: the sun's patch on the floor with a glass ball's caustic
-- in it, the sky's light through the opening, and what both bounce onto the walls and ceiling —
-- without bounces the room would be black but for the patch (the `indirect` layer, docs/lights.md).
--   refrakt render examples/white_room.lua --size 1280x720 --photons 1e6 --samples 8
local r = require("refrakt")

local scene = r.scene{
  camera         = r.camera{ position = {-2.1, 1.6, 2.3}, target = {0.2, 0.6, -0.6}, fov = 62, size = {640, 360} },
  environment    = r.environment{ preset = "sky" },
  volume         = { resolution = 80 },
  photons        = 400000,
  bounce_photons = 1000000,
  bounces        = 4,
  samples        = 4,
}

local white = r.diffuse{ color = {0.8, 0.8, 0.78} }

-- A 5 × 3 × 5 m room; its planes face the room (either side of a plane is lit the same).
local function panel(name, centre, rotation, size)
  scene:add(r.node{ name = name, translation = centre, rotation = rotation, shape = r.plane{ size = size }, material = white })
end
panel("floor", {0, 0, 0}, {0, 0, 0}, {5, 5})
panel("ceiling", {0, 3, 0}, {180, 0, 0}, {5, 5})
panel("wall east", {2.5, 1.5, 0}, {0, 0, 90}, {3, 5})
panel("wall west", {-2.5, 1.5, 0}, {0, 0, -90}, {3, 5})
panel("wall south", {0, 1.5, 2.5}, {-90, 0, 0}, {5, 3})
-- The north wall has a window 1.6 m wide from 1.0 to 2.2 m high.
panel("wall north left", {-1.65, 1.5, -2.5}, {90, 0, 0}, {1.7, 3})
panel("wall north right", {1.65, 1.5, -2.5}, {90, 0, 0}, {1.7, 3})
panel("sill", {0, 0.5, -2.5}, {90, 0, 0}, {1.6, 1.0})
panel("lintel", {0, 2.6, -2.5}, {90, 0, 0}, {1.6, 0.8})

scene:add(r.node{ name = "ball", translation = {0.2, 0.4, 0.2}, shape = r.sphere{ radius = 0.35 },
                  material = r.glass{ ior = 1.5, absorption = {0.05, 0.02, 0.0} } })
-- Low sun through the window, into the room (+z) and down.
scene:add(r.node{ name = "sun", light = r.sun{ direction = {0.12, -0.5, 1}, intensity = 60000, angular_diameter = 0.53 } })

return scene
