"""``weatherd watch`` and ``get`` as a new user meets them (issue 13): a word on stderr when
nobody is reachable or nothing is published, and a human view beside the JSON lines."""

from __future__ import annotations

import io
import threading
import time

import pytest

from daemon.service.fusion import fuse
from daemon.transport import watch as watch_mod
from daemon.transport.publisher import zenoh_config
from daemon.transport.watch import human_line, watch
from tests.conftest import run_weatherd
from tests.daemon.service.test_fusion import T0, _view
from tests.daemon.transport.test_publisher import client_publisher, wait_until
from tests.zenoh_tools import RouterProcess, free_port


def test_nothing_reachable_is_said_on_stderr():
    port = free_port()  # nobody listens there
    started = time.monotonic()
    done = run_weatherd("watch", "--connect", f"tcp/127.0.0.1:{port}", "--timeout", "5")
    assert done.returncode == 0 and done.stdout == ""
    assert f"weatherd: no Zenoh peer or router reachable at tcp/127.0.0.1:{port}" in done.stderr, (
        done.stderr
    )
    assert "still waiting" in done.stderr
    assert time.monotonic() - started < 30


@pytest.mark.e2e
def test_connected_but_silent_then_a_human_line(monkeypatch):
    monkeypatch.setattr(watch_mod, "SILENT_NOTICE_S", 1.0)
    with RouterProcess(free_port()) as router:
        config = zenoh_config(mode="client", connect=[router.endpoint])
        # nothing published: the notice names the key expression
        err = io.StringIO()
        watch("weather/nobody/**", config, out=io.StringIO(), timeout_s=3.5, err=err)
        assert "connected, but nothing published on weather/nobody/**" in err.getvalue()
        assert "no Zenoh peer" not in err.getvalue()
        # then a state, shown as one short line
        out, err = io.StringIO(), io.StringIO()
        state = fuse({"cam1": _view(True, R=1234.0)}, site="s1", t_ns=T0)
        thread = threading.Thread(
            target=watch,
            args=("weather/e2e-human/state", config),
            kwargs={"out": out, "count": 1, "timeout_s": 20.0, "human": True, "err": err},
        )
        thread.start()
        with client_publisher("e2e-human", router.endpoint) as pub:
            wait_until(lambda: pub.connected, what="publisher connected")
            while thread.is_alive():
                pub.put("state", state)
                thread.join(0.2)
    line = out.getvalue()
    assert line.count("\n") == 1
    assert "weather/e2e-human/state  precipitation yes (unknown)" in line
    assert "rate unknown" in line and "cam1 ok precipitation R 1234" in line


def test_human_lines_of_each_message():
    dry = fuse({"cam1": _view(False)}, site="s1", t_ns=T0, camera_rate=lambda r: 0.003 * r)
    line = human_line({"key": "weather/s1/state", "payload": dry})
    assert line.startswith("08:26:40Z weather/s1/state  precipitation no, rate 0 mm/h (camera)")
    assert "cam1 ok dry" in line
    blind = fuse({"cam1": _view(True, "dark")}, site="s1", t_ns=T0)
    assert "precipitation unknown" in human_line({"key": "k", "payload": blind})
    assert "no source can judge" in human_line({"key": "k", "payload": blind})
    camera = {
        "schema": "weather.camera/1", "t": "2026-01-01T00:00:08.000000Z", "state": "ok",
        "rain": True, "camera_precipitation_type": "rain", "pi_smoothed": 0.95,
        "mu_smoothed_deg": 90.9, "R": 1232.4, "R_mean": 1351.9, "fps": 25.0,
    }  # fmt: skip
    assert human_line({"key": "c", "payload": camera}) == (
        "00:00:08Z c  ok rain, Π 0.95, μ 91°, R 1232 (mean 1352), 25.0 fps"
    )
    snowing = camera | {"camera_precipitation_type": "snow"}
    assert human_line({"key": "c", "payload": snowing}).startswith("00:00:08Z c  ok snow, Π")
    typeless = camera | {"camera_precipitation_type": "unknown"}
    assert "ok precipitation, Π" in human_line({"key": "c", "payload": typeless})
    assert human_line({"key": "a", "alive": False}).endswith("a  gone")
    assert len(human_line({"key": "x", "payload": {"long": "y" * 500}})) < 150


def test_get_text_format_and_help():
    done = run_weatherd("get", "--help")
    assert "--format" in done.stdout and "weather/demo/**" in done.stdout
    done = run_weatherd("watch", "--help")
    assert "one short line" in done.stdout
