"""A refrakt subprocess (`render` or `watch` with `--progress json`) read on background threads,
so Blender's UI thread only polls a queue and never waits on the process.

Events are refrakt's JSON lines (see refrakt's src/progress.rs): start, frame, skip, done, error.
"""

import json
import os
import queue
import signal
import subprocess
import threading
import time

from . import binary

# After a cancel, refrakt finishes the frame in hand; past this many seconds it is killed.
KILL_AFTER_SECONDS = 30.0


class Job:
    """One refrakt process and what it reported so far."""

    def __init__(self, argv, cwd=None, output_dir=None):
        self.argv = argv
        self.output_dir = output_dir
        self.events = queue.Queue()
        self.stderr = []
        self.total = 0
        self.done = 0
        self.percent = 0.0
        self.files = []
        self.error = ""
        self.finished = False
        self.returncode = None
        self.cancelled_at = None
        try:
            self.proc = subprocess.Popen(
                argv,
                cwd=cwd,
                stdin=subprocess.DEVNULL,
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                text=True,
                encoding="utf-8",
                errors="replace",
                bufsize=1,
            )
        except OSError as e:
            raise binary.BinaryError(f"{argv[0]} cannot be started: {e.strerror}. {binary.INSTALL_HINT}") from None
        self._readers = [
            threading.Thread(target=self._read_stdout, daemon=True),
            threading.Thread(target=self._read_stderr, daemon=True),
        ]
        for t in self._readers:
            t.start()

    def _read_stdout(self):
        for line in self.proc.stdout:
            line = line.strip()
            if not line:
                continue
            try:
                event = json.loads(line)
            except json.JSONDecodeError:
                self.stderr.append(line)  # not an event: keep it with the diagnostics
                continue
            if isinstance(event, dict):
                self.events.put(event)

    def _read_stderr(self):
        for line in self.proc.stderr:
            self.stderr.append(line.rstrip("\n"))
            del self.stderr[:-200]  # a chatty process must not grow without bound

    def poll(self):
        """Takes the events that arrived since the last call (never blocks) and updates the
        state; returns them. Sets `finished` once the process has exited and all its output
        is read."""
        # Checked before draining: once the readers are done, the queue holds everything.
        exited = self.proc.poll() is not None and not any(t.is_alive() for t in self._readers)
        new = []
        while True:
            try:
                new.append(self.events.get_nowait())
            except queue.Empty:
                break
        for event in new:
            self._apply(event)
        if self.cancelled and self.proc.poll() is None and time.monotonic() - self.cancelled_at > KILL_AFTER_SECONDS:
            self.proc.kill()
        if exited and not self.finished:
            self._finish()
        return new

    def _apply(self, event):
        kind = event.get("event")
        if kind == "start":
            self.total = int(event.get("frames", 0))
            self.percent = 0.0
        elif kind in ("frame", "skip"):
            self.done = int(event.get("done", self.done + 1))
            self.total = int(event.get("total", self.total))
            # Each file once: `refrakt watch` reports its one preview file with every frame.
            self.files += [f for f in event.get("files", []) if f not in self.files]
            if self.total:
                self.percent = 100.0 * self.done / self.total
        elif kind == "done":
            self.percent = 100.0
        elif kind == "error" and not self.cancelled:
            # After a cancel, refrakt's "interrupted" message is the expected ending, not an error.
            self.error = str(event.get("message", ""))

    def _finish(self):
        self.finished = True
        self.returncode = self.proc.returncode
        if self.returncode < 0 and self.output_dir:
            self._remove_temporaries()
        if self.returncode != 0 and not self.error and not self.cancelled:
            self.error = binary.first_paragraph("\n".join(self.stderr)) or f"refrakt exited with status {self.returncode}"

    def _remove_temporaries(self):
        """A killed refrakt may leave the hidden temporary of the file it was writing
        (`.name.tmp-PID.ext`, see refrakt's output module); whole frames are never touched."""
        mark = f".tmp-{self.proc.pid}."
        try:
            names = os.listdir(self.output_dir)
        except OSError:
            return
        for name in names:
            if name.startswith(".") and mark in name:
                try:
                    os.remove(os.path.join(self.output_dir, name))
                except OSError:
                    pass

    @property
    def running(self):
        return not self.finished

    @property
    def cancelled(self):
        return self.cancelled_at is not None

    def cancel(self):
        """Asks refrakt to stop after the frame in hand (SIGTERM; files are written whole)."""
        if self.cancelled_at is None and self.proc.poll() is None:
            self.cancelled_at = time.monotonic()
            if os.name == "posix":
                self.proc.send_signal(signal.SIGTERM)
            else:
                # No SIGTERM on Windows: the process ends at once. refrakt renames each file
                # into place when it is complete, so only a hidden temporary can be left.
                self.proc.terminate()

    def stop(self, timeout):
        """Cancels (after the frame in hand) and waits up to `timeout` s, then kills refrakt."""
        self.cancel()
        try:
            self.wait(timeout=timeout)
        except TimeoutError:
            self.proc.kill()
            self.wait()

    def wait(self, timeout=None, interval=0.05):
        """Polls until the process has finished (for background mode and tests)."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while not self.finished:
            self.poll()
            if deadline is not None and time.monotonic() > deadline:
                raise TimeoutError(f"refrakt still running after {timeout} s: {' '.join(self.argv)}")
            time.sleep(interval)
        return self
