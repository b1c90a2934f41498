-- The default scene: what refrakt is for. A glass ball and a Luneburg lens (a gradient-index
-- sphere, n = √(2 − r²/R²)) rest on a floor under a low sun. The ball focuses the sunlight into a
-- bright caustic on the floor in front of it; the lens, which focuses parallel light on its own
-- far surface, spreads a wide glow. Both bend the studio behind them.
--
-- Its sizes are chosen to render in well under a minute on a CPU (Mesa's lavapipe, 2 cores) and
-- in a fraction of a second on a GPU; for a finer picture raise them on the command line:
--   refrakt render examples/default.lua --size 1920x1080 --volume 192 --photons 2e6 --samples 8
local r = require("refrakt")

local scene = r.scene{
  camera      = r.camera{ position = {0, 0.9, 3.1}, target = {0, -0.1, 0}, fov = 35, size = {640, 360} },
  environment = r.environment{ preset = "studio", intensity = 0.5 },
  -- The index volume holds the two spheres and stops a millimetre above the floor, so the
  -- floor is shaded outside it everywhere.
  volume      = { resolution = 64, min = {-1.05, -0.399, -0.6}, max = {1.05, 0.45, 0.45} },
  photons     = 200000,
  samples     = 2,
}

scene:add(r.node{ name = "floor", translation = {0, -0.4, 0}, shape = r.plane{ size = {12, 12} },
                  material = r.diffuse{ color = {0.7, 0.7, 0.7} } })
scene:add(r.node{ name = "ball", translation = {0.55, 0, 0},
                  shape = r.sphere{ radius = 0.4 },
                  material = r.glass{ ior = 1.5, absorption = {0.4, 0.15, 0.0} } })
scene:add(r.node{ name = "lens", translation = {-0.55, 0, -0.1},
                  shape = r.luneburg{ radius = 0.4 } })
-- The sun shines from behind the objects, towards the camera, so their caustics fall in front.
scene:add(r.node{ name = "sun", light = r.sun{ direction = {0.25, -0.75, 0.6}, intensity = 700 } })

return scene
