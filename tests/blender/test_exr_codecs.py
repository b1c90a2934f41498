"""refrakt's own EXR writers (ZIP, ZIPS and uncompressed scan lines, colors as 32- or 16-bit
floats) read by OpenEXR's Python bindings — the library every compositor links — to the very
samples the uncompressed file holds."""

import subprocess

import numpy as np
import pytest

SCENE = """local r = require("refrakt")
local scene = r.scene{ volume = { resolution = 16 }, photons = 2000, samples = 1,
                       camera = r.camera{ position = {0, 0.6, 2}, target = {0, 0, 0}, size = {37, 21} } }
scene:add(r.node{ shape = r.sphere{ radius = 0.25 }, material = r.glass{ ior = 1.5 } })
scene:add(r.node{ translation = {0, -0.25, 0}, shape = r.plane{ size = {2, 2} }, material = r.diffuse{} })
scene:add(r.node{ light = r.sun{ direction = {0.2, -1, 0.1}, intensity = 683 } })
return scene
"""


def channels(path):
    import OpenEXR

    with OpenEXR.File(str(path), separate_channels=True) as f:
        header = dict(f.parts[0].header)  # (emptied when the file closes)
        planes = {name: np.asarray(c.pixels) for name, c in f.parts[0].channels.items()}
    return header, planes


@pytest.mark.parametrize("half", [False, True])
def test_openexr_reads_every_codec_refrakt_writes_exactly(real_refrakt, tmp_path, half):
    scene = tmp_path / "ball.lua"
    scene.write_text(SCENE)
    files = {}
    for codec in ("none", "zip", "zips"):
        out = tmp_path / codec
        args = [real_refrakt, "render", str(scene), "-o", str(out), "--format", "exr", "--exr-compression", codec, "-q"]
        subprocess.run(args + (["--exr-half"] if half else []), check=True, capture_output=True)
        files[codec] = channels(out / "ball.exr")
    _, raw = files["none"]
    assert raw["R"].dtype == (np.float16 if half else np.float32)
    assert raw["depth.Z"].dtype == np.float32, "depth stays 32-bit"
    assert np.any(raw["caustic.R"] > 0), "an empty frame proves nothing"
    for codec in ("zip", "zips"):
        header, planes = files[codec]
        assert str(header["compression"]).upper().endswith(codec.upper() + "_COMPRESSION"), header["compression"]
        assert planes.keys() == raw.keys(), codec
        for name, pixels in raw.items():
            assert planes[name].dtype == pixels.dtype and np.array_equal(planes[name], pixels), f"{codec}: {name}"
