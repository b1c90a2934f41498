"""The default view of a glTF file without a camera, measured without a GPU: writes a file with a
glass cube far from the origin that an animation moves (no camera), and for each refrakt binary
given counts, over frames 0..24, the cube's corners inside the image of the camera `refrakt dump`
reports. Usage: python3 scripts/gltf_default_view.py REFRAKT [REFRAKT…] (e.g. an older build and
target/debug/refrakt). Standard library only; writes /tmp/refrakt_far_cube.glb."""
import json, math, struct, subprocess, sys

def glb(doc, bin_):
    pad = lambda b, c: b + c * ((4 - len(b) % 4) % 4)
    j, b = pad(json.dumps(doc).encode(), b" "), pad(bin_, b"\0")
    total = 12 + 8 + len(j) + 8 + len(b)
    return b"glTF" + struct.pack("<II", 2, total) + struct.pack("<I", len(j)) + b"JSON" + j + struct.pack("<I", len(b)) + b"BIN\0" + b

corners = [(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]
tris = [(0,1,3),(0,3,2),(4,6,7),(4,7,5),(0,4,5),(0,5,1),(2,3,7),(2,7,6),(0,2,6),(0,6,4),(1,5,7),(1,7,3)]
pos = b"".join(struct.pack("<3f", *c) for c in corners)
idx = b"".join(struct.pack("<3H", *t) for t in tris)
times = struct.pack("<2f", 0.0, 1.0)
moves = struct.pack("<6f", 30, 5, -20, 34, 5, -20)
bin_ = pos + idx + times + moves
o = [0, len(pos), len(pos) + len(idx), len(pos) + len(idx) + len(times)]
doc = {"asset": {"version": "2.0"}, "extensionsUsed": ["KHR_materials_transmission"],
  "buffers": [{"byteLength": len(bin_)}],
  "bufferViews": [{"buffer": 0, "byteOffset": o[0], "byteLength": len(pos)}, {"buffer": 0, "byteOffset": o[1], "byteLength": len(idx)},
                  {"buffer": 0, "byteOffset": o[2], "byteLength": len(times)}, {"buffer": 0, "byteOffset": o[3], "byteLength": len(moves)}],
  "accessors": [{"bufferView": 0, "componentType": 5126, "count": 8, "type": "VEC3", "min": [-1, -1, -1], "max": [1, 1, 1]},
                {"bufferView": 1, "componentType": 5123, "count": 36, "type": "SCALAR"},
                {"bufferView": 2, "componentType": 5126, "count": 2, "type": "SCALAR", "min": [0], "max": [1]},
                {"bufferView": 3, "componentType": 5126, "count": 2, "type": "VEC3"}],
  "materials": [{"extensions": {"KHR_materials_transmission": {"transmissionFactor": 1}}}],
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}]}],
  "nodes": [{"name": "Cube", "mesh": 0, "translation": [30, 5, -20]}],
  "animations": [{"samplers": [{"input": 2, "output": 3}], "channels": [{"sampler": 0, "target": {"node": 0, "path": "translation"}}]}],
  "scenes": [{"nodes": [0]}], "scene": 0}
open("/tmp/refrakt_far_cube.glb", "wb").write(glb(doc, bin_))

def sub(a, b): return [x - y for x, y in zip(a, b)]
def dot(a, b): return sum(x * y for x, y in zip(a, b))
def cross(a, b): return [a[1]*b[2]-a[2]*b[1], a[2]*b[0]-a[0]*b[2], a[0]*b[1]-a[1]*b[0]]

for exe in sys.argv[1:]:
    out = subprocess.run([exe, "dump", "/tmp/refrakt_far_cube.glb", "--frames", "0..24"], capture_output=True, text=True)
    inside = total = 0
    for line in out.stdout.splitlines():
        d = json.loads(line)
        c = d["camera"]; f, up = c["forward"], c["up"]; right = cross(f, up)
        ty = math.tan(c["yfov"] / 2); tx = ty * c["size"][0] / c["size"][1]
        m = d["meshes"][0]["world"]
        for p in corners:
            w = [m[0]*p[0]+m[4]*p[1]+m[8]*p[2]+m[12], m[1]*p[0]+m[5]*p[1]+m[9]*p[2]+m[13], m[2]*p[0]+m[6]*p[1]+m[10]*p[2]+m[14]]
            v = sub(w, c["position"]); z = dot(v, f)
            total += 1
            inside += z > 0 and abs(dot(v, right) / z) <= tx and abs(dot(v, up) / z) <= ty
    print(f"{exe}: camera {d['camera']['position']}, {inside}/{total} cube corners inside the image over frames 0..24")
