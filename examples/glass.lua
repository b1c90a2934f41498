-- Glass as a path tracer shows it: every surface reflects by the Fresnel equations (the studio,
-- the floor, the sun's disc and a bulb mirrored in the glass, strongest at grazing angles) and
-- refracts the rest, so caustics come from refraction and from reflection. A clear ball, a
-- tinted block (coloured glass: `tint`, per surface) and an amber pebble (`absorption`, per
-- metre of glass) under a low sun.
local r = require("refrakt")

local scene = r.scene{
  camera      = r.camera{ position = {0, 0.85, 3.2}, target = {0, 0.05, 0}, fov = 35, size = {1024, 576} },
  environment = r.environment{ preset = "studio", intensity = 0.6 },
  volume      = { resolution = 128, margin = 0.05 },
  photons     = 400000,
}

scene:add(r.node{ name = "floor", translation = {0, -0.4, 0}, shape = r.plane{ size = {16, 16} },
                  material = r.diffuse{ color = {0.6, 0.6, 0.6} } })
scene:add(r.node{ name = "ball", translation = {-0.8, 0, 0}, shape = r.sphere{ radius = 0.4 },
                  material = r.glass{ ior = 1.5 } })
scene:add(r.node{ name = "block", translation = {0.05, -0.15, 0.35}, rotation = {0, 30, 0},
                  shape = r.box{ size = {0.4, 0.5, 0.4} },
                  material = r.glass{ ior = 1.5, tint = r.srgb("#6fd08c") } })
scene:add(r.node{ name = "pebble", translation = {0.85, -0.08, -0.1}, shape = r.blob{ radius = 0.33 },
                  material = r.glass{ ior = 1.5, color = r.srgb("#ffb347"), distance = 0.3 } })
scene:add(r.node{ name = "sun", light = r.sun{ direction = {0.3, -1, 0.75}, intensity = 900 } })
scene:add(r.node{ name = "bulb", translation = {1.4, 1.3, 1.2}, light = r.point{ intensity = 60, radius = 0.08 } })

return scene
