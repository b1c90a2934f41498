-- Shared materials: require("lib.materials") from any scene in examples/.
-- Absorption is given as the color light takes after travelling `distance` metres (as in
-- glTF's KHR_materials_volume), picked as sRGB and turned linear by refrakt.srgb.
local r = require("refrakt")

local M = {}

M.water   = r.glass{ ior = r.ior.water }
M.crown   = r.glass{ ior = r.ior.crown }
M.flint   = r.glass{ ior = r.ior.flint, color = r.srgb("#e8f0ff"), distance = 0.3 }
M.amber   = r.glass{ ior = 1.55, color = r.srgb("#ffc46b"), distance = 0.3 }
M.emerald = r.glass{ ior = 1.58, color = r.srgb("#7fe0a0"), distance = 0.25 }

return M
