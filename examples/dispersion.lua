-- Dispersion in a glass ball and in a Luneburg lens. The ball has n_d = 1.7 and Abbe number 10
-- (twice as dispersive as the densest flint, to show it): each wavelength has its own focus,
-- n(λ)R / (2(n(λ) − 1)) from the centre, so its caustic is a warm core ringed by blue. The Luneburg lens is a gradient-index sphere
-- (n = √(2 − r²/R²) at 587.6 nm) given the same dispersion: its index disperses around the local
-- n (n(λ) − 1 = (n − 1)·k(λ)), so blue light focuses inside the rim and red beyond it.
local r = require("refrakt")

local scene = r.scene{
  camera      = r.camera{ position = {0, 1.5, 1.9}, target = {0, -0.3, 0}, fov = 38, size = {1024, 576} },
  environment = r.environment{ preset = "studio", intensity = 0.05 },
  volume      = { resolution = 128, margin = 0.05 },
  photons     = 1000000,
  samples     = 16,
}

-- A low sun throws both caustics toward the camera; the floor lies past the ball's focus (0.36 m
-- from its centre at 587.6 nm), where each colour has spread to its own ring.
scene:add(r.node{ name = "floor", translation = {0, -0.38, 0}, shape = r.plane{ size = {8, 8} },
                  material = r.diffuse{ color = {0.8, 0.8, 0.8} } })
scene:add(r.node{ name = "ball", translation = {-0.55, 0, 0}, shape = r.sphere{ radius = 0.3 },
                  material = r.glass{ ior = 1.7, abbe = 10 } })
scene:add(r.node{ name = "luneburg", translation = {0.55, 0, 0}, shape = r.luneburg{ radius = 0.3 },
                  material = r.glass{ abbe = 10 } })
scene:add(r.node{ name = "sun", light = r.sun{ direction = {0.1, -1, 0.65}, intensity = 400 } })

return scene
