"""The user documentation: the site builds with warnings as errors, every command has its page, the format pages
cover every key and column pen writes, and the product carries no history (numbered work periods, draw or issue
numbers, commit hashes: those belong to git and the changelog)."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import duckdb
import pytest

from tests.conftest import REPO

EXAMPLE = REPO / "examples" / "workspace"


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("site")
    done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(out)], cwd=REPO,
                          capture_output=True, text=True, timeout=300, env={"NO_MKDOCS_2_WARNING": "1",
                                                                            "PATH": "/usr/bin:/bin"})
    assert done.returncode == 0, done.stderr[-3000:]
    return out


def _commands() -> list[str]:
    from typer.main import get_command

    from pencli.cli import app

    def walk(command, path=()):
        if path:
            yield " ".join(path)
        for name, sub in (getattr(command, "commands", None) or {}).items():
            yield from walk(sub, path + (name,))

    return list(walk(get_command(app)))


def test_every_command_has_a_generated_page_with_its_help(site):
    for command in _commands():
        page = site / "commands" / command.replace(" ", "-") / "index.html"
        assert page.is_file(), command
        assert f"Usage: pen {command}" in page.read_text(), command


def test_the_getting_started_page_is_the_readmes_tour(site):
    page = (site / "getting-started" / "index.html").read_text()
    assert "pen ingest lab/tour/mc-*" in page and "pen diagnose all" in page


def test_the_parameter_keys_page_lists_every_key_with_its_unit(site):
    from pencli.params.definitions import CHOICES, PARAMETERS

    page = (site / "reference" / "parameters" / "index.html").read_text()
    for p in PARAMETERS:
        assert f"<code>{p.key}</code>" in page, p.key
    for c in CHOICES:  # the named choices, each option listed
        assert f"<code>{c.key}</code>" in page and all(f"<code>{o}</code>" in page for o in c.options), c.key


def test_the_catalog_page_names_every_column_of_every_table(site):
    page = (site / "formats" / "catalog" / "index.html").read_text()
    con = duckdb.connect(str(EXAMPLE / "runs.duckdb"), read_only=True)
    try:
        columns = con.execute("SELECT table_name, column_name FROM information_schema.columns").fetchall()
    finally:
        con.close()
    assert len(columns) > 40
    missing = [(t, c) for t, c in columns if c not in page]
    assert not missing, missing


def test_the_run_folder_page_names_every_column_and_file(site):
    from pencli.io.runfolder import PARAMETER_FILES
    from pencli.run import RAW_COLUMNS

    page = (site / "formats" / "run-folders" / "index.html").read_text()
    for name in (*RAW_COLUMNS, *PARAMETER_FILES.values(), "run.yaml", "data.csv", "data.xlsx"):
        assert name in page, name


def _keys(value, out: set) -> set:
    if isinstance(value, dict):
        for key, inner in value.items():
            out.add(key)
            _keys(inner, out)
    elif isinstance(value, list):
        for inner in value:
            _keys(inner, out)
    return out


@pytest.mark.slow
def test_the_diagnosis_json_page_names_every_key_a_report_holds(site, tmp_path):
    out = tmp_path / "d.json"
    done = subprocess.run([sys.executable, "-m", "pencli", "diagnose", "mc-1.0-4", "mc-1.0-6", "mc-2.0-2",
                           "--bootstrap", "20", "--json", str(out), "--db", str(EXAMPLE / "runs.duckdb")],
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    report = json.loads(out.read_text())
    runs = set(report["runs"])
    page = (site / "formats" / "diagnosis-json" / "index.html").read_text()
    missing = sorted(k for k in _keys(report, set()) - runs if k not in page)
    assert not missing, missing


# ---------------------------------------------------------------------------- no history in the product
_ORDINAL = (r"(?:first|second|third|fourth|fifth|sixth|seventh|eighth|ninth|tenth|eleventh|twelfth|thirteenth|"
            r"fourteenth|fifteenth|sixteenth|seventeenth|eighteenth|nineteenth|twentieth|thirtieth|fortieth|fiftieth|"
            r"sixtieth|twenty|thirty|forty|fifty|"
            r"sixty|seventy|eighty|ninety)(?:-\w+)?")
HISTORY = {
    "a numbered work period": re.compile(rf"\b{_ORDINAL}\s+sessions?\b|\bsessions?\s+\d+\b", re.IGNORECASE),
    "an issue number": re.compile(r"\bissues? #?\d+\b", re.IGNORECASE),
    "a draw number": re.compile(r"\bdraw \d+\b", re.IGNORECASE),
    "a commit hash": re.compile(r"\b(?=[0-9a-f]*[a-f])(?=[0-9a-f]*\d)[0-9a-f]{7,12}\b"),
    "the development log": re.compile(r"diagnosis-log|diagnosis-history|bench/records"),
}
SCANNED = ("pencli", "tests", "docs", "bench", "README.md", "schema")
ALLOWED_HASHES = re.compile(r"sha256|content_sha256|digest", re.IGNORECASE)
"""Lines that name a content hash of data (a test's expected digest) may hold hex."""


def _product_files() -> list[Path]:
    files = []
    for name in SCANNED:
        path = REPO / name
        candidates = [path] if path.is_file() else sorted(path.rglob("*"))
        files += [p for p in candidates if p.is_file() and p.suffix in (".py", ".md", ".yaml", ".yml", ".json")
                  and "__pycache__" not in p.parts and p.name != Path(__file__).name]
    return files


def test_no_history_in_code_tests_docs_or_readme():
    found = []
    for path in _product_files():
        text = path.read_text(encoding="utf-8", errors="replace")
        for what, pattern in HISTORY.items():
            for match in pattern.finditer(text):
                number = text.count("\n", 0, match.start()) + 1
                line = text.splitlines()[number - 1]
                if not (what == "a commit hash" and ALLOWED_HASHES.search(line)):
                    found.append(f"{path.relative_to(REPO)}:{number}: {what}: {match.group(0)!r}")
    assert not found, "\n".join(found[:60]) + (f"\n… and {len(found) - 60} more" if len(found) > 60 else "")
