"""sd_notify over a real AF_UNIX datagram socket, the watchdog variables and the kick rate."""

from __future__ import annotations

import os
import socket
import sys
import uuid
from collections.abc import Iterator
from pathlib import Path

import pytest

from daemon.service import sdnotify
from daemon.service.sdnotify import Watchdog, notify, watchdog_interval_s

pytestmark = pytest.mark.skipif(not hasattr(socket, "AF_UNIX"), reason="needs AF_UNIX sockets")


@pytest.fixture
def receiver(tmp_path: Path) -> Iterator[tuple[str, socket.socket]]:
    """A datagram socket standing in for systemd: (NOTIFY_SOCKET value, socket)."""
    path = tmp_path / "n"  # short: sun_path holds 107 bytes
    with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as sock:
        sock.bind(str(path))
        sock.settimeout(5.0)
        yield str(path), sock


def _received(sock: socket.socket) -> list[str]:
    return sock.recv(4096).decode().split("\n")


def test_notify_sends_all_fields_in_one_datagram(receiver):
    address, sock = receiver
    assert notify("READY=1", "STATUS=2 cameras", environ={"NOTIFY_SOCKET": address})
    assert _received(sock) == ["READY=1", "STATUS=2 cameras"]


def test_notify_reads_os_environ_by_default(receiver, monkeypatch):
    address, sock = receiver
    monkeypatch.setenv("NOTIFY_SOCKET", address)
    assert notify("STOPPING=1")
    assert _received(sock) == ["STOPPING=1"]


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="abstract sockets are Linux-only")
def test_notify_to_an_abstract_socket():
    name = f"weatherd-test-{uuid.uuid4().hex}"
    with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as sock:
        sock.bind("\0" + name)
        sock.settimeout(5.0)
        assert notify("WATCHDOG=1", environ={"NOTIFY_SOCKET": "@" + name})
        assert _received(sock) == ["WATCHDOG=1"]


def test_a_newline_cannot_inject_an_assignment(receiver):
    address, sock = receiver
    assert notify("STATUS=camera lost\nREADY=1", environ={"NOTIFY_SOCKET": address})
    assert _received(sock) == ["STATUS=camera lost READY=1"]


@pytest.mark.parametrize("environ", [{}, {"NOTIFY_SOCKET": ""}])
def test_notify_without_systemd_is_a_no_op(environ):
    assert notify("READY=1", environ=environ) is False


def test_notify_never_raises_and_logs_once(tmp_path, caplog, monkeypatch):
    monkeypatch.setattr(sdnotify, "_failure_logged", False)
    caplog.set_level("DEBUG", logger="daemon.service.sdnotify")
    environ = {"NOTIFY_SOCKET": str(tmp_path / "nobody-listens")}
    assert notify("READY=1", environ=environ) is False
    assert notify("WATCHDOG=1", environ=environ) is False
    assert notify("READY=1", environ={"NOTIFY_SOCKET": "vsock:2:9999"}) is False
    failures = [r for r in caplog.records if r.name == "daemon.service.sdnotify"]
    assert len(failures) == 1
    assert "nobody-listens" in failures[0].getMessage()


def test_watchdog_interval_from_usec():
    assert watchdog_interval_s({"WATCHDOG_USEC": "30000000"}) == 30.0
    environ = {"WATCHDOG_USEC": "2500000", "WATCHDOG_PID": str(os.getpid())}
    assert watchdog_interval_s(environ) == 2.5


@pytest.mark.parametrize(
    "environ",
    [
        {},
        {"WATCHDOG_USEC": ""},
        {"WATCHDOG_USEC": "0"},
        {"WATCHDOG_USEC": "-5"},
        {"WATCHDOG_USEC": "thirty"},
        {"WATCHDOG_USEC": "30000000", "WATCHDOG_PID": "not-a-pid"},
    ],
)
def test_no_watchdog_interval(environ):
    assert watchdog_interval_s(environ) is None


def test_watchdog_meant_for_another_process_is_ignored():
    environ = {"WATCHDOG_USEC": "30000000", "WATCHDOG_PID": str(os.getpid() + 1)}
    assert watchdog_interval_s(environ) is None
    assert Watchdog.from_env(environ) is None


class _FakeClock:
    def __init__(self) -> None:
        self.t_s = 1000.0

    def __call__(self) -> float:
        return self.t_s


def test_kicks_are_sent_at_most_every_half_interval():
    clock, sent = _FakeClock(), []
    dog = Watchdog(10.0, clock=clock, send=lambda *f: sent.append(f) or True)
    kicks = []
    for _ in range(25):  # kicked every second for 25 s: sent at 0, 5, 10, 15, 20 s
        kicks.append(dog.kick())
        clock.t_s += 1.0
    assert kicks == [i % 5 == 0 for i in range(25)]
    assert sent == [("WATCHDOG=1",)] * 5


def test_a_failed_kick_is_retried_at_the_next_kick():
    clock, results = _FakeClock(), [False, True]
    dog = Watchdog(10.0, clock=clock, send=lambda *f: results.pop(0))
    assert dog.kick() is False
    clock.t_s += 0.1
    assert dog.kick() is True
    clock.t_s += 0.1
    assert dog.kick() is False  # rate-limited again, no send attempted
    assert results == []


@pytest.mark.parametrize("interval_s", [0.0, -1.0, float("nan")])
def test_watchdog_rejects_a_non_positive_interval(interval_s):
    with pytest.raises(ValueError, match="watchdog interval"):
        Watchdog(interval_s)


def test_watchdog_from_env_kicks_the_real_socket(receiver):
    address, sock = receiver
    dog = Watchdog.from_env({"NOTIFY_SOCKET": address, "WATCHDOG_USEC": "20000000"})
    assert dog is not None
    assert dog.interval_s == 20.0
    assert dog.kick() is True
    assert dog.kick() is False  # within 10 s of the first
    assert _received(sock) == ["WATCHDOG=1"]
    sock.setblocking(False)
    with pytest.raises(BlockingIOError):
        sock.recv(4096)  # the second kick sent nothing


def test_no_watchdog_from_an_empty_environment():
    assert Watchdog.from_env({}) is None
