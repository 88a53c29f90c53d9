"""The clock's synchronisation, as the status reports it."""

from __future__ import annotations

import pytest

from daemon.service import clock
from daemon.service.clock import ClockStatus, clock_status


def test_adjtimex_answers_on_linux():
    """Read-only adjtimex needs no privilege: the kernel's own view, with its error bound."""
    status = clock_status()
    assert status.source == "adjtimex"
    assert isinstance(status.synchronized, bool)
    assert 0 <= status.max_error_s <= 16.0  # the kernel caps maxerror at 16 s (NTP_PHASE_LIMIT)


@pytest.mark.parametrize(
    ("flag", "folder", "expected"),
    [(True, True, ClockStatus(True, "timesyncd")), (False, True, ClockStatus(False, "timesyncd"))],
)
def test_timesyncd_flag_when_adjtimex_is_filtered(tmp_path, monkeypatch, flag, folder, expected):
    """Under ProtectClock=yes adjtimex fails with EPERM: timesyncd's flag file tells instead."""
    monkeypatch.setattr(clock, "_adjtimex", lambda: None)
    path = tmp_path / "timesync" / "synchronized"
    path.parent.mkdir()
    if flag:
        path.touch()
    assert clock_status(timesyncd_flag=path) == expected


def test_unknown_when_nothing_can_tell(tmp_path, monkeypatch):
    monkeypatch.setenv("WEATHERD_CLOCK_ADJTIMEX", "0")
    status = clock_status(timesyncd_flag=tmp_path / "absent" / "synchronized")
    assert status == ClockStatus(None, None)
    assert status.to_json() == {"synchronized": None, "source": None, "max_error_s": None}
