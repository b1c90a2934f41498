-- A white room open to the sky, under a low sun: the sun's patch on the floor and the right wall,
-- a glass ball's caustic in it, and the light both bounce onto the shaded walls — without bounces
-- the left wall would be lit by the sky alone (the `indirect` layer, docs/lights.md).
--   refrakt render examples/white_room.lua --size 1280x720 --photons 7e5 --samples 8
local r = require("refrakt")

local scene = r.scene{
  camera         = r.camera{ position = {0.2, 1.7, 4.6}, target = {0, 0.7, 0}, fov = 50, size = {640, 360} },
  environment    = r.environment{ preset = "sky", intensity = 0.5 },
  volume         = { resolution = 80 },
  photons        = 400000,
  bounce_photons = 1000000,
  bounces        = 4,
  samples        = 4,
}

local white = r.diffuse{ color = {0.8, 0.8, 0.78} }

-- A 4 × 2.5 × 4 m room without a ceiling or a front wall; either side of a plane is lit the same.
local function panel(name, centre, rotation, size)
  scene:add(r.node{ name = name, translation = centre, rotation = rotation, shape = r.plane{ size = size }, material = white })
end
panel("floor", {0, 0, 0}, {0, 0, 0}, {4, 4})
panel("wall left", {-2, 1.25, 0}, {0, 0, -90}, {2.5, 4})
panel("wall right", {2, 1.25, 0}, {0, 0, 90}, {2.5, 4})
panel("wall back", {0, 1.25, -2}, {90, 0, 0}, {4, 2.5})

scene:add(r.node{ name = "ball", translation = {0.2, 0.5, -0.2}, shape = r.sphere{ radius = 0.4 },
                  material = r.glass{ ior = 1.5, absorption = {0.05, 0.02, 0.0} } })
-- A low sun over the left wall: the floor's right half and the right wall in sunlight.
scene:add(r.node{ name = "sun", light = r.sun{ direction = {1, -0.8, -0.25}, intensity = 2500, angular_diameter = 0.53 } })

return scene
