-- Lit by its environment alone: no light in the scene, only the "sunny" sky (a blue sky and a
-- sun disc ~2.3° across, five times as bright as the sky on the ground). The sky is a light as
-- any light is: its sun throws a hard shadow and a caustic through the glass, the blue sky a soft
-- shadow under each object, and both pass the glass as photons (docs/lights.md).
--   refrakt render examples/sunlit.lua --size 1280x720 --photons 2e6 --samples 8
local r = require("refrakt")

local scene = r.scene{
  camera      = r.camera{ position = {0.4, 0.7, 3.0}, target = {0, -0.1, -0.3}, fov = 35, size = {640, 360} },
  environment = r.environment{ preset = "sunny", intensity = 0.2, rotation = 20 },
  volume      = { resolution = 80 },
  photons     = 400000,
  samples     = 4,
}

scene:add(r.node{ name = "floor", translation = {0, -0.4, 0}, shape = r.plane{ size = {60, 60} },
                  material = r.diffuse{ color = {0.75, 0.72, 0.68} } })
scene:add(r.node{ name = "ball", translation = {-0.45, 0, -0.2},
                  shape = r.sphere{ radius = 0.4 },
                  material = r.glass{ ior = 1.5, absorption = {0.0, 0.1, 0.3} } })
scene:add(r.node{ name = "block", translation = {0.55, -0.15, -0.1}, rotation = {0, 30, 0},
                  shape = r.box{ size = {0.5, 0.5, 0.5} },
                  material = r.glass{ ior = 1.5, absorption = {0.4, 0.05, 0.1} } })

return scene
