-- Thin and rough glass: a window pane of one quad (a thin sheet: it reflects the Fresnel of a
-- thin slab and passes the rest undeviated, tinted once) throws a patch of blue-green sunlight
-- on the floor; beside it a frosted ball (GGX roughness 0.3) blurs what it refracts and reflects,
-- and spreads its caustic, next to a polished one. `samples` lets the frosted surface converge.
local r = require("refrakt")

local scene = r.scene{
  camera      = r.camera{ position = {0, 0.95, 3.3}, target = {0, 0.05, 0}, fov = 35, size = {1024, 576} },
  environment = r.environment{ preset = "studio", intensity = 0.6 },
  volume      = { resolution = 128, margin = 0.05 },
  photons     = 400000,
  samples     = 16,
}

scene:add(r.node{ name = "floor", translation = {0, -0.4, 0}, shape = r.plane{ size = {16, 16} },
                  material = r.diffuse{ color = {0.6, 0.6, 0.6} } })

-- A pane 0.9 × 0.7 m standing on the floor, turned toward the low sun: one quad, so a sheet.
local w, h = 0.45, 0.7
scene:add(r.node{ name = "pane", translation = {0.75, -0.4, -0.35}, rotation = {0, -25, 0},
                  shape = r.mesh{ vertices = {{-w, 0, 0}, {w, 0, 0}, {w, h, 0}, {-w, h, 0}}, triangles = {{1, 2, 3}, {1, 3, 4}} },
                  material = r.glass{ ior = 1.52, thin = true, tint = r.srgb("#8fd8d0") } })

scene:add(r.node{ name = "frosted", translation = {-0.45, -0.1, 0.25}, shape = r.sphere{ radius = 0.3 },
                  material = r.glass{ ior = 1.5, roughness = 0.3 } })
scene:add(r.node{ name = "polished", translation = {-1.2, -0.15, -0.2}, shape = r.sphere{ radius = 0.25 },
                  material = r.glass{ ior = 1.5 } })

scene:add(r.node{ name = "sun", light = r.sun{ direction = {-0.35, -0.8, 0.75}, intensity = 900 } })

return scene
