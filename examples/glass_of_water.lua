-- A glass of water with ice on a table, lit by a low sun: the commonest glass still life, and
-- three media that touch. The water's outside is the glass's inside (the same lathe profile,
-- so the surfaces coincide), the ice cubes stick out of the water, and the glass stands on the
-- table. Where two surfaces meet, light crosses one interface between the two media — water
-- against glass is n 1.33 against 1.5, with no air between — and where solids overlap, the
-- smaller holds (the ice where it dips into the water). See docs/glass.md, "Glass that touches".
--   refrakt render examples/glass_of_water.lua --size 1280x960 --photons 4e6 --samples 8
local r = require("refrakt")

local scene = r.scene{
  camera      = r.camera{ position = {0.0, 0.16, 0.34}, target = {0.02, 0.04, -0.02}, fov = 35, size = {640, 480} },
  environment = r.environment{ preset = "studio", intensity = 0.5 },
  volume      = { resolution = 160 },
  photons     = 1000000,
  samples     = 4,
}

-- {radius, height} in metres, counter-clockwise around the solid: a tumbler 0.1 m tall with a
-- 3 mm wall and an 8 mm base.
local outer, inner, base, top, fill = 0.040, 0.037, 0.008, 0.100, 0.070
scene:add(r.node{ name = "glass", shape = r.lathe{ segments = 96, profile = {
                    {0, 0}, {outer, 0}, {outer, top}, {inner, top}, {inner, base}, {0, base} } },
                  material = r.glass{ ior = 1.5 } })
scene:add(r.node{ name = "water", shape = r.lathe{ segments = 96, profile = {
                    {0, base}, {inner, base}, {inner, fill}, {0, fill} } },
                  material = r.glass{ ior = 1.333, absorption = {0.3, 0.06, 0.04} } })
for i, ice in ipairs{ { {0.012, fill + 0.002, 0.006}, {18, 30, 9} }, { {-0.011, fill - 0.001, -0.009}, {-12, 75, 20} } } do
  scene:add(r.node{ name = "ice" .. i, translation = ice[1], rotation = ice[2],
                    shape = r.box{ size = {0.022, 0.022, 0.022} },
                    material = r.glass{ ior = 1.31 } })
end

scene:add(r.node{ name = "table", shape = r.plane{ size = {2, 2} },
                  material = r.diffuse{ color = {0.8, 0.78, 0.74} } })
scene:add(r.node{ name = "sun", light = r.sun{ direction = {-0.55, -0.6, -0.58}, intensity = 2000, angular_diameter = 0.53 } })

return scene
