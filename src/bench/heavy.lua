-- Benchmark "heavy": film-like settings — 1920×1080, a 256³ volume, a million photons, fog for
-- light shafts, three refractive objects (mesh, sphere, Luneburg lens) and a moving spot light.
local r = require("refrakt")

local scene = r.scene{
  camera      = r.camera{ position = {0, 0.9, 2.6}, target = {0, 0.05, 0}, fov = 40, size = {1920, 1080} },
  environment = r.environment{ preset = "studio", intensity = 0.15 },
  volume      = { resolution = 256, min = {-1.0, -0.3, -0.6}, max = {1.0, 1.2, 0.6} },
  fog         = r.fog{ density = 0.3, g = 0.3 },
  photons     = 1000000,
  samples     = 1,
}

scene:add(r.node{ name = "pebble", translation = {-0.55, 0.0, 0}, shape = r.blob{ radius = 0.25, detail = 32 },
                  material = r.glass{ ior = 1.5, absorption = {0.5, 0.2, 0.0} } })
scene:add(r.node{ name = "ball", translation = {0.05, 0.0, 0.1}, shape = r.sphere{ radius = 0.22 },
                  material = r.glass{ ior = 1.6 } })
scene:add(r.node{ name = "lens", translation = {0.6, 0.05, -0.1}, shape = r.luneburg{ radius = 0.25 } })
scene:add(r.node{ name = "floor", translation = {0, -0.26, 0}, shape = r.plane{ size = {6, 4} },
                  material = r.diffuse{ color = {0.8, 0.8, 0.8} } })
scene:add(r.node{ name = "key", translation = {0.4, 2.2, 0.3},
                  light = r.spot{ target = {0, -0.2, 0}, intensity = 6000, angle = 30, blend = 0.3 } })

function update(scene, t)
  scene:find("pebble").rotation = {0, 30 * t, 0}
  scene:find("key").translation = {0.8 * math.cos(0.4 * t), 2.2, 0.8 * math.sin(0.4 * t)}
end

return scene
