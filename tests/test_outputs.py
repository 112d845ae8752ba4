"""No output path can harm the workspace, and the machine's faults are one line.

Three corpora:

- every command with an output option × every target that must be refused (the catalog, its log and lock
  files, a raw stage, a stage folder, the workspace root, an existing file of the wrong kind, a folder,
  /dev/full, a read-only folder): one line, exit 1, the workspace and the target byte-identical;
- every writing command on a full disk (a small tmpfs, filled): one line, exit 1, nothing half-written;
- a read-only workspace and a sweep too large for the free space.

The disk cases need a tmpfs, which only root can mount; they are skipped elsewhere (CI runs as root).
"""

from __future__ import annotations

import contextlib
import hashlib
import shutil
import subprocess
from pathlib import Path
from typing import Callable, Iterator

import pytest

from tests.conftest import REPO, invoke

EXAMPLE = REPO / "examples" / "workspace"

OUTPUTS: dict[str, tuple[tuple[str, ...], bool, str]] = {
    # name: (arguments with {out}, writes a folder, suffix of the file it writes)
    "predict": (("predict", "-p", "appendix_c", "-m", "grill_brick", "-e", "appendix_c", "--out", "{out}"), False,
                ".parquet"),
    "sweep": (("sweep", "--vary", "blade_width_mm=100:200", "--out", "{out}"), False, ".parquet"),
    "fit": (("fit", "-m", "x", "gb-*", "--bootstrap", "0", "--out", "{out}"), False, ".yaml"),
    "report": (("report", "gb-1.0-2", "--out", "{out}"), False, ".html"),
    "report-all": (("report", "--all", "--out", "{out}"), True, ""),
    "diagnose-json": (("diagnose", "gb-*", "--json", "{out}"), False, ".json"),
    "diagnose-plot": (("diagnose", "gb-*", "--plot", "{out}"), False, ".png"),
    "predict-plot": (("predict", "-p", "appendix_c", "-m", "grill_brick", "-e", "appendix_c", "--plot", "{out}"), False,
                     ".png"),
    "export": (("export", "gb-1.0-2", "--to", "{out}", "--force"), True, ""),
    "schema": (("params", "schema", "--out", "{out}"), True, ""),
    "truth-out": (("acquire", "--springs", "4", "--yes", "--discard", "--truth-out", "{out}"), False, ".json"),
}


def _target(name: str, ws: Path, inputs: Path, folder: bool, suffix: str) -> tuple[Path, str]:
    """The path a case writes to, and a word its one line must hold."""
    if name == "catalog":
        return ws / "runs.duckdb", "catalog"
    if name == "wal":
        return ws / "runs.duckdb.wal", "catalog"
    if name == "lock":
        return ws / ".runs.duckdb.compact-1", "catalog"
    if name == "raw-stage":
        return ws / "runs" / "gb-1.0-2" / "00-raw.parquet", "runs/"
    if name == "stage-folder":
        return (ws / "runs" / "gb-1.0-2") if folder else (ws / "runs" / "gb-1.0-2" / f"out{suffix}"), "runs/"
    if name == "workspace-root":
        return ws, ("holds the workspace" if folder else "folder")
    if name == "existing-file":
        if folder:
            (inputs / "a-file").write_text("keep me\n")
            return inputs / "a-file", "is a file"
        shutil.copy(ws / "runs.duckdb", inputs / f"other{suffix}")  # another workspace's catalog, misnamed
        return inputs / f"other{suffix}", "DuckDB"
    if name == "directory":
        if folder:  # a folder holding the workspace
            return ws.parent, "holds the workspace"
        (inputs / f"a-folder{suffix}").mkdir()
        return inputs / f"a-folder{suffix}", "folder"
    if name == "dev-full":
        return Path("/dev/full"), "/dev/full"
    raise ValueError(name)


TARGETS = ("catalog", "wal", "lock", "raw-stage", "stage-folder", "workspace-root", "existing-file", "directory",
           "dev-full")
CASES = [(command, target) for command in OUTPUTS for target in TARGETS]


def _bytes_of(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def _folders_of(folder: Path) -> set[str]:
    return {str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_dir()}


@pytest.fixture(scope="module")
def shared_workspace(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("outputs") / "ws"
    shutil.copytree(EXAMPLE, root)
    return root


def test_the_output_corpus_has_at_least_40_cases():
    assert len(CASES) >= 40


def _refused(runner, args: list[str], ws: Path, watched: Path | None, words: tuple[str, ...]) -> None:
    before = _bytes_of(ws), _folders_of(ws)
    watched_before = watched.read_bytes() if watched is not None and watched.is_file() else None
    r = invoke(runner, *args)
    assert r.exit_code == 1, (r.exit_code, r.output, r.stderr)
    assert "Traceback" not in r.output + r.stderr
    lines = [line for line in r.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, r.stderr
    for word in words:
        assert word in lines[0], (word, lines[0])
    assert (_bytes_of(ws), _folders_of(ws)) == before
    if watched_before is not None:
        assert watched.read_bytes() == watched_before


@pytest.mark.parametrize("command,target", CASES, ids=[f"{c}:{t}" for c, t in CASES])
def test_an_output_onto_the_workspace_or_a_device_is_refused(command, target, shared_workspace, tmp_path, runner,
                                                              monkeypatch):
    template, folder, suffix = OUTPUTS[command]
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("PEN_DB", str(shared_workspace / "runs.duckdb"))
    inputs = tmp_path / "inputs"
    inputs.mkdir()
    out, word = _target(target, shared_workspace, inputs, folder, suffix)
    args = [a.replace("{out}", str(out)) for a in template]
    _refused(runner, args, shared_workspace, out if out.is_file() and out.parent == inputs else None, (word,))


# ---------------------------------------------------------------------------- disks: read-only, full
def _mount(folder: Path, options: str) -> bool:
    folder.mkdir(parents=True, exist_ok=True)
    try:
        done = subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(folder)], capture_output=True,
                              timeout=30)
    except (OSError, subprocess.TimeoutExpired):
        return False
    return done.returncode == 0


def _umount(folder: Path) -> None:
    subprocess.run(["umount", "-l", str(folder)], capture_output=True, timeout=30)


@contextlib.contextmanager
def tmpfs(folder: Path, size: str, prepare: Callable[[Path], None] | None = None, *,
          read_only: bool = False, full: bool = False) -> Iterator[Path]:
    """A small tmpfs at ``folder`` (skip the test where it cannot be mounted): ``prepare`` fills it, then it is
    made read-only or filled to the last byte."""
    if not _mount(folder, f"size={size}"):
        pytest.skip("mounting a tmpfs needs root (CI runs as root)")
    try:
        if prepare is not None:
            prepare(folder)
        if read_only:
            done = subprocess.run(["mount", "-o", "remount,ro", str(folder)], capture_output=True, timeout=30)
            assert done.returncode == 0, done.stderr
        if full:
            for k, block in enumerate((1 << 16, 1 << 12, 1 << 9, 1)):
                with contextlib.suppress(OSError), open(folder / f".filler-{k}", "wb") as handle:
                    while True:
                        handle.write(b"\0" * block)
                        handle.flush()
        yield folder
    finally:
        _umount(folder)


@pytest.mark.parametrize("command", ["predict", "report", "diagnose-json", "export", "schema", "truth-out"])
def test_an_output_into_a_read_only_folder_is_refused_before_any_work(command, shared_workspace, tmp_path, runner,
                                                                     monkeypatch):
    template, folder, suffix = OUTPUTS[command]
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("PEN_DB", str(shared_workspace / "runs.duckdb"))
    with tmpfs(tmp_path / "ro", "1m", read_only=True) as ro:
        out = ro / (f"out{suffix}" if not folder else "out")
        _refused(runner, [a.replace("{out}", str(out)) for a in template], shared_workspace, None,
                 ("read-only",))


def _example_with_work_to_do(root: Path) -> None:
    """The example workspace, with stages taken away so that tare and subtract-inertia have something to write,
    and a run folder to ingest."""
    ws = root / "ws"
    shutil.copytree(EXAMPLE, ws)
    for run, stage in (("mc-1.5-2", "tare"), ("mc-1.5-6", "inertia")):
        r = invoke_sub(ws, "runs", "rm", run, "--stage", stage, "--purge")
        assert r.returncode == 0, r.stderr
    r = invoke_sub(ws, "export", "gb-1.0-2", "--to", str(root / "lab" / "gb"))
    assert r.returncode == 0, r.stderr
    r = invoke_sub(ws, "runs", "rm", "gb-1.0-2", "--purge")
    assert r.returncode == 0, r.stderr


def invoke_sub(ws: Path, *args: str) -> subprocess.CompletedProcess:
    """pen in its own process on the workspace ``ws``; a shot that cannot be saved is rescued beside it."""
    import os
    import sys

    env = {k: v for k, v in os.environ.items() if k != "PEN_DB"}
    env["TMPDIR"] = str(ws.parent.parent)
    return subprocess.run([sys.executable, "-m", "pencli", *args, "--db", str(ws / "runs.duckdb")],
                          capture_output=True, text=True, env=env, timeout=300)


WRITERS = {
    "ingest": ("ingest", "{root}/lab/gb"),
    "acquire": ("acquire", "--springs", "4", "--yes", "--save"),
    "tare": ("tare", "mc-1.5-2"),
    "subtract-inertia": ("subtract-inertia", "mc-1.5-6"),
    "fit": ("fit", "-m", "x", "gb-*", "--bootstrap", "0"),
    "sweep": ("sweep", "--vary", "blade_width_mm=100:200"),
    "sweep-out": ("sweep", "--vary", "blade_width_mm=100:200", "--out", "{root}/s.parquet"),
    "predict-out": ("predict", "-p", "appendix_c", "-m", "grill_brick", "-e", "appendix_c", "--out",
                    "{root}/p.parquet"),
    "export": ("export", "gb-1.0-6", "--to", "{root}/exported"),
    "report": ("report", "gb-1.0-6", "--out", "{root}/r.html"),
    "report-all": ("report", "--all", "--out", "{root}/reports"),
    "diagnose-json": ("diagnose", "mc-1.0-4", "mc-1.0-6", "mc-2.0-2", "--bootstrap", "20", "--json",
                      "{root}/d.json"),
    "schema": ("params", "schema", "--out", "{root}/schema"),
    "runs-rm": ("runs", "rm", "gb-1.0-6"),
}


@pytest.fixture(scope="module")
def work_to_do(tmp_path_factory) -> Path:
    """One copy of the example with work left for every writing command, made once and copied per case."""
    root = tmp_path_factory.mktemp("work")
    _example_with_work_to_do(root)
    return root


@pytest.mark.slow
@pytest.mark.parametrize("command", list(WRITERS))
def test_a_full_disk_is_one_line_and_nothing_half_written(command, tmp_path, work_to_do):
    def prepare(root: Path) -> None:
        shutil.copytree(work_to_do, root, dirs_exist_ok=True)

    with tmpfs(tmp_path / "disk", "48m", prepare, full=True) as root:
        ws = root / "ws"
        before = _bytes_of(root), _folders_of(root)
        args = [a.replace("{root}", str(root)) for a in WRITERS[command]]
        done = invoke_sub(ws, *args)
        assert done.returncode == 1, (done.returncode, done.stdout, done.stderr)
        assert "Traceback" not in done.stdout + done.stderr
        errors = [line for line in done.stderr.splitlines() if line.startswith(("error:", "rejected"))]
        assert len(errors) == 1, done.stderr
        assert "space" in errors[0], errors[0]
        after = _bytes_of(root), _folders_of(root)
        # DuckDB leaves an empty write-ahead log behind a commit it could not write: no content, and it goes
        # at the next checkpoint
        wal = "ws/runs.duckdb.wal"
        if wal in after[0] and wal not in before[0]:
            assert (root / wal).stat().st_size == 0
            del after[0][wal]
        assert after == before


def test_a_read_only_workspace_is_one_line(tmp_path):
    def prepare(root: Path) -> None:
        shutil.copytree(EXAMPLE, root / "ws")

    with tmpfs(tmp_path / "disk", "48m", prepare, read_only=True) as root:
        before = _bytes_of(root)
        for args in (("sweep", "--vary", "blade_width_mm=100:200"), ("tare", "gb-1.0-2", "--window", "-150,-20"),
                     ("fit", "-m", "x", "gb-*", "--bootstrap", "0")):
            done = invoke_sub(root / "ws", *args)
            assert done.returncode == 1, (args, done.stderr)
            assert "Traceback" not in done.stderr
            errors = [line for line in done.stderr.splitlines() if line.startswith(("error:", "rejected"))]
            assert len(errors) == 1 and "read-only" in errors[0].lower(), (args, done.stderr)
        assert _bytes_of(root) == before


def test_a_sweep_larger_than_the_free_space_is_refused_before_writing(tmp_path, runner, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with tmpfs(tmp_path / "small", "1m") as small:
        out = small / "s.parquet"
        r = invoke(runner, "sweep", "--vary", "blade_width_mm=100:200", "--sample", "lhs", "--n", "1000000000",
                   "--out", str(out))
        assert r.exit_code == 1, r.output
        lines = [line for line in r.stderr.splitlines() if line.strip()]
        assert len(lines) == 1 and "GB" in lines[0] and "free" in lines[0], r.stderr
        assert list(small.iterdir()) == []
