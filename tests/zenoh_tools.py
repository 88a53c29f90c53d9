"""Zenoh helpers for end-to-end tests: a router process, a subscriber process, a one-shot query.

``zenohd`` is not on PyPI, so the router is a Python process running a session in router mode.
Every Zenoh peer of a test that is not the code under test runs in a fresh interpreter started
with :mod:`subprocess` (``fork`` after ``zenoh.open`` hangs the child). Run as a script, this
file is the program of those processes and imports nothing but zenoh and the standard library::

    python tests/zenoh_tools.py router PORT [CONFIG_JSON5]
    python tests/zenoh_tools.py subscribe ENDPOINT KEYEXPR LIVELINESS_KEYEXPR OUT_JSONL

Everything listens and connects on 127.0.0.1 only, with multicast scouting off.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any

__all__ = [
    "RouterProcess",
    "SubscriberProcess",
    "client_config",
    "free_port",
    "port_open",
    "query",
]

_THIS = Path(__file__).resolve()
_STOP_TIMEOUT_S = 5.0


def free_port() -> int:
    """A TCP port on 127.0.0.1 that was free a moment ago (bound to port 0, then released)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def client_config(endpoint: str) -> Any:
    """A ``zenoh.Config`` in client mode connecting to ``endpoint``, multicast scouting off."""
    import zenoh

    config = zenoh.Config()
    config.insert_json5("mode", '"client"')
    config.insert_json5("connect/endpoints", json.dumps([endpoint]))
    config.insert_json5("scouting/multicast/enabled", "false")
    return config


def port_open(port: int) -> bool:
    """Whether something accepts TCP connections on 127.0.0.1:``port``."""
    try:
        with socket.create_connection(("127.0.0.1", port), timeout=0.2):
            return True
    except OSError:
        return False


class _ChildProcess:
    """A Python child running this file with a sub-command; stopped by SIGTERM, then SIGKILL."""

    def __init__(self, args: list[str]) -> None:
        self._args = args
        self.proc: subprocess.Popen | None = None
        self._stderr: IO[bytes] | None = None

    def _spawn(self) -> None:
        self._stderr = tempfile.TemporaryFile()
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        self.proc = subprocess.Popen(
            [sys.executable, str(_THIS), *self._args],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=self._stderr,
            env=env,
        )

    def stderr_text(self) -> str:
        """What the child wrote on stderr so far (for failure messages)."""
        if self._stderr is None:
            return ""
        self._stderr.seek(0)
        return self._stderr.read().decode("utf-8", "replace")

    def _fail(self, what: str) -> None:
        text = self.stderr_text().strip()[-2000:]
        self.stop()
        raise RuntimeError(f"{what}; child stderr:\n{text}")

    def stop(self) -> int | None:
        """Terminate the child (SIGTERM, SIGKILL after 5 s); returns its exit status."""
        proc, self.proc = self.proc, None
        status = None
        if proc is not None:
            if proc.poll() is None:
                proc.send_signal(signal.SIGTERM)
            try:
                status = proc.wait(_STOP_TIMEOUT_S)
            except subprocess.TimeoutExpired:
                proc.kill()
                status = proc.wait(_STOP_TIMEOUT_S)
        if self._stderr is not None:
            self._stderr.close()
            self._stderr = None
        return status

    def __exit__(self, *_exc: object) -> None:
        self.stop()


class RouterProcess(_ChildProcess):
    """A Zenoh router in its own Python process, listening on ``tcp/127.0.0.1:<port>``.

    Parameters
    ----------
    port : int
        TCP port on 127.0.0.1, e.g. from :func:`free_port`.
    config_json5 : str, optional
        Extra router configuration (JSON5 object, e.g. an ``access_control`` section) applied
        over the defaults before listen/mode are set.
    start_timeout_s : float
        How long to wait for the port to accept connections, seconds.

    Use as a context manager; :meth:`stop` and a new ``RouterProcess`` on the same port
    simulate a router restart.
    """

    def __init__(
        self, port: int, *, config_json5: str | None = None, start_timeout_s: float = 15.0
    ) -> None:
        super().__init__(["router", str(port), *([config_json5] if config_json5 else [])])
        self.port = port
        self.endpoint = f"tcp/127.0.0.1:{port}"
        self._start_timeout_s = start_timeout_s

    def start(self) -> RouterProcess:
        """Spawn the router and wait until its port accepts TCP connections."""
        self._spawn()
        deadline = time.monotonic() + self._start_timeout_s
        while not port_open(self.port):
            if self.proc is None or self.proc.poll() is not None:
                self._fail(f"router on port {self.port} exited at start")
            if time.monotonic() > deadline:
                self._fail(f"router on port {self.port} not listening after start timeout")
            time.sleep(0.05)
        return self

    def __enter__(self) -> RouterProcess:
        return self.start()


class SubscriberProcess(_ChildProcess):
    """A client-mode subscriber in its own Python process, writing one JSON line per sample.

    Each line holds ``key``, ``kind`` (``"PUT"``/``"DELETE"``), ``encoding`` (str),
    ``payload`` (UTF-8 text, undecodable bytes replaced), ``json`` (the parsed payload or
    None), ``json_ok`` (bool), ``recv_ns`` (``time.time_ns()`` at reception) and
    ``liveliness`` (True for liveliness events from ``liveliness_keyexpr``: PUT when a token
    appears, DELETE when it goes; tokens already present are reported at start).

    Parameters
    ----------
    endpoint : str
        The router's endpoint (``tcp/127.0.0.1:7447``).
    keyexpr : str
        What to subscribe to.
    out_path : path, optional
        Where to write the lines; a temporary file by default.
    liveliness_keyexpr : str or None
        Liveliness tokens to follow; None follows none.
    start_timeout_s : float
        How long to wait for the subscriber to be declared, seconds (the child retries
        opening its session meanwhile, so the router may come up a little later).
    """

    def __init__(
        self,
        endpoint: str,
        keyexpr: str = "weather/**",
        *,
        out_path: str | os.PathLike | None = None,
        liveliness_keyexpr: str | None = "weather/*/alive",
        start_timeout_s: float = 15.0,
    ) -> None:
        self._tmpdir = None
        if out_path is None:
            self._tmpdir = tempfile.TemporaryDirectory(prefix="zenoh-sub-")
            out_path = Path(self._tmpdir.name) / "samples.jsonl"
        self.out_path = Path(out_path)
        self._ready_path = self.out_path.with_name(self.out_path.name + ".ready")
        super().__init__(
            [
                "subscribe",
                endpoint,
                keyexpr,
                liveliness_keyexpr or "",
                str(self.out_path),
                str(start_timeout_s),
            ]
        )
        self._start_timeout_s = start_timeout_s

    def start(self) -> SubscriberProcess:
        """Spawn the subscriber and wait until its subscriptions are declared."""
        self._ready_path.unlink(missing_ok=True)
        self._spawn()
        deadline = time.monotonic() + self._start_timeout_s + 5.0
        while not self._ready_path.exists():
            if self.proc is None or self.proc.poll() is not None:
                self._fail("subscriber exited at start")
            if time.monotonic() > deadline:
                self._fail("subscriber not ready after start timeout")
            time.sleep(0.05)
        return self

    def __enter__(self) -> SubscriberProcess:
        return self.start()

    def __exit__(self, *_exc: object) -> None:
        self.stop()
        if self._tmpdir is not None:
            self._tmpdir.cleanup()

    def messages(self) -> list[dict]:
        """Every complete line written so far, parsed, in order of reception."""
        try:
            text = self.out_path.read_text(encoding="utf-8")
        except FileNotFoundError:
            return []
        lines = text.split("\n")[:-1]  # the last piece may be a line being written
        return [json.loads(line) for line in lines if line]

    def wait_for(
        self, predicate: Callable[[dict], bool], timeout: float = 10.0, *, count: int = 1
    ) -> list[dict]:
        """Wait until ``count`` messages satisfy ``predicate``; return them all.

        Raises
        ------
        AssertionError
            On timeout, with the keys seen so far.
        """
        deadline = time.monotonic() + timeout
        while True:
            found = [m for m in self.messages() if predicate(m)]
            if len(found) >= count:
                return found
            if time.monotonic() > deadline:
                seen = [(m["key"], m["kind"]) for m in self.messages()][-20:]
                raise AssertionError(
                    f"{len(found)}/{count} matching messages after {timeout} s; last seen: {seen}"
                )
            time.sleep(0.05)


def query(endpoint: str, selector: str, timeout: float = 5.0) -> list[tuple[str, Any]]:
    """``get`` on ``selector`` through the router at ``endpoint``, from an in-process client.

    Returns
    -------
    list of (key, payload)
        One per OK reply, in arrival order; ``payload`` is the parsed JSON when it parses,
        the text otherwise. The session is closed before returning.
    """
    import zenoh

    session = _open_with_retry(zenoh, client_config(endpoint), timeout)
    try:
        replies = session.get(selector, timeout=timeout)
        out = []
        for reply in replies:
            sample = reply.ok
            if sample is not None:
                out.append((str(sample.key_expr), _decode(sample.payload.to_bytes())[0]))
        return out
    finally:
        session.close()


def _decode(raw: bytes) -> tuple[Any, bool]:
    """``(parsed JSON, True)`` or ``(text, False)``."""
    text = raw.decode("utf-8", "replace")
    try:
        return json.loads(text), True
    except ValueError:
        return text, False


def _open_with_retry(zenoh: Any, config: Any, timeout_s: float) -> Any:
    deadline = time.monotonic() + timeout_s
    while True:
        try:
            return zenoh.open(config)
        except zenoh.ZError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.1)


# -- the child programs ------------------------------------------------------------------------


def _stop_event() -> threading.Event:
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    return stop


def _run_router(port: str, extra_json5: str | None = None) -> None:
    import zenoh

    config = zenoh.Config.from_json5(extra_json5) if extra_json5 else zenoh.Config()
    config.insert_json5("mode", '"router"')
    config.insert_json5("listen/endpoints", json.dumps([f"tcp/127.0.0.1:{int(port)}"]))
    config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("scouting/delay", "0")
    stop = _stop_event()
    session = zenoh.open(config)
    try:
        while not stop.wait(0.5):
            pass
    finally:
        session.close()


def _run_subscriber(
    endpoint: str, keyexpr: str, live_keyexpr: str, out_path: str, timeout_s: str
) -> None:
    import zenoh

    stop = _stop_event()
    lock = threading.Lock()
    out = open(out_path, "a", encoding="utf-8")

    def write(sample: Any, liveliness: bool) -> None:
        recv_ns = time.time_ns()
        raw = sample.payload.to_bytes()
        value, ok = _decode(raw)
        line = {
            "key": str(sample.key_expr),
            "kind": "PUT" if sample.kind == zenoh.SampleKind.PUT else "DELETE",
            "encoding": str(sample.encoding),
            "payload": raw.decode("utf-8", "replace"),
            "json": value if ok else None,
            "json_ok": ok,
            "recv_ns": recv_ns,
            "liveliness": liveliness,
        }
        with lock:
            out.write(json.dumps(line) + "\n")
            out.flush()

    session = _open_with_retry(zenoh, client_config(endpoint), float(timeout_s))
    try:
        session.declare_subscriber(keyexpr, lambda s: write(s, False))
        if live_keyexpr:
            session.liveliness().declare_subscriber(
                live_keyexpr, lambda s: write(s, True), history=True
            )
        Path(out_path + ".ready").touch()
        while not stop.wait(0.2):
            pass
    finally:
        session.close()
        with lock:
            out.close()


def main(argv: list[str]) -> None:
    """Entry point of the child processes (see the module docstring)."""
    programs = {"router": _run_router, "subscribe": _run_subscriber}
    with contextlib.suppress(KeyboardInterrupt):
        programs[argv[0]](*argv[1:])


if __name__ == "__main__":
    main(sys.argv[1:])
