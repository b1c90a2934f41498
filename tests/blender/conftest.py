"""Headless tests of the Blender add-on with the `bpy` module from PyPI.

The add-on is built into its extension zip and installed the way a user installs it (Install
from Disk, enabled on install) into a throw-away Blender user folder, so these tests never touch
the machine's own Blender settings. `refrakt` is either the real binary (REFRAKT_BIN, or the
repository's target/{release,debug}/refrakt) or `fake_refrakt.py`, which keeps refrakt's
command-line contract without a GPU.
"""

import os
import pathlib
import shutil
import subprocess
import sys
import tempfile

import pytest

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parent.parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(ROOT / "scripts"))

# Blender reads its user folders when bpy is imported: point them at a temporary one first.
os.environ["BLENDER_USER_RESOURCES"] = tempfile.mkdtemp(prefix="refrakt-blender-user-")

import bpy  # noqa: E402
import build_blender_addon  # noqa: E402

MODULE = "bl_ext.user_default.refrakt"
FAKE = HERE / "fake_refrakt.py"


def pytest_report_header(config):
    return f"Blender {bpy.app.version_string} (bpy module), Python {sys.version.split()[0]}"


@pytest.fixture(scope="session")
def addon_zip(tmp_path_factory):
    return build_blender_addon.build(tmp_path_factory.mktemp("dist"))


def install(zip_path):
    """Installs an extension zip as Install from Disk does (replacing the add-on installed
    before, if any) and enables it; returns the add-on's module."""
    result = bpy.ops.extensions.package_install_files(
        filepath=str(zip_path), repo="user_default", enable_on_install=True
    )
    assert result == {"FINISHED"}
    assert MODULE in bpy.context.preferences.addons
    return sys.modules[MODULE]


@pytest.fixture(scope="session")
def installed(addon_zip):
    """The platform-independent zip (no bundled refrakt), installed once for the session.
    (test_bundle.py installs the zip that carries refrakt over it, and this one back after.)"""
    return install(addon_zip)


@pytest.fixture
def addon(installed):
    """The enabled add-on on an empty scene, with live mode and renders stopped afterwards."""
    bpy.ops.wm.read_homefile(use_empty=True)
    prefs().binary = ""
    yield sys.modules[MODULE]  # not `installed`: a reinstall imports the add-on anew
    sys.modules[MODULE + ".live"].stop(bpy.context)
    render = sys.modules[MODULE + ".operators"].current_render
    if render is not None and render.running:
        render.cancel()
        render.wait(timeout=30)


def prefs():
    return bpy.context.preferences.addons[MODULE].preferences


def submodule(name):
    return sys.modules[f"{MODULE}.{name}"]


@pytest.fixture
def fake_refrakt(addon, tmp_path, monkeypatch):
    """Points the add-on at the fake refrakt; returns the file its invocations are logged to."""
    log = tmp_path / "fake-refrakt-argv.jsonl"
    monkeypatch.setenv("FAKE_REFRAKT_LOG", str(log))
    prefs().binary = str(FAKE)
    return log


def real_refrakt_path():
    """The real refrakt binary, or None: $REFRAKT_BIN, else the newest build in target/."""
    if os.environ.get("REFRAKT_BIN"):
        return os.environ["REFRAKT_BIN"]
    built = [ROOT / "target" / kind / "refrakt" for kind in ("release", "debug")]
    built = [p for p in built if p.is_file()]
    if built:
        return str(max(built, key=lambda p: p.stat().st_mtime))
    return shutil.which("refrakt")


@pytest.fixture
def real_refrakt():
    path = real_refrakt_path()
    if path is None:
        pytest.skip("no refrakt binary: build it (cargo build) or set REFRAKT_BIN")
    return path


def refrakt_supports(path, *args):
    """Whether this refrakt build has a command (e.g. `dump`): its --help exits 0."""
    done = subprocess.run([path, *args, "--help"], capture_output=True, text=True)
    return done.returncode == 0


@pytest.fixture
def saved_blend(addon, tmp_path):
    """Saves the current file under tmp_path so `//` paths resolve there."""
    def save():
        path = tmp_path / "shot.blend"
        bpy.ops.wm.save_as_mainfile(filepath=str(path))
        return path
    return save
