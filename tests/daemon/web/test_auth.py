"""Who may open the page: loopback without a secret; elsewhere the password or the token."""

from __future__ import annotations

import base64
from pathlib import Path

import pytest

from daemon.config import WebConfig, parse_config
from daemon.web.auth import Secrets, load_secrets
from drivers.errors import ConfigError


def _basic(user: str, password: str) -> str:
    return "Basic " + base64.b64encode(f"{user}:{password}".encode()).decode()


def test_no_secret_lets_everyone_in() -> None:
    assert Secrets().allows(None)
    assert Secrets().allows("Basic garbage")


@pytest.mark.parametrize(
    ("header", "ok"),
    [
        (None, False),
        ("", False),
        (_basic("anyone", "s3cret"), True),
        (_basic("", "s3cret"), True),
        (_basic("tech", "s3cret!"), False),
        (_basic("tech", "tok"), True),  # the token also works as a password
        ("Bearer tok", True),
        ("bearer tok", True),
        ("Bearer s3cret", False),  # the password is not a token
        ("Bearer ", False),
        ("Basic !!!not-base64", False),
        ("Basic " + base64.b64encode(b"no-colon").decode(), False),
        ("Digest x", False),
    ],
)
def test_password_or_token(header: str | None, ok: bool) -> None:
    assert Secrets(password="s3cret", token="tok").allows(header) is ok


def test_a_remote_bind_needs_a_secret(tmp_path: Path) -> None:
    web = WebConfig(listen="0.0.0.0:8750")
    with pytest.raises(ConfigError, match=r"web\.listen: 0\.0\.0\.0:8750 can be reached"):
        load_secrets(web, environ={})
    assert load_secrets(web, environ={"WEATHERD_WEB_TOKEN": "t"}).token == "t"
    pw = tmp_path / "pw"
    pw.write_text("hunter2\nignored\n")
    pw.chmod(0o600)
    secrets = load_secrets(WebConfig(listen="[::]:8750", password_file=str(pw)), environ={})
    assert secrets.password == "hunter2" and secrets.token is None


@pytest.mark.parametrize("listen", ["127.0.0.1:8750", "[::1]:0", "localhost:80", "127.8.9.1:1"])
def test_loopback_needs_no_secret(listen: str) -> None:
    assert not load_secrets(WebConfig(listen=listen), environ={}).required


def test_empty_password_file_is_refused(tmp_path: Path) -> None:
    pw = tmp_path / "pw"
    pw.write_text("\n")
    with pytest.raises(ConfigError, match=r"the first line .* is empty"):
        load_secrets(WebConfig(password_file=str(pw)), environ={})


@pytest.mark.parametrize(
    ("web", "message"),
    [
        ({"listen": "8750"}, "expected HOST:PORT"),
        ({"listen": "127.0.0.1:70000"}, "port must be"),
        ({"tls_cert": "/etc/hostname"}, "tls_cert and tls_key go together"),
        ({"password_file": "/nonexistent/pw"}, "no such readable file"),
        ({"token_env": "NOT A NAME"}, "environment variable's name"),
        ({"password": "x"}, "password"),  # a secret in the TOML in clear is not a key
    ],
)
def test_web_config_errors_name_the_key(web: dict, message: str) -> None:
    with pytest.raises(ConfigError, match=message) as err:
        parse_config({"web": web})
    assert str(err.value).startswith("web")
