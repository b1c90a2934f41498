-- Caustics: a spot light shines through a glass ball and a Luneburg lens onto a floor, in a
-- light fog that shows the beams. The lens focuses the parallel-ish light to a point on its far
-- side; the ball throws a bright caustic ring with a focused core.
local r = require("refrakt")

local scene = r.scene{
  camera      = r.camera{ position = {0, 1.1, 3.4}, target = {0, -0.2, 0}, fov = 35, size = {1024, 576} },
  environment = r.environment{ color = {0.02, 0.022, 0.03} },
  -- The volume covers the objects and the air above the floor where the beams show.
  volume      = { resolution = 128, min = {-1.6, -0.62, -1.0}, max = {1.6, 1.4, 1.0} },
  fog         = r.fog{ density = 0.25, g = 0.3 },
  photons     = 400000,
}

scene:add(r.node{ name = "lens", translation = {-0.6, -0.1, 0},
                  shape = r.luneburg{ radius = 0.35 } })
scene:add(r.node{ name = "ball", translation = {0.6, -0.15, 0},
                  shape = r.sphere{ radius = 0.3 },
                  material = r.glass{ ior = 1.5, absorption = {0.3, 0.1, 0.0} } })
scene:add(r.node{ name = "floor", translation = {0, -0.6, 0},
                  shape = r.plane{ size = {6, 4} }, material = r.diffuse{ color = {0.8, 0.8, 0.8} } })
scene:add(r.node{ name = "key", translation = {0, 2.6, 0.2},
                  light = r.spot{ target = {0, -0.6, 0}, intensity = 8000, angle = 35, blend = 0.3 } })

return scene
