"""The install is reproducible: the locks pin every dependency, ``make install`` installed exactly
those versions, and the offline wheelhouse can be made for every target (x86-64 and aarch64)."""

from __future__ import annotations

import json
import re
import subprocess
import sys
import tomllib
from importlib import metadata

import pytest
from packaging.markers import Marker
from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

from .conftest import REPO

#: The interpreter the wheelhouse targets (Debian 12's python3), as markers see it.
TARGET = {"python_version": "3.11", "python_full_version": "3.11.2", "sys_platform": "linux"}


def _lock(name: str, env: dict[str, str] | None = None) -> dict[str, str]:
    """``name -> pinned version`` of a lock file, for the lines whose markers hold in ``env``."""
    out = {}
    for line in (REPO / name).read_text().splitlines():
        text = line.split("#", 1)[0].strip()
        if not text:
            continue
        spec, _, marker = text.partition(";")
        if marker.strip() and not Marker(marker.strip()).evaluate(env or TARGET):
            continue
        pkg, _, version = spec.strip().partition("==")
        assert version, f"{name}: {line!r} is not pinned with =="
        out[canonicalize_name(pkg)] = version
    return out


def _pyproject_requirements(*extras: str) -> list[Requirement]:
    project = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
    reqs = list(project["dependencies"])
    for extra in extras:
        reqs += project["optional-dependencies"][extra]
    return [Requirement(r) for r in reqs]


@pytest.mark.parametrize(
    ("lock", "extras"), [("requirements.lock", ()), ("requirements-dev.lock", ("test",))]
)
def test_the_lock_pins_every_dependency_within_its_range(lock, extras):
    pinned = _lock(lock)
    for req in _pyproject_requirements(*extras):
        name = canonicalize_name(req.name)
        assert name in pinned, f"{req.name} is not in {lock}: run make lock"
        assert req.specifier.contains(pinned[name], prereleases=True), (
            f"{lock} pins {req.name}=={pinned[name]}, outside pyproject.toml's {req.specifier}"
        )


def test_the_two_locks_agree():
    runtime, dev = _lock("requirements.lock"), _lock("requirements-dev.lock")
    assert {k: dev[k] for k in runtime} == runtime


def test_make_install_installed_the_locked_versions():
    here = {
        "python_version": f"{sys.version_info.major}.{sys.version_info.minor}",
        "python_full_version": ".".join(map(str, sys.version_info[:3])),
        "sys_platform": sys.platform,
    }
    wrong = {}
    for name, version in _lock("requirements-dev.lock", here).items():
        try:
            installed = metadata.version(name)
        except metadata.PackageNotFoundError:
            installed = None
        if installed != version:
            wrong[name] = (version, installed)
    assert wrong == {}, "locked != installed (locked, installed): " + json.dumps(wrong)


def _glibc_platforms(arch: str) -> list[str]:
    """What the Makefile's wheelhouse target accepts: manylinux up to glibc 2.35."""
    makefile = (REPO / "Makefile").read_text()
    first, last = map(
        int, re.search(r"WHEEL_GLIBC_MINORS := \$\(shell seq (\d+) (\d+)\)", makefile).groups()
    )
    out = []
    for minor in range(first, last + 1):
        out += ["--platform", f"manylinux_2_{minor}_{arch}"]
    return [*out, "--platform", f"manylinux2014_{arch}"]


@pytest.mark.parametrize("arch", ["x86_64", "aarch64"])
def test_every_runtime_dependency_has_a_wheel_for_the_target(arch, tmp_path):
    """What ``make wheelhouse`` downloads resolves completely for each target: pip, told the
    target's platform and interpreter and to take wheels only, finds one for every pin (a
    dry run: it reads the index, and downloads little)."""
    report = tmp_path / "report.json"
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "install",
            "--dry-run",
            "--quiet",
            "--disable-pip-version-check",
            "--ignore-installed",
            "--no-deps",
            "--only-binary=:all:",
            "--implementation",
            "cp",
            "--python-version",
            TARGET["python_version"],
            *_glibc_platforms(arch),
            "--target",
            str(tmp_path / "target"),
            "--report",
            str(report),
            "-r",
            str(REPO / "requirements.lock"),
        ],
        capture_output=True,
        text=True,
        timeout=240,
    )
    if proc.returncode != 0 and re.search(
        r"NewConnectionError|Temporary failure in name resolution|Network is unreachable",
        proc.stderr,
    ):
        pytest.skip(f"the package index is unreachable from here: {proc.stderr.strip()[-200:]}")
    assert proc.returncode == 0, proc.stderr[-2000:]
    wheels = {
        canonicalize_name(item["metadata"]["name"]): item["download_info"]["url"].rsplit("/", 1)[-1]
        for item in json.loads(report.read_text())["install"]
    }
    assert set(wheels) == set(_lock("requirements.lock"))
    for name, wheel in wheels.items():
        assert wheel.endswith(".whl"), f"{name}: {wheel}"
        assert wheel.endswith("-any.whl") or arch in wheel, f"{name}: {wheel} is not for {arch}"
