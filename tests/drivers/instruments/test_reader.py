"""InstrumentReader on real pseudo-terminals and a loopback socket, with simulated instruments."""

from __future__ import annotations

import os
import queue
import select
import socket
import threading
import time
import tty
from collections.abc import Callable
from pathlib import Path

import pytest

from drivers.errors import ConfigError
from drivers.instruments import parsivel, vaisala
from drivers.instruments.base import Frame, Reading
from drivers.instruments.reader import InstrumentReader

WAIT_S = 10.0  # generous upper bound for events that take milliseconds
FAST = {"backoff_initial_s": 0.05, "backoff_max_s": 0.2, "read_timeout_s": 0.05}
PWD = b"\x01PW  1\x02 00  9163  9298   L   52   52   40  0.18  50.30  112\x03\r\n"
ANSWER = b"TYP OP4A\r\n01:0002.356\r\n03:61\r\n05:  -RA\r\n08:08134\r\n18:0\r\n\x03\r\n\x00"


class Pty:
    """A pseudo-terminal: the reader opens the slave, the simulated instrument the master."""

    def __init__(self) -> None:
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)
        self.path = os.ttyname(self.slave)

    def write(self, data: bytes) -> None:
        os.write(self.master, data)

    def read(self, timeout_s: float) -> bytes:
        ready, _, _ = select.select([self.master], [], [], timeout_s)
        return os.read(self.master, 4096) if ready else b""

    def close(self) -> None:
        os.close(self.master)
        os.close(self.slave)


class Collector:
    """on_frame callback putting (frame, reading, error) in a queue."""

    def __init__(self) -> None:
        self.items: queue.Queue[tuple[Frame, Reading | None, str | None]] = queue.Queue()

    def __call__(self, frame: Frame, reading: Reading | None, error: str | None) -> None:
        self.items.put((frame, reading, error))

    def take(self, n: int) -> list[tuple[Frame, Reading | None, str | None]]:
        return [self.items.get(timeout=WAIT_S) for _ in range(n)]


def wait_for(condition: Callable[[], bool]) -> None:
    deadline = time.monotonic() + WAIT_S
    while not condition():
        assert time.monotonic() < deadline, "condition not met in time"
        time.sleep(0.01)


def link(path: Path, target: str) -> None:
    """Point the symlink ``path`` at ``target`` atomically (re-plugging a cable)."""
    tmp = path.with_suffix(".new")
    os.symlink(target, tmp)
    os.replace(tmp, path)


@pytest.fixture
def pty():
    p = Pty()
    yield p
    for fd in (p.master, p.slave):
        try:
            os.close(fd)
        except OSError:
            pass


def test_automatic_mode_readings_garbage_and_bad_frames(pty: Pty) -> None:
    got = Collector()
    calls = []

    def on_frame(frame: Frame, reading: Reading | None, error: str | None) -> None:
        calls.append(frame)
        if len(calls) == 1:
            raise RuntimeError("a broken consumer must not stop the reader")
        got(frame, reading, error)

    reader = InstrumentReader("pwd1", vaisala.DRIVER, pty.path, on_frame=on_frame, **FAST)
    reader.start()
    try:
        wait_for(lambda: reader.stats()["state"] == "ok")
        before = time.time_ns()
        pty.write(PWD)  # swallowed by the broken callback, still counted
        pty.write(b"\xff\xfe\x00" + PWD)  # power-up noise glued to a message
        pty.write(PWD[:30] + b"\r\n")  # truncated: no ETX
        pty.write(b"\x95\xe3" * 40 + b"\r\n")  # wrong-baud noise
        pty.write(PWD[:20])
        pty.write(PWD[20:] + PWD)  # split, then merged reads
        items = got.take(5)
        kinds = ["ok" if r is not None else "bad" for _, r, _ in items]
        assert kinds == ["ok", "bad", "bad", "ok", "ok"]
        assert "ETX" in items[1][2] and "non-ASCII" in items[2][2]
        frame, reading, _ = items[0]
        assert reading.visibility_m == 9163 and reading.rain_accum_mm == 50.30
        assert frame.t_ns is not None and reading.t_ns == frame.t_ns
        assert before <= reading.t_ns <= time.time_ns()  # the receive time, UTC ns
        stats = reader.stats()
        assert (stats["frames"], stats["readings"], stats["bad_frames"]) == (6, 4, 2)
        assert stats["garbage_bytes"] >= 3
        assert stats["reconnects"] == 0 and stats["last_reading_age_s"] >= 0
    finally:
        reader.stop()
    assert reader.stats()["state"] == "stopped"


def test_polled_mode_answers_only_when_asked(pty: Pty) -> None:
    got = Collector()
    reader = InstrumentReader(
        "parsivel1",
        parsivel.DRIVER,
        pty.path,
        mode="polled",
        poll_interval_s=0.2,
        on_frame=got,
        **FAST,
    )
    received = bytearray()
    stop = threading.Event()

    def instrument() -> None:
        while not stop.is_set():
            received.extend(pty.read(0.05))
            while b"CS/PA\r\n" in received:
                del received[: received.index(b"CS/PA\r\n") + 7]
                pty.write(ANSWER)

    sim = threading.Thread(target=instrument, daemon=True)
    sim.start()
    reader.start()
    try:
        items = got.take(2)
        for _frame, reading, error in items:
            assert error is None
            assert (reading.rain_rate_mm_h, reading.wawa, reading.metar) == (2.356, 61, "-RA")
            assert reading.visibility_m == 8134
        assert items[1][1].t_ns > items[0][1].t_ns
    finally:
        reader.stop()
        stop.set()
        sim.join(WAIT_S)


def test_vaisala_poll_command_reaches_the_instrument(pty: Pty) -> None:
    got = Collector()
    options = {"unit_id": "7", "message": 2}
    reader = InstrumentReader(
        "pwd", vaisala.DRIVER, pty.path, mode="polled", options=options, on_frame=got, **FAST
    )
    reader.start()
    try:
        data = b""
        deadline = time.monotonic() + WAIT_S
        while b"\r" not in data[1:] and time.monotonic() < deadline:
            data += pty.read(0.05)
        assert data.startswith(b"\r\x05PW 7 2\r")
        assert got.items.empty()  # nothing arrives unasked
        pty.write(PWD.replace(b"PW  1", b"PW  7"))
        [(_, reading, _)] = got.take(1)
        assert reading.extra["unit_id"] == "7"
    finally:
        reader.stop()


def test_cable_pull_and_replug_through_a_symlink(tmp_path: Path) -> None:
    first = Pty()
    port = tmp_path / "ttyPWD"
    link(port, first.path)
    got = Collector()
    reader = InstrumentReader("pwd", vaisala.DRIVER, str(port), on_frame=got, **FAST)
    reader.start()
    second = None
    try:
        wait_for(lambda: reader.stats()["state"] == "ok")
        first.write(PWD)
        assert got.take(1)[0][1] is not None
        first.close()  # the cable is pulled: reads fail, the device path goes away
        wait_for(lambda: reader.stats()["state"] == "reconnecting")
        assert reader.stats()["last_error"]
        second = Pty()
        link(port, second.path)  # plugged in again (a new device behind the same path)
        wait_for(lambda: reader.stats()["state"] == "ok")
        second.write(PWD)
        [(_, reading, _)] = got.take(1)
        assert reading.visibility_m == 9163
        stats = reader.stats()
        assert stats["reconnects"] >= 1 and stats["readings"] == 2
    finally:
        reader.stop()
        if second is not None:
            second.close()


def serve_once(srv: socket.socket, payload: bytes, hold_s: float = 0.3) -> threading.Event:
    """A serial-to-Ethernet converter: accept one connection, stop listening, send
    ``payload`` every 50 ms (pyserial drops what arrives while it opens), hang up after
    ``hold_s`` or when the returned event is set."""
    done = threading.Event()

    def run() -> None:
        conn, _ = srv.accept()
        srv.close()
        deadline = time.monotonic() + hold_s
        try:
            while time.monotonic() < deadline and not done.wait(0.05):
                if payload:
                    conn.sendall(payload)
        except OSError:
            pass
        finally:
            conn.close()
            done.set()

    threading.Thread(target=run, daemon=True).start()
    return done


def test_socket_url_reconnects_after_the_server_restarts() -> None:
    srv = socket.create_server(("127.0.0.1", 0))
    host, port_no = srv.getsockname()
    got = Collector()
    url = f"socket://{host}:{port_no}"
    reader = InstrumentReader("pwd", vaisala.DRIVER, url, on_frame=got, **FAST)
    server = serve_once(srv, PWD)
    reader.start()
    try:
        assert got.take(1)[0][1] is not None
        assert server.wait(WAIT_S)  # hung up and not listening: the converter is gone
        wait_for(lambda: "cannot open" in (reader.stats()["last_error"] or ""))
        assert reader.stats()["state"] == "reconnecting"
        while not got.items.empty():  # the frames of the first connection
            got.items.get()
        server = serve_once(socket.create_server(("127.0.0.1", port_no)), PWD)
        assert got.take(1)[0][1].rain_rate_mm_h == 0.18
        assert reader.stats()["reconnects"] >= 1
    finally:
        reader.stop()
        server.set()


def test_idle_timeout_reopens_a_silent_connection() -> None:
    srv = socket.create_server(("127.0.0.1", 0))
    host, port_no = srv.getsockname()
    got = Collector()
    url = f"socket://{host}:{port_no}"
    reader = InstrumentReader("pwd", vaisala.DRIVER, url, on_frame=got, idle_timeout_s=0.2, **FAST)
    silent = serve_once(srv, b"", hold_s=WAIT_S)  # connected, then silent
    reader.start()
    try:
        wait_for(lambda: "no data" in (reader.stats()["last_error"] or ""))
        talking = serve_once(socket.create_server(("127.0.0.1", port_no)), PWD)
        assert got.take(1)[0][1] is not None
        assert reader.stats()["reconnects"] >= 1
        talking.set()
    finally:
        reader.stop()
        silent.set()


def test_missing_port_keeps_retrying_and_stops_promptly(tmp_path: Path) -> None:
    reader = InstrumentReader("gone", vaisala.DRIVER, str(tmp_path / "ttyNONE"), **FAST)
    reader.start()
    wait_for(lambda: reader.stats()["state"] == "reconnecting")
    assert "ttyNONE" in reader.stats()["last_error"]
    reader.stop()
    assert reader.stats()["state"] == "stopped"
    assert not reader._thread.is_alive()


def test_configuration_errors() -> None:
    with pytest.raises(ConfigError, match="mode"):
        InstrumentReader("x", vaisala.DRIVER, "loop://", mode="push")
    with pytest.raises(ConfigError, match=r"serial\.speed"):
        InstrumentReader("x", vaisala.DRIVER, "loop://", serial={"speed": 1})
    with pytest.raises(ConfigError, match=r"options\.bogus"):
        InstrumentReader("x", vaisala.DRIVER, "loop://", options={"bogus": 1})
    with pytest.raises(ConfigError, match="idle_timeout_s"):
        InstrumentReader("x", vaisala.DRIVER, "loop://", idle_timeout_s=0)
    with pytest.raises(ConfigError, match="poll_interval_s"):
        InstrumentReader("x", vaisala.DRIVER, "loop://", mode="polled", poll_interval_s=0)


def test_loop_url_echoes_the_poll_command_as_a_bad_frame() -> None:
    """``loop://`` sends back what is written: the poll command comes back, is framed, and is
    rejected by the parser (a real instrument never echoes it)."""
    got = Collector()
    reader = InstrumentReader(
        "loop", vaisala.DRIVER, "loop://", mode="polled", poll_interval_s=60, on_frame=got, **FAST
    )
    reader.start()
    try:
        [(frame, reading, error)] = got.take(1)
        assert frame.data == b"\x05PW 1 2" and reading is None and "not a PWD" in error
    finally:
        reader.stop()


def test_bad_serial_values_are_config_errors() -> None:
    with pytest.raises(ConfigError, match="serial"):
        InstrumentReader("x", vaisala.DRIVER, "loop://", serial={"parity": "Q"})
    with pytest.raises(ConfigError, match="serial"):
        InstrumentReader("x", vaisala.DRIVER, "loop://", serial={"bytesize": 9})
