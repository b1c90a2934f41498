"""Finding the `refrakt` executable and checking that it runs, with messages a user can act on."""

import os
import shutil
import stat
import subprocess
import sys
import typing

INSTALL_HINT = (
    "Install the add-on zip that carries refrakt (refrakt-<version>-<platform>.zip, built with "
    "scripts/build_blender_addon.py on your platform), or install refrakt (in its source folder: "
    "cargo install --path .) so it is on your PATH, or set its full path in Preferences > Add-ons > refrakt."
)


FARM_INSTALL_HINT = (
    "Install refrakt-farm (pip install ./farm from refrakt's source folder, in a Python that has Ray) "
    "so it is on your PATH, or set its full path in Preferences > Add-ons > refrakt."
)

# Where the executable came from, as `locate` says and the messages word it.
PREFERENCES, BUNDLED, PATH = "preferences", "bundled", "PATH"
SOURCES = {
    PREFERENCES: "set in the add-on preferences",
    BUNDLED: "bundled with the add-on",
    PATH: "found on PATH",
}

# The platform zip carries refrakt in this folder of the add-on (scripts/build_blender_addon.py);
# refrakt-farm (Python, with Ray) is never bundled.
BUNDLE_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "bin")
BUNDLED_PROGRAMS = ("refrakt",)


class BinaryError(Exception):
    """The refrakt executable is missing or does not work; the message says what to do."""


def bundled_path(program="refrakt"):
    """Where the add-on zip built for this platform carries `program`: bin/<program>[.exe]."""
    return os.path.join(BUNDLE_DIR, program + (".exe" if sys.platform == "win32" else ""))


def _make_executable(path, program):
    """Blender's extension installer extracts the zip with Python's zipfile, which drops the
    executable bit: set it again (as far as the file's read bits allow) before the first use."""
    if os.access(path, os.X_OK):
        return
    mode = os.stat(path).st_mode
    try:
        os.chmod(path, mode | ((mode & 0o444) >> 2) | stat.S_IXUSR)
    except OSError as e:
        raise BinaryError(
            f"The {program} bundled with the add-on ({path}) is not executable and cannot be made so: {e.strerror}. "
            f"chmod +x it, or set another {program} in Preferences > Add-ons > refrakt."
        ) from None
    if not os.access(path, os.X_OK):
        raise BinaryError(f"The {program} bundled with the add-on ({path}) is not executable (chmod +x it).")


def locate(configured, program="refrakt", hint=INSTALL_HINT):
    """(absolute path, source) of the `program` executable (refrakt, or refrakt-farm), looked for
    in this order: `configured` (a path from the add-on preferences, may start with ~) when
    set; else the one bundled with the add-on (bin/ in its folder, refrakt only); else
    `program` on PATH.
    `source` is PREFERENCES, BUNDLED or PATH. A preferences path that is wrong is an error, not
    a reason to look elsewhere: the user asked for that one."""
    if configured.strip():
        path = os.path.abspath(os.path.expanduser(configured.strip()))
        if os.path.isdir(path):
            raise BinaryError(f"The {program} path in the preferences is a folder: {path}. Point it at the executable itself.")
        if not os.path.isfile(path):
            raise BinaryError(f"{program} was not found at {path}. {hint}")
        if not os.access(path, os.X_OK):
            raise BinaryError(f"{path} is not executable (chmod +x it, or pick the {program} executable).")
        return path, PREFERENCES
    bundled = bundled_path(program) if program in BUNDLED_PROGRAMS else None
    if bundled is not None and os.path.isfile(bundled):
        _make_executable(bundled, program)
        return bundled, BUNDLED
    found = shutil.which(program)
    if found is None:
        carried = f", and this add-on carries none ({bundled} does not exist)" if bundled else ""
        raise BinaryError(f"{program} was not found on PATH{carried}. {hint}")
    return os.path.abspath(found), PATH


def resolve(configured, program="refrakt", hint=INSTALL_HINT):
    """The absolute path of the `program` executable, found as `locate` says."""
    return locate(configured, program, hint)[0]


def describe(path, source):
    """`path (bundled with the add-on)` and so on, for the interface."""
    return f"{path} ({SOURCES[source]})"


def first_paragraph(text):
    """The first non-empty paragraph of a program's error output, without a leading `error: `."""
    for block in text.strip().split("\n\n"):
        block = block.strip()
        if block:
            return block.removeprefix("error: ").strip()
    return ""


class Checked(typing.NamedTuple):
    path: str
    source: str  # PREFERENCES, BUNDLED or PATH
    report: str  # what `refrakt info` printed


def check(configured, timeout=60.0):
    """Runs `refrakt info` with the refrakt that `locate` finds; returns Checked(path, source,
    its report) or raises BinaryError with the reason (naming the refrakt and where it came from)."""
    path, source = locate(configured)
    where = describe(path, source)
    try:
        done = subprocess.run([path, "info"], capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        raise BinaryError(f"`refrakt info` did not answer within {timeout:.0f} s ({where}).") from None
    except OSError as e:
        raise BinaryError(f"{where} cannot be run: {e.strerror}. {INSTALL_HINT}") from None
    if done.returncode != 0:
        reason = first_paragraph(done.stderr) or f"exit status {done.returncode}"
        raise BinaryError(f"`refrakt info` failed: {reason} ({where})")
    return Checked(path, source, done.stdout.strip())
