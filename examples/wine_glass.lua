-- A wine glass turned on a lathe: its profile, from the middle of the foot out and up the
-- outside of the stem and bowl, over the rim and back down the inside, swept around the
-- vertical axis. The glass is 0.2 m tall; its walls are a few voxels thick at 192³.
local r = require("refrakt")

local scene = r.scene{
  camera      = r.camera{ position = {0, 0.16, 0.5}, target = {0, 0.1, 0}, fov = 35, size = {1024, 576} },
  environment = r.environment{ preset = "studio" },
  volume      = { resolution = 192, margin = 0.01 },
}

-- {radius, height} in metres, counter-clockwise: foot, stem, bowl outside, rim, bowl inside.
local profile = {
  {0.000, 0.000}, {0.035, 0.000}, {0.036, 0.004}, {0.008, 0.010}, {0.005, 0.020},
  {0.005, 0.075}, {0.012, 0.085}, {0.030, 0.100}, {0.040, 0.125}, {0.042, 0.160},
  {0.038, 0.200}, {0.034, 0.200}, {0.037, 0.160}, {0.035, 0.127}, {0.026, 0.104},
  {0.010, 0.092}, {0.000, 0.090},
}

scene:add(r.node{ name = "glass", shape = r.lathe{ profile = profile, segments = 128 },
                  material = r.glass{ ior = 1.5 } })

return scene
