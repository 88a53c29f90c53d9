"""The layout tells the architecture: no import circle, each layer imports only those below it,
and the README's layout section names every folder there is."""

from __future__ import annotations

import ast
import re
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest

from .conftest import REPO

PACKAGES = ("hos", "drivers", "daemon")


def _modules() -> dict[str, Path]:
    """Every module of the project's packages, by dotted name (a package by its ``__init__``)."""
    out = {}
    for top in PACKAGES:
        for path in sorted((REPO / top).rglob("*.py")):
            parts = list(path.relative_to(REPO).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            out[".".join(parts)] = path
    return out


def _imports(name: str, path: Path, modules: dict[str, Path]) -> Iterator[str]:
    """The project modules ``name`` imports anywhere in its file (lazy imports in functions
    count too: a circle through one is still a circle), with the packages whose ``__init__``
    an import runs."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*anchor, base] if base else anchor)
            targets = [
                f"{base}.{alias.name}" if f"{base}.{alias.name}" in modules else base
                for alias in node.names
            ]
        else:
            continue
        for target in targets:
            parts = target.split(".")
            for i in range(1, len(parts) + 1):  # importing a.b.c runs a and a.b first,
                prefix = ".".join(parts[:i])  # but a module's own packages are running already
                if prefix in modules and not f"{name}.".startswith(f"{prefix}."):
                    yield prefix


def _graph() -> dict[str, set[str]]:
    modules = _modules()
    return {name: set(_imports(name, path, modules)) for name, path in modules.items()}


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                out.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_the_checker_finds_a_planted_circle():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert _cycles(graph) == [["a", "b", "c"]]


def test_no_module_imports_itself_back():
    cycles = _cycles(_graph())
    assert cycles == [], f"import circles: {cycles}"


# Who may import whom: the detector is pure; drivers know the detector's results only through
# the simulator's tests, never the daemon; within daemon, each job only those listed before it.
LAYERS = {
    "hos": set(),
    "drivers": {"hos"},
    "daemon.config": {"hos", "drivers"},
    "daemon.transport": {"hos", "drivers", "daemon.config"},
    "daemon.recording": {"hos", "drivers", "daemon.config", "daemon.transport"},
    "daemon.web": {"hos", "drivers", "daemon.config", "daemon.transport", "daemon.recording"},
    "daemon.service": {
        "hos",
        "drivers",
        "daemon.config",
        "daemon.transport",
        "daemon.recording",
        "daemon.web",
    },
    "daemon.offline": {
        "hos",
        "drivers",
        "daemon.config",
        "daemon.transport",
        "daemon.recording",
        "daemon.web",
        "daemon.service",
    },
}


def _layer(module: str) -> str | None:
    return max(
        (k for k in LAYERS if module == k or module.startswith(k + ".")), key=len, default=None
    )


def test_each_layer_imports_only_the_layers_below_it():
    bad = []
    for module, targets in _graph().items():
        layer = _layer(module)
        if layer is None:  # daemon.cli and daemon's own __init__ may import anything
            continue
        for target in targets:
            other = _layer(target)
            if other not in (None, layer) and other not in LAYERS[layer]:
                bad.append(f"{module} -> {target}")
    assert bad == []


def test_hos_holds_the_detector_only():
    """No simulator, video or I/O module in ``hos/``: arrays in, results out."""
    names = {p.stem for p in (REPO / "hos").glob("*.py")}
    assert not names & {"render", "scene", "street", "precipitation", "demo", "video_writer"}


def _readme_layout() -> str:
    text = (REPO / "README.md").read_text()
    match = re.search(r"## Layout\n```\n(.*?)```", text, re.S)
    assert match, "README.md has no layout block"
    return match.group(1)


def _tracked_folders() -> list[str]:
    """The folders git tracks files in: every top-level one, and those one level into the
    packages and the tests (generated folders such as ``.venv`` or ``recordings`` are not)."""
    files = subprocess.run(
        ["git", "ls-files"], cwd=REPO, capture_output=True, text=True, check=True
    ).stdout.split()
    out = set()
    for f in files:
        parts = f.split("/")[:-1]
        if parts and not parts[0].startswith("."):
            out.add(parts[0])
            if parts[0] in (*PACKAGES, "tests") and len(parts) > 1:
                out.add("/".join(parts[:2]))
    return sorted(out)


@pytest.mark.parametrize("folder", _tracked_folders())
def test_readme_layout_names_every_folder(folder):
    layout = _readme_layout()
    name = folder.rsplit("/", 1)[-1]
    assert re.search(rf"(^|[\s/]){re.escape(name)}/", layout, re.M), f"{folder}/ is not in it"
