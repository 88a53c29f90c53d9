"""The real daemon with present-weather sensors simulated on pseudo-terminals speaking the real
Vaisala PWD protocol: one automatic (it sends by itself), one polled (it answers the poll
command only). Covered: readings published on ``weather/<site>/instrument/<id>`` and fused into
the state (type, rate, wawa, visibility); the online calibration of R converging on the rate the
sensor reports; a cable pull (camera-only mm/h from the calibration takes over) and a re-plug
(the sensor is back); the calibration kept across a restart.
"""

from __future__ import annotations

import os
import signal
import threading
import time
from pathlib import Path

import pytest

from tests.daemon.transport.schemas import validate
from tests.zenoh_tools import RouterProcess, SubscriberProcess, free_port

from .test_e2e_run import CAM, SITE, Daemon, rain_clip  # noqa: F401 - fixture

pytestmark = pytest.mark.e2e

RATE_MM_H = 4.0


def pwd_message(unit: str, *, rate: float = RATE_MM_H, wawa: int = 61) -> bytes:
    """A PWD message 2, raw: <SOH>PW <id><STX> body <ETX><CR><LF>."""
    body = f" 00  3500  3900   R   {wawa}   {wawa}   {wawa}  {rate:.2f}  12.34     0"
    return b"\x01PW " + unit.rjust(2).encode() + b"\x02" + body.encode() + b"\x03\r\n"


class SimulatedPwd:
    """A PWD on the master side of a pty; ``port`` is a symlink to the slave, so a re-plug
    (a new pty) keeps the daemon's configured path."""

    def __init__(self, port: Path, unit: str, *, polled: bool):
        self.port, self.unit, self.polled = port, unit, polled
        self.polls = 0
        self._stop = threading.Event()
        self.plug()

    def plug(self) -> None:
        self.master, self.slave = os.openpty()
        tmp = self.port.with_suffix(".new")
        tmp.unlink(missing_ok=True)
        os.symlink(os.ttyname(self.slave), tmp)
        os.replace(tmp, self.port)
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def pull(self) -> None:
        """The cable is pulled: the instrument side goes away."""
        self._stop.set()
        self._thread.join(5)
        os.close(self.master)
        os.close(self.slave)
        self.port.unlink()

    def _run(self) -> None:
        os.set_blocking(self.master, False)
        buffer = b""
        while not self._stop.wait(0.2):
            try:
                buffer += os.read(self.master, 4096)
            except BlockingIOError:
                pass
            except OSError:
                return
            if self.polled:
                command = b"\r\x05PW " + self.unit.encode() + b" 2\r"
                while command in buffer:
                    buffer = buffer.replace(command, b"", 1)
                    self.polls += 1
                    os.write(self.master, b"noise\x7f" + pwd_message(self.unit))
            else:
                buffer = b""
                os.write(self.master, pwd_message(self.unit))


def write_config(path: Path, *, clip: Path, endpoint: str, tmp: Path) -> Path:
    path.write_text(
        f"""
[site]
id = "{SITE}"
state_dir = "{tmp / "state"}"

[[camera]]
id = "{CAM}"
source = "file:{clip}"
loop = true

[[instrument]]
id = "pwd-auto"
driver = "vaisala-pwd"
port = "{tmp / "pwd-auto"}"
mode = "automatic"
stale_s = 3.0

[[instrument]]
id = "pwd-polled"
driver = "vaisala-pwd"
port = "{tmp / "pwd-polled"}"
mode = "polled"
poll_interval_s = 0.5
stale_s = 3.0
[instrument.options]
unit_id = "2"

[calibration]
window_s = 1.0
min_windows = 3
rate_smoothing_s = 1.0

[zenoh]
mode = "client"
connect = ["{endpoint}"]

[recording]
dir = "{tmp / "rec"}"

[publish]
state_interval_s = 0.5
camera_interval_s = 0.5
status_interval_s = 1.0
"""
    )
    return path


def test_instruments_fusion_calibration_cable_pull_and_replug(
    rain_clip: Path,  # noqa: F811
    tmp_path: Path,
) -> None:
    auto = SimulatedPwd(tmp_path / "pwd-auto", "1", polled=False)
    polled = SimulatedPwd(tmp_path / "pwd-polled", "2", polled=True)
    port = free_port()
    with (
        RouterProcess(port) as router,
        SubscriberProcess(router.endpoint, "weather/**", liveliness_keyexpr=None) as sub,
    ):
        config = write_config(
            tmp_path / "w.toml", clip=rain_clip, endpoint=router.endpoint, tmp=tmp_path
        )
        daemon = Daemon(config, tmp_path / "daemon.log")
        try:
            state_key = f"weather/{SITE}/state"

            def is_state(m: dict) -> bool:
                return m["key"] == state_key

            # Both instruments publish readings; the polled one only answers polls.
            for iid in ("pwd-auto", "pwd-polled"):
                sub.wait_for(lambda m, i=iid: m["key"] == f"weather/{SITE}/instrument/{i}", 30)
            assert polled.polls >= 1
            # The fused state takes type, rate and wawa from the sensors.
            fused = sub.wait_for(
                lambda m: (
                    is_state(m)
                    and m["json"]["precipitation"] is True
                    and m["json"]["rain_rate_source"] == "sensor"
                ),
                timeout=60,
            )[-1]["json"]
            assert fused["precipitation_type"] == "rain"
            assert fused["rain_rate_mm_h"] == pytest.approx(RATE_MM_H)
            assert (fused["wawa"], fused["visibility_m"]) == (61, 3500.0)
            assert fused["intensity_class"] == "moderate"
            # The calibration learns the rate from the sensor's readings.
            sub.wait_for(
                lambda m: is_state(m) and (m["json"]["calibration"] or {}).get("ready"),
                timeout=60,
            )
            # Cable pull of both: camera-only mm/h from the calibration.
            auto.pull()
            polled.pull()
            camera_only = sub.wait_for(
                lambda m: is_state(m) and m["json"]["rain_rate_source"] == "camera",
                timeout=30,
            )[-1]["json"]
            assert camera_only["rain_rate_mm_h"] == pytest.approx(RATE_MM_H, rel=0.35), (
                camera_only["camera_R"],
                camera_only["calibration"],
            )
            assert camera_only["instruments"]["pwd-auto"]["usable"] is False
            # Without the sensor, the type is the camera's own: a rain clip is never snow.
            assert camera_only["precipitation_type"] == camera_only["camera_precipitation_type"]
            assert camera_only["precipitation_type"] == "rain"
            pulled_at = time.time_ns()
            # Re-plug: the sensor is back and wins again.
            auto.plug()
            sub.wait_for(
                lambda m: (
                    is_state(m)
                    and m["recv_ns"] > pulled_at
                    and m["json"]["rain_rate_source"] == "sensor"
                ),
                timeout=60,
            )
            sub.wait_for(
                lambda m: (
                    m["key"] == f"weather/{SITE}/status"
                    and m["json"]["instruments"]["pwd-auto"]["reconnects"] >= 1
                    and m["json"]["instruments"]["pwd-auto"]["state"] == "ok"
                ),
                timeout=10,
            )
            assert daemon.stop(signal.SIGTERM) == 0, daemon.stderr()
        finally:
            daemon.stop(signal.SIGKILL)
        samples = [m for m in sub.messages() if m["json_ok"]]
    for m in samples:
        validate(m["json"])
    readings = [m["json"] for m in samples if "/instrument/" in m["key"]]
    assert {r["instrument"] for r in readings} == {"pwd-auto", "pwd-polled"}
    assert all(r["rain_rate_mm_h"] == RATE_MM_H and r["wawa"] == 61 for r in readings)
    log = daemon.stderr()
    assert "Traceback" not in log
    assert "reopening" in log  # the cable pull, logged once
    # The calibration survived in the state directory, and a restart restores it.
    assert (tmp_path / "state" / "calibration.json").exists()
    auto.pull()
    restart = Daemon(config, tmp_path / "daemon2.log")
    try:
        restart.wait_log("calibration: restored", timeout=30)
    finally:
        assert restart.stop() == 0
