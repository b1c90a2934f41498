"""The extension installs from its zip, registers everything, and unregisters cleanly (also
while a render and live mode are running: their processes are stopped)."""

import os
import sys
import tomllib
import zipfile

import bpy
import pytest

import scenes
from conftest import FAKE, MODULE, ROOT, prefs, submodule

OPERATORS = ("check_binary", "export", "render", "cancel_render", "load_frames", "live")
PANELS = ("RENDER_PT_refrakt", "OBJECT_PT_refrakt", "MATERIAL_PT_refrakt")


def registered():
    return {
        "properties": all(hasattr(t, "refrakt") for t in (bpy.types.Scene, bpy.types.Object, bpy.types.Material)),
        "operators": all(hasattr(bpy.ops.refrakt, op) and getattr(bpy.types, f"REFRAKT_OT_{op}", None) for op in OPERATORS),
        "panels": all(getattr(bpy.types, p, None) is not None for p in PANELS),
        "preferences": MODULE in bpy.context.preferences.addons,
    }


def test_zip_is_a_valid_extension(addon_zip):
    manifest = tomllib.loads((ROOT / "blender_addon" / "blender_manifest.toml").read_text())
    assert addon_zip.name == f"refrakt-{manifest['version']}.zip"
    names = zipfile.ZipFile(addon_zip).namelist()
    assert "blender_manifest.toml" in names and "__init__.py" in names
    assert not [n for n in names if "__pycache__" in n or n.endswith(".pyc")]
    assert manifest["blender_version_min"] == "4.2.0"


def test_registers_everything(addon):
    assert all(registered().values()), registered()
    assert bpy.context.scene.refrakt.photons == 70000
    # Blender's glTF exporter finds the hooks through this name on the add-on's module.
    assert addon.glTF2ExportUserExtension is submodule("gltf_hooks").RefraktGltfExtension


def test_unregister_and_register_again(addon):
    for _ in range(2):
        bpy.ops.preferences.addon_disable(module=MODULE)
        assert not any(registered().values()), registered()
        bpy.ops.preferences.addon_enable(module=MODULE)
        assert all(registered().values()), registered()


def test_unregister_stops_running_processes(fake_refrakt, saved_blend, monkeypatch):
    scene = scenes.round_trip_scene()
    scene.frame_end = 100
    saved_blend()
    monkeypatch.setenv("FAKE_REFRAKT_DELAY", "0.5")
    live = submodule("live").start(bpy.context, str(FAKE))
    paths = submodule("scene_export").paths(scene)
    render = submodule("job").Job(submodule("cli").render(str(FAKE), scene, paths))
    submodule("operators").current_render = render
    watch = live.watch

    bpy.ops.preferences.addon_disable(module=MODULE)
    try:
        assert render.wait(timeout=10).cancelled and watch.finished
        assert not [h for h in bpy.app.handlers.depsgraph_update_post if h.__module__.startswith(MODULE)]
    finally:
        bpy.ops.preferences.addon_enable(module=MODULE)


def test_check_binary(fake_refrakt, tmp_path):
    assert bpy.ops.refrakt.check_binary() == {"FINISHED"}
    assert "fake refrakt" in prefs().check_report

    folder = tmp_path / "bin"
    folder.mkdir()
    prefs().binary = str(folder)
    with pytest.raises(RuntimeError, match="is a folder"):
        bpy.ops.refrakt.check_binary()

    script = folder / "refrakt"
    script.write_text("#!/bin/sh\necho 'error: no GPU adapter found: install mesa-vulkan-drivers' >&2\nexit 1\n")
    prefs().binary = str(script)
    with pytest.raises(RuntimeError, match="not executable"):
        bpy.ops.refrakt.check_binary()
    os.chmod(script, 0o755)
    with pytest.raises(RuntimeError, match="`refrakt info` failed: no GPU adapter found: install mesa-vulkan-drivers"):
        bpy.ops.refrakt.check_binary()


def test_check_the_real_binary(addon, real_refrakt):
    prefs().binary = real_refrakt
    assert bpy.ops.refrakt.check_binary() == {"FINISHED"}
    assert prefs().check_report.startswith("adapter:")


def test_binary_found_on_path(addon, tmp_path, monkeypatch):
    link = tmp_path / "refrakt"
    link.symlink_to(FAKE)
    monkeypatch.setenv("PATH", f"{tmp_path}{os.pathsep}{os.environ['PATH']}")
    assert submodule("binary").resolve("") == str(link)
    assert sys.modules[MODULE + ".binary"].check("")[0] == str(link)
