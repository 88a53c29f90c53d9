"""Who may open the status page: nobody needs to on the loopback default; on any other address,
whoever knows the password (HTTP Basic, any user name) or the token (``Authorization: Bearer``).

The secrets come from a file (``[web] password_file``) or the environment (``[web] token_env``),
never from the TOML in clear. Comparisons take constant time.
"""

from __future__ import annotations

import base64
import binascii
import hmac
import logging
import os
import stat
from dataclasses import dataclass

from daemon.config import WebConfig, is_loopback, split_listen
from drivers.errors import ConfigError

__all__ = ["Secrets", "load_secrets"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Secrets:
    """The password and token a request may carry; none: the page is open."""

    password: str | None = None
    token: str | None = None

    @property
    def required(self) -> bool:
        return self.password is not None or self.token is not None

    def allows(self, authorization: str | None) -> bool:
        """True if the ``Authorization`` header carries the password or the token (always,
        when neither is set)."""
        if not self.required:
            return True
        if not authorization:
            return False
        scheme, _, value = authorization.strip().partition(" ")
        value = value.strip()
        scheme = scheme.lower()
        if scheme == "bearer":
            return self.token is not None and _same(value, self.token)
        if scheme == "basic":
            try:
                decoded = base64.b64decode(value, validate=True).decode("utf-8")
            except (binascii.Error, UnicodeDecodeError):
                return False
            _, sep, password = decoded.partition(":")
            if not sep:
                return False
            return any(s is not None and _same(password, s) for s in (self.password, self.token))
        return False


def _same(a: str, b: str) -> bool:
    return hmac.compare_digest(a.encode("utf-8"), b.encode("utf-8"))


def load_secrets(config: WebConfig, *, environ: dict[str, str] | None = None) -> Secrets:
    """The secrets of ``[web]``; checks that a bind beyond this machine has one.

    Raises
    ------
    ConfigError : an unreadable or empty password file, or a non-loopback ``listen`` with
        neither a password nor a token.
    """
    env = os.environ if environ is None else environ
    password = None
    if config.password_file is not None:
        path = config.password_file
        try:
            with open(path, encoding="utf-8") as f:
                password = f.readline().rstrip("\r\n")
            mode = os.stat(path).st_mode
        except (OSError, UnicodeDecodeError) as exc:
            raise ConfigError(f"web.password_file: cannot read {path} ({exc})") from None
        if not password:
            raise ConfigError(f"web.password_file: {path}: the first line (the password) is empty")
        if mode & (stat.S_IRWXG | stat.S_IRWXO):
            log.warning(
                "web.password_file %s can be read by other users: chmod 600 it",
                config.password_file,
            )
    token = env.get(config.token_env) or None
    host, _ = split_listen(config.listen)
    if not is_loopback(host) and password is None and token is None:
        raise ConfigError(
            f"web.listen: {config.listen} can be reached from other machines: set "
            f"web.password_file, or a token in the environment variable {config.token_env}"
        )
    return Secrets(password=password, token=token)
