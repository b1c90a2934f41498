-- Depth of field: three glass balls 1.9, 2.7 and 4.0 m away, the camera's thin lens focused on the middle one
-- (`focus`: 2.5 m along the view, its near side) through an aperture of 6 cm (`aperture`: a 50 mm lens at
-- about f/0.8) with six blades. The near ball and the far one blur into the aperture's shape,
-- highlights into hexagons; the caustics on the floor blur with them. The blur converges with
-- `samples`.
local r = require("refrakt")

local scene = r.scene{
  camera      = r.camera{ position = {0.2, 0.5, 2.6}, target = {0, 0.02, 0}, fov = 30, size = {640, 360},
                          aperture = 0.06, focus = 2.5, blades = 6, blade_rotation = 15 },
  environment = r.environment{ preset = "studio", intensity = 0.6 },
  volume      = { resolution = 128, margin = 0.05 },
  photons     = 400000,
  samples     = 32,
}

scene:add(r.node{ name = "floor", translation = {0, -0.2, 0}, shape = r.plane{ size = {16, 16} },
                  material = r.diffuse{ color = {0.6, 0.6, 0.6} } })
for i, at in ipairs({{-0.55, 0.9}, {0, 0}, {0.65, -1.3}}) do
  scene:add(r.node{ name = "ball" .. i, translation = {at[1], 0, at[2]}, shape = r.sphere{ radius = 0.2 },
                    material = r.glass{ ior = 1.5, tint = ({{1, 1, 1}, {1, 0.85, 0.6}, {0.7, 0.9, 1}})[i] } })
end
scene:add(r.node{ name = "sun", light = r.sun{ direction = {0.25, -1, 0.55}, intensity = 900 } })
scene:add(r.node{ name = "bulb", translation = {-0.8, 0.9, 1.6}, light = r.point{ intensity = 30, radius = 0.03 } })

return scene
