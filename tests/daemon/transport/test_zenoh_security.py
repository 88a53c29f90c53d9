"""Nobody else speaks for the site: the hardened Zenoh configuration, end to end.

The real ``weatherd run`` listens with ``config/zenoh-secure.json5`` (user/password
authentication and access control). Real client processes then try what a rogue on the
roadside network would: connect without credentials; with a reader's credentials, publish a
forged state, declare a queryable on the state and a liveliness token under the site. None of
it may reach a subscriber or a ``get``; the daemon's own state must. The same clients against
the daemon's default (open) configuration show that the attack is real: there, the forgery
reaches the subscriber.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.conftest import REPO
from tests.zenoh_tools import free_port, port_open

pytestmark = pytest.mark.e2e

SITE = "secure-site"

CLIENTS = r"""
import json, sys, time, zenoh

endpoint, with_credentials = sys.argv[1], sys.argv[2] == "1"

def conf(user=None):
    c = zenoh.Config()
    c.insert_json5("mode", '"client"')
    c.insert_json5("scouting/multicast/enabled", "false")
    c.insert_json5("connect/endpoints", json.dumps([endpoint]))
    if user and with_credentials:
        c.insert_json5("transport/auth/usrpwd/user", json.dumps(user))
        c.insert_json5("transport/auth/usrpwd/password", json.dumps(user + "-pw"))
    return c

out = {"samples": [], "liveliness": []}
reader = zenoh.open(conf("reader"))
sub = reader.declare_subscriber(
    "weather/**", lambda s: out["samples"].append([str(s.key_expr), s.payload.to_string()])
)
live = reader.liveliness().declare_subscriber(
    "weather/**", lambda s: out["liveliness"].append(str(s.key_expr)), history=True
)
try:
    anonymous = zenoh.open(conf())
    out["anonymous"] = "connected"
    anonymous.put("weather/SITE/state", json.dumps({"rain_rate_mm_h": 998}))
except zenoh.ZError as exc:
    anonymous = None
    out["anonymous"] = "refused: " + str(exc)
rogue = zenoh.open(conf("rogue"))
forged = json.dumps({"schema": "weather.state/1", "rain_rate_mm_h": 999})
queryable = rogue.declare_queryable(
    "weather/SITE/state", lambda q: q.reply("weather/SITE/state", forged)
)
token = rogue.liveliness().declare_token("weather/SITE/alive")
other_token = rogue.liveliness().declare_token("weather/SITE/rogue")
for _ in range(6):
    rogue.put("weather/SITE/state", forged)
    time.sleep(0.5)
third = zenoh.open(conf("reader"))
# Every reply, not the consolidated latest per key: the daemon's and a rogue's replies for
# one key otherwise race on their timestamps.
replies = third.get("weather/SITE/**", consolidation=zenoh.ConsolidationMode.NONE)
out["get"] = [r.ok.payload.to_string() for r in replies if r.ok]
out["admin"] = [str(r.ok.key_expr) for r in third.get("@/**") if r.ok]
out["own_zids"] = [str(third.info.zid()), str(reader.info.zid()), str(rogue.info.zid())]
for s in (third, rogue, anonymous, reader):
    if s is not None:
        s.close()
print(json.dumps(out))
""".replace("SITE", SITE)


def _run_daemon(
    tmp_path: Path, port: int, zenoh_file: Path | None, *, scheme: str = "tcp"
) -> subprocess.Popen:
    config = tmp_path / "weatherd.toml"
    host = "localhost" if scheme == "tls" else "127.0.0.1"  # a TLS name the certificate holds
    config.write_text(
        f'[site]\nid = "{SITE}"\nstate_dir = "{tmp_path / "state"}"\n'
        f'[zenoh]\nlisten = ["{scheme}/{host}:{port}"]\n'
        + (f'config_file = "{zenoh_file}"\n' if zenoh_file else "")
        + "[recording]\nenabled = false\n[publish]\nstate_interval_s = 0.5\n"
    )
    proc = subprocess.Popen(
        [sys.executable, "-m", "daemon.cli", "run", "--config", str(config)],
        cwd=REPO,
        env={**os.environ, "PYTHONPATH": str(REPO), "HOS_JIT": "0"},
        stdout=subprocess.DEVNULL,
        stderr=open(tmp_path / "run.log", "w"),
    )
    deadline = time.monotonic() + 20
    while not port_open(port):
        assert proc.poll() is None, (tmp_path / "run.log").read_text()
        assert time.monotonic() < deadline, "the daemon does not listen"
        time.sleep(0.1)
    time.sleep(1.0)  # a first state published
    return proc


def _attack(port: int, *, credentials: bool) -> dict:
    done = subprocess.run(
        [sys.executable, "-c", CLIENTS, f"tcp/127.0.0.1:{port}", "1" if credentials else "0"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def _stop(proc: subprocess.Popen, tmp_path: Path) -> None:
    proc.send_signal(signal.SIGTERM)
    assert proc.wait(timeout=30) == 0, (tmp_path / "run.log").read_text()[-2000:]


def _hardened_file(tmp_path: Path) -> Path:
    users = tmp_path / "zenoh-users.txt"
    users.write_text("reader:reader-pw\nrogue:rogue-pw\n")
    text = (REPO / "config" / "zenoh-secure.json5").read_text()
    text = re.sub(r'dictionary_file: "[^"]*"', f'dictionary_file: "{users}"', text)
    path = tmp_path / "zenoh-secure.json5"
    path.write_text(text)
    return path


def test_only_the_daemon_speaks_for_the_site(tmp_path):
    port = free_port()
    proc = _run_daemon(tmp_path, port, _hardened_file(tmp_path))
    try:
        out = _attack(port, credentials=True)
    finally:
        _stop(proc, tmp_path)
    assert out["anonymous"].startswith("refused"), out["anonymous"]
    states = [json.loads(p) for k, p in out["samples"] if k == f"weather/{SITE}/state"]
    assert states, "the reader received no state from the daemon"
    assert all(s.get("rain_rate_mm_h") not in (998, 999) for s in states)
    assert {s["site"] for s in states} == {SITE}  # the daemon's own messages
    assert set(out["liveliness"]) == {f"weather/{SITE}/alive"}  # the daemon's token only
    got = [json.loads(p) for p in out["get"]]
    assert got and all(g.get("rain_rate_mm_h") != 999 for g in got)
    assert any(g.get("schema") == "weather.state/1" and g.get("site") == SITE for g in got)
    # the admin space answers only for the querier's own session, never for the daemon's
    assert all(k.split("/")[1] in out["own_zids"] for k in out["admin"])


def test_without_the_hardened_file_the_attack_works(tmp_path):
    """The control: the same clients against the default configuration forge the state."""
    port = free_port()
    proc = _run_daemon(tmp_path, port, None)
    try:
        out = _attack(port, credentials=False)
    finally:
        _stop(proc, tmp_path)
    assert out["anonymous"] == "connected"
    forged = [p for k, p in out["samples"] if '"rain_rate_mm_h": 999' in p]
    assert forged, "the forged state did not reach the subscriber: the control shows nothing"
    assert any("999" in p for p in out["get"])


TLS_CLIENTS = r"""
import json, sys, zenoh, time

endpoint, certs = sys.argv[1], sys.argv[2]

def conf(cert):
    c = zenoh.Config()
    c.insert_json5("mode", '"client"')
    c.insert_json5("scouting/multicast/enabled", "false")
    c.insert_json5("connect/endpoints", json.dumps([endpoint]))
    c.insert_json5("transport/auth/usrpwd/user", '"reader"')
    c.insert_json5("transport/auth/usrpwd/password", '"reader-pw"')
    tls = {"root_ca_certificate": certs + "/ca.pem"}
    if cert:
        tls["enable_mtls"] = True  # present the certificate below
        tls["connect_certificate"] = f"{certs}/{cert}.pem"
        tls["connect_private_key"] = f"{certs}/{cert}.key"
    c.insert_json5("transport/link/tls", json.dumps(tls))
    return c

out = {}
reader = zenoh.open(conf("reader"))
got = []
sub = reader.declare_subscriber("weather/**", lambda s: got.append(str(s.key_expr)))
time.sleep(2.0)
out["reader"] = got
try:
    zenoh.open(conf(None)).close()
    out["without_certificate"] = "connected"
except zenoh.ZError as exc:
    out["without_certificate"] = "refused: " + str(exc)
reader.close()
print(json.dumps(out))
"""


def _certificates(folder: Path) -> None:
    """A throwaway CA, and certificates for the daemon (localhost) and a reader."""
    folder.mkdir()
    key = ["-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:P-256", "-nodes"]

    def openssl(*args: str) -> None:
        subprocess.run(["openssl", *args], cwd=folder, check=True, capture_output=True)

    openssl("req", "-x509", *key, "-keyout", "ca.key", "-out", "ca.pem", "-days", "2",
            "-subj", "/CN=weatherd test CA")  # fmt: skip
    for name in ("daemon", "reader"):
        openssl("req", *key, "-keyout", f"{name}.key", "-out", f"{name}.csr",
                "-subj", f"/CN={name}")  # fmt: skip
        (folder / f"{name}.ext").write_text("subjectAltName=DNS:localhost,IP:127.0.0.1\n")
        openssl("x509", "-req", "-in", f"{name}.csr", "-CA", "ca.pem", "-CAkey", "ca.key",
                "-CAcreateserial", "-out", f"{name}.pem", "-days", "2",
                "-extfile", f"{name}.ext")  # fmt: skip


def _with_tls(path: Path, certs: Path) -> None:
    """The shipped file with its commented TLS block switched on, pointing at ``certs``."""
    out, inside = [], False
    for line in path.read_text().splitlines():
        if line == "    // link: {":
            inside = True
        if inside:
            line = line.replace("// ", "", 1)
            inside = line != "    },"  # the block's own closing line
        out.append(line)
    text = "\n".join(out).replace("/etc/weatherd/tls", str(certs))
    path.write_text(
        text.replace("weatherd.pem", "daemon.pem").replace("weatherd.key", "daemon.key")
    )


@pytest.mark.skipif(shutil.which("openssl") is None, reason="openssl makes the test certificates")
def test_mutual_tls_refuses_a_client_without_a_certificate(tmp_path):
    certs = tmp_path / "tls"
    _certificates(certs)
    secure = _hardened_file(tmp_path)
    _with_tls(secure, certs)
    port = free_port()
    proc = _run_daemon(tmp_path, port, secure, scheme="tls")
    try:
        done = subprocess.run(
            [sys.executable, "-c", TLS_CLIENTS, f"tls/localhost:{port}", str(certs)],
            capture_output=True,
            text=True,
            timeout=60,
        )
    finally:
        _stop(proc, tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    out = json.loads(done.stdout.strip().splitlines()[-1])
    assert f"weather/{SITE}/state" in out["reader"]  # a reader with a certificate reads
    assert out["without_certificate"].startswith("refused"), out
