"""The configuration: every shipped file valid, every error names its key, nothing unknown."""

from __future__ import annotations

from pathlib import Path

import pytest

from daemon.config import default_recording_dir, load_config, parse_config
from drivers.errors import ConfigError
from tests.conftest import REPO


@pytest.mark.parametrize("name", ["weatherd.toml", "site-example.toml"])
def test_shipped_configs_are_valid(name: str) -> None:
    config = load_config(REPO / "config" / name)
    for i in range(len(config.camera)):
        config.camera_params(i)


def test_defaults_are_the_demo() -> None:
    config = parse_config({})
    assert config.site.id == "demo"
    assert config.camera == []
    assert config.zenoh.mode == "peer"
    assert config.publish.state_interval_s == 1.0
    assert config.publish.status_interval_s == 10.0


@pytest.mark.parametrize(
    ("data", "key"),
    [
        ({"site": {"id": "a/b"}}, "site.id:"),
        ({"site": {"name": "x"}}, "site.name: unknown key"),
        ({"sites": {}}, "sites: unknown key"),
        ({"camera": [{"source": "demo:"}]}, "camera[0].id: required key missing"),
        ({"camera": [{"id": "c", "source": "ftp://x"}]}, "camera[0].source:"),
        ({"camera": [{"id": "c", "source": "demo:", "fps": 0}]}, "camera[0].fps:"),
        ({"camera": [{"id": "c", "source": "demo:", "width": 10}]}, "camera[0]: width and height"),
        ({"camera": [{"id": "c", "source": "demo:", "colour": 1}]}, "camera[0].colour: unknown"),
        (
            {"camera": [{"id": "c", "source": "demo:"}, {"id": "c", "source": "demo:"}]},
            "camera id 'c' is used twice",
        ),
        (
            {"camera": [{"id": "c", "source": "demo:", "detector": {"decision": {"pi": 1}}}]},
            "camera[0].detector.decision.pi: unknown parameter",
        ),
        ({"detector": {"decision": {"pi_rain": "high"}}}, "detector.decision.pi_rain:"),
        ({"detector": {"bogus": {}}}, "detector.bogus: unknown parameter group"),
        ({"zenoh": {"mode": "server"}}, "zenoh.mode:"),
        ({"zenoh": {"config_file": "/no/such/zenoh.json5"}}, "zenoh.config_file:"),
        ({"recording": {"budget_mb": -5}}, "recording.budget_mb:"),
        ({"recording": {"flush": 1}}, "recording.flush: unknown key"),
        ({"publish": {"state_interval_s": 0}}, "publish.state_interval_s:"),
    ],
)
def test_errors_name_the_key(data: dict, key: str) -> None:
    with pytest.raises(ConfigError) as err:
        parse_config(data)
    assert key in str(err.value)
    assert "\n" not in str(err.value)


def test_camera_detector_overrides_the_global_table() -> None:
    config = parse_config(
        {
            "detector": {"decision": {"pi_rain": 0.3, "min_blobs": 20}},
            "camera": [
                {"id": "a", "source": "demo:"},
                {"id": "b", "source": "demo:", "detector": {"decision": {"pi_rain": 0.5}}},
            ],
        }
    )
    a, b = config.camera_params(0), config.camera_params(1)
    assert a.decision.pi_rain == pytest.approx(0.3)
    assert b.decision.pi_rain == pytest.approx(0.5)
    assert b.decision.min_blobs == 20  # inherited


def test_file_errors_name_the_file(tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text("[site\nid=1")
    with pytest.raises(ConfigError, match=r"bad\.toml: not valid TOML"):
        load_config(bad)
    with pytest.raises(ConfigError, match="cannot read"):
        load_config(tmp_path / "missing.toml")
    wrong = tmp_path / "wrong.toml"
    wrong.write_text('[site]\nid = "ok"\n[recording]\nrotate_s = "hourly"\n')
    with pytest.raises(ConfigError, match=r"wrong\.toml: recording\.rotate_s:"):
        load_config(wrong)


def test_recording_dir_defaults_to_the_state_directory(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("STATE_DIRECTORY", "/var/lib/weatherd")
    assert default_recording_dir(parse_config({}).recording) == Path("/var/lib/weatherd/recordings")
    monkeypatch.delenv("STATE_DIRECTORY")
    assert default_recording_dir(parse_config({}).recording) == Path("recordings")
    cfg = parse_config({"recording": {"dir": "/data/rec"}}).recording
    assert default_recording_dir(cfg) == Path("/data/rec")
