"""Every `pen` command the README and the user documentation show runs as written.

The commands are read from the indented code blocks of the README and of each page of the documentation, in the
site's order, and run through a shell in a scratch folder (one for the README, one for the documentation) laid
out as they assume: the example workspace under ``examples/workspace``, the field records under
``examples/field``, lab folders to
ingest (CONTRACT §3 folders exported from the example), a BAM-era workbook under ``old/``, ``my_blade.yaml``.
The two set-up commands (install, test) are what CI runs; they are not re-run here.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import REPO
from pencli.testing.helpers import synthetic_columns, write_bam_workbook

SETUP = ("python -m pip", "python -m pytest")


def readme_commands(text: str) -> list[str]:
    """`pen …` lines (and shell loops over `pen`) of indented code blocks (continuations joined, trailing comments
    cut)."""
    out, pending = [], ""
    for line in text.splitlines():
        if not line.startswith("    "):
            pending = ""
            continue
        body = line[4:]
        if pending:
            body = pending + " " + body.strip()
            pending = ""
        elif body.startswith("$ "):
            body = body[2:]
        if not (body.startswith("pen ") or (body.startswith("for ") and "; do pen " in body)):
            continue
        if body.rstrip().endswith("\\"):
            pending = body.rstrip()[:-1].rstrip()
            continue
        out.append(re.sub(r"\s{2,}#.*$", "", body).strip())
    return out


def _prepare(root: Path) -> None:
    """The scratch folder as the commands assume it (made in this process: what is tested is the commands)."""
    import yaml

    from pencli import api

    shutil.copytree(REPO / "examples" / "workspace", root / "examples" / "workspace")
    shutil.copytree(REPO / "examples" / "field", root / "examples" / "field")
    example = root / "examples" / "workspace" / "runs.duckdb"
    lab = root / "lab" / "2026-11-20"
    for run in ("mc-1.0-4", "mc-1.0-6", "mc-1.5-2", "mc-1.5-6", "mc-2.0-2", "mc-2.0-4", "gb-1.0-2"):
        api.export_run(example, run, lab / run)
    write_bam_workbook(root / "old" / "experiment_12", synthetic_columns(n=800),
                       ["Time (ms)", "Pos", "Fx", "Fy", "Fz", "Mx", "My", "Mz"], lambda row: [row[0] * 1000, *row[1:]])
    blade = api.show_preset("al6061_1mm", "penetrator")[0].to_mapping()
    (root / "my_blade.yaml").write_text(yaml.safe_dump({**blade, "name": "my_blade"}, sort_keys=False))


def docs_pages() -> list[Path]:
    """The documentation's pages in the site's navigation order (generated pages have no file)."""
    import yaml

    def flat(entries):
        for entry in entries:
            for value in (entry.values() if isinstance(entry, dict) else [entry]):
                if isinstance(value, list):
                    yield from flat(value)
                elif isinstance(value, str):
                    yield REPO / "docs" / value

    nav = yaml.safe_load((REPO / "mkdocs.yml").read_text())["nav"]
    return [page for page in flat(nav) if page.is_file()]


def docs_commands() -> list[str]:
    return [c for page in docs_pages() for c in readme_commands(page.read_text())]


def test_readme_and_docs_commands_are_found():
    commands = readme_commands((REPO / "README.md").read_text())
    assert len(commands) >= 8 and any(c.startswith("pen diagnose") for c in commands)
    documented = docs_commands()
    assert len(documented) > 30
    assert any("--sample lhs" in c for c in documented) and any(c.startswith("pen diagnose") for c in documented)
    assert not any(c.startswith(SETUP) for c in commands + documented)


def _run_all(commands: list[str], root: Path) -> list[str]:
    _prepare(root)
    env = {k: v for k, v in os.environ.items() if k != "PEN_DB"}
    env["PATH"] = str(Path(sys.executable).parent) + os.pathsep + env.get("PATH", "")
    failures = []
    for command in commands:
        done = subprocess.run(["bash", "-c", command], cwd=root, env=env, capture_output=True, text=True,
                              timeout=600)
        if done.returncode != 0:
            failures.append(f"{command}\n  exit {done.returncode}: {(done.stderr or done.stdout).strip()[-400:]}")
    return failures


@pytest.mark.slow
def test_every_readme_command_runs_as_written(tmp_path):
    failures = _run_all(readme_commands((REPO / "README.md").read_text()), tmp_path)
    assert not failures, "\n".join(failures)


@pytest.mark.slow
def test_every_documented_command_runs_as_written(tmp_path):
    failures = _run_all(docs_commands(), tmp_path)
    assert not failures, "\n".join(failures)
