-- A pool in the sun: the water's surface is flat, and a normal map makes it ripple. Each ray and
-- photon refracts about the normal the map gives where it crosses the surface, so the sun's
-- light comes down through the ripples in the net of bright lines every pool floor shows. The
-- map is textures/ripples.png (scripts/make_ripples.py), tiled three times across the pool.
--   refrakt render examples/pool.lua --size 1280x720 --samples 8
local r = require("refrakt")

local scene = r.scene{
  camera      = r.camera{ position = {0, 2.6, 1.9}, target = {0, 0, -0.1}, fov = 45, size = {960, 540} },
  environment = r.environment{ preset = "sunny", intensity = 0.4 },
  volume      = { resolution = 128 },
  photons     = 1000000,
  samples     = 4,
}

-- The water: a box whose top carries texture coordinates tiled `tiles` times; the other faces
-- give every corner the same coordinates, so no tangent frame and no ripples there (water
-- against the pool's walls is flat).
local function water(width, depth, tiles)
  local a, vertices, uvs, triangles = width / 2, {}, {}, {}
  -- Each face: four corners counter-clockwise seen from outside.
  local faces = {
    { {-a, depth, -a}, {-a, depth, a}, {a, depth, a}, {a, depth, -a} },  -- top
    { {-a, 0, -a}, {a, 0, -a}, {a, 0, a}, {-a, 0, a} },                  -- bottom
    { {-a, 0, a}, {a, 0, a}, {a, depth, a}, {-a, depth, a} },            -- +z
    { {a, 0, -a}, {-a, 0, -a}, {-a, depth, -a}, {a, depth, -a} },        -- -z
    { {a, 0, a}, {a, 0, -a}, {a, depth, -a}, {a, depth, a} },            -- +x
    { {-a, 0, -a}, {-a, 0, a}, {-a, depth, a}, {-a, depth, -a} },        -- -x
  }
  for f, corners in ipairs(faces) do
    local base = #vertices
    for _, p in ipairs(corners) do
      vertices[#vertices + 1] = p
      uvs[#uvs + 1] = f == 1 and { (p[1] + a) / width * tiles, (p[3] + a) / width * tiles } or { 0, 0 }
    end
    triangles[#triangles + 1] = { base + 1, base + 2, base + 3 }
    triangles[#triangles + 1] = { base + 1, base + 3, base + 4 }
  end
  return r.mesh{ vertices = vertices, triangles = triangles, uvs = uvs }
end

local width, depth = 2.0, 0.5
scene:add(r.node{ name = "water", shape = water(width, depth, 3),
                  material = r.glass{ ior = 1.333, absorption = {0.25, 0.06, 0.04},
                                      normal_texture = "textures/ripples.png" } })
scene:add(r.node{ name = "floor", shape = r.plane{ size = {width, width} },
                  material = r.diffuse{ color = {0.55, 0.78, 0.85} } })
-- The deck: four slabs of stone around the water, a little higher than it.
local rim, height = 1.2, depth + 0.08
for _, side in ipairs{ { {0, height / 2, (width + rim) / 2}, {width + 2 * rim, height, rim} },
                       { {0, height / 2, -(width + rim) / 2}, {width + 2 * rim, height, rim} },
                       { {(width + rim) / 2, height / 2, 0}, {rim, height, width} },
                       { {-(width + rim) / 2, height / 2, 0}, {rim, height, width} } } do
  scene:add(r.node{ translation = side[1], shape = r.box{ size = side[2] },
                    material = r.diffuse{ color = {0.5, 0.47, 0.43} } })
end
scene:add(r.node{ name = "sun", light = r.sun{ direction = {-0.3, -1, -0.45}, intensity = 600, angular_diameter = 0.53 } })

return scene
