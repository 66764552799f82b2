"""A run streamed to a Rerun viewer as it goes (`--view`, `--connect`), never waited on.

Before the run, the viewer is started (`--view`) or looked for (`--connect`): an address where
nothing answers as a gRPC server within PROBE_S is refused as bad input, as is `--view` with no
display or no viewer executable. During the run the viewer has a recording stream of its own
(the file's application and recording id), so the file never waits for the viewer: chunks are
handed to the viewer's stream without waiting for them to be sent. At the end the viewer's
stream is closed within CLOSE_S; a viewer that has not taken the whole stream by then (it went
away, or stopped answering) is told about once on stderr, and the process exits all the same.
"""

from __future__ import annotations

import os
import shutil
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path
from urllib.parse import urlsplit

from testbed.errors import InputError, quoted

VIEWER_PORT = 9876  # Rerun's default
VIEWER_URL = "rerun+http://127.0.0.1:{port}/proxy"
PROBE_S = 3.0    # an address must answer as a gRPC server within this
SPAWN_S = 20.0   # a viewer started by --view must answer within this
CLOSE_S = 5.0    # the viewer's stream is given this long to send what is left at the end
POLL_S = 0.1
# An HTTP/2 client's connection preface and an empty SETTINGS frame (RFC 9113 §3.4, §6.5): a
# gRPC server answers with a SETTINGS frame of its own (frame type 0x4 at byte 3 of its header).
_H2_PREFACE = b"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n" + bytes([0, 0, 0, 4, 0, 0, 0, 0, 0])
_SETTINGS = 4


def grpc_silence(host: str, port: int, timeout: float, tls: bool = False) -> str | None:
    """Why nothing answers as an HTTP/2 (gRPC) server at host:port within `timeout` s, or None
    when something does. Over TLS only the connection itself is tried."""
    deadline = time.monotonic() + timeout
    try:
        with socket.create_connection((host, port), timeout=timeout) as conn:
            if tls:
                return None
            conn.sendall(_H2_PREFACE)
            header = b""
            while len(header) < 9:
                conn.settimeout(max(deadline - time.monotonic(), 1e-3))
                part = conn.recv(9 - len(header))
                if not part:
                    return "the connection was closed without an answer"
                header += part
    except socket.timeout:
        return f"no answer within {timeout:g} s"
    except OSError as exc:
        return exc.strerror or str(exc)
    return None if header[3] == _SETTINGS else "it does not answer as a gRPC server"


def check_reachable(url: str, field: str = "--connect", timeout: float = PROBE_S) -> str:
    """`url` (rerun+http://HOST:PORT/proxy) when a gRPC server answers there within `timeout`
    s; InputError(field) otherwise, naming the address and why."""
    try:
        parts = urlsplit(url.removeprefix("rerun+"))
        host, port = parts.hostname, parts.port
    except ValueError as exc:
        raise InputError(field, f"{quoted(url)} is not a viewer address ({exc})") from None
    if parts.scheme not in ("http", "https", "rerun") or not host or port is None:
        raise InputError(field, f"{quoted(url)} is not a viewer address; give one such as "
                                f"{VIEWER_URL.format(port=VIEWER_PORT)}")
    why = grpc_silence(host, port, timeout, tls=parts.scheme == "https")
    if why is not None:
        raise InputError(field, f"no Rerun viewer answers at {quoted(url)}: {why}")
    return url


def viewer_executable() -> str | None:
    """The `rerun` viewer installed with the SDK (beside this interpreter), else one on PATH."""
    beside = Path(sys.executable).with_name("rerun")
    return str(beside) if beside.exists() else shutil.which("rerun")


def start_viewer(port: int = VIEWER_PORT) -> str:
    """The address of a Rerun viewer on this machine's `port`: one already there, else one
    started now and answering within SPAWN_S. InputError("--view") when none can be: no
    display, no viewer executable, or a viewer that exits or stays silent."""
    url = VIEWER_URL.format(port=port)
    if grpc_silence("127.0.0.1", port, PROBE_S) is None:
        return url  # a viewer already runs there (as Rerun's own spawn() reuses it)
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise InputError("--view", "no display to open the Rerun viewer on (DISPLAY and WAYLAND_DISPLAY are "
                                   "unset); stream to a viewer elsewhere with --connect URL, "
                                   "or open the .rrd after the run")
    executable = viewer_executable()
    if executable is None:
        raise InputError("--view", "no Rerun viewer executable ('rerun' beside the interpreter or on PATH)")
    try:
        viewer = subprocess.Popen([executable, "--port", str(port), "--expect-data-soon"],
                                  stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                  start_new_session=True, env=os.environ | {"RERUN_APP_ONLY": "true"})
    except OSError as exc:
        raise InputError("--view", f"cannot start the Rerun viewer {quoted(executable)}: {exc.strerror}") from None
    deadline = time.monotonic() + SPAWN_S
    while time.monotonic() < deadline:
        if viewer.poll() is not None:
            raise InputError("--view", f"the Rerun viewer exited at start (status {viewer.returncode})")
        if grpc_silence("127.0.0.1", port, POLL_S * 5) is None:
            return url
        time.sleep(POLL_S)
    viewer.kill()
    raise InputError("--view", f"the Rerun viewer did not answer within {SPAWN_S:g} s")


class ViewerStream:
    """The viewer at `url` as a second sink of a run: `open` gives it a recording stream of its
    own beside the file's (`Tee` sends each call to both); this side never waits (module doc)."""

    def __init__(self, url: str):
        self.url = url
        self.rec = None
        self.complete = False  # whether the viewer took the whole run (set by close)

    def open(self, application: str, recording_id: str) -> None:
        from testbed.recording.rerun_sdk import rr

        self.rec = rr.RecordingStream(application, recording_id=recording_id)
        self.rec.set_sinks(rr.GrpcSink(self.url))

    def flush(self) -> None:
        self.rec.flush(timeout_sec=0.0)  # start sending, do not wait

    def close(self, timeout: float = CLOSE_S) -> None:
        """Send what is left within `timeout` s (0: do not wait), setting `complete`. A stream
        not closed by then is left to the process's exit, and Rerun's wait at exit dropped."""
        from testbed.recording.rerun_sdk import rr

        if self.rec is None:
            return
        closing = threading.Thread(target=self._send_rest, args=(timeout,), daemon=True)
        if timeout > 0:
            closing.start()
            closing.join(timeout)
        if not self.complete:
            rr.unregister_shutdown()  # its wait at exit for this stream would have no end

    def _send_rest(self, timeout: float) -> None:
        try:
            self.rec.flush(timeout_sec=timeout)
            self.rec.disconnect()
            self.complete = True
        except Exception:  # noqa: BLE001  (the viewer went away: the caller says so once)
            pass


class Tee:
    """The Rerun calls a trace writer makes (log, send_columns, send_blueprint, flush), sent to
    a file's stream and to a viewer's."""

    def __init__(self, file_rec, viewer: ViewerStream):
        self.streams = [rec for rec in (file_rec, viewer.rec) if rec is not None]
        self.file_rec, self.viewer = file_rec, viewer

    def log(self, *args, **kwargs):
        for rec in self.streams:
            rec.log(*args, **kwargs)

    def send_columns(self, *args, **kwargs):
        for rec in self.streams:
            rec.send_columns(*args, **kwargs)

    def send_blueprint(self, *args, **kwargs):
        for rec in self.streams:
            rec.send_blueprint(*args, **kwargs)

    def flush(self):
        if self.file_rec is not None:
            self.file_rec.flush()
        self.viewer.flush()
