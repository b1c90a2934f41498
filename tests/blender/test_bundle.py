"""The zip that carries refrakt (scripts/build_blender_addon.py): what is in it, what the script
refuses to bundle, and the add-on finding refrakt in the order preferences > bundled > PATH, also
when installed from that zip as a user does, with no refrakt on PATH."""

import os
import pathlib
import shutil
import stat
import struct
import subprocess
import sys
import tomllib
import zipfile
import zlib

import bpy
import pytest

import build_blender_addon
from conftest import FAKE, ROOT, install, prefs, real_refrakt_path, submodule

PLATFORM = build_blender_addon.this_platform()
EXE = build_blender_addon.executable_name(PLATFORM)
SCRIPT = ROOT / "scripts" / "build_blender_addon.py"
SOURCE_MANIFEST = (ROOT / "blender_addon" / "blender_manifest.toml").read_text()


def run_build(*args):
    return subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True, text=True, timeout=300)


def manifest_in(zip_path):
    with zipfile.ZipFile(zip_path) as z:
        return z.read("blender_manifest.toml").decode()


@pytest.fixture(scope="module")
def bundle_binary():
    path = real_refrakt_path()
    if path is None:
        pytest.skip("no refrakt binary to bundle: build it (cargo build --release) or set REFRAKT_BIN")
    return pathlib.Path(path)


@pytest.fixture(scope="module")
def bundled_zip(bundle_binary, tmp_path_factory):
    """The zip the script builds, run as a user runs it, carrying the real refrakt."""
    out = tmp_path_factory.mktemp("dist-bundled")
    done = run_build("--binary", str(bundle_binary), "--out", str(out))
    assert done.returncode == 0, done.stderr
    path = pathlib.Path(done.stdout.strip())
    assert path.parent == out and path.is_file()
    assert [p.name for p in out.iterdir()] == [path.name]  # no temporary file left
    return path


# --- The zips ---------------------------------------------------------------------------------


def test_bundled_zip_carries_refrakt_for_this_platform(bundled_zip, bundle_binary, addon_zip):
    version = tomllib.loads(SOURCE_MANIFEST)["version"]
    assert bundled_zip.name == f"refrakt-{version}-{PLATFORM.replace('-', '_')}.zip"
    text = manifest_in(bundled_zip)
    assert f'platforms = ["{PLATFORM}"]' in text.splitlines()
    manifest = tomllib.loads(text)
    assert manifest.pop("platforms") == [PLATFORM]
    assert manifest == tomllib.loads(SOURCE_MANIFEST)  # nothing else changed

    with zipfile.ZipFile(bundled_zip) as z, zipfile.ZipFile(addon_zip) as plain:
        assert set(z.namelist()) == set(plain.namelist()) | {f"bin/{EXE}"}
        info = z.getinfo(f"bin/{EXE}")
        assert z.testzip() is None
    mode = info.external_attr >> 16
    assert info.create_system == 3 and stat.S_ISREG(mode) and stat.S_IMODE(mode) == 0o755
    assert info.file_size == bundle_binary.stat().st_size
    assert info.CRC == zlib.crc32(bundle_binary.read_bytes())


def test_zip_without_binary_is_for_every_platform(addon_zip, tmp_path):
    assert manifest_in(addon_zip) == SOURCE_MANIFEST
    assert "platforms" not in tomllib.loads(manifest_in(addon_zip))
    names = zipfile.ZipFile(addon_zip).namelist()
    assert not [n for n in names if n.startswith("bin/")]

    done = run_build("--no-binary", "--out", str(tmp_path))
    assert done.returncode == 0, done.stderr
    path = pathlib.Path(done.stdout.strip())
    assert path.name == addon_zip.name and sorted(zipfile.ZipFile(path).namelist()) == sorted(names)


def test_build_refuses_what_is_not_refrakt_for_this_platform(tmp_path):
    out = tmp_path / "out"
    cases = [
        (tmp_path / "missing" / EXE, "build refrakt first (`cargo build --release`"),
        (FAKE, f"is not a {PLATFORM} executable"),  # a Python script
        (pathlib.Path(sys.executable).resolve(), "is not refrakt: its --version says 'Python 3."),
    ]
    for binary, message in cases:
        done = run_build("--binary", str(binary), "--out", str(out))
        assert done.returncode == 1 and message in done.stderr, done.stderr
        assert not done.stdout and not out.exists()
    assert build_blender_addon.default_binary() == ROOT / "target" / "release" / EXE


def test_the_real_binary_is_recognised(bundle_binary):
    assert build_blender_addon.executable_platforms(bundle_binary) == {PLATFORM}


def _elf(machine, e_type=3):
    head = bytearray(64)
    head[:6] = b"\x7fELF\x02\x01"
    struct.pack_into("<HH", head, 16, e_type, machine)
    return bytes(head)


def _macho(cpu, filetype=2):
    return struct.pack("<IiII", 0xFEEDFACF, cpu, 0, filetype) + bytes(16)


def _universal(*cpus):
    return struct.pack(">II", 0xCAFEBABE, len(cpus)) + b"".join(struct.pack(">iiIII", c, 0, 0, 0, 0) for c in cpus)


def _pe(machine, characteristics=0x22):
    head = bytearray(256)
    head[:2] = b"MZ"
    struct.pack_into("<I", head, 0x3C, 128)
    head[128:132] = b"PE\0\0"
    struct.pack_into("<H", head, 132, machine)
    struct.pack_into("<H", head, 150, characteristics)
    return bytes(head)


@pytest.mark.parametrize("head, platforms", [
    (_elf(62), {"linux-x64"}),
    (_elf(183), {"linux-arm64"}),
    (_elf(62, e_type=1), set()),  # an object file
    (_elf(40), set()),  # 32-bit ARM
    (_macho(0x0100000C), {"macos-arm64"}),
    (_macho(0x01000007), {"macos-x64"}),
    (_macho(0x0100000C, filetype=6), set()),  # a dylib
    (_universal(0x01000007, 0x0100000C), {"macos-x64", "macos-arm64"}),
    (_pe(0x8664), {"windows-x64"}),
    (_pe(0xAA64), {"windows-arm64"}),
    (_pe(0x8664, 0x2022), set()),  # a DLL
    (b"#!/bin/sh\necho refrakt 0.1.0\n", set()),
    (b"", set()),
])
def test_executable_formats(tmp_path, head, platforms):
    path = tmp_path / "exe"
    path.write_bytes(head)
    assert build_blender_addon.executable_platforms(path) == platforms


# --- Where the add-on finds refrakt -----------------------------------------------------------


def stand_in(path):
    """A refrakt at `path` that runs the fake refrakt (a copy of its own, so it can be chmod'ed)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(f'#!/bin/sh\nexec "{sys.executable}" "{FAKE}" "$@"\n')
    path.chmod(0o755)
    return str(path)


@pytest.fixture
def places(addon, tmp_path, monkeypatch):
    """Folders for a refrakt in the preferences, bundled (the add-on's bin/ pointed elsewhere)
    and on PATH (the only folder on it)."""
    folders = {name: tmp_path / name for name in ("preferences", "bundled", "path")}
    monkeypatch.setattr(submodule("binary"), "BUNDLE_DIR", str(folders["bundled"]))
    monkeypatch.setenv("PATH", str(folders["path"]))
    return folders


def test_resolution_order(places):
    binary = submodule("binary")
    configured = stand_in(places["preferences"] / "refrakt")
    bundled = stand_in(places["bundled"] / EXE)
    on_path = stand_in(places["path"] / "refrakt")
    assert binary.bundled_path() == bundled

    assert binary.locate(configured) == (configured, "preferences")
    assert binary.locate("") == (bundled, "bundled")
    assert binary.resolve("") == bundled
    os.remove(bundled)
    assert binary.locate("") == (on_path, "PATH")
    os.remove(on_path)
    with pytest.raises(binary.BinaryError) as raised:
        binary.locate("")
    message = str(raised.value)
    assert f"refrakt was not found on PATH, and this add-on carries none ({bundled} does not exist)" in message
    assert "refrakt-<version>-<platform>.zip" in message and "Preferences > Add-ons > refrakt" in message


def test_a_wrong_preferences_path_is_not_passed_over(places):
    binary = submodule("binary")
    stand_in(places["bundled"] / EXE)
    stand_in(places["path"] / "refrakt")
    nowhere = places["preferences"] / "refrakt"
    with pytest.raises(binary.BinaryError, match=f"refrakt was not found at {nowhere}"):
        binary.locate(str(nowhere))


def test_bundled_binary_without_its_exec_bit_gets_it_back(places):
    binary = submodule("binary")
    bundled = stand_in(places["bundled"] / EXE)
    os.chmod(bundled, 0o644)
    assert binary.locate("") == (bundled, "bundled")
    assert stat.S_IMODE(os.stat(bundled).st_mode) == 0o755


def test_refrakt_farm_is_never_looked_for_in_the_bundle(places):
    binary = submodule("binary")
    stand_in(places["bundled"] / "refrakt-farm")
    with pytest.raises(binary.BinaryError, match=r"^refrakt-farm was not found on PATH\. Install refrakt-farm"):
        binary.locate("", "refrakt-farm", binary.FARM_INSTALL_HINT)


def test_check_says_where_refrakt_came_from(places):
    binary = submodule("binary")
    bundled = stand_in(places["bundled"] / EXE)
    assert bpy.ops.refrakt.check_binary() == {"FINISHED"}
    assert prefs().check_source == "bundled" and "fake refrakt" in prefs().check_report

    prefs().binary = stand_in(places["preferences"] / "refrakt")
    assert bpy.ops.refrakt.check_binary() == {"FINISHED"}
    assert prefs().check_source == "preferences"

    prefs().binary = ""
    os.remove(bundled)
    on_path = stand_in(places["path"] / "refrakt")
    assert binary.check("")[:2] == (on_path, "PATH")
    assert bpy.ops.refrakt.check_binary() == {"FINISHED"}
    assert prefs().check_source == "PATH"

    pathlib.Path(bundled).write_text("#!/bin/sh\necho 'error: no GPU adapter found' >&2\nexit 1\n")
    with pytest.raises(RuntimeError, match=rf"`refrakt info` failed: no GPU adapter found \({bundled} \(bundled with the add-on\)\)"):
        bpy.ops.refrakt.check_binary()
    assert prefs().check_source == "" and prefs().check_report == ""


# --- Installed from the zip that carries refrakt ----------------------------------------------


@pytest.fixture
def installed_bundle(addon, bundled_zip, addon_zip):
    """The add-on installed from the zip that carries refrakt, over the session's; the session's
    zip (without refrakt) goes back afterwards, so the other tests find no bundled refrakt."""
    try:
        yield install(bundled_zip)
    finally:
        install(addon_zip)
        assert not os.path.exists(submodule("binary").bundled_path())


def test_installed_zip_runs_its_own_refrakt(installed_bundle, tmp_path, monkeypatch):
    monkeypatch.setenv("PATH", str(tmp_path))
    assert shutil.which("refrakt") is None
    prefs().binary = ""
    folder = pathlib.Path(installed_bundle.__file__).parent
    assert folder.is_relative_to(os.environ["BLENDER_USER_RESOURCES"])
    bundled = folder / "bin" / EXE
    assert bundled.is_file()

    # Blender's installer extracts with Python's zipfile, which drops the executable bit
    # (Blender 4.5 leaves bin/refrakt -rw-r--r--): the add-on sets it again when it first looks
    # for refrakt. (Dropped here too, should a later Blender keep it.)
    if os.access(bundled, os.X_OK):
        os.chmod(bundled, 0o644)
    binary = submodule("binary")
    assert binary.locate("") == (str(bundled), "bundled")
    assert os.access(bundled, os.X_OK)
    assert bpy.ops.refrakt.check_binary() == {"FINISHED"}
    assert prefs().check_source == "bundled"
    assert prefs().check_report.startswith("adapter:")


def test_a_zip_for_another_platform_is_refused(addon, addon_zip, tmp_path, capfd):
    other = "windows-arm64" if PLATFORM != "windows-arm64" else "linux-x64"
    foreign = tmp_path / "refrakt-foreign.zip"
    with zipfile.ZipFile(addon_zip) as src, zipfile.ZipFile(foreign, "w") as dst:
        for info in src.infolist():
            data = src.read(info)
            if info.filename == "blender_manifest.toml":
                data = build_blender_addon.manifest_for(other, data.decode()).encode()
            dst.writestr(info, data)
    capfd.readouterr()
    # Blender reports the refusal (the operator still answers FINISHED) and installs nothing.
    bpy.ops.extensions.package_install_files(filepath=str(foreign), repo="user_default", enable_on_install=True)
    assert f"refrakt: This platform ({PLATFORM}) isn't one of ({other})" in capfd.readouterr().out
    installed = pathlib.Path(submodule("binary").__file__).parent / "blender_manifest.toml"
    assert "platforms" not in tomllib.loads(installed.read_text())  # the installed add-on stays
