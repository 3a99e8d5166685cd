"""The package's shape: imports only go down the layers of the data flow (lazy imports included), no import cycles,
no module above 500 lines. See docs/DESIGN.md."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "durer"

# scene description -> compile and accelerators -> integrators and film -> query API and command line; kernels are
# the bottom (Numba only), errors and options are plain definitions every layer may use
LAYERS = {
    "errors": 0, "options": 0,
    "kernels": 1,
    "scene": 2,
    "io": 3,
    "accel": 4,
    "rendering": 5,
    "query": 6, "query_args": 6, "query_normals": 6, "pinhole": 6, "trimesh": 7,
    "cli": 7, "cli_args": 7, "cli_explain": 7, "cli_frames": 7, "preview": 7, "dask": 7, "warmup": 7, "__init__": 7,
    "__main__": 8,
}
MAX_LINES = 500


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(SRC.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _imports(path: Path, module: str | None = None) -> list[tuple[int, str]]:
    """(line, absolute module) of every durer import in the file, at any depth (functions included)."""
    module = module or _module_name(path)
    package = module.split(".") if path.name == "__init__.py" else module.split(".")[:-1]
    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if not target.startswith("durer"):
                continue
            for alias in node.names:  # `from . import x` may name a module
                sub = f"{target}.{alias.name}"
                found.append((node.lineno, sub if (SRC.parent / (sub.replace(".", "/") + ".py")).exists()
                              or (SRC.parent / sub.replace(".", "/")).is_dir() else target))
        elif isinstance(node, ast.Import):
            found += [(node.lineno, a.name) for a in node.names if a.name.startswith("durer")]
    return found


def _layer(module: str) -> int:
    parts = module.split(".")
    key = parts[1] if len(parts) > 1 else "__init__"
    if key not in LAYERS:
        raise AssertionError(f"{module}: not in any layer of tests/test_project_architecture.py LAYERS")
    return LAYERS[key]


FILES = sorted(SRC.rglob("*.py"))


def test_the_layers_cover_every_module():
    for path in FILES:
        _layer(_module_name(path) if path.name != "__init__.py" or path.parent != SRC else "durer")


@pytest.mark.parametrize("path", FILES, ids=lambda p: str(p.relative_to(SRC)))
def test_imports_go_down_the_layers(path):
    me = _module_name(path)
    mine = _layer(me if path.parent != SRC or path.name != "__init__.py" else "durer")
    upward = [f"{path.name}:{line} imports {target} (layer {_layer(target)} > {mine})"
              for line, target in _imports(path) if _layer(target) > mine]
    assert not upward, "\n".join(upward)


def test_no_import_cycles():
    graph = {_module_name(p): {t for _, t in _imports(p)} for p in FILES}
    # a module importing its own package's __init__ is not a cycle of concepts; drop package self-edges
    for mod, targets in graph.items():
        targets.discard(mod)
        targets.difference_update({t for t in targets if mod.startswith(t + ".") and t != "durer"})
    state: dict[str, int] = {}

    def visit(mod: str, trail: list[str]) -> None:
        state[mod] = 1
        for t in sorted(graph.get(mod, ())):
            if t == "durer" or t not in graph:
                continue
            if state.get(t) == 1:
                raise AssertionError("import cycle: " + " -> ".join(trail[trail.index(t):] + [t]))
            if not state.get(t):
                visit(t, trail + [t])
        state[mod] = 2

    for mod in graph:
        if not state.get(mod):
            visit(mod, [mod])


@pytest.mark.parametrize("path", FILES, ids=lambda p: str(p.relative_to(SRC)))
def test_no_module_above_500_lines(path):
    n = len(path.read_text().splitlines())
    assert n <= MAX_LINES, f"{path.relative_to(SRC)} has {n} lines (split it along its concerns)"


def test_the_checker_sees_a_lazy_upward_import(tmp_path):
    """The rule is not vacuous: an import inside a function, from a lower layer to a higher one, is found."""
    fake = tmp_path / "probe.py"
    fake.write_text("def f():\n    from ..rendering.renderer import render\n    return render\n")
    assert [t for _, t in _imports(fake, "durer.scene.probe")] == ["durer.rendering.renderer"]
    assert _layer("durer.rendering.renderer") > _layer("durer.scene.probe")


TESTS = Path(__file__).resolve().parent


def _module_paths() -> set[str]:
    """'kernels_bvh_single', 'rendering', 'query', ... : every module and package as a test name would spell it."""
    names = set()
    for path in FILES:
        parts = list(path.relative_to(SRC).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        for depth in range(1, len(parts) + 1):
            names.add("_".join(parts[:depth]))
    return names


def test_test_files_are_named_after_what_they_test():
    """One scheme: test_<folder>_<module>[_<aspect>].py for a module, test_project_<topic>.py for the whole pipeline
    (course assignments, README, examples, fuzzing, architecture, real Mitsuba scenes)."""
    modules = _module_paths()
    stray = []
    for path in sorted(TESTS.glob("test_*.py")):
        words = path.stem.removeprefix("test_").split("_")
        if words[0] == "project":
            continue
        if not any("_".join(words[:n]) in modules for n in range(1, len(words) + 1)):
            stray.append(path.name)
    assert not stray, f"test files not named after a module (see docs/DESIGN.md, Tests): {stray}"


def test_every_kernel_concern_has_a_test_module():
    concerns = [p.name for p in (SRC / "kernels").iterdir() if p.is_dir() and (p / "__init__.py").exists()]
    missing = [c for c in concerns if not list(TESTS.glob(f"test_kernels_{c}*.py"))]
    assert not missing, f"kernel concerns without tests/test_kernels_<concern>*.py: {missing}"
