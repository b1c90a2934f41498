"""Finding the `refrakt` executable and checking that it runs, with messages a user can act on."""

import os
import shutil
import subprocess

INSTALL_HINT = (
    "Install refrakt (in its source folder: cargo install --path .) so it is on your PATH, "
    "or set its full path in Preferences > Add-ons > refrakt."
)


FARM_INSTALL_HINT = (
    "Install refrakt-farm (pip install ./farm from refrakt's source folder, in a Python that has Ray) "
    "so it is on your PATH, or set its full path in Preferences > Add-ons > refrakt."
)


class BinaryError(Exception):
    """The refrakt executable is missing or does not work; the message says what to do."""


def resolve(configured, program="refrakt", hint=INSTALL_HINT):
    """The absolute path of the `program` executable (refrakt, or refrakt-farm): `configured`
    (a path from the add-on preferences, may start with ~) when set, otherwise `program` found
    on PATH."""
    if configured.strip():
        path = os.path.abspath(os.path.expanduser(configured.strip()))
        if os.path.isdir(path):
            raise BinaryError(f"The {program} path in the preferences is a folder: {path}. Point it at the executable itself.")
        if not os.path.isfile(path):
            raise BinaryError(f"{program} was not found at {path}. {hint}")
        if not os.access(path, os.X_OK):
            raise BinaryError(f"{path} is not executable (chmod +x it, or pick the {program} executable).")
        return path
    found = shutil.which(program)
    if found is None:
        raise BinaryError(f"{program} was not found on PATH. {hint}")
    return found


def first_paragraph(text):
    """The first non-empty paragraph of a program's error output, without a leading `error: `."""
    for block in text.strip().split("\n\n"):
        block = block.strip()
        if block:
            return block.removeprefix("error: ").strip()
    return ""


def check(configured, timeout=60.0):
    """Runs `refrakt info`; returns (path, its report) or raises BinaryError with the reason."""
    path = resolve(configured)
    try:
        done = subprocess.run([path, "info"], capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        raise BinaryError(f"`{path} info` did not answer within {timeout:.0f} s.") from None
    except OSError as e:
        raise BinaryError(f"{path} cannot be run: {e.strerror}. {INSTALL_HINT}") from None
    if done.returncode != 0:
        reason = first_paragraph(done.stderr) or f"exit status {done.returncode}"
        raise BinaryError(f"`refrakt info` failed: {reason}")
    return path, done.stdout.strip()
