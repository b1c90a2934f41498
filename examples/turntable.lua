-- A gradient-index lens turning on its axis and a glass ball bobbing beside it: 48 frames, one
-- full loop at 24 fps.
--
--   refrakt render examples/turntable.lua --frames 1..48
--
-- The lens is a Wood lens: a flat plate whose index falls off with the distance r from its
-- axis, n = 1.6 − 3 r², so it focuses like a convex lens without curved faces (focal length
-- about 1 / (2 · 3 · 0.25 m) ≈ 0.67 m: the studio behind it shows upside down). n reaches 1 at
-- r = 0.45 m, so the corners of the square plate are air and the lens is a seamless disc. No
-- built-in shape has this profile, so it is a Lua function (refrakt.field), sampled on the CPU
-- each frame — the slow but general way to define an index field (see docs/lua-api.md).
local r = require("refrakt")

local scene = r.scene{
  camera      = r.camera{ position = {0, 0.35, 3}, target = {0, 0, 0}, fov = 35, size = {1024, 576} },
  environment = r.environment{ preset = "studio" },
  volume      = { resolution = 128, margin = 0.05 },
}

local lens = scene:add(r.node{
  name = "lens", translation = {-0.55, 0, 0},
  shape = r.field{
    size = {0.9, 0.9, 0.25},                -- metres: a square plate, 25 cm thick along z
    n = function(x, y, z)
      return math.max(1, 1.6 - 3 * (x * x + y * y))
    end,
  },
})

local ball = scene:add(r.node{
  name = "ball", translation = {0.6, 0, 0},
  shape = r.sphere{ radius = 0.35 },
  material = r.glass{ ior = r.ior.flint, color = r.srgb("#ffd089"), distance = 0.5 },  -- amber
})

local loop = 2.0   -- seconds: frames 1..48 at 24 fps are one full loop

-- Everything is set from t alone, so any frame can be rendered on its own (--time, or
-- --skip-existing after an interruption) and comes out the same as in a full run.
function update(scene, t)
  lens.rotation = r.axis_angle({0, 1, 0}, 360 * t / loop)
  ball.translation = {0.6, 0.15 * math.sin(4 * math.pi * t / loop), 0}
end

return scene
