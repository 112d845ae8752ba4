"""STYLE.md §1: imports go one way; the pure core stays pure."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parents[1] / "pencli"
CORE = ("model", "filter", "fit", "predict", "diagnose", "params", "sensors")
FORBIDDEN_IN_CORE = {"pandas", "pyarrow", "duckdb", "openpyxl", "rich", "typer", "click", "matplotlib"}
UPWARD_FROM_CORE = {"pencli.commands", "pencli.cli", "pencli.api", "pencli.store", "pencli.io", "pencli.report",
                    "pencli.acquire"}


def imports_of(path: Path) -> set[str]:
    """Every module named by an import statement anywhere in the file (lazy ones too)."""
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
    return names


def core_files():
    for package in CORE:
        yield from sorted((PKG / package).rglob("*.py"))


@pytest.mark.parametrize("path", list(core_files()), ids=lambda p: str(p.relative_to(PKG)))
def test_core_imports_no_io_or_ui_libraries(path):
    for name in imports_of(path):
        assert name.split(".")[0] not in FORBIDDEN_IN_CORE, f"{path.name} imports {name}"
        assert not any(name == up or name.startswith(up + ".") for up in UPWARD_FROM_CORE), \
            f"{path.name} imports {name} (core must not import edges or the CLI)"


def test_only_store_imports_duckdb():
    """The store, and the test tools that read a catalog to prove a command left it as it was."""
    for path in PKG.rglob("*.py"):
        if {"store", "testing"} & set(path.relative_to(PKG).parts):
            continue
        assert not any(n.split(".")[0] == "duckdb" for n in imports_of(path)), path


def test_nobody_imports_click_directly():
    for path in PKG.rglob("*.py"):
        assert not any(n.split(".")[0] == "click" for n in imports_of(path)), path


def test_heavy_libraries_are_not_imported_at_module_level_by_the_cli():
    """`pen --help` must not pay for matplotlib, openpyxl, pyarrow or duckdb."""
    import subprocess
    import sys

    code = ("import sys, pencli.cli; heavy = [m for m in ('matplotlib', 'openpyxl', 'pyarrow', 'duckdb', 'pandas') "
            "if m in sys.modules]; print(','.join(heavy))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == "", f"imported at start-up: {out}"


def test_the_example_workspace_has_a_folder_of_its_own():
    """The example's runs/ sat in the repository root, where the default workspace
    (./runs.duckdb) keeps its runs, so `pen acquire --save` wrote into the tracked example."""
    from tests.conftest import REPO

    example = REPO / "examples" / "workspace"
    assert (example / "runs.duckdb").is_file() and (example / "runs").is_dir()
    assert not (REPO / "runs").exists() and not (REPO / "fits").exists() and not (REPO / "sweeps").exists()


REPO = PKG.parent


def test_tests_and_benches_are_apart_and_pen_never_imports_its_test_tools():
    """Truth worlds and campaign builders live in pencli.testing, which the tests and benches share; the tests
    import no bench, the benches no test, and nothing of pen but pencli.testing imports pencli.testing."""
    for path in sorted((REPO / "tests").rglob("*.py")):
        assert not any(n.split(".")[0] == "bench" for n in imports_of(path)), path
    for path in sorted((REPO / "bench").rglob("*.py")):
        assert not any(n.split(".")[0] == "tests" for n in imports_of(path)), path
    for path in PKG.rglob("*.py"):
        if "testing" in path.relative_to(PKG).parts:
            continue
        assert not any(n == "pencli.testing" or n.startswith("pencli.testing.") for n in imports_of(path)), path
