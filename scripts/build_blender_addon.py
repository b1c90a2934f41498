#!/usr/bin/env python3
"""Builds the Blender extension zip from blender_addon/, carrying the refrakt binary for this platform.

The zip installs with Blender's Preferences > Get Extensions > Install from Disk (Blender 4.2 or
later) and then needs nothing else: refrakt is inside it (bin/refrakt, bin/refrakt.exe on
Windows) and the manifest names the one platform it runs on, so Blender refuses the zip on
another one. refrakt cannot be cross-built on Linux, so each platform's zip is built on that
platform: `cargo build --release`, then this script.

    python3 scripts/build_blender_addon.py                 # dist/refrakt-<version>-<platform>.zip
    python3 scripts/build_blender_addon.py --binary PATH   # bundle another refrakt build
    python3 scripts/build_blender_addon.py --no-binary     # dist/refrakt-<version>.zip, any platform;
                                                           # refrakt comes from the preferences or PATH

<platform> is Blender's name for it with `_` for `-`, as Blender's own `extension build
--split-platforms` writes it: linux_x64, linux_arm64, macos_arm64, macos_x64, windows_x64,
windows_arm64.
"""

import argparse
import os
import pathlib
import platform as platform_module
import shutil
import stat
import struct
import subprocess
import sys
import time
import tomllib
import zipfile

ROOT = pathlib.Path(__file__).resolve().parent.parent
SOURCE = ROOT / "blender_addon"
MANIFEST = "blender_manifest.toml"


class BuildError(Exception):
    """The zip cannot be built; the message says why and what to do."""


def this_platform():
    """This machine's platform as Blender names it (bl_pkg's platform_from_this_system):
    linux-x64, linux-arm64, macos-arm64, macos-x64, windows-x64, windows-arm64."""
    system = platform_module.system().lower()
    machine = platform_module.machine().lower()
    system = {"darwin": "macos"}.get(system, system)
    machine = {"x86_64": "x64", "amd64": "x64", "aarch64": "arm64"}.get(machine, machine)
    return f"{system}-{machine}"


def executable_name(platform):
    return "refrakt.exe" if platform.startswith("windows-") else "refrakt"


def default_binary(platform=None):
    return ROOT / "target" / "release" / executable_name(platform or this_platform())


# Machine codes of the executable formats, by Blender's architecture name.
ELF_MACHINES = {62: "x64", 183: "arm64"}  # EM_X86_64, EM_AARCH64
MACHO_CPUS = {0x01000007: "x64", 0x0100000C: "arm64"}  # CPU_TYPE_X86_64, CPU_TYPE_ARM64
PE_MACHINES = {0x8664: "x64", 0xAA64: "arm64"}  # IMAGE_FILE_MACHINE_AMD64, _ARM64


def executable_platforms(path):
    """The platforms (Blender's names) the executable at `path` runs on, read from its header:
    ELF on Linux, Mach-O (also universal) on macOS, PE on Windows. Empty when it is none of them
    (a script, a library's text, a truncated file)."""
    with open(path, "rb") as f:
        head = f.read(4096)
    if head[:4] == b"\x7fELF" and len(head) >= 20:
        endian = "<" if head[5] == 1 else ">"
        (machine,) = struct.unpack_from(endian + "H", head, 18)
        e_type = struct.unpack_from(endian + "H", head, 16)[0]
        if e_type not in (2, 3):  # ET_EXEC, ET_DYN (position-independent executables)
            return set()
        return {f"linux-{ELF_MACHINES[machine]}"} if machine in ELF_MACHINES else set()
    if head[:4] == b"\xcf\xfa\xed\xfe" and len(head) >= 16:  # MH_MAGIC_64, little-endian
        cpu, _, filetype = struct.unpack_from("<iII", head, 4)
        if filetype != 2:  # MH_EXECUTE
            return set()
        return {f"macos-{MACHO_CPUS[cpu]}"} if cpu in MACHO_CPUS else set()
    if head[:4] == b"\xca\xfe\xba\xbe" and len(head) >= 8:  # FAT_MAGIC (universal binary)
        (count,) = struct.unpack_from(">I", head, 4)
        if count > 20:  # Java class files share this magic; universal binaries have a few slices.
            return set()
        cpus = [struct.unpack_from(">i", head, 8 + 20 * i)[0] for i in range(count) if 8 + 20 * i + 4 <= len(head)]
        return {f"macos-{MACHO_CPUS[c]}" for c in cpus if c in MACHO_CPUS}
    if head[:2] == b"MZ" and len(head) >= 64:
        (pe,) = struct.unpack_from("<I", head, 0x3C)
        if pe + 24 <= len(head) and head[pe:pe + 4] == b"PE\0\0":
            (machine,) = struct.unpack_from("<H", head, pe + 4)
            (characteristics,) = struct.unpack_from("<H", head, pe + 22)
            if characteristics & 0x2000:  # IMAGE_FILE_DLL
                return set()
            return {f"windows-{PE_MACHINES[machine]}"} if machine in PE_MACHINES else set()
    return set()


def check_binary(binary, platform):
    """Raises BuildError unless `binary` is a refrakt executable for `platform` (this machine's)
    that runs (its `--version` exits 0 and names refrakt); returns that version line."""
    binary = pathlib.Path(binary)
    if not binary.is_file():
        raise BuildError(
            f"{binary} does not exist: build refrakt first (`cargo build --release` in {ROOT}), "
            "pass --binary PATH, or --no-binary for the zip without refrakt."
        )
    found = executable_platforms(binary)
    if platform not in found:
        kind = ", ".join(sorted(found)) if found else "not an executable this script knows (ELF, Mach-O, PE)"
        raise BuildError(f"{binary} is not a {platform} executable ({kind}).")
    try:
        done = subprocess.run([str(binary), "--version"], capture_output=True, text=True, timeout=60)
    except (OSError, subprocess.TimeoutExpired) as e:
        raise BuildError(f"`{binary} --version` did not run: {e}") from None
    version = done.stdout.strip()
    if done.returncode != 0:
        raise BuildError(
            f"`{binary} --version` failed (exit status {done.returncode}): {(done.stderr or done.stdout).strip()[:500]}"
        )
    if not version.startswith("refrakt "):
        raise BuildError(f"{binary} is not refrakt: its --version says {version.splitlines()[0] if version else 'nothing'!r}.")
    return version


def manifest_for(platform, text):
    """The manifest text with `platforms = ["<platform>"]` added among its top-level keys
    (before the first table), checked by parsing it back."""
    if "platforms" in tomllib.loads(text):
        raise BuildError(f"blender_addon/{MANIFEST} already sets platforms: the build script writes them.")
    lines = text.splitlines(keepends=True)
    first_table = next((i for i, line in enumerate(lines) if line.lstrip().startswith("[")), len(lines))
    entry = [f'# Written by scripts/build_blender_addon.py: this zip carries refrakt for {platform}.\n',
             f'platforms = ["{platform}"]\n', "\n"]
    out = "".join(lines[:first_table] + entry + lines[first_table:])
    assert tomllib.loads(out)["platforms"] == [platform]
    return out


def source_files():
    return sorted(
        p for p in SOURCE.rglob("*")
        if p.is_file() and "__pycache__" not in p.parts and not p.name.startswith(".") and p.suffix != ".pyc"
        and p.relative_to(SOURCE).parts[0] != "bin"  # a stray bundled binary in the source folder
    )


def _mtime(path):
    return time.localtime(os.stat(path).st_mtime)[:6]


def _zip_info(name, mode, mtime):
    info = zipfile.ZipInfo(name, date_time=max(mtime, (1980, 1, 1, 0, 0, 0)))
    info.compress_type = zipfile.ZIP_DEFLATED
    info.create_system = 3  # Unix: the permission bits below are read from external_attr
    info.external_attr = (stat.S_IFREG | mode) << 16
    return info


def build(out_dir, binary=None):
    """Writes the extension zip into `out_dir` and returns its path. With `binary` (a refrakt
    executable for this platform) the zip carries it as bin/refrakt[.exe] with its executable
    bit and its manifest names the platform: <id>-<version>-<platform>.zip; without, it is the
    platform-independent <id>-<version>.zip."""
    manifest_text = (SOURCE / MANIFEST).read_text()
    manifest = tomllib.loads(manifest_text)
    out_dir = pathlib.Path(out_dir)
    if binary is not None:
        platform = this_platform()
        version = check_binary(binary, platform)
        print(f"build_blender_addon: bundling {binary} ({version}) for {platform}", file=sys.stderr)
        if version.split()[-1] != manifest["version"]:
            print(f"build_blender_addon: warning: the add-on is version {manifest['version']}, the binary {version}",
                  file=sys.stderr)
        manifest_text = manifest_for(platform, manifest_text)
        target = out_dir / f"{manifest['id']}-{manifest['version']}-{platform.replace('-', '_')}.zip"
    else:
        target = out_dir / f"{manifest['id']}-{manifest['version']}.zip"
    out_dir.mkdir(parents=True, exist_ok=True)
    tmp = target.with_name("." + target.name + ".tmp")
    try:
        with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
            for p in source_files():
                name = p.relative_to(SOURCE).as_posix()
                info = _zip_info(name, 0o644, _mtime(p))
                z.writestr(info, manifest_text.encode() if name == MANIFEST else p.read_bytes())
            if binary is not None:
                info = _zip_info(f"bin/{executable_name(platform)}", 0o755, _mtime(binary))
                with open(binary, "rb") as src, z.open(info, "w") as dst:
                    shutil.copyfileobj(src, dst, 1 << 20)
        tmp.replace(target)
    finally:
        tmp.unlink(missing_ok=True)
    return target


def main():
    parser = argparse.ArgumentParser(
        description=__doc__.splitlines()[0], epilog="\n".join(__doc__.splitlines()[2:]),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--out", default=str(ROOT / "dist"), help="folder for the zip (default: dist/)")
    which = parser.add_mutually_exclusive_group()
    which.add_argument(
        "--binary", type=pathlib.Path,
        help=f"the refrakt executable to carry (default: {default_binary().relative_to(ROOT)}, from `cargo build --release`)",
    )
    which.add_argument("--no-binary", action="store_true", help="build the platform-independent zip without refrakt")
    args = parser.parse_args()
    binary = None if args.no_binary else (args.binary or default_binary())
    try:
        target = build(args.out, binary)
    except BuildError as e:
        print(f"build_blender_addon: {e}", file=sys.stderr)
        return 1
    print(target)
    return 0


if __name__ == "__main__":
    sys.exit(main())
