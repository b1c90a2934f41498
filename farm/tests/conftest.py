"""Shared fixtures: the refrakt binary and a tiny animated scene."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

#: A tiny animated scene reading a module and a mesh (no photons: quick on lavapipe; frames
#: still differ over time).
SCENE = """local r = require("refrakt")
local looks = require("lib.looks")
local scene = r.scene{
  camera = r.camera{ position = {0, 0.2, 2.5}, target = {0, 0, 0}, fov = 35, size = {32, 18} },
  volume = { resolution = 16 },
  photons = 0,
  samples = 1,
}
local gem = r.node{ name = "gem", shape = r.mesh{ file = "meshes/tetra.obj" }, material = looks.glass }
scene:add(gem)
scene:add(r.node{ name = "floor", translation = {0, -0.35, 0}, shape = r.plane{ size = {4, 4} },
                  material = r.diffuse{ color = {0.6, 0.6, 0.6} } })
scene:add(r.node{ name = "sun", light = r.sun{ direction = {0.3, -1, 0.5}, intensity = 500 } })
function update(scene, t)
  gem.rotation = {0, 40 * t, 0}
end
return scene
"""
LOOKS = 'local r = require("refrakt")\nreturn { glass = r.glass{ ior = 1.5 } }\n'
TETRA = "v 0 0.5 0\nv -0.45 -0.3 0.3\nv 0.45 -0.3 0.3\nv 0 -0.3 -0.45\nf 1 2 3\nf 1 3 4\nf 1 4 2\nf 2 4 3\n"


@pytest.fixture(scope="session")
def refrakt_bin() -> str:
    path = os.environ.get("REFRAKT_BIN") or str(ROOT / "target" / "debug" / "refrakt")
    if not (Path(path).is_file() or shutil.which(path)):
        pytest.skip(f"no refrakt binary at {path} (cargo build, or set REFRAKT_BIN)")
    return path


@pytest.fixture(scope="session")
def scene_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("shot")
    (d / "lib").mkdir()
    (d / "meshes").mkdir()
    (d / "gem.lua").write_text(SCENE)
    (d / "lib" / "looks.lua").write_text(LOOKS)
    (d / "meshes" / "tetra.obj").write_text(TETRA)
    return d
