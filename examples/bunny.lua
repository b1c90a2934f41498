-- The Stanford bunny in glass, as in the paper's figures (1024×576, 128³ volume).
--
-- The bunny is not part of refrakt (the Stanford 3D Scanning Repository's models are not ours
-- to redistribute). Download a bunny.obj — e.g. a watertight one such as the reconstruction in
-- the public repository michelkluger/mesh-bunny, or the original scan from
-- https://graphics.stanford.edu/data/3Dscanrep/ — and tell the script where it is:
--
--   REFRAKT_BUNNY=/path/to/bunny.obj refrakt render examples/bunny.lua --allow-read /path/to
--
-- (--allow-read lets the script read a file outside its own folder), or put bunny.obj next to
-- this script. Any OBJ works: the volume fits itself to the mesh. Without one, the script says
-- so and renders a glass pebble in its place.
local r = require("refrakt")

-- The bunny's shape and where to put it.
local function load_bunny()
  local path = r.getenv("REFRAKT_BUNNY")
  -- The scanned bunny has no normals of its own: smooth = 30 shades it smooth where its faces
  -- meet at less than 30° (without it, it is shaded flat, facet by facet, as Blender shows it).
  local ok, mesh = pcall(r.mesh, { file = path or "bunny.obj", smooth = 30 })
  if ok then
    return mesh, {0, 0, 0}
  end
  local why = tostring(mesh):match("^[^\n]*"):gsub("^runtime error: ", "")
  local help = "the Stanford bunny is not shipped with refrakt: get a bunny.obj and run " ..
               "REFRAKT_BUNNY=/path/to/bunny.obj refrakt render examples/bunny.lua --allow-read /path/to " ..
               "(see the top of examples/bunny.lua)"
  if path then
    error(why .. " — " .. help, 0)    -- a bunny was asked for: say why it could not be read
  end
  print("no bunny.obj next to the script and REFRAKT_BUNNY is not set; " .. help ..
        ". Rendering a glass pebble in its place.")
  return r.blob{ radius = 0.06, bumps = 0.25, seed = 9 }, {-0.015, 0.1, 0}
end

-- The seed's setting: 1024×576, a 128³ volume, 70k photons from a spot light, the bunny on a
-- floor that catches its caustic (the bright, focused light under and behind it).
local scene = r.scene{
  camera      = r.camera{ position = {-0.06, 0.16, 0.42}, target = {-0.015, 0.1, 0}, fov = 35, size = {1024, 576} },
  environment = r.environment{ preset = "studio", intensity = 0.35 },
  volume      = { resolution = 128, margin = 0.01 },
  photons     = 70000,
}

local shape, where = load_bunny()
scene:add(r.node{ name = "bunny", translation = where, shape = shape,
                  material = r.glass{ ior = 1.5, color = {0.8, 0.9, 1.0}, distance = 0.1 } })
-- The bunny's feet are at y = 0.033 (the pebble stands in at the same height).
scene:add(r.node{ name = "floor", translation = {0, 0.033, 0}, shape = r.plane{ size = {1.2, 1.2} },
                  material = r.diffuse{ color = {0.75, 0.75, 0.75} } })
scene:add(r.node{ name = "key", translation = {0.25, 0.45, -0.2},
                  light = r.spot{ target = {-0.015, 0.09, 0}, intensity = 150, angle = 18, blend = 0.3 } })

return scene
