"""Reads a .glb and evaluates node world matrices at a time, by the glTF 2.0 spec (TRS or
matrix per node, parent × child, animation channels with STEP or LINEAR interpolation; the
add-on's exports sample every frame, so the tests look at sample times). Independent of both
Blender's importer and refrakt's, so it checks what the file itself says."""

import json
import struct

from mathutils import Matrix, Quaternion, Vector

COMPONENTS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}


class Gltf:
    def __init__(self, path):
        with open(path, "rb") as f:
            data = f.read()
        magic, _, _ = struct.unpack_from("<4sII", data, 0)
        assert magic == b"glTF", f"{path} is not a .glb"
        offset, self.json, self.bin = 12, None, b""
        while offset < len(data):
            length, kind = struct.unpack_from("<I4s", data, offset)
            chunk = data[offset + 8: offset + 8 + length]
            if kind == b"JSON":
                self.json = json.loads(chunk)
            elif kind == b"BIN\0":
                self.bin = chunk
            offset += 8 + length
        self.parents = {}
        for i, node in enumerate(self.json["nodes"]):
            for child in node.get("children", []):
                self.parents[child] = i

    def accessor(self, index):
        acc = self.json["accessors"][index]
        assert acc["componentType"] == 5126, "only float accessors are needed here"
        view = self.json["bufferViews"][acc["bufferView"]]
        n = COMPONENTS[acc["type"]]
        start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
        stride = view.get("byteStride", 4 * n)
        return [struct.unpack_from(f"<{n}f", self.bin, start + i * stride) for i in range(acc["count"])]

    def node_index(self, name):
        return next(i for i, n in enumerate(self.json["nodes"]) if n.get("name") == name)

    def _trs(self, index, t):
        node = self.json["nodes"][index]
        trs = {
            "translation": list(node.get("translation", (0, 0, 0))),
            "rotation": list(node.get("rotation", (0, 0, 0, 1))),
            "scale": list(node.get("scale", (1, 1, 1))),
        }
        for anim in self.json.get("animations", [])[:1]:
            for channel in anim["channels"]:
                if channel["target"].get("node") == index:
                    sampler = anim["samplers"][channel["sampler"]]
                    trs[channel["target"]["path"]] = self._sample(sampler, t)
        return trs

    def _sample(self, sampler, t):
        times = [x[0] for x in self.accessor(sampler["input"])]
        values = self.accessor(sampler["output"])
        if t <= times[0]:
            return list(values[0])
        if t >= times[-1]:
            return list(values[-1])
        i = max(k for k, x in enumerate(times) if x <= t)
        if sampler.get("interpolation", "LINEAR") == "STEP":
            return list(values[i])
        u = (t - times[i]) / (times[i + 1] - times[i])
        return [a + (b - a) * u for a, b in zip(values[i], values[i + 1])]

    def local(self, index, t):
        node = self.json["nodes"][index]
        if "matrix" in node:
            m = node["matrix"]
            return Matrix([[m[c * 4 + r] for c in range(4)] for r in range(4)])  # column-major
        trs = self._trs(index, t)
        x, y, z, w = trs["rotation"]
        return (
            Matrix.Translation(Vector(trs["translation"]))
            @ Quaternion((w, x, y, z)).normalized().to_matrix().to_4x4()
            @ Matrix.Diagonal(Vector(trs["scale"])).to_4x4()
        )

    def world(self, name, t):
        index = self.node_index(name)
        m = self.local(index, t)
        while index in self.parents:
            index = self.parents[index]
            m = self.local(index, t) @ m
        return m

    def node(self, name):
        return self.json["nodes"][self.node_index(name)]

    def material(self, name):
        return next(m for m in self.json["materials"] if m.get("name") == name)

    def light(self, name):
        lights = self.json["extensions"]["KHR_lights_punctual"]["lights"]
        return lights[self.node(name)["extensions"]["KHR_lights_punctual"]["light"]]

    def camera(self, name):
        return self.json["cameras"][self.node(name)["camera"]]
