-- A neon tube over a table at night, and nothing else to light it: the tube is a glowing mesh
-- (a receiver with emission), a light on its own as in Cycles. Its shadow rays give the table
-- soft, long shadows along the tube; its photons bend through a glass ball into a line-shaped
-- caustic (the tube's image); its light bounces off the table onto the wall (docs/lights.md).
--   refrakt render examples/neon.lua --size 1280x720 --photons 1e6 --samples 8
local r = require("refrakt")

local scene = r.scene{
  camera         = r.camera{ position = {0.3, 1.3, 2.3}, target = {0, 0.8, 0}, fov = 40, size = {640, 360} },
  environment    = r.environment{ color = {0, 0, 0} },
  volume         = { resolution = 96 },
  photons        = 400000,
  bounce_photons = 600000,
  samples        = 4,
}

scene:add(r.node{ name = "table", translation = {0, 0.7, 0}, shape = r.box{ size = {2.0, 0.05, 1.0} },
                  material = r.diffuse{ color = {0.6, 0.6, 0.62} } })
scene:add(r.node{ name = "floor", shape = r.plane{ size = {8, 8} }, material = r.diffuse{ color = {0.4, 0.4, 0.4} } })
scene:add(r.node{ name = "wall", translation = {0, 1.5, -0.8}, rotation = {90, 0, 0}, shape = r.plane{ size = {8, 3} },
                  material = r.diffuse{ color = {0.8, 0.8, 0.82} } })

-- The tube: a thin cylinder lying along X, glowing pink (radiance 60 W/m²/sr, both sides).
scene:add(r.node{ name = "tube", translation = {0, 1.45, -0.45}, rotation = {0, 0, 90}, shape = r.cylinder{ radius = 0.015, height = 0.9 },
                  material = r.pbr{ color = {0, 0, 0}, emission = {1, 0.35, 0.7}, emission_strength = 60 } })

-- A clear ball on the table: the tube's caustic is a short bright line under it.
scene:add(r.node{ name = "ball", translation = {0.1, 0.85, 0.05}, shape = r.sphere{ radius = 0.12 },
                  material = r.glass{ ior = 1.5 } })

return scene
