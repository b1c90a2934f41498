-- Benchmark "grin": gradient-index optics only — a Luneburg lens and a linear-gradient slab
-- under a sun, caustics on a floor; no mesh, so no mesh voxelization.
local r = require("refrakt")

local scene = r.scene{
  camera      = r.camera{ position = {0, 0.8, 2.4}, target = {0, -0.1, 0}, fov = 35, size = {1024, 576} },
  environment = r.environment{ preset = "sky", intensity = 0.5 },
  volume      = { resolution = 128 },
  photons     = 70000,
  samples     = 1,
}

scene:add(r.node{ name = "lens", translation = {-0.5, 0.0, 0}, shape = r.luneburg{ radius = 0.35 } })
scene:add(r.node{ name = "slab", translation = {0.5, 0.0, 0}, rotation = {0, 0, 10},
                  shape = r.slab{ size = {0.6, 0.3, 0.6}, ior = 1.45, gradient = 0.8 } })
scene:add(r.node{ name = "floor", translation = {0, -0.5, 0}, shape = r.plane{ size = {4, 3} },
                  material = r.diffuse{ color = {0.8, 0.8, 0.8} } })
scene:add(r.node{ name = "sun", light = r.sun{ direction = {0.2, -1, -0.3}, intensity = 20000, angular_diameter = 0.53 } })

function update(scene, t)
  scene:find("lens").translation = {-0.5, 0.05 * math.sin(2 * math.pi * t), 0}
end

return scene
