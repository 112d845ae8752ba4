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


def shown_outputs(text: str) -> dict[str, list[str]]:
    """The output the README shows under each ``$ pen …`` line of its indented blocks (up to the next command or
    the block's end): command → lines."""
    out: dict[str, list[str]] = {}
    command = None
    for line in text.splitlines():
        if not line.startswith("    "):
            command = None
            continue
        body = line[4:]
        if body.startswith("$ "):
            command = re.sub(r"\s{2,}#.*$", "", body[2:]).strip()
            out[command] = []
        elif command is not None:
            out[command].append(body)
    return {c: lines for c, lines in out.items() if lines}


def _squeezed(text: str) -> str:
    return " ".join(text.split())


def missing_from(shown: list[str], output: str) -> list[str]:
    """The shown lines the output does not hold, whitespace aside: "…" stands for what is left out (a time that
    varies, the rest of a long line, or, alone, lines), and the pieces around it must each be printed."""
    printed = _squeezed(output)
    missing = []
    for line in shown:
        pieces = [_squeezed(piece) for piece in line.split("…")]
        if any(piece and piece not in printed for piece in pieces):
            missing.append(line)
    return missing


def _run_all(commands: list[str], root: Path) -> tuple[list[str], dict[str, str]]:
    """(failures, each command's output): the commands run in order in the scratch folder ``root``."""
    _prepare(root)
    env = {k: v for k, v in os.environ.items() if k != "PEN_DB"}
    env["PATH"] = str(Path(sys.executable).parent) + os.pathsep + env.get("PATH", "")
    env["COLUMNS"] = "200"  # the README shows tables and lines unwrapped
    failures, outputs = [], {}
    for command in commands:
        done = subprocess.run(["bash", "-c", command], cwd=root, env=env, capture_output=True, text=True,
                              timeout=600)
        outputs[command] = done.stdout + done.stderr
        if done.returncode != 0:
            failures.append(f"{command}\n  exit {done.returncode}: {(done.stderr or done.stdout).strip()[-400:]}")
    return failures, outputs


@pytest.mark.slow
def test_every_readme_command_runs_as_written_and_prints_what_it_shows(tmp_path):
    """Each command runs, and each line of output the README shows under it is in what the command prints now (a
    figure the README quotes cannot go stale as the presets and the model change)."""
    text = (REPO / "README.md").read_text()
    failures, outputs = _run_all(readme_commands(text), tmp_path)
    for command, shown in shown_outputs(text).items():
        missing = missing_from(shown, outputs.get(command, ""))
        if missing:
            failures.append(f"{command}\n  shows lines it no longer prints: {missing}")
    assert not failures, "\n".join(failures)


def test_the_output_check_finds_a_stale_figure_and_passes_the_same_figure():
    shown = ["│ speed at contact │  3.4630 │ m/s  │", "verdict: none   over 6 runs", "…",
             "baseline held-out RMS 2.2 N (NRMSE 0.001); its null …", "100 designs in … designs/s); 20.0 % reach"]
    printed = ("│ speed at contact                  │  3.4630 │ m/s  │\nverdict: none   over 6 runs\n"
               "baseline held-out RMS 2.2 N (NRMSE 0.001); its null replicates 2.4 N\n"
               "100 designs in 0.61 s (164 designs/s); 20.0 % reach full depth")
    assert missing_from(shown, printed) == []
    stale = "│ speed at contact │  2.8752 │ m/s  │"
    assert missing_from([stale], printed) == [stale]


@pytest.mark.slow
def test_every_documented_command_runs_as_written_and_prints_what_it_shows(tmp_path):
    failures, outputs = _run_all(docs_commands(), tmp_path)
    for page in docs_pages():
        for command, shown in shown_outputs(page.read_text()).items():
            missing = missing_from(shown, outputs.get(command, ""))
            if missing:
                failures.append(f"{page.name}: {command}\n  shows lines it no longer prints: {missing}")
    assert not failures, "\n".join(failures)
