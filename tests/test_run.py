"""The one run object: what the readers, the store and conditioning make of a run, and a campaign of them."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from pencli import api
from pencli.errors import DataError, StoreError
from pencli.io.runfolder import read_run_folder
from pencli.run import RAW_COLUMNS, Campaign
from tests.conftest import REPO

EXAMPLE = REPO / "examples" / "workspace"


@pytest.fixture(scope="module")
def example(tmp_path_factory):
    """A copy of the bundled example workspace (tared and inertia-subtracted runs)."""
    root = tmp_path_factory.mktemp("example")
    shutil.copytree(EXAMPLE, root / "workspace")
    return root / "workspace" / "runs.duckdb"


def test_a_stored_run_carries_its_lineage_events_and_parameter_sets(example):
    ws = api.workspace(example)
    run = ws.load_run("mc-1.0-4")
    records = ws.stages("mc-1.0-4")
    assert [s.name for s in run.lineage] == ["raw", "tare", "inertia"]
    assert [s.number for s in run.lineage] == [r.stage_no for r in records if r.stage_no in
                                               {s.number for s in run.lineage}]
    assert run.lineage[0].parent is None
    assert all(b.parent == a.number for a, b in zip(run.lineage, run.lineage[1:]))
    assert run.stage == "inertia" and run.events.to_dict() == records[-1].parameters["events"]
    assert run.material.name == "mpacs_c" and run.design.blade_thickness_m == pytest.approx(1e-3)
    raw = ws.load_run("mc-1.0-4", "raw")
    assert tuple(raw.columns) == RAW_COLUMNS and raw.events is None and raw.stage == "raw"


def test_the_tare_of_a_run_object_is_the_stage_pen_tare_stored(example):
    """`pen tare` stores what :meth:`Run.tared` returns, and the raw run it was given stays as it was."""
    ws = api.workspace(example)
    raw = ws.load_run("gb-1.5-4", "raw")
    before = {k: v.copy() for k, v in raw.columns.items()}
    tared = raw.tared()
    stored = ws.load_run("gb-1.5-4", "tare")
    assert set(tared.columns) == set(stored.columns)
    for name in stored.columns:
        np.testing.assert_array_equal(tared.columns[name], stored.columns[name])
    assert tared.events == stored.events
    assert tared.lineage[-1].parent == raw.lineage[-1].number
    for name, values in before.items():
        np.testing.assert_array_equal(raw.columns[name], values)


def test_a_run_read_from_a_folder_conditions_without_a_workspace(tmp_path, example):
    folder = api.export_run(example, "mc-1.5-2", tmp_path / "mc-1.5-2")
    run = read_run_folder(folder)
    assert run.run_id == "" and run.stage == "raw" and run.name == "mc-1.5-2"
    inertia, estimate = run.tared().inertia_subtracted("spline")
    assert inertia.stage == "inertia" and [s.name for s in inertia.lineage] == ["tare", "inertia"]
    # the window is the tare's: inside it the tip is in the material and moving
    depth, speed = inertia.in_window("depth_m"), inertia.in_window("velocity_m_s")
    assert depth.size > 100 and depth.min() >= 0.0 and speed.min() > 0.0
    stored = api.workspace(example).load_run("mc-1.5-2")
    np.testing.assert_allclose(inertia.columns["resistance_n"], stored.columns["resistance_n"], rtol=0, atol=1e-9)
    with pytest.raises(StoreError, match="only a new stage of a stored run"):
        api.workspace(example).save_stage(inertia)


def test_a_stage_out_of_order_is_one_line_naming_the_step(example):
    raw = api.workspace(example).load_run("mc-1.0-6", "raw")
    with pytest.raises(DataError, match=r"run 'mc-1.0-6'.*pen tare mc-1.0-6"):
        raw.inertia_subtracted("spline")
    with pytest.raises(DataError, match="no events"):
        _ = raw.window
    with pytest.raises(DataError, match=r"no column 'resistance_n'.*pen subtract-inertia"):
        raw.column("resistance_n")


def test_a_campaign_is_a_sequence_of_runs_and_the_fit_takes_it(example):
    from pencli.fit.resistance import fit_resistance

    campaign = api.load_campaign(example, ["mc-*", "gb-1.0-2"])
    assert isinstance(campaign, Campaign) and len(campaign) == 7
    assert campaign.ids[-1] == "gb-1.0-2" and campaign.materials == ("grill_brick", "mpacs_c")
    assert isinstance(campaign[:2], Campaign) and campaign[:2].ids == campaign.ids[:2]
    assert campaign.by_id("gb-1.0-2") is campaign[-1]
    with pytest.raises(KeyError):
        campaign.by_id("nope")
    mc = Campaign(tuple(r for r in campaign if r.material.name == "mpacs_c"))
    as_list = fit_resistance(list(mc), "mpacs_c", bootstrap=0).values()
    assert fit_resistance(mc, "mpacs_c", bootstrap=0).values() == as_list
    # the example's MPACS C truth (REFERENCE Table 1): Cs 0.6, P 31.6 kPa, K 34.4
    assert as_list["strength_factor"] == pytest.approx(0.6, rel=0.03)
    assert as_list["inertia_coefficient"] == pytest.approx(34.4, rel=0.03)


def test_a_campaign_of_unconditioned_runs_is_refused_naming_the_run(tmp_path, example):
    shutil.copytree(example.parent, tmp_path / "ws")
    db = tmp_path / "ws" / "runs.duckdb"
    api.remove_runs(db, ["mc-2.0-2"], stage="inertia", purge=True)
    with pytest.raises(DataError, match=r"run 'mc-2.0-2'.*latest stage is 'tare'.*pen subtract-inertia mc-2.0-2"):
        api.load_campaign(db, ["mc-*"])
