"""The broken-input corpus: every case is one line naming the file, row, column, key or option, exit 1
(2 for a usage error), no traceback, and a workspace byte-identical to before.

One workspace (a copy of the bundled example: runs with every stage, fitted materials, a sweep) serves every
case; each case hashes every byte of it before and after.  Inputs are made outside it.
"""

from __future__ import annotations

import hashlib
import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import pytest

from tests.conftest import REPO, invoke
from pencli.testing.helpers import synthetic_columns, write_folder
from tests.test_ingest import BROKEN, _broken
from tests.test_params import BAD, GOOD

EXAMPLE = REPO / "examples" / "workspace"


@dataclass(frozen=True)
class Case:
    name: str
    make: Callable[[Path, Path], list | tuple]
    """(inputs folder, workspace folder) → the command's arguments, or (arguments, the words the line must hold)
    when the maker knows them best."""
    words: tuple[str, ...]
    code: int = 1
    env: tuple[tuple[str, str], ...] = ()
    """Environment variables the case sets."""


def _folder_with(name: str, edit: Callable[[Path], None]) -> Callable[[Path, Path], list]:
    def make(inputs: Path, ws: Path) -> list:
        folder = write_folder(inputs / name, synthetic_columns(n=600))
        edit(folder)
        return ["ingest", folder]
    return make


def _laughs(folder: Path) -> None:
    lol = '["lol","lol","lol","lol","lol","lol","lol","lol","lol"]'
    (folder / "run.yaml").write_text(f"a: &a {lol}\nb: &b [*a,*a,*a,*a,*a,*a,*a,*a,*a]\n"
                                     "c: &c [*b,*b,*b,*b,*b,*b,*b,*b,*b]\nid: laughs\n")


def _predict_with(kind: str, text: str) -> Callable[[Path, Path], list]:
    def make(inputs: Path, ws: Path) -> list:
        path = inputs / f"{kind}.yaml"
        path.write_text(text)
        refs = {"penetrator": "al6061_1mm", "material": "mpacs_c", "energizing": "springs_4", kind: str(path)}
        return ["predict", "-p", refs["penetrator"], "-m", refs["material"], "-e", refs["energizing"]]
    return make


def _args(*args: str) -> Callable[[Path, Path], list]:
    return lambda inputs, ws: [a.replace("{ws}", str(ws)).replace("{in}", str(inputs)) for a in args]


CASES: list[Case] = []
# run folders, one flaw each (tests/test_ingest.py builds them)
def _ingest_broken(name: str) -> Callable[[Path, Path], tuple]:
    def make(inputs: Path, ws: Path) -> tuple:
        folder, words = _broken(name, inputs / name)
        return ["ingest", folder], (words,)
    return make


CASES += [Case(f"ingest:{name}", _ingest_broken(name), ()) for name in BROKEN]
# parameter files, one flaw each (tests/test_params.py), through predict
CASES += [Case(f"params:{name}", _predict_with(kind, change(GOOD[kind])), tuple(words))
          for name, kind, change, words in BAD]
CASES += [
    Case("ingest:header_names_fz_twice", _folder_with("dup", lambda f: (f / "data.csv").write_text(
        (f / "data.csv").read_text().replace("fx_n", "fz_n", 1))), ("'fz_n' twice",)),
    Case("ingest:billion_laughs_run_yaml", _folder_with("laughs", _laughs), ("run.yaml", "alias")),
    Case("ingest:python_tag_in_yaml", _folder_with("tag", lambda f: (f / "run.yaml").write_text(
        "id: !!python/object/apply:os.system ['true']\n")), ("run.yaml",)),
    Case("ingest:run_yaml_not_a_mapping", _folder_with("list", lambda f: (f / "run.yaml").write_text("- a\n- b\n")),
         ("run.yaml", "mapping")),
    Case("ingest:no_data_file", _folder_with("nodata", lambda f: (f / "data.csv").unlink()),
         ("nodata", "no run folders")),
    Case("ingest:nothing_there", _args("ingest", "{in}/nowhere"), ("nowhere",)),
    Case("ingest:unmapped_bam_workbook_headers", _folder_with("bam", lambda f: (f / "data.csv").write_text(
        (f / "data.csv").read_text().replace("time_s", "Time (s)", 1))), ("missing column 'time_s'", "--columns")),
    Case("usage:set_without_equals", _args("predict", "-p", "figure10", "-m", "figure10", "-e", "figure10",
                                           "--set", "blade_width_mm"), ("--set", "KEY=VALUE"), 2),
    Case("usage:unknown_term", _args("predict", "-p", "figure10", "-m", "figure10", "-e", "figure10",
                                     "--terms", "bogus"), ("--terms", "bogus"), 2),
    Case("usage:time_unit_furlongs", _args("ingest", "{in}", "--time-unit", "furlongs"),
         ("--time-unit", "furlongs"), 2),
    Case("usage:report_out_not_html", _args("report", "gb-1.0-2", "--out", "{in}/r.txt"), ("--out", "r.txt"), 2),
    Case("usage:unknown_derivative_method", _args("subtract-inertia", "all", "--method", "guess"),
         ("--method", "guess"), 2),
    Case("query:copy_to_a_file", _args("runs", "query", "COPY runs TO '{in}/x.csv'"), ("query failed",)),
    Case("query:copy_onto_a_stage", _args("runs", "query", "COPY (SELECT 1) TO '{ws}/runs/gb-1.0-2/00-raw.parquet'"),
         ("query failed",)),
    Case("query:attach_another_catalog", _args("runs", "query", "ATTACH '{in}/other.duckdb' AS o"),
         ("query failed",)),
    Case("query:write_to_the_catalog", _args("runs", "query", "DELETE FROM runs"), ("query failed",)),
    Case("export:into_the_run_itself", _args("export", "gb-1.0-2", "--to", "{ws}/runs/gb-1.0-2", "--force"),
         ("--to", "runs/")),
    Case("export:unknown_run", _args("export", "nope", "--to", "{in}/out"), ("no run 'nope'",)),
    Case("tare:unknown_run", _args("tare", "nope"), ("no run 'nope'",)),
    Case("fit:unknown_run_pattern", _args("fit", "--material", "x", "zz-*"), ("no run id matches 'zz-*'",)),
    Case("fit:fix_unknown_term", _args("fit", "--material", "x", "gb-*", "--fix", "colour=3"), ("--fix", "colour")),
    Case("diagnose:too_few_runs", _args("diagnose", "gb-1.0-2"), ("at least 3 runs",)),
    Case("report:unknown_material", _args("report", "--material", "unobtainium", "--out", "{in}/r.html"),
         ("unobtainium",)),
    Case("report:unknown_sweep", _args("report", "--sweep", "99", "--out", "{in}/r.html"), ("99",)),
    Case("sweep:grid_too_large", _args("sweep", "-p", "appendix_c", "-m", "grill_brick", "-e", "appendix_c",
                                       "--vary", "blade_width_mm=100:200", "--vary", "blade_thickness_mm=1:2",
                                       "--resolution", "100000"), ("1e+10 designs", "--sample")),
    Case("sweep:unknown_key", _args("sweep", "-p", "appendix_c", "-m", "grill_brick", "-e", "appendix_c",
                                    "--vary", "strength_factor=0.5:2", "--out", "{in}/s.parquet"),
         ("strength_factor",)),
    Case("predict:absurd_density", _args("predict", "-p", "appendix_c", "-m", "grill_brick", "-e", "appendix_c",
                                         "--set", "density_kg_m3=1e300"), ("density_kg_m3", "documented range")),
    Case("predict:unknown_preset", _args("predict", "-p", "nope", "-m", "grill_brick", "-e", "appendix_c"),
         ("no penetrator preset named 'nope'",)),
]


def _edit_data(edit: Callable[[bytes], bytes]) -> Callable[[Path], None]:
    def change(folder: Path) -> None:
        (folder / "data.csv").write_bytes(edit((folder / "data.csv").read_bytes()))
    return change


def _scale_columns(names: tuple[str, ...], factor: float) -> Callable[[Path], None]:
    """A run recorded in other units than the file claims: each named column divided by ``factor``."""
    def change(folder: Path) -> None:
        lines = (folder / "data.csv").read_text().splitlines()
        header = lines[0].split(",")
        at = [header.index(n) for n in names]
        out = [lines[0]]
        for line in lines[1:]:
            fields = line.split(",")
            for i in at:
                fields[i] = repr(float(fields[i]) / factor)
            out.append(",".join(fields))
        (folder / "data.csv").write_text("\n".join(out) + "\n")
    return change


def _xlsx_beside(folder: Path) -> None:
    from openpyxl import Workbook

    book = Workbook()
    book.active.append(["time_s"])
    book.save(folder / "data.xlsx")


def _deep_yaml(inputs: Path, ws: Path) -> list:
    (inputs / "deep.yaml").write_text("kind: penetrator\nname: " + "[" * 200_000 + "]" * 200_000 + "\n")
    return ["predict", "-p", str(inputs / "deep.yaml"), "-m", "grill_brick", "-e", "appendix_c"]


def _latin1_parameter_file(inputs: Path, ws: Path) -> list:
    (inputs / "latin1.yaml").write_bytes("kind: material\nname: caf\xe9\n".encode("latin-1"))
    return ["predict", "-p", "appendix_c", "-m", str(inputs / "latin1.yaml"), "-e", "appendix_c"]


CASES += [
    Case("ingest:latin1_header", _folder_with("latin1", _edit_data(lambda b: b.replace(b"time_s", b"time_s\xb5", 1))),
         ("row 1", "0xb5", "UTF-8")),
    Case("ingest:invalid_date", _folder_with("date", lambda f: (f / "run.yaml").write_text("date: 2026-13-45\n")),
         ("run.yaml", "month")),
    Case("ingest:invalid_date_quoted", _folder_with("date2", lambda f: (f / "run.yaml").write_text(
        "date: '2026-13-45'\n")), ("run.yaml", "'2026-13-45'", "YYYY-MM-DD")),
    Case("ingest:csv_beside_xlsx", _folder_with("both", _xlsx_beside), ("data.csv and data.xlsx", "keep one")),
    Case("ingest:forces_in_kN", _folder_with("kn", _scale_columns(("fx_n", "fy_n", "fz_n"), 1000.0)),
         ("fz_n", "kN", "--allow-implausible-units")),
    Case("ingest:positions_in_inches", _folder_with("inch", _scale_columns(("position_mm",), 25.4)),
         ("position_mm", "inches", "--allow-implausible-units")),
    Case("params:dev_zero", _args("predict", "-p", "/dev/zero", "-m", "grill_brick", "-e", "appendix_c"),
         ("/dev/zero", "bytes")),
    Case("params:200k_deep_yaml", _deep_yaml, ("deep.yaml", "nested")),
    Case("params:latin1_file", _latin1_parameter_file, ("latin1.yaml", "0xe9", "UTF-8")),
    Case("query:empty", _args("runs", "query", ""), ("empty",)),
    Case("query:only_a_semicolon", _args("runs", "query", ";"), ("empty",)),
    Case("env:lock_timeout_not_a_number", _args("runs"), ("PEN_LOCK_TIMEOUT_S", "'soon'"),
         env=(("PEN_LOCK_TIMEOUT_S", "soon"),)),
    Case("env:lock_timeout_negative", _args("tare", "all"), ("PEN_LOCK_TIMEOUT_S",),
         env=(("PEN_LOCK_TIMEOUT_S", "-1"),)),
    Case("env:workers_not_a_number", _args("diagnose", "all"), ("PEN_WORKERS", "'two'", "whole number"),
         env=(("PEN_WORKERS", "two"),)),
    Case("env:workers_zero", _args("diagnose", "all", "--json", "{ws}/d.json"), ("PEN_WORKERS", "'0'"),
         env=(("PEN_WORKERS", "0"),)),
    Case("predict:speed_at_contact_1e200", _args("predict", "-p", "appendix_c", "-m", "grill_brick", "-e",
                                                 "appendix_c", "--speed-at-contact", "1e200"),
         ("speed at contact", "1000 m/s")),
    Case("sweep:speed_at_contact_1e200", _args("sweep", "--speed-at-contact", "1e200", "--vary",
                                               "blade_width_mm=100:200", "--out", "{in}/s.parquet"),
         ("speed at contact", "1000 m/s")),
    Case("sweep:vary_speed_to_1e200", _args("sweep", "--vary", "speed_at_contact=1:1e200", "--out",
                                            "{in}/s.parquet"), ("speed_at_contact", "1000 m/s")),
    Case("fit:material_300_characters", _args("fit", "--material", "m" * 300, "gb-*"), ("--material", "300")),
    Case("fit:material_empty", _args("fit", "--material", "", "gb-*"), ("--material", "empty")),
    Case("usage:fit_terms_empty", _args("fit", "--material", "x", "gb-*", "--terms", ""), ("--terms", "no model term"),
         2),
    Case("usage:predict_terms_empty", _args("predict", "-p", "figure10", "-m", "figure10", "-e", "figure10",
                                            "--terms", ""), ("--terms", "no model term"), 2),
    Case("usage:report_check_malformed", _args("report", "gb-1.0-2", "--out", "{in}/r.html", "--check", "nrmse<=1e"),
         ("--check", "nrmse<=1e"), 2),
    Case("export:to_an_existing_file", lambda inputs, ws: ((inputs / "f").write_text("x"),
                                                           ["export", "gb-1.0-2", "--to", inputs / "f"])[1],
         ("--to", "is a file")),
    Case("report:all_to_an_existing_file", lambda inputs, ws: ((inputs / "f").write_text("x"),
                                                               ["report", "--all", "--out", inputs / "f"])[1],
         ("--out", "is a file")),
    Case("report:all_to_dev_full", _args("report", "--all", "--out", "/dev/full"), ("/dev/full", "not a folder")),
    Case("export:to_dev_full", _args("export", "gb-1.0-2", "--to", "/dev/full"), ("/dev/full", "not a folder")),
    Case("runs:rm_unknown_stage", _args("runs", "rm", "gb-1.0-2", "--stage", "polish"), ("no stage 'polish'",)),
    Case("runs:rm_unknown_run", _args("runs", "rm", "nope"), ("nope",)),
]


def test_the_corpus_has_at_least_40_cases():
    assert len(CASES) >= 40 and len({c.name for c in CASES}) == len(CASES)


@pytest.fixture(scope="module")
def shared_workspace(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("corpus") / "ws"
    shutil.copytree(EXAMPLE, root)
    return root


def _bytes_of(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_broken_input_is_one_line_and_leaves_the_workspace_byte_identical(case, shared_workspace, tmp_path,
                                                                         runner, monkeypatch):
    monkeypatch.chdir(tmp_path)
    db = shared_workspace / "runs.duckdb"
    monkeypatch.setenv("PEN_DB", str(db))
    for name, value in case.env:
        monkeypatch.setenv(name, value)
    before = _bytes_of(shared_workspace)
    inputs = tmp_path / "inputs"
    inputs.mkdir()
    made = case.make(inputs, shared_workspace)
    args, words = made if isinstance(made, tuple) else (made, case.words)
    r = invoke(runner, *args)
    assert r.exit_code == case.code, (r.exit_code, r.output, r.stderr)
    assert "Traceback" not in r.output + r.stderr
    lines = [line for line in r.stderr.splitlines() if line.strip()]
    if case.code == 2:  # click's usage lines, then one error line
        lines = [line for line in lines if line.startswith("Error:")]
    assert len(lines) == 1, r.stderr
    for word in words:
        assert word in lines[0], (word, lines[0])
    assert _bytes_of(shared_workspace) == before
