"""The Zenoh publisher: key space, JSON payloads, queryable, liveliness, a late or restarted router.

The end-to-end tests run a real router in its own process on 127.0.0.1 and a subscriber in
another (tests/zenoh_tools.py); the publisher under test runs in this process in client mode.
"""

from __future__ import annotations

import io
import json
import subprocess
import sys
import textwrap
import threading
import time

import pytest

from daemon.transport.publisher import (
    MemoryPublisher,
    Publisher,
    ZenohPublisher,
    encode_message,
    site_key,
    zenoh_config,
)
from daemon.transport.watch import get, sample_line, watch
from drivers.errors import ConfigError, SourceError
from tests.conftest import REPO
from tests.zenoh_tools import RouterProcess, SubscriberProcess, free_port, query


def wait_until(condition, timeout_s: float = 15.0, what: str = "condition") -> None:
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < deadline, f"{what} not reached within {timeout_s} s"
        time.sleep(0.05)


def client_publisher(site: str, endpoint: str) -> ZenohPublisher:
    config = zenoh_config(mode="client", connect=[endpoint])
    return ZenohPublisher(site, config, retry_initial_s=0.1, retry_max_s=0.5)


# -- pure parts ---------------------------------------------------------------------------------


def test_site_key_builds_and_rejects():
    assert site_key("site-001") == "weather/site-001"
    assert site_key("s", "camera/cam0/hos") == "weather/s/camera/cam0/hos"
    for site, suffix in [
        ("a/b", "state"),
        ("*", "state"),
        ("", "state"),
        ("s", "a/*"),
        ("s", "a//b"),
        ("s", ""),
        ("s", "**"),
        ("s", "x$y"),
        ("s", "/state"),
    ]:
        with pytest.raises(ValueError):
            site_key(site, suffix)


def test_encode_message_is_compact_utf8_json_and_refuses_nan():
    assert (
        encode_message({"a": 1, "b": [1.5, None], "t": "é"})
        == '{"a":1,"b":[1.5,null],"t":"é"}'.encode()
    )
    with pytest.raises(ValueError):
        encode_message({"x": float("nan")})
    with pytest.raises(TypeError):
        encode_message({"x": object()})


def test_zenoh_config_modes_endpoints_and_multicast_default():
    config = zenoh_config(mode="client", connect=["tcp/127.0.0.1:7447"], listen=["tcp/127.0.0.1:0"])
    assert json.loads(config.get_json("mode")) == "client"
    assert json.loads(config.get_json("connect/endpoints")) == ["tcp/127.0.0.1:7447"]
    assert json.loads(config.get_json("listen/endpoints")) == ["tcp/127.0.0.1:0"]
    assert json.loads(config.get_json("scouting/multicast/enabled")) is False
    assert json.loads(config.get_json("transport/shared_memory/enabled")) is False
    assert json.loads(zenoh_config(shared_memory=None).get_json("transport/shared_memory/enabled"))


def test_zenoh_config_file_is_loaded_then_overridden(tmp_path):
    path = tmp_path / "zenoh.json5"
    path.write_text(
        '{ mode: "peer", connect: { endpoints: ["tcp/10.0.0.1:7447"] },'
        " scouting: { multicast: { enabled: true } }, // the user's choice\n"
        ' transport: { auth: { usrpwd: { user: "site", password: "secret" } } } }'
    )
    config = zenoh_config(config_file=str(path), mode="client")
    assert json.loads(config.get_json("mode")) == "client"
    assert json.loads(config.get_json("connect/endpoints")) == ["tcp/10.0.0.1:7447"]
    assert json.loads(config.get_json("scouting/multicast/enabled")) is True
    assert json.loads(config.get_json("transport/auth/usrpwd/user")) == "site"
    config = zenoh_config(config_file=str(path), connect=["tcp/10.0.0.2:7447"])
    assert json.loads(config.get_json("connect/endpoints")) == ["tcp/10.0.0.2:7447"]
    path.write_text('{ mode: "client" }')
    assert json.loads(zenoh_config(config_file=str(path)).get_json("mode")) == "client"
    assert json.loads(zenoh_config().get_json("mode")) == "peer"


@pytest.mark.parametrize(
    ("kwargs", "file_text", "starts"),
    [
        ({"mode": "server"}, None, "zenoh.mode:"),
        ({"connect": ["not-an-endpoint"]}, None, "zenoh.connect:"),
        ({"listen": ["nope"]}, None, "zenoh.listen:"),
        ({}, "{ mode: ", "zenoh.config_file:"),
        ({}, "{ bogus_key: 1 }", "zenoh.config_file:"),
    ],
)
def test_zenoh_config_errors_name_the_key(tmp_path, kwargs, file_text, starts):
    if file_text is not None:
        path = tmp_path / "bad.json5"
        path.write_text(file_text)
        kwargs = {**kwargs, "config_file": str(path)}
    with pytest.raises(ConfigError) as err:
        zenoh_config(**kwargs)
    message = str(err.value)
    assert message.startswith(starts)
    assert "\n" not in message and ".rs:" not in message


def test_zenoh_config_missing_file(tmp_path):
    with pytest.raises(ConfigError, match="no such file"):
        zenoh_config(config_file=str(tmp_path / "absent.json5"))


def test_memory_publisher_records_what_a_subscriber_would_parse():
    pub = MemoryPublisher("s1")
    assert isinstance(pub, Publisher)
    pub.put("state", {"rain": True, "t": (1, 2)})
    pub.put("state", {"x": float("inf")})  # refused like the real one, never raised
    pub.put("bad/*", {})
    pub.close()
    assert pub.messages == [("weather/s1/state", {"rain": True, "t": [1, 2]})]
    assert pub.put_errors == 2
    assert pub.latest("state") == {"rain": True, "t": [1, 2]}
    assert pub.closed


def test_zenoh_publisher_rejects_bad_site_and_never_raises_on_put():
    config = zenoh_config(mode="client", connect=["tcp/127.0.0.1:9"])
    with pytest.raises(ConfigError, match="site"):
        ZenohPublisher("a/b", config)
    pub = ZenohPublisher("s1", config)
    assert isinstance(pub, Publisher)
    pub.put("state", {"x": float("nan")})
    pub.put("a/**", {"x": 1})
    pub.put("state", {"x": 1})  # not started: cached, counted unsent
    stats = pub.stats()
    assert (stats["put_errors"], stats["unsent"], stats["session_open"]) == (2, 1, False)
    assert pub.latest() == {"weather/s1/state": b'{"x":1}'}
    pub.close()
    pub.close()
    pub.put("state", {"x": 2})  # after close: still no exception


# -- against a real router ------------------------------------------------------------------------


@pytest.fixture(scope="module")
def router():
    with RouterProcess(free_port()) as proc:
        yield proc


@pytest.fixture(scope="module")
def subscriber(router):
    with SubscriberProcess(router.endpoint) as proc:
        yield proc


@pytest.mark.e2e
def test_messages_arrive_as_application_json(router, subscriber):
    state = {"schema": "weather.state/1", "precipitation": True, "rain_rate_mm_h": 2.5}
    hos = {"schema": "weather.camera/1", "pi": 0.4, "mu_deg": 88.0}
    with client_publisher("e2e-json", router.endpoint) as pub:
        wait_until(lambda: pub.connected, what="publisher connected")
        wanted = {"weather/e2e-json/state", "weather/e2e-json/camera/cam0/hos"}
        deadline = time.monotonic() + 15
        while not wanted <= {m["key"] for m in subscriber.messages()}:
            # the subscription may reach the publisher a moment after the session opens
            assert time.monotonic() < deadline, "messages never arrived"
            pub.put("state", state)
            pub.put("camera/cam0/hos", hos)
            time.sleep(0.1)
        stats = pub.stats()
    got = {m["key"]: m for m in subscriber.messages() if not m["liveliness"] and m["key"] in wanted}
    for key, expected in [
        ("weather/e2e-json/state", state),
        ("weather/e2e-json/camera/cam0/hos", hos),
    ]:
        assert got[key]["encoding"] == "application/json"
        assert got[key]["json_ok"] and got[key]["json"] == expected
        assert got[key]["payload"] == json.dumps(expected, separators=(",", ":"))
    assert stats["puts"] >= 2 and stats["put_errors"] == 0 and stats["opens"] == 1
    assert stats["zid"]


@pytest.mark.e2e
def test_queryable_answers_latest_value_of_each_key(router):
    with client_publisher("e2e-query", router.endpoint) as pub:
        pub.put("state", {"v": 1})
        pub.put("state", {"v": 2})
        pub.put("status", {"ok": True})
        pub.put("instrument/gauge0", {"mm": 0.2})
        wait_until(lambda: pub.session_open, what="session open")
        wait_until(
            lambda: len(query(router.endpoint, "weather/e2e-query/**")) == 3,
            what="queryable reachable",
        )
        everything = dict(query(router.endpoint, "weather/e2e-query/**"))
        narrow = query(router.endpoint, "weather/e2e-query/instrument/*")
        one = query(router.endpoint, "weather/e2e-query/state")
        other_site = query(router.endpoint, "weather/nobody/**")
    assert everything == {
        "weather/e2e-query/state": {"v": 2},
        "weather/e2e-query/status": {"ok": True},
        "weather/e2e-query/instrument/gauge0": {"mm": 0.2},
    }
    assert narrow == [("weather/e2e-query/instrument/gauge0", {"mm": 0.2})]
    assert one == [("weather/e2e-query/state", {"v": 2})]
    assert other_site == []


def test_teardown_waits_for_the_callback_thread_that_drops_late():
    """As zenoh-python does: the undeclaration returns, and the callback's own thread calls
    the drop later, then ends. The teardown returns only once that thread has ended."""
    from daemon.transport.publisher import _CallbackEnd, _teardown

    end = _CallbackEnd()

    def late_drop():
        time.sleep(0.3)
        end()
        time.sleep(0.1)

    worker = threading.Thread(target=late_drop, name="fake (pyo3-closure)")

    class Queryable:
        def undeclare(self):
            worker.start()

    class Session:
        def close(self):
            pass

    _teardown(Session(), None, Queryable(), end)
    assert not worker.is_alive()


@pytest.mark.e2e
def test_close_waits_for_the_query_callback_thread(router):
    """zenoh-python runs the queryable's Python callback on a thread of its own, which ends a
    moment after the undeclaration returns: close() waits for it, so that `weatherd run`
    leaves no thread behind at exit (tests/daemon/service/test_shutdown.py saw one, once)."""

    def callback_threads():
        return [t for t in threading.enumerate() if "pyo3-closure" in t.name]

    before = set(callback_threads())
    with client_publisher("e2e-query-end", router.endpoint) as pub:
        pub.put("state", {"v": 1})
        wait_until(lambda: pub.session_open, what="session open")
        wait_until(
            lambda: len(query(router.endpoint, "weather/e2e-query-end/**")) == 1,
            what="queryable reachable",
        )
        assert set(callback_threads()) - before, "the callback runs on a thread of its own"
    assert not set(callback_threads()) - before


@pytest.mark.e2e
def test_liveliness_token_appears_and_disappears_on_close(router, subscriber):
    def alive(kind):
        return lambda m: (
            m["liveliness"] and m["key"] == "weather/e2e-alive/alive" and m["kind"] == kind
        )

    pub = client_publisher("e2e-alive", router.endpoint)
    try:
        pub.start()
        subscriber.wait_for(alive("PUT"), timeout=15)
        assert not [m for m in subscriber.messages() if alive("DELETE")(m)]
    finally:
        closer = threading.Thread(target=pub.close)  # close from another thread
        closer.start()
        closer.join(10)
    assert not closer.is_alive()
    subscriber.wait_for(alive("DELETE"), timeout=15)


@pytest.mark.e2e
def test_router_down_at_start_then_messages_flow(tmp_path):
    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    pub = client_publisher("e2e-late", endpoint)
    try:
        pub.start()  # returns although nothing listens on the port
        pub.put("state", {"before": True})
        wait_until(lambda: pub.stats()["open_attempts"] >= 2, what="open retried")
        stats = pub.stats()
        assert not stats["session_open"] and not pub.connected
        assert stats["unsent"] == 1 and stats["last_error"].startswith("open:")
        with RouterProcess(port) as router, SubscriberProcess(router.endpoint) as sub:
            wait_until(lambda: pub.connected, what="session opened after router start")
            # what was put before the session opened is served by the queryable
            assert query(endpoint, "weather/e2e-late/state") == [
                ("weather/e2e-late/state", {"before": True})
            ]
            n = 0
            deadline = time.monotonic() + 15
            while not [m for m in sub.messages() if m["key"] == "weather/e2e-late/state"]:
                assert time.monotonic() < deadline, "no message after the router came up"
                n += 1
                pub.put("state", {"after": n})
                time.sleep(0.1)
        assert pub.stats()["opens"] == 1
    finally:
        pub.close()


@pytest.mark.e2e
def test_peer_mode_with_router_down_opens_and_connects_later():
    port = free_port()
    config = zenoh_config(
        mode="peer", connect=[f"tcp/127.0.0.1:{port}"], listen=["tcp/127.0.0.1:0"]
    )
    with ZenohPublisher("e2e-peer", config, retry_initial_s=0.1, retry_max_s=0.5) as pub:
        wait_until(lambda: pub.session_open, what="peer session open without router")
        assert not pub.connected
        pub.put("state", {"peer": True})
        with RouterProcess(port) as router:
            wait_until(lambda: pub.connected, what="peer connected to the late router")
            wait_until(
                lambda: (
                    query(router.endpoint, "weather/e2e-peer/state")
                    == [("weather/e2e-peer/state", {"peer": True})]
                ),
                what="peer queryable",
            )


@pytest.mark.e2e
def test_router_restart_is_survived():
    port = free_port()
    router = RouterProcess(port).start()
    try:
        with client_publisher("e2e-restart", router.endpoint) as pub:
            wait_until(lambda: pub.connected, what="connected")
            router.stop()
            wait_until(lambda: not pub.connected, what="router loss seen")
            pub.put("state", {"during": "outage"})  # dropped by zenoh, never raised
            router = RouterProcess(port).start()
            with SubscriberProcess(router.endpoint) as sub:
                wait_until(lambda: pub.connected, what="reconnected")
                sub.wait_for(lambda m: m["key"] == "weather/e2e-restart/alive", timeout=15)
                n = 0
                deadline = time.monotonic() + 15
                while not [m for m in sub.messages() if m["key"] == "weather/e2e-restart/state"]:
                    assert time.monotonic() < deadline, "no message after the restart"
                    n += 1
                    pub.put("state", {"after": n})
                    time.sleep(0.1)
            assert pub.stats()["opens"] == 1  # zenoh reconnected the same session
    finally:
        router.stop()


CHILD = textwrap.dedent(
    """
    import sys, time
    from daemon.transport.publisher import ZenohPublisher, zenoh_config
    pub = ZenohPublisher("e2e-exit", zenoh_config(mode="client", connect=[sys.argv[1]]),
                         retry_initial_s=0.1, retry_max_s=0.5)
    pub.start()
    pub.put("state", {"bye": True})
    if sys.argv[2] == "wait":
        deadline = time.monotonic() + 15
        while not pub.connected and time.monotonic() < deadline:
            time.sleep(0.05)
        assert pub.connected, "never connected"
        pub.put("state", {"bye": True})
    pub.close()
    print("closed", flush=True)
    """
)


@pytest.mark.e2e
@pytest.mark.parametrize("router_up", [True, False], ids=["connected", "router-down"])
def test_close_lets_the_interpreter_exit(router, router_up):
    endpoint = router.endpoint if router_up else f"tcp/127.0.0.1:{free_port()}"
    proc = subprocess.Popen(
        [sys.executable, "-c", CHILD, endpoint, "wait" if router_up else "nowait"],
        cwd=REPO,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        out, err = proc.communicate(timeout=30)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, err = proc.communicate()
        pytest.fail(f"child did not exit after close(); stdout={out!r} stderr={err[-1000:]!r}")
    assert proc.returncode == 0, err[-2000:]
    assert out.strip() == "closed"


# -- weatherd watch / get -----------------------------------------------------------------------


def test_watch_and_get_reject_bad_keyexpr_and_unreachable_router():
    config = zenoh_config(mode="client", connect=[f"tcp/127.0.0.1:{free_port()}"])
    with pytest.raises(ConfigError, match="keyexpr"):
        watch("weather//x", config, timeout_s=0.1)
    with pytest.raises(SourceError, match="cannot open"):
        watch("weather/**", config, timeout_s=0.1)
    with pytest.raises(SourceError, match="cannot open"):
        get("weather/**", config)


def test_sample_line_parses_json_or_keeps_text():
    assert sample_line("a/b", b'{"x":1}') == {"key": "a/b", "payload": {"x": 1}}
    assert sample_line("a/b", b"not json \xff") == {"key": "a/b", "payload": "not json \ufffd"}


@pytest.mark.e2e
def test_watch_prints_json_lines_and_get_returns_latest(router):
    config = zenoh_config(mode="client", connect=[router.endpoint])
    out = io.StringIO()
    stop = threading.Event()
    result = {}
    watcher = threading.Thread(
        target=lambda: result.update(
            n=watch(
                "weather/e2e-watch/**",
                config,
                out=out,
                count=3,
                timeout_s=20,
                stop_event=stop,
                liveliness=True,
            )
        )
    )
    with client_publisher("e2e-watch", router.endpoint) as pub:
        watcher.start()
        try:
            n = 0
            while watcher.is_alive() and n < 150:
                n += 1
                pub.put("state", {"n": n})
                time.sleep(0.1)
        finally:
            stop.set()
            watcher.join(10)
        replies = get("weather/e2e-watch/**", config)
    assert not watcher.is_alive()
    lines = [json.loads(line) for line in out.getvalue().splitlines()]
    assert result["n"] == 0 and len(lines) == 3
    assert {"key": "weather/e2e-watch/alive", "alive": True} in lines
    states = [line for line in lines if line["key"] == "weather/e2e-watch/state"]
    assert states and all(isinstance(line["payload"]["n"], int) for line in states)
    assert replies == [{"key": "weather/e2e-watch/state", "payload": {"n": n}}]


@pytest.mark.e2e
def test_watch_stops_on_timeout_and_on_event(router):
    config = zenoh_config(mode="client", connect=[router.endpoint])
    out = io.StringIO()
    t0 = time.monotonic()
    assert watch("weather/nobody/**", config, out=out, timeout_s=0.3) == 0
    assert time.monotonic() - t0 >= 0.3  # it waited for the timeout, then stopped
    stop = threading.Event()
    stop.set()
    assert watch("weather/nobody/**", config, out=out, stop_event=stop) == 0
    assert out.getvalue() == ""
