-- A prism and a beam of white light: the spectrum on the floor. The prism's glass has n_d = 1.6
-- and Abbe number 12 (`abbe`, or `dispersion = 20 / abbe` as glTF writes it: twice as dispersive
-- as the densest flint, so the spectrum spreads wide), so its index runs from about 1.66 in the
-- violet to 1.58 in the red (KHR_materials_dispersion's n(λ)). A
-- narrow spot light stands in for the slit of a school experiment and meets the prism at its
-- angle of minimum deviation for 587.6 nm; each photon carries one wavelength, so white light
-- spreads into a continuous rainbow, red deviated least.
local r = require("refrakt")

local n, side, length, height = 1.6, 0.4, 0.5, 1.4

-- An equilateral prism along z with its apex toward +x: light enters the top face and leaves
-- the bottom one.
local h = side / math.sqrt(3)
local corners = { {h, 0}, {-h / 2, side / 2}, {-h / 2, -side / 2} }
local vertices = {}
for _, z in ipairs({ -length / 2, length / 2 }) do
  for _, c in ipairs(corners) do vertices[#vertices + 1] = { c[1], c[2] + height, z } end
end
local prism = r.mesh{ vertices = vertices,
  triangles = { {1, 3, 2}, {4, 5, 6}, {1, 2, 5}, {1, 5, 4}, {2, 3, 6}, {2, 6, 5}, {3, 1, 4}, {3, 4, 6} } }

-- Minimum deviation of a 60° prism: δ = 2·asin(n·sin 30°) − 60°; the beam arrives δ/2 off the
-- vertical, here from the upper left.
local delta = 2 * math.asin(n * 0.5) - math.pi / 3
local dir = { math.sin(delta / 2), -math.cos(delta / 2), 0 }
local entrance = { (corners[1][1] + corners[2][1]) / 2, (corners[1][2] + corners[2][2]) / 2 + height, 0 }
local lamp = { entrance[1] - 3 * dir[1], entrance[2] - 3 * dir[2], 0 }

local scene = r.scene{
  camera      = r.camera{ position = {-0.3, 2.2, 2.6}, target = {-0.45, 0.45, 0}, fov = 40, size = {1024, 576} },
  environment = r.environment{ color = {0.02, 0.02, 0.025} },
  volume      = { resolution = 128, margin = 0.05 },
  photons     = 1000000,
  samples     = 16,
}

scene:add(r.node{ name = "floor", shape = r.plane{ size = {8, 8} }, material = r.diffuse{ color = {0.85, 0.85, 0.85} } })
scene:add(r.node{ name = "prism", shape = prism, material = r.glass{ ior = n, abbe = 12 } })
scene:add(r.node{ name = "lamp", translation = lamp,
                  light = r.spot{ target = entrance, intensity = 200000, angle = 0.8, blend = 0.1, radius = 0.01 } })

return scene
