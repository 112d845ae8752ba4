"""CLI surface: help with examples on every command, --db everywhere, predict outputs."""

from __future__ import annotations

import json

import pyarrow.parquet as pq
import pytest
import typer

from pencli.cli import app
from tests.conftest import invoke


def all_commands(typer_app: typer.Typer, prefix=()):
    for info in typer_app.registered_commands:
        yield prefix + (info.name or info.callback.__name__,), info
    for group in typer_app.registered_groups:
        yield from all_commands(group.typer_instance, prefix + (group.name,))


COMMANDS = list(all_commands(app))


def test_there_are_commands():
    names = {" ".join(path) for path, _ in COMMANDS}
    assert {"predict", "params list", "params show", "params validate", "params schema"} <= names


@pytest.mark.parametrize("path,info", COMMANDS, ids=[" ".join(p) for p, _ in COMMANDS])
def test_every_command_has_help_with_an_example_and_takes_db(runner, path, info):
    doc = info.callback.__doc__ or ""
    assert "Example: pen " in doc, f"pen {' '.join(path)} has no example in its help"
    result = invoke(runner, *path, "--help")
    assert result.exit_code == 0
    if tuple(path) not in (("soundings", "fit"), ("soundings", "diagnose")):  # these read a units file's soundings
        assert "--db" in result.output


def test_predict_writes_a_self_describing_parquet_trajectory(tmp_path, runner):
    out = tmp_path / "traj.parquet"
    result = invoke(runner, "predict", "-p", "appendix_c", "-m", "grill_brick", "-e", "appendix_c", "--out", out,
                    "--json")
    assert result.exit_code == 0, result.output
    record = json.loads(result.stdout)
    table = pq.read_table(out)
    for col in ("time_s", "depth_m", "velocity_m_s", "acceleration_m_s2", "strength_n", "friction_n", "damping_n",
                "inertia_n", "resistance_n", "load_cell_force_n", "phase"):
        assert col in table.column_names
    meta = table.schema.metadata
    assert json.loads(meta[b"pen:summary"])["final_depth_mm"] == record["final_depth_mm"]
    params = json.loads(meta[b"pen:parameters"])
    assert params["penetrator"]["name"] == "appendix_c"
    depth = table.column("depth_m").to_numpy()
    assert depth[0] == pytest.approx(-0.150) and depth[-1] == pytest.approx(record["final_depth_mm"] / 1e3)


def test_predict_out_must_be_parquet(tmp_path, runner):
    r = invoke(runner, "predict", "-p", "appendix_c", "-m", "grill_brick", "-e", "appendix_c", "--out",
               tmp_path / "x.csv")
    assert r.exit_code == 2
    assert not (tmp_path / "x.csv").exists()


def test_predict_terms_switch_terms_off(runner):
    r = invoke(runner, "predict", "-p", "appendix_c", "-m", "grill_brick", "-e", "appendix_c", "--json",
               "--terms", "strength,inertia")
    rec = json.loads(r.stdout)
    assert rec["terms"] == ["strength", "inertia"] and rec["energy_friction_j"] == 0.0
    bad = invoke(runner, "predict", "-p", "appendix_c", "-m", "grill_brick", "-e", "appendix_c", "--terms", "drag")
    assert bad.exit_code == 2 and "drag" in bad.stderr and "strength" in bad.stderr  # CONTRACT §6: usage


def test_predict_json_has_every_contract_key(runner):
    r = invoke(runner, "predict", "-p", "figure10", "-m", "figure10", "-e", "figure10", "--json")
    rec = json.loads(r.stdout)
    for key in ("contact_speed_m_s", "penetration_time_s", "final_depth_mm", "full_penetration",
                "peak_resistance_n", "peak_resistance_depth_mm", "residual_ke_j", "spring_energy_j",
                "energy_strength_j", "energy_friction_j", "energy_damping_j", "energy_inertia_j"):
        assert key in rec
    assert isinstance(rec["full_penetration"], bool)


def test_messages_with_brackets_reach_the_user_intact(runner):
    """Rich markup must not eat '[0.1, 50]' or "pen[daq]" from an error message."""
    r = invoke(runner, "predict", "-p", "al6061_1mm", "-m", "mpacs_c", "-e", "springs_4",
               "--set", "blade_thickness_mm=60")
    assert r.exit_code == 1 and "[0.1, 50] mm" in r.stderr


@pytest.mark.parametrize("args", [
    ("predict", "-p", "figure10", "-m", "figure10", "-e", "figure10", "--set", "blade_width_mm"),
    ("predict", "-p", "figure10", "-m", "figure10", "-e", "figure10", "--terms", "bogus"),
    ("fit", "--material", "m", "all", "--terms", "bogus"),
    ("ingest", "somewhere", "--time-unit", "furlongs"),
    ("ingest", "somewhere", "--position-unit", "cubits"),
])
def test_malformed_options_are_usage_errors(workspace, runner, args):
    """CONTRACT §6: exit 2 for a usage error, with the option named; nothing written."""
    r = invoke(runner, *args)
    assert r.exit_code == 2, r.output
    assert "Invalid value" in r.output or "Invalid value" in r.stderr
    assert not (workspace / "runs.duckdb").exists()


def test_long_commands_report_progress(tmp_path):
    """Tare, subtract-inertia, fit and a single report ran in silence (a diagnosis 146 s)."""
    import shutil

    from pencli import api
    from tests.conftest import REPO

    work = tmp_path / "ws"
    shutil.copytree(REPO / "examples" / "workspace", work)
    db = work / "runs.duckdb"
    calls: list[tuple[str, int, int]] = []
    record = lambda what, done, total: calls.append((what, done, total))  # noqa: E731
    api.tare_runs(db, ["mc-*"], progress=record)
    assert [c[1:] for c in calls] == [(k, 6) for k in range(6)]
    calls.clear()
    api.subtract_inertia_runs(db, ["mc-1.0-4", "mc-1.0-6"], progress=record)
    assert [c[0] for c in calls] == ["mc-1.0-4", "mc-1.0-6"]
    calls.clear()
    api.fit(db, "mpacs_c", ["mc-*"], bootstrap=40, record=False, progress=record)
    boot = [c for c in calls if "bootstrap" in c[0]]
    assert [c[1] for c in boot] == [10, 20, 30, 40] and all(c[2] == 40 for c in boot)
    assert sum("reading" in c[0] for c in calls) == 6


def test_help_loads_neither_numpy_nor_the_api():
    """`pen --help` under 0.3 s rests on this: the heavy modules load when a command runs."""
    import subprocess
    import sys

    probe = ("import importlib.util, sys\n"
             "import pencli.cli\n"
             "sys.argv = ['pen', '--help']\n"
             "try:\n    pencli.cli.main()\nexcept SystemExit:\n    pass\n"
             "heavy = ('numpy', 'scipy', 'pandas', 'pyarrow', 'duckdb', 'numba', 'matplotlib', 'pencli.api')\n"
             "print('loaded:', [m for m in heavy if m in sys.modules\n"
             "                  and not isinstance(sys.modules[m], importlib.util._LazyModule)])\n")
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    assert "Usage: pen" in out.stdout
    assert out.stdout.strip().splitlines()[-1] == "loaded: []"
