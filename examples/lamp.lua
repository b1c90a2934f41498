-- A lamp in a glass shade on a table, at night: a bulb inside a thin, warm-tinted glass sphere.
-- Light reaches the table through the shade (shadow rays pass thin glass, dimmed by its
-- transmittance and tint), the shade's inner reflections leave through its far side as photons,
-- and the tabletop's light bounces onto the wall behind (docs/lights.md).
--   refrakt render examples/lamp.lua --size 1280x720 --photons 1e6 --samples 8
local r = require("refrakt")

local scene = r.scene{
  camera         = r.camera{ position = {0.2, 1.25, 2.4}, target = {0, 0.85, 0}, fov = 40, size = {640, 360} },
  environment    = r.environment{ color = {0, 0, 0} },
  volume         = { resolution = 96 },
  photons        = 400000,
  bounce_photons = 1000000,
  samples        = 4,
}

scene:add(r.node{ name = "table", translation = {0, 0.7, 0}, shape = r.box{ size = {2.0, 0.05, 1.0} },
                  material = r.diffuse{ color = {0.55, 0.38, 0.25} } })
scene:add(r.node{ name = "floor", shape = r.plane{ size = {8, 8} }, material = r.diffuse{ color = {0.5, 0.5, 0.5} } })
scene:add(r.node{ name = "wall", translation = {0, 1.5, -0.8}, rotation = {90, 0, 0}, shape = r.plane{ size = {8, 3} },
                  material = r.diffuse{ color = {0.85, 0.83, 0.8} } })

-- The lamp: a bulb at the centre of a thin glass globe on a stem.
scene:add(r.node{ name = "stem", translation = {-0.4, 0.83, -0.1}, shape = r.box{ size = {0.03, 0.2, 0.03} },
                  material = r.diffuse{ color = {0.1, 0.1, 0.1} } })
scene:add(r.node{ name = "shade", translation = {-0.4, 1.1, -0.1}, shape = r.sphere{ radius = 0.16 },
                  material = r.glass{ ior = 1.5, thin = true, tint = {1.0, 0.8, 0.55} } })
scene:add(r.node{ name = "bulb", translation = {-0.4, 1.1, -0.1}, light = r.point{ intensity = 300, radius = 0.02 } })

-- A glass tumbler's worth of glass on the table: a clear ball throwing the bulb's caustic.
scene:add(r.node{ name = "ball", translation = {0.25, 0.85, 0.1}, shape = r.sphere{ radius = 0.12 },
                  material = r.glass{ ior = 1.5 } })

return scene
