"""The README's promises (issue 25): its first command writes the picture it shows, and its snippets run as printed."""

from __future__ import annotations

import ast
import builtins
import re
import shlex
import shutil

import numpy as np
import pytest
from conftest import REPO
from PIL import Image

from durer.cli import main

README = (REPO / "README.md").read_text()


def snippets(language: str) -> list[str]:
    return re.findall(rf"```{language}\n(.*?)```", README, flags=re.S)


def test_the_first_command_writes_the_hero_image(tmp_path, capsys):
    first = snippets("bash")[0].splitlines()[0]
    argv = shlex.split(first.split("&& durer ", 1)[1])
    assert argv[:2] == ["render", "examples/spheres.txt"] and argv[argv.index("-o") + 1] == "spheres.png"
    argv[argv.index("-o") + 1] = str(tmp_path / "spheres.png")
    argv[1] = str(REPO / argv[1])
    assert main(argv) == 0
    capsys.readouterr()
    hero = np.asarray(Image.open(REPO / "docs" / "images" / "spheres.png")).astype(int)
    mine = np.asarray(Image.open(tmp_path / "spheres.png")).astype(int)
    assert mine.shape == hero.shape == (320, 480, 3)
    assert (np.abs(mine - hero).max(axis=2) <= 2).mean() >= 0.999


def test_the_python_snippet_runs_as_printed(tmp_path, monkeypatch):
    code = next(s for s in snippets("python") if 'durer.load("examples/spheres.txt")' in s)
    shutil.copytree(REPO / "examples", tmp_path / "examples")
    monkeypatch.chdir(tmp_path)
    exec(compile(code, "README.md", "exec"), {"__name__": "__main__"})
    for name in ("out.png", "depth.npy", "normals.png", "sphere.png"):
        assert (tmp_path / name).stat().st_size > 0
    assert np.load(tmp_path / "depth.npy").shape == (320, 480)


def _undefined_names(code: str) -> set[str]:
    """Names the code reads that it neither imports nor assigns (nor are builtins)."""
    tree = ast.parse(code)
    defined = set(dir(builtins))
    for node in ast.walk(tree):
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            defined |= {(a.asname or a.name).split(".")[0] for a in node.names}
        elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
            defined.add(node.id)
    return {n.id for n in ast.walk(tree) if isinstance(n, ast.Name) and isinstance(n.ctx, ast.Load)} - defined


def test_the_dask_snippet_is_self_contained_and_guarded():
    code = next(s for s in snippets("python") if "durer.dask" in s)
    assert not _undefined_names(code)  # issue 25: `scene` was undefined
    tree = ast.parse(code)
    top = [n for n in tree.body if not isinstance(n, (ast.Import, ast.ImportFrom))]
    assert len(top) == 1 and isinstance(top[0], ast.If) and "__main__" in ast.unparse(top[0].test)
    pytest.importorskip("distributed", reason="the Dask snippet needs the dask extra")
    exec(compile(code, "README.md", "exec"), {"__name__": "__mp_main__"})  # as a worker re-imports it: no work


def test_every_python_snippet_is_self_contained():
    for code in snippets("python"):
        assert not _undefined_names(code), code


@pytest.mark.parametrize("flag", sorted(set(re.findall(r"--[a-z][a-z-]+", README)) - {"--hypothesis-profile", "--dist"}))  # pytest options
def test_every_flag_the_readme_names_exists(flag):
    from durer.cli import COMMANDS

    helps = "".join(parser().format_help() for _, parser in COMMANDS.values())
    # the README also names the options of the scripts in benchmarks/ and tools/ (their argparse flags)
    scripts = "".join(f.read_text() for folder in ("benchmarks", "tools") for f in (REPO / folder).glob("*.py"))
    script_flags = set(re.findall(r'add_argument\(\s*"(--[a-z][a-z-]+)"', scripts))
    assert flag in helps or flag in script_flags, flag
