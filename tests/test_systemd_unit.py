"""systemd/weatherd.service: the settings the daemon relies on, ``systemd-analyze verify`` and the
exposure figure of ``systemd-analyze security``."""

from __future__ import annotations

import errno
import os
import platform
import re
import shutil
import struct
import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import REPO

UNIT = REPO / "systemd" / "weatherd.service"
SYSUSERS = REPO / "systemd" / "weatherd.sysusers"
UDEV_RULES = REPO / "systemd" / "99-weatherd-camera.rules"
EXEC_START = "/opt/weatherd/bin/weatherd run --config /etc/weatherd/weatherd.toml"
#: ``systemd-analyze security`` figure reached by the unit on systemd 252 (lower is better); what
#: is left is the network, the devices, the supplementary groups and a group-readable UMask.
MAX_EXPOSURE = 1.3


def parse_unit(text: str) -> dict[str, dict[str, list[str]]]:
    """A unit file as {section: {key: [values in order]}}; keys may repeat, as in systemd."""
    sections: dict[str, dict[str, list[str]]] = {}
    current: dict[str, list[str]] | None = None
    logical = ""
    for raw in text.splitlines():
        line = logical + raw.strip()
        if line.endswith("\\"):  # continuation
            logical = line[:-1].rstrip() + " "
            continue
        logical = ""
        if not line or line[0] in "#;":
            continue
        if line.startswith("[") and line.endswith("]"):
            current = sections.setdefault(line[1:-1], {})
            continue
        assert current is not None, f"assignment outside a section: {line!r}"
        key, sep, value = line.partition("=")
        assert sep, f"not an assignment: {line!r}"
        current.setdefault(key.strip(), []).append(value.strip())
    return sections


@pytest.fixture(scope="module")
def unit() -> dict[str, dict[str, list[str]]]:
    return parse_unit(UNIT.read_text(encoding="utf-8"))


def _one(unit, section: str, key: str) -> str:
    values = unit[section].get(key)
    assert values, f"[{section}] {key}= is missing"
    return values[-1]


def _words(unit, section: str, key: str) -> list[str]:
    return " ".join(unit[section].get(key, [])).split()


def test_parse_unit_keeps_repeated_keys_and_continuations():
    text = "[Service]\n# comment\nA=1\nA=2\nB=x \\\n  y\n"
    assert parse_unit(text) == {"Service": {"A": ["1", "2"], "B": ["x y"]}}


def test_started_as_the_lead_decided(unit):
    assert _one(unit, "Service", "ExecStart") == EXEC_START
    assert _one(unit, "Install", "WantedBy") == "multi-user.target"
    assert "network-online.target" in _words(unit, "Unit", "After")
    assert "network-online.target" in _words(unit, "Unit", "Wants")


def test_notify_and_watchdog(unit):
    assert _one(unit, "Service", "Type") == "notify"
    assert _one(unit, "Service", "NotifyAccess") == "main"
    watchdog = re.fullmatch(r"(\d+)s", _one(unit, "Service", "WatchdogSec"))
    assert watchdog and 10 <= int(watchdog[1]) <= 120


def test_restart_on_crash_but_not_on_a_config_error(unit):
    assert _one(unit, "Service", "Restart") == "on-failure"
    assert "2" in _words(unit, "Service", "RestartPreventExitStatus")
    assert _one(unit, "Service", "RestartSec")
    # The rate limit belongs to [Unit]: in [Service] systemd ignores it with a warning.
    assert int(_one(unit, "Unit", "StartLimitBurst")) >= 1
    assert _one(unit, "Unit", "StartLimitIntervalSec")
    assert "StartLimitIntervalSec" not in unit["Service"]


def test_dedicated_user_with_video_and_dialout_only(unit):
    assert _one(unit, "Service", "User") == "weatherd"
    assert _one(unit, "Service", "Group") == "weatherd"
    assert sorted(_words(unit, "Service", "SupplementaryGroups")) == ["dialout", "video"]
    assert _one(unit, "Service", "NoNewPrivileges") == "yes"
    assert unit["Service"]["CapabilityBoundingSet"] == [""]
    assert "DynamicUser" not in unit["Service"]


def test_read_only_system_and_state_directory(unit):
    assert _one(unit, "Service", "ProtectSystem") == "strict"
    assert _one(unit, "Service", "StateDirectory") == "weatherd"  # one entry: $STATE_DIRECTORY
    assert _one(unit, "Service", "ProtectHome") == "yes"
    assert _one(unit, "Service", "PrivateTmp") == "yes"
    for key in ("ReadWritePaths", "ReadWriteDirectories", "LogsDirectory", "CacheDirectory"):
        assert key not in unit["Service"], f"{key}= would allow writes outside the state dir"


def test_devices_are_cameras_and_serial_ports_only(unit):
    assert _one(unit, "Service", "DevicePolicy") == "closed"
    allowed = {tuple(v.split()) for v in unit["Service"]["DeviceAllow"]}
    assert allowed == {
        ("char-video4linux", "rw"),
        ("char-ttyS", "rw"),
        ("char-ttyUSB", "rw"),
        ("char-ttyACM", "rw"),
    }


def test_network_families_zenoh_needs(unit):
    families = set(_words(unit, "Service", "RestrictAddressFamilies"))
    assert {"AF_INET", "AF_INET6", "AF_UNIX"} <= families
    assert "AF_PACKET" not in families
    assert unit["Service"].get("PrivateNetwork", ["no"])[-1] == "no"


def test_sysusers_declares_the_system_user():
    entries = [
        line.split()
        for line in SYSUSERS.read_text(encoding="utf-8").splitlines()
        if line.strip() and not line.startswith("#")
    ]
    assert entries and entries[0][:3] == ["u", "weatherd", "-"]


def test_udev_example_tags_video_and_serial_devices():
    rules = [
        line
        for line in UDEV_RULES.read_text(encoding="utf-8").splitlines()
        if line.strip() and not line.startswith("#")
    ]
    assert any('SUBSYSTEM=="video4linux"' in r and "SYMLINK+=" in r for r in rules)
    assert any('SUBSYSTEM=="tty"' in r and "SYMLINK+=" in r for r in rules)
    for rule in rules:  # every assignment is KEY op "value", comma-separated
        assert re.fullmatch(r'(\s*[A-Z_]+(\{[^}]+\})?\s*(==|!=|\+=|-=|:=|=)\s*"[^"]*"\s*,?)+', rule)


# -- systemd-analyze -------------------------------------------------------------------------
def _systemd_analyze() -> str:
    tool = shutil.which("systemd-analyze")
    if tool is None:
        pytest.skip("systemd-analyze is not installed")
    return tool


def _unit_copy(tmp_path: Path, *, text: str | None = None) -> Path:
    """The unit in tmp_path, its ExecStart on an executable that exists here (verify checks it)."""
    text = UNIT.read_text(encoding="utf-8") if text is None else text
    copy = tmp_path / "weatherd.service"
    copy.write_text(text.replace("/opt/weatherd/bin/weatherd", sys.executable), encoding="utf-8")
    return copy


def _verify_complaints(tool: str, unit_path: Path) -> list[str]:
    """What ``systemd-analyze verify`` says about our unit (messages about other units dropped;
    it exits 0 even on unknown keys or bad values, so its output is what counts)."""
    proc = subprocess.run(
        [tool, "verify", "--man=no", str(unit_path)],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    lines = (proc.stdout + proc.stderr).splitlines()
    ours = [ln for ln in lines if str(unit_path) in ln or "weatherd.service" in ln]
    return ours + ([f"exit status {proc.returncode}"] if proc.returncode else [])


@pytest.mark.e2e
def test_systemd_analyze_verify_is_clean(tmp_path):
    tool = _systemd_analyze()
    assert _verify_complaints(tool, _unit_copy(tmp_path)) == []


@pytest.mark.e2e
def test_systemd_analyze_verify_would_catch_a_mistake(tmp_path):
    tool = _systemd_analyze()
    broken = UNIT.read_text(encoding="utf-8").replace("WatchdogSec=", "WatchdogSecs=")
    complaints = _verify_complaints(tool, _unit_copy(tmp_path, text=broken))
    assert any("WatchdogSecs" in c for c in complaints)


@pytest.mark.e2e
def test_systemd_analyze_security_exposure(tmp_path):
    tool = _systemd_analyze()
    proc = subprocess.run(
        [tool, "security", "--offline=true", "--no-pager", str(_unit_copy(tmp_path))],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    if proc.returncode != 0 and "offline" in proc.stderr:
        pytest.skip("systemd-analyze security --offline needs systemd >= 250")
    found = re.search(r"Overall exposure level for weatherd\.service: (\d+(?:\.\d+)?)", proc.stdout)
    assert found, proc.stdout + proc.stderr
    assert float(found[1]) <= MAX_EXPOSURE, proc.stdout


@pytest.mark.e2e
def test_sysusers_file_creates_the_user(tmp_path):
    tool = shutil.which("systemd-sysusers")
    if tool is None:
        pytest.skip("systemd-sysusers is not installed")
    (tmp_path / "etc").mkdir()
    proc = subprocess.run(
        [tool, f"--root={tmp_path}", "--dry-run", str(SYSUSERS)],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    assert "Creating user 'weatherd'" in proc.stdout + proc.stderr


# -- MemoryDenyWriteExecute= and SystemCallFilter=~@resources on the real stack -------------
#: What the service does, in miniature: every native library loaded and exercised.
_STACK = """
import ctypes, itertools, mmap
try:  # the filter is on: writable+executable memory is refused
    mmap.mmap(-1, 4096, prot=mmap.PROT_READ | mmap.PROT_WRITE | mmap.PROT_EXEC)
    raise SystemExit("MemoryDenyWriteExecute filter not active")
except PermissionError:
    pass
import numpy as np, cv2, av, mcap, zenoh
from hos.pipeline import HosDetector
from drivers.simulator import demo_frames
a = np.random.default_rng(0).random((300, 300))
assert (a @ a).shape == (300, 300)
det = HosDetector()
for i, (gray, _) in enumerate(itertools.islice(demo_frames(320, 180, 25, seed=0), 30)):
    det.process(gray, i / 25)
from hos import _jit  # numba's compiled kernels need W+X memory: the numpy path runs instead
assert not det.compiled and "executable memory" in _jit.why_disabled(), _jit.why_disabled()
values = (ctypes.c_int * 3)(3, 1, 2)  # a ctypes callback: libffi closure memory
cmp = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.POINTER(ctypes.c_int), ctypes.POINTER(ctypes.c_int))
ctypes.CDLL(None).qsort(values, 3, 4, cmp(lambda x, y: x[0] - y[0]))
assert list(values) == [1, 2, 3]
conf = zenoh.Config()
conf.insert_json5("listen/endpoints", '["tcp/127.0.0.1:0"]')
conf.insert_json5("scouting/multicast/enabled", "false")
session = zenoh.open(conf)
try:
    got = []
    sub = session.declare_subscriber("weather/**", lambda s: got.append(s.payload.to_string()))
    session.put("weather/test/state", "{}")
finally:
    session.close()
print("stack ok")
"""

#: x86-64 syscall numbers and seccomp constants.
_MMAP, _MPROTECT, _SHMAT, _MBIND, _PKEY_MPROTECT = 9, 10, 30, 237, 329
_PROT_WRITE, _PROT_EXEC, _SHM_EXEC = 2, 4, 0o100000
_AUDIT_ARCH_X86_64 = 0xC000003E


def _bpf_systemd_252_filter() -> bytes:
    """The seccomp rules systemd 252 installs for MemoryDenyWriteExecute=yes (mmap W+X, mprotect
    or pkey_mprotect +X, shmat SHM_EXEC), plus mbind() (the one syscall of ~@resources the stack
    makes), all refused with EPERM as SystemCallErrorNumber= says."""
    ld, jeq, band, ret = 0x20, 0x15, 0x54, 0x06
    allow, eperm = 0x7FFF0000, 0x00050000 | errno.EPERM

    def op(code: int, k: int, jt: int = 0, jf: int = 0) -> bytes:
        return struct.pack("HBBI", code, jt, jf, k)

    arg2 = 16 + 2 * 8  # seccomp_data.args[2], its low 32 bits (little endian)
    return b"".join(
        [
            op(ld, 4),  # 0: seccomp_data.arch
            op(jeq, _AUDIT_ARCH_X86_64, 1, 0),
            op(ret, allow),
            op(ld, 0),  # 3: seccomp_data.nr
            op(jeq, _MMAP, 5, 0),  # -> 10
            op(jeq, _MPROTECT, 8, 0),  # -> 14
            op(jeq, _PKEY_MPROTECT, 7, 0),  # -> 14
            op(jeq, _SHMAT, 10, 0),  # -> 18
            op(jeq, _MBIND, 13, 0),  # -> 22
            op(ret, allow),  # 9
            op(ld, arg2),  # 10: mmap prot
            op(band, _PROT_WRITE | _PROT_EXEC),
            op(jeq, _PROT_WRITE | _PROT_EXEC, 9, 0),  # -> 22
            op(ret, allow),
            op(ld, arg2),  # 14: mprotect prot
            op(band, _PROT_EXEC),
            op(jeq, _PROT_EXEC, 5, 0),  # -> 22
            op(ret, allow),
            op(ld, arg2),  # 18: shmat shmflg
            op(band, _SHM_EXEC),
            op(jeq, _SHM_EXEC, 1, 0),  # -> 22
            op(ret, allow),
            op(ret, eperm),  # 22
        ]
    )


#: Installs the filter given in hex, then executes Python on the code given, as systemd does.
_UNDER_FILTER = """
import ctypes, os, sys
prog = bytes.fromhex(sys.argv[1])
class Fprog(ctypes.Structure):
    _fields_ = [("len", ctypes.c_ushort), ("filter", ctypes.c_char_p)]
libc = ctypes.CDLL(None, use_errno=True)
PR_SET_NO_NEW_PRIVS, PR_SET_SECCOMP, SECCOMP_MODE_FILTER = 38, 22, 2
if libc.prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) or libc.prctl(
    PR_SET_SECCOMP, SECCOMP_MODE_FILTER, ctypes.byref(Fprog(len(prog) // 8, prog)), 0, 0
):
    sys.exit("seccomp unavailable: errno %d" % ctypes.get_errno())
os.execv(sys.executable, [sys.executable, "-c", sys.argv[2]])
"""


@pytest.mark.e2e
@pytest.mark.skipif(
    not sys.platform.startswith("linux") or platform.machine() != "x86_64",
    reason="the seccomp program is written for Linux on x86-64",
)
def test_the_stack_runs_under_memory_deny_write_execute():
    proc = subprocess.run(
        [sys.executable, "-c", _UNDER_FILTER, _bpf_systemd_252_filter().hex(), _STACK],
        cwd=REPO,
        env={**os.environ, "PYTHONPATH": str(REPO), "PYTHONDONTWRITEBYTECODE": "1"},
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    if "seccomp unavailable" in proc.stderr:
        pytest.skip(proc.stderr.strip())
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert proc.stdout.strip() == "stack ok"
