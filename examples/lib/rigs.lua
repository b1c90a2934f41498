-- Small animation rigs: each takes nodes and returns a function(t) that poses them at time t
-- (seconds). Poses depend on t alone, never on the previous frame, so frames can be rendered
-- in any order.
local r = require("refrakt")

local M = {}

--- Turns `node` about its local y axis, one turn every `period` seconds.
function M.turntable(node, period)
  local rest = node.rotation
  return function(t)
    node.rotation = rest * r.axis_angle({0, 1, 0}, 360 * t / period)
  end
end

--- Moves `node` up and down by `height` metres around where it stands, once every `period` seconds.
function M.bob(node, height, period, phase)
  local rest = node.translation
  return function(t)
    local dy = height * math.sin(2 * math.pi * (t / period + (phase or 0)))
    node.translation = r.vec.add(rest, {0, dy, 0})
  end
end

--- Runs several rigs as one.
function M.all(rigs)
  return function(t)
    for _, rig in ipairs(rigs) do rig(t) end
  end
end

return M
