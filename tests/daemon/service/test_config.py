"""The configuration: every shipped file valid, every error names its key, nothing unknown."""

from __future__ import annotations

from pathlib import Path

import pytest

from daemon.config import ConfigErrors, default_recording_dir, load_config, parse_config
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
        (
            {"detector": {"precipitation_type": {"across_rain_deg": 26}}},
            "detector.precipitation_type.across_rain_deg: across_rain is not an angle",
        ),
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


# -- issue 11: what run would trip on is refused here, every problem at once --------------
@pytest.mark.parametrize(
    "text",
    [
        "a = " + "[" * 65 + "]" * 65,
        "a = " + "[" * 900 + "]" * 900,
        "a = " + "[" * 5000 + "]" * 5000,
        "a = " + "{b = " * 70 + "1" + "}" * 70,
        "a" + ".b" * 70 + " = 1",
    ],
    ids=["arrays-65", "arrays-900", "arrays-5000", "inline-tables-70", "dotted-keys-70"],
)
def test_deep_nesting_is_a_config_error(tmp_path: Path, text: str) -> None:
    deep = tmp_path / "deep.toml"
    deep.write_text(text + "\n")
    with pytest.raises(ConfigError, match=r"deep\.toml: .*nested"):
        load_config(deep)


def test_nesting_within_the_limit_reaches_validation(tmp_path: Path) -> None:
    ok = tmp_path / "ok.toml"
    ok.write_text(
        "[[instrument]]\nid='g'\ndriver='tipping-bucket'\nport='x'\noptions = { a = [[[1.0]]] }\n"
    )
    assert load_config(ok).instrument[0].options == {"a": [[[1.0]]]}


@pytest.mark.parametrize(
    ("data", "key"),
    [
        ({"recording": {"rotate_s": float("inf")}}, "recording.rotate_s: Input should be a finite"),
        ({"calibration": {"window_s": float("nan")}}, "calibration.window_s:"),
        ({"camera": [{"id": "c", "source": "demo:", "fps": float("inf")}]}, "camera[0].fps:"),
        (
            {
                "instrument": [
                    {"id": "g", "driver": "x", "port": "p", "options": {"k": [float("inf")]}}
                ]
            },
            "instrument[0].options.k[0]: must be a finite number",
        ),
        ({"recording": {"rotate_mb": 1e-9}}, "recording.rotate_mb:"),
        ({"recording": {"flush_interval_s": 0.01}}, "recording.flush_interval_s:"),
        ({"recording": {"thumbnail_interval_s": 0.5}}, "recording.thumbnail_interval_s: must be 0"),
        ({"publish": {"status_interval_s": 1e-6}}, "publish.status_interval_s:"),
        ({"publish": {"state_interval_s": 1e300}}, "publish.state_interval_s:"),
        (
            {"instrument": [{"id": "g", "driver": "x", "port": "p", "poll_interval_s": 1e-9}]},
            "instrument[0].poll_interval_s:",
        ),
        (
            {"camera": [{"id": "c", "source": "demo:", "max_pixels": 10**9}]},
            "camera[0].max_pixels:",
        ),
        (
            {"camera": [{"id": "c", "source": "demo:", "width": 2560, "height": 1440}]},
            "camera[0]: width x height = 2560x1440",
        ),
    ],
)
def test_values_run_cannot_use_are_refused(data: dict, key: str) -> None:
    with pytest.raises(ConfigError) as err:
        parse_config(data)
    assert key in str(err.value)


@pytest.mark.parametrize(
    "endpoint",
    [
        "tcp/127.0.0.1:7447",
        "udp/10.0.0.1:7447",
        "tls/router.example:7447",
        "quic/host:1",
        "ws/127.0.0.1:8000",
        "tcp/[::1]:7447",
        "tcp/[fe80::1%eth0]:7447",
        "unixsock-stream//run/zenoh.sock",
        "tcp/127.0.0.1:7447?prio=1#iface=lo",
    ],
)
def test_good_endpoints_pass(endpoint: str) -> None:
    config = parse_config({"zenoh": {"connect": [endpoint], "listen": [endpoint]}})
    assert config.zenoh.connect == [endpoint]


@pytest.mark.parametrize(
    ("endpoint", "what"),
    [
        ("tcp/127.0.0.1:99999", "port must be"),
        ("tcp/127.0.0.1:0", "port must be 1 to 65535"),
        ("tcp/127.0.0.1", "expected HOST:PORT"),
        ("tcp/::1:7447", "expected HOST:PORT"),
        ("127.0.0.1:7447", "expected PROTOCOL/ADDRESS"),
        ("http/x:1", "unknown protocol"),
        ("tcp/", "expected PROTOCOL/ADDRESS"),
        ("tcp/a b:1", "expected HOST:PORT"),
    ],
)
def test_bad_endpoints_name_the_key_and_the_rule(endpoint: str, what: str) -> None:
    with pytest.raises(ConfigError) as err:
        parse_config({"zenoh": {"connect": ["tcp/127.0.0.1:7447", endpoint]}})
    assert f"zenoh.connect[1]: {endpoint!r}: {what}" in str(err.value)


def test_port_zero_may_be_listened_on() -> None:
    assert parse_config({"zenoh": {"listen": ["tcp/127.0.0.1:0"]}}).zenoh.listen


def test_every_problem_is_reported_at_once(tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text(
        '[site]\nid = "a b"\n[recording]\nrotate_s = -1\nbogus = 1\n'
        "[detector.decision]\npi_rain = 'x'\nmin_blobs = 1.5\n"
        '[[camera]]\nid = "c"\nsource = "demo:"\n[camera.detector.decision]\npi_rain = 2.0\n'
    )
    with pytest.raises(ConfigErrors) as err:
        load_config(bad)
    lines = err.value.errors
    keys = [line.split(": ")[1] for line in lines]
    assert keys == [
        "site.id",
        "recording.rotate_s",
        "recording.bogus",
        "detector.decision.pi_rain",
        "detector.decision.min_blobs",
    ], lines
    assert all(line.startswith(f"{bad}: ") for line in lines)
    assert str(err.value) == "; ".join(lines)


def test_booleans_and_strings_are_not_numbers() -> None:
    with pytest.raises(ConfigError, match=r"recording\.rotate_s: Input should be a valid number"):
        parse_config({"recording": {"rotate_s": True}})
    with pytest.raises(ConfigError, match=r"publish\.state_interval_s"):
        parse_config({"publish": {"state_interval_s": "1"}})
    assert parse_config({"recording": {"rotate_s": 60}}).recording.rotate_s == 60.0


def test_a_flood_of_problems_is_cut_to_twenty_lines() -> None:
    with pytest.raises(ConfigErrors) as err:
        parse_config({f"k{i}": i for i in range(50)})
    assert len(err.value.errors) == 20
    assert err.value.errors[-1] == "... and 31 more problems"


def test_run_without_a_file_listens_where_watch_looks(tmp_path, monkeypatch):
    """`weatherd run` alone must be reachable by `weatherd watch` alone."""
    from daemon.cli.common import validated_config
    from daemon.cli.zenoh_options import DEFAULT_CONNECT

    monkeypatch.chdir(tmp_path)  # the default recordings and state folders are made here
    assert validated_config(None).zenoh.listen == [DEFAULT_CONNECT]
