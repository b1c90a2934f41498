-- The default scene: a Luneburg lens (a gradient-index sphere that focuses parallel light on its
-- far side) and a glass ball, in front of the built-in studio environment.
local r = require("refrakt")

local scene = r.scene{
  camera      = r.camera{ position = {0, 0.25, 3}, target = {0, 0, 0}, fov = 35, size = {1024, 576} },
  environment = r.environment{ preset = "studio", intensity = 1.0, rotation = 0 },
  volume      = { resolution = 128, margin = 0.05 },
}

scene:add(r.node{ name = "lens", translation = {-0.6, 0, 0},
                  shape = r.luneburg{ radius = 0.5 } })
scene:add(r.node{ name = "ball", translation = {0.6, 0, 0},
                  shape = r.sphere{ radius = 0.4 },
                  material = r.glass{ ior = 1.5, absorption = {0.4, 0.15, 0.0} } })

return scene
