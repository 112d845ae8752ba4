"""Batch simulator and `pen sweep`."""

from __future__ import annotations

import json
from dataclasses import fields

import numpy as np
import pyarrow.parquet as pq
import pytest

from pencli import api
from pencli.model.design import Design, design_from_sets
from pencli.model.dynamics import simulate
from pencli.params.load import load_preset
from pencli.predict import chunks
from pencli.predict.batch import designs_from, simulate_batch
from tests.conftest import invoke


def random_designs(n: int, seed: int) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    width = rng.uniform(0.03, 0.3, n)
    nominal = rng.uniform(0.3, 0.7, n)
    sprung = rng.uniform(0.5, 8.0, n)
    return designs_from({
        "blade_width_m": width, "blade_thickness_m": width * rng.uniform(0.005, 0.05, n),
        "tip_angle_rad": np.radians(rng.uniform(10, 90, n)), "penetration_depth_m": rng.uniform(0.03, 0.3, n),
        "sprung_mass_kg": sprung, "load_cell_mass_kg": sprung * rng.uniform(0, 0.5, n),
        "density_kg_m3": rng.uniform(50, 1000, n), "strength_pa": 10 ** rng.uniform(5, 7.5, n),
        "friction_coefficient": rng.uniform(0, 1.2, n), "gravity_m_s2": rng.choice([0.0, 9.81, 1.6], n),
        "strength_factor": rng.uniform(0.1, 2.5, n), "sidewall_pressure_pa": rng.uniform(0, 6e5, n),
        "damping_pa_s_m": rng.choice([0.0, 0.0, 1e5], n) * rng.random(n), "inertia_coefficient": rng.uniform(0, 80, n),
        "spring_count": rng.choice([1, 2, 4, 6], n).astype(float), "spring_stiffness_n_m": rng.uniform(500, 1.5e4, n),
        "spring_mass_kg": rng.uniform(0, 1.5, n), "nominal_length_m": nominal,
        "compressed_length_m": nominal * rng.uniform(0.3, 0.95, n), "surface_offset_m": rng.uniform(0, 0.35, n),
        "efficiency": rng.uniform(0.5, 1.0, n)})


def scalar(d: dict[str, np.ndarray], i: int, speed=None):
    design = Design(**{f.name: (int(d[f.name][i]) if f.name == "spring_count" else float(d[f.name][i]))
                       for f in fields(Design)})
    return simulate(design, speed_at_contact_m_s=speed, output_rate_hz=2000.0).summary


@pytest.mark.slow
def test_batch_agrees_with_the_scalar_simulator_on_3000_random_designs():
    """Each way a run ends in a hundred designs or more; `python -m bench.bench_batch_fuzz --designs 10000` fuzzes
    wider (designs spread 30× either way, half damped)."""
    d = random_designs(3_000, 7)
    speeds = np.where(np.arange(3_000) % 5 == 0, np.random.default_rng(8).uniform(0, 15, 3_000), np.nan)
    flight = np.isnan(speeds)
    batch = simulate_batch({k: v[flight] for k, v in d.items()}).figures
    batch_s = simulate_batch({k: v[~flight] for k, v in d.items()}, speed_at_contact_m_s=speeds[~flight]).figures
    kinds = {"arrest": 0, "full_depth": 0, "springs_spent_before_contact": 0, "speed_given": 0}
    for pos, i in enumerate(np.flatnonzero(flight)):
        ref = scalar(d, i)
        kinds[ref.end] = kinds.get(ref.end, 0) + 1
        kinds["springs_spent_before_contact"] += bool(d["surface_offset_m"][i] > d["nominal_length_m"][i]
                                                      - d["compressed_length_m"][i])
        assert batch["full_penetration"][pos] == ref.full_penetration, i
        for key in ("penetration_time_s", "final_depth_mm", "contact_speed_m_s"):
            want = getattr(ref, key)
            assert batch[key][pos] == pytest.approx(want, rel=1e-4, abs=1e-12), (i, key)
    for pos, i in enumerate(np.flatnonzero(~flight)):
        ref = scalar(d, i, speeds[i])
        kinds["speed_given"] += 1
        for key in ("penetration_time_s", "final_depth_mm"):
            assert batch_s[key][pos] == pytest.approx(getattr(ref, key), rel=1e-4, abs=1e-9), (i, key)
    assert min(kinds.values()) > 100, kinds  # every case is exercised


def test_figure10_sweep_reproduces_point_predictions(tmp_path, runner):
    out = tmp_path / "f10.parquet"
    r = invoke(runner, "sweep", "-p", "figure10", "-m", "figure10", "-e", "figure10", "--speed-at-contact", "7.155133",
               "--vary", "speed_at_contact=+20%,-50%", "--vary", "friction_coefficient=+40%,-30%", "--resolution", "20",
               "--out", out, "--json")
    assert r.exit_code == 0, r.output
    table = pq.read_table(out).to_pydict()
    assert len(table["speed_at_contact"]) == 400
    speeds = sorted(set(table["speed_at_contact"]))
    assert speeds[0] == pytest.approx(7.155133 * 0.5) and speeds[-1] == pytest.approx(7.155133 * 1.2)
    assert sorted(set(table["friction_coefficient"]))[0] == pytest.approx(0.4 * 0.7)
    for i in (0, 137, 399):
        p = api.predict("figure10", "figure10", "figure10", speed_at_contact_m_s=table["speed_at_contact"][i],
                        overrides=[f"friction_coefficient={table['friction_coefficient'][i]!r}"]).result.summary
        assert table["penetration_time_s"][i] == pytest.approx(p.penetration_time_s, rel=1e-4)
        assert table["final_depth_mm"][i] == pytest.approx(p.final_depth_mm, rel=1e-4)


def test_sweep_is_indexed_in_the_workspace(workspace, runner):
    r = invoke(runner, "sweep", "--vary", "blade_thickness_mm=1,1.5,2", "--vary", "spring_stiffness_kn_m=8:12",
               "--resolution", "5", "--json")
    record = json.loads(r.stdout)
    assert record["n_designs"] == 15 and record["sweep_id"] == 1
    assert (workspace / record["path"]).is_file()
    q = invoke(runner, "runs", "query", "SELECT n_designs, penetrator FROM sweeps", "--json")
    assert json.loads(q.stdout) == [{"n_designs": 15, "penetrator": "appendix_c"}]


def test_appendix_c_sensitivity_table(runner):
    rows = api.sensitivity()
    default = rows[0]
    ref = simulate(design_from_sets(load_preset("appendix_c", "penetrator"), load_preset("grill_brick", "material"),
                                    load_preset("appendix_c", "energizing"))).summary
    assert default.key == "(default)" and default.penetration_time_s == pytest.approx(ref.penetration_time_s, rel=1e-4)
    blanks = [r for r in rows if r.penetration_time_s is None]
    assert blanks and all(r.end == "arrest" for r in blanks)
    shorter = [r for r in rows if r.key == "spring_nominal_length_mm" and r.step < 0]
    assert shorter and all(r.end != "invalid" for r in shorter)  # 250 mm free < 300 mm at release: a gravity drop
    wider = next(r for r in rows if r.key == "blade_width_mm" and r.step == 0.5)
    assert wider.peak_resistance_n > default.peak_resistance_n
    r = invoke(runner, "sweep", "--sensitivity")
    assert r.exit_code == 0, r.output
    assert "spring_stif" in r.output and "spring_nom" in r.output and "invalid" not in r.output


@pytest.mark.parametrize("target,until,check", [
    ("max:microstructure_strength_kpa", "full_penetration", lambda s: s.full_penetration),
    ("min:spring_stiffness_kn_m", "depth_mm>=100", lambda s: s.final_depth_mm >= 100),
    ("max:blade_thickness_mm", "peak_n<=1500", lambda s: s.peak_resistance_n <= 1500),
])
def test_inverse_solves_are_right_on_either_side(target, until, check):
    answer = api.solve("al6061_1mm", "mpacs_c", "springs_4", target=target, until=until)
    assert answer.value is not None
    inside = answer.value - (answer.resolution if answer.want == "max" else -answer.resolution) * 0.5
    outside = answer.value + (2 * answer.resolution + 1e-3 * abs(answer.value)) * (1 if answer.want == "max" else -1)
    for value, expect in ((inside, True), (outside, False)):
        p = api.predict("al6061_1mm", "mpacs_c", "springs_4", overrides=[f"{answer.key}={value!r}"],
                        allow_out_of_range=True).result.summary
        assert check(p) == expect, (value, p)


def test_latin_hypercube_is_stratified(tmp_path):
    from pencli.predict.sweep import sample

    cols = sample({"a": (0.0, 1.0), "b": (10.0, 20.0)}, 50, "lhs", seed=3)
    for key, (lo, hi) in (("a", (0, 1)), ("b", (10, 20))):
        bins = np.floor((cols[key] - lo) / (hi - lo) * 50).astype(int)
        assert sorted(bins) == list(range(50))


@pytest.mark.parametrize("n", [1, 2, 3, 5, 64, 65, 1000, 100_003])
def test_hypercube_permutation_is_a_bijection_evaluated_in_any_chunks(n):
    from pencli.predict.sweep import permuted

    keys = np.random.default_rng(n).integers(0, 2 ** 63, 4, dtype=np.uint64)
    whole = permuted(0, n, n, keys)
    assert np.array_equal(np.sort(whole), np.arange(n))  # every stratum exactly once
    cuts = sorted({0, n, *np.random.default_rng(1).integers(0, n + 1, 5)})
    assert np.array_equal(np.concatenate([permuted(a, b, n, keys) for a, b in zip(cuts, cuts[1:])]), whole)


@pytest.mark.parametrize("method", ["lhs", "random"])
def test_sample_is_the_same_in_any_chunks_and_its_keys_are_independent(method):
    from pencli.predict.sweep import Sample

    n = 100_003
    s = Sample({"a": (0.0, 1.0), "b": (-5.0, 5.0), "c": np.array([1.0, 2.0, 3.0])}, n, method, seed=4)
    whole = s.take(0, n)
    parts = [s.take(a, b) for a, b in ((0, 17), (17, 50_000), (50_000, n))]
    for key in whole:
        assert np.array_equal(np.concatenate([p[key] for p in parts]), whole[key])
    a, b = whole["a"], (whole["b"] + 5.0) / 10.0
    assert 0.0 <= a.min() and a.max() < 1.0 and 0.0 <= b.min() and b.max() < 1.0
    limit = 5 / np.sqrt(n)  # a correlation of independent uniforms has sd 1/√n
    assert abs(np.corrcoef(a, b)[0, 1]) < limit
    assert abs(np.corrcoef(a[:-1], a[1:])[0, 1]) < limit  # neighbours in the table are not related
    counts = np.histogram(a, bins=20, range=(0, 1))[0]
    if method == "lhs":
        assert np.array_equal(np.sort(np.floor(a * n).astype(int)), np.arange(n))
        assert counts.max() - counts.min() <= 2  # a stratum may straddle a bin edge
    else:  # 20 bins of about 5,000: chi-squared with 19 degrees of freedom, 99.99 % quantile 52
        assert ((counts - n / 20) ** 2 / (n / 20)).sum() < 52
    assert set(np.unique(whole["c"])) == {1.0, 2.0, 3.0}


def test_batch_reads_values_all_designs_share_without_copies():
    """A field given once (0-d) for every design gives bit for bit what the same value repeated gives."""
    d = random_designs(3000, 12)
    lean = {k: (v if k in ("blade_width_m", "spring_stiffness_n_m", "damping_pa_s_m") else np.asarray(v[7]))
            for k, v in d.items()}
    full = {k: np.broadcast_to(v, (3000,)).copy() for k, v in lean.items()}
    for speed in (None, np.random.default_rng(2).uniform(0, 12, 3000)):
        got, want = simulate_batch(lean, speed_at_contact_m_s=speed), simulate_batch(full, speed_at_contact_m_s=speed)
        assert np.array_equal(got.code, want.code)
        for key, values in want.figures.items():
            assert np.array_equal(got.figures[key], values), key
    one = simulate_batch({k: np.asarray(v[0]) for k, v in d.items()})  # every field shared: one design
    assert len(one) == 1


def test_chunks_do_not_change_results(tmp_path, monkeypatch):
    args = dict(vary=["blade_width_mm=100:200", "friction_coefficient=0.2:0.8"], resolution=40)
    one = api.sweep("appendix_c", "mpacs_c", "appendix_c", out=tmp_path / "one.parquet", workers=1, **args)
    monkeypatch.setattr(chunks, "CHUNK", 300)
    many = api.sweep("appendix_c", "mpacs_c", "appendix_c", out=tmp_path / "many.parquet", workers=2, **args)
    assert one.n_designs == many.n_designs == 1600
    assert pq.read_table(tmp_path / "one.parquet").equals(pq.read_table(tmp_path / "many.parquet"))


def test_dask_engine_gives_identical_results(tmp_path, monkeypatch):
    pytest.importorskip("dask.distributed")
    monkeypatch.setattr(chunks, "CHUNK", 500)
    args = dict(vary=["blade_thickness_mm=1:2", "surface_offset_mm=50:250"], resolution=30)
    local = api.sweep("appendix_c", "grill_brick", "appendix_c", out=tmp_path / "local.parquet", **args)
    dask = api.sweep("appendix_c", "grill_brick", "appendix_c", out=tmp_path / "dask.parquet", engine="dask",
                     workers=2, **args)
    assert local.n_designs == dask.n_designs == 900
    assert pq.read_table(tmp_path / "local.parquet").equals(pq.read_table(tmp_path / "dask.parquet"))


@pytest.mark.parametrize("args,words", [
    (["--vary", "blade_colour=1:2"], "unknown key"),
    (["--vary", "blade_width_mm=wide"], "could not read"),
    (["--vary", "blade_width_mm=-10:100", "--resolution", "3"], "must be > 0"),
    ([], "at least one --vary"),
    (["--solve", "biggest:blade_width_mm"], "max:KEY"),
    (["--solve", "max:blade_width_mm", "--until", "depth>3"], "--until"),
])
def test_bad_sweeps_are_one_line(workspace, runner, args, words):
    r = invoke(runner, "sweep", *args)
    assert r.exit_code == 1 and words in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.output
    assert not (workspace / "sweeps").exists() or not any((workspace / "sweeps").iterdir())


def test_sampled_sweep_keeps_a_list_a_set_of_values(tmp_path):
    """``--vary spring_count=2,4,6 --sample random`` gave 4.55 springs; a list given to
    --vary stays a set of values in a sampled sweep, while a range is sampled continuously."""
    out = tmp_path / "s.parquet"
    api.sweep("al6061_1mm", "mpacs_c", "springs_4", vary=["spring_count=2,4,6", "blade_thickness_mm=1.0,1.5,2.0",
                                                         "friction_coefficient=0.2:0.8"],
              sample="random", n=300, seed=1, out=out)
    table = pq.read_table(out).to_pydict()
    assert set(table["spring_count"]) == {2, 4, 6}
    assert set(table["blade_thickness_mm"]) == {1.0, 1.5, 2.0}
    assert len(set(table["friction_coefficient"])) == 300
    lhs = tmp_path / "l.parquet"
    api.sweep("al6061_1mm", "mpacs_c", "springs_4", vary=["spring_count=2,4,6", "friction_coefficient=0.2:0.8"],
              sample="lhs", n=300, seed=1, out=lhs)
    counts = np.unique(pq.read_table(lhs).to_pydict()["spring_count"], return_counts=True)[1]
    assert list(counts) == [100, 100, 100]  # the hypercube's strata split equally among the values


def test_batch_peak_depth_is_located_inside_the_step():
    """The batch read the peak resistance's depth at step ends (up to 19 % off where R peaks
    inside a step); against the scalar simulator's dense output on random designs."""
    d = random_designs(400, 11)
    batch = simulate_batch(d).figures
    errors = []
    for i in range(400):
        ref = scalar(d, i)
        if ref.end == "no_contact" or ref.peak_resistance_depth_mm <= 0.0:
            continue
        errors.append(abs(batch["peak_resistance_depth_mm"][i] / ref.peak_resistance_depth_mm - 1.0))
        assert batch["peak_resistance_n"][i] == pytest.approx(ref.peak_resistance_n, rel=1e-4), i
    assert len(errors) > 200
    assert max(errors) < 1e-3, max(errors)


def test_a_huge_grid_is_refused_in_one_line_and_a_large_one_is_made_in_slices(workspace, runner, monkeypatch):
    """`--resolution 100000` on two variables built the whole grid before chunking (MemoryError)."""
    r = invoke(runner, "sweep", "-p", "appendix_c", "-m", "mpacs_c", "-e", "appendix_c", "--resolution", "100000",
               "--vary", "blade_width_mm=100:200", "--vary", "blade_thickness_mm=1:2")
    assert r.exit_code == 1 and "1e+10 designs" in r.stderr and "--sample" in r.stderr, r.output
    assert "Traceback" not in r.output and not list(workspace.glob("sweeps/*"))
    import pencli.predict.sweep as sweep_module

    biggest = []
    take = sweep_module.Grid.take

    def spy(self, start, stop):
        biggest.append(stop - start)
        return take(self, start, stop)

    monkeypatch.setattr(sweep_module.Grid, "take", spy)
    r = invoke(runner, "sweep", "-p", "appendix_c", "-m", "mpacs_c", "-e", "appendix_c", "--resolution", "400",
               "--vary", "blade_width_mm=100:200", "--vary", "blade_thickness_mm=1:2", "--json")
    assert r.exit_code == 0, r.output
    from pencli.predict.chunks import CHUNK

    assert sum(biggest) == 160_000 and max(biggest) <= CHUNK < 160_000


def test_sweep_accepts_out_of_range_base_values_when_asked(runner, tmp_path):
    """The validation error tells the user to pass --allow-out-of-range; pen sweep had no such option."""
    args = ["sweep", "-p", "appendix_c", "-m", "mpacs_c", "-e", "appendix_c", "--set", "density_kg_m3=5000",
            "--vary", "blade_width_mm=100:200", "--resolution", "3", "--out", str(tmp_path / "s.parquet"), "--json"]
    refused = invoke(runner, *args)
    assert refused.exit_code != 0 and "--allow-out-of-range" in refused.output
    assert not (tmp_path / "s.parquet").exists()
    accepted = invoke(runner, *args, "--allow-out-of-range")
    assert accepted.exit_code == 0, accepted.output
    assert pq.read_table(tmp_path / "s.parquet").num_rows == 3
    for extra in (["--sensitivity"], ["--solve", "max:microstructure_strength_kpa", "--range", "10:5000"]):
        r = invoke(runner, "sweep", "-p", "appendix_c", "-m", "mpacs_c", "-e", "appendix_c", "--set",
                   "density_kg_m3=5000", "--allow-out-of-range", "--json", *extra)
        assert r.exit_code == 0, (extra, r.output)


def test_cached_kernels_are_dropped_when_any_kernel_source_changes(tmp_path):
    """numba checks a cached kernel against its own file only; a change to a module it calls must drop it."""
    from pencli.predict.compiled import drop_stale_kernels

    folders = [tmp_path / "predict", tmp_path / "model"]
    for folder in folders:
        (folder / "__pycache__").mkdir(parents=True)
        (folder / "kernel.py").write_text("x = 1\n")
    stamp = tmp_path / "predict" / "__pycache__" / "kernels.sha256"

    def cached() -> set[str]:
        for folder in folders:  # what numba would have written since
            (folder / "__pycache__" / "kernel.f-1.py311.nbi").write_text("")
            (folder / "__pycache__" / "kernel.f-1.py311.1.nbc").write_text("")
        return {p.name for folder in folders for p in (folder / "__pycache__").iterdir()}

    assert drop_stale_kernels(folders, stamp)  # no stamp yet: nothing is known about the caches
    before = cached()
    assert not drop_stale_kernels(folders, stamp)  # nothing changed: the caches stay
    assert {p.name for f in folders for p in (f / "__pycache__").iterdir()} == before
    (tmp_path / "model" / "kernel.py").write_text("x = 2\n")  # a callee changes in another folder
    assert drop_stale_kernels(folders, stamp)
    assert {p.name for f in folders for p in (f / "__pycache__").iterdir()} == {"kernels.sha256"}


def test_the_full_penetration_boundary_is_found_where_the_scalar_simulator_flips(tmp_path):
    """Each crossing the batch simulator's bisection places on a grid line has, a ten-thousandth of a grid step
    either side of it along that line, one design that reaches full depth and one that does not, by the scalar
    simulator (an independent integration); the report's map draws exactly those points."""
    import json

    import pyarrow.parquet as pq

    from pencli.predict.sweep import boundary_roots
    from pencli.report import figures
    from pencli.report.sections import sweep_boundary

    x, y = "blade_thickness_mm", "spring_stiffness_kn_m"
    out = tmp_path / "grid.parquet"
    api.sweep("appendix_c", "grill_brick", "appendix_c", vary=[f"{x}=0.8:2.5", f"{y}=6:14"], resolution=7, out=out)
    arrow = pq.read_table(out)
    table = {name: arrow.column(name).to_numpy(zero_copy_only=False) for name in arrow.column_names}
    base = json.loads(arrow.schema.metadata[b"pen:base"])
    points = sweep_boundary(table, base, x, y, [])
    assert points is not None and len(points) >= 4
    xs, ys = np.unique(table[x]), np.unique(table[y])
    step = {x: xs[1] - xs[0], y: ys[1] - ys[0]}

    def reaches(values):
        prediction = api.predict("appendix_c", "grill_brick", "appendix_c",
                                 overrides=[f"{k}={float(v)!r}" for k, v in values.items()])
        return prediction.result.summary.full_penetration

    for px, py in points:
        along = x if np.any(np.isclose(ys, py, rtol=0, atol=1e-9)) else y  # on a row it moved along x
        at = {x: px, y: py}
        below, above = dict(at), dict(at)
        below[along] -= 1e-4 * step[along]
        above[along] += 1e-4 * step[along]
        assert reaches(below) != reaches(above), (px, py, along)
    fig, caption = figures.sweep_map(table, x, y, "final_depth_mm", (), points)
    try:
        (dots,) = [line for line in fig.axes[0].get_lines() if line.get_label() == "full-penetration boundary"]
        assert np.allclose(np.column_stack([dots.get_xdata(), dots.get_ydata()]), points)
        assert f"{len(points)} crossings found on the simulator" in caption
    finally:
        import matplotlib.pyplot as plt

        plt.close(fig)
    assert boundary_roots(base, x, y, xs, ys, np.ones((ys.size, xs.size), dtype=bool)).shape == (0, 2)


def test_designs_not_simulated_have_no_figures_and_are_counted_by_reason(tmp_path):
    """A sweep row the simulator did not run (here a load cell heavier than the body it sits in, which the
    parameter rules forbid) has NaN figures, not zeros, which read as an arrest at the surface, and the
    summary's ranges come from the simulated designs alone."""
    out = tmp_path / "sweep.parquet"
    outcome = api.sweep("al6061_1mm", "mpacs_c", "springs_4", vary=["load_cell_mass_kg=0.1:5",
                                                                    "surface_offset_mm=100:600"],
                        resolution=5, out=out)
    table = pq.read_table(out).to_pydict()
    end = np.asarray(table["end"])
    sprung = load_preset("al6061_1mm", "penetrator").values["sprung_mass_kg"]
    heavy = np.asarray(table["load_cell_mass_kg"]) > sprung
    assert np.array_equal(end == "invalid", heavy) and 0 < heavy.sum() < heavy.size
    floats = [k for k, v in table.items() if k not in ("end", "full_penetration", "load_cell_mass_kg",
                                                     "surface_offset_mm") and isinstance(v[0], float)]
    assert len(floats) == 11
    for key in floats:
        values = np.asarray(table[key], dtype=float)
        assert np.all(np.isnan(values[heavy])), key
        assert np.all(np.isfinite(values[~heavy])), key
    assert not np.any(np.asarray(table["full_penetration"])[heavy])
    assert outcome.summary["not_simulated"] == {"invalid": int(heavy.sum())}
    depth = np.asarray(table["final_depth_mm"])[~heavy]
    assert outcome.summary["final_depth_mm"] == [float(depth.min()), float(depth.max())]
    # the edge of the valid designs is no full-penetration boundary: every design simulated here reaches full
    # depth, so a map of this sweep draws none
    from pencli.report.sections import sweep_boundary

    assert np.all(np.asarray(table["full_penetration"])[~heavy])
    base = json.loads(pq.read_schema(out).metadata[b"pen:base"])
    arrays = {k: np.asarray(v) for k, v in table.items()}
    assert sweep_boundary(arrays, base, "load_cell_mass_kg", "surface_offset_mm", []).shape == (0, 2)


@pytest.mark.parametrize("damping_pa_s_m", [3e4, 3e5, 3e6])
def test_damped_batch_with_the_inertia_term_matches_its_closed_form(damping_pa_s_m):
    """No springs in the bed and no friction: m·v' = −(c + b·v + d·v²) with c = a0 − m·g, a Riccati motion
    with closed forms (written here, not taken from the code under test): the arrest time
    T = m·∫₀^v0 dv/Q(v) = 2m/√Δ·(atan((2d·v0 + b)/√Δ) − atan(b/√Δ)) for Δ = 4dc − b² > 0, or
    m/r·ln((2d·v0 + b − r)(b + r) / ((2d·v0 + b + r)(b − r))) with r = √(−Δ), the depth
    X = m/(2d)·ln(Q(v0)/c) − b/(2d)·T, and the rate terms' work by quadrature over speed."""
    from scipy.integrate import quad

    from pencli.model.resistance import eq9_coefficients

    base = design_from_sets(load_preset("appendix_c", "penetrator"), load_preset("mpacs_c", "material"),
                            load_preset("appendix_c", "energizing"))
    values = {f.name: getattr(base, f.name) for f in fields(Design)}
    values.update(friction_coefficient=0.0, damping_pa_s_m=damping_pa_s_m, penetration_depth_m=2.0)
    design = Design(**values)
    a0, a1, b, d = (float(c) for c in eq9_coefficients(design))
    assert a1 == 0.0 and b > 0.0 and d > 0.0
    m, v0 = design.effective_mass_kg, 9.0
    c = a0 - m * design.gravity_m_s2
    q = lambda v: c + b * v + d * v * v  # noqa: E731
    disc = 4 * d * c - b * b
    if disc > 0:
        root = np.sqrt(disc)
        time = 2 * m / root * (np.arctan((2 * d * v0 + b) / root) - np.arctan(b / root))
    else:
        r = np.sqrt(-disc)
        time = m / r * np.log((2 * d * v0 + b - r) * (b + r) / ((2 * d * v0 + b + r) * (b - r)))
    depth = m / (2 * d) * np.log(q(v0) / c) - b / (2 * d) * time
    damping_work = quad(lambda v: b * v * v * m / q(v), 0.0, v0, epsabs=0, epsrel=1e-13)[0]
    inertia_work = quad(lambda v: d * v ** 3 * m / q(v), 0.0, v0, epsabs=0, epsrel=1e-13)[0]

    arrays = designs_from({f.name: np.asarray(values[f.name], dtype=float) for f in fields(Design)})
    arrays["surface_offset_m"] = np.asarray(design.stroke_m + 0.01)  # the springs are spent before contact
    result = simulate_batch(arrays, speed_at_contact_m_s=v0)
    assert result.end[0] == "arrest"
    assert result.figures["penetration_time_s"][0] == pytest.approx(time, rel=1e-8)
    assert result.figures["final_depth_mm"][0] == pytest.approx(depth * 1e3, rel=1e-8)
    assert result.figures["energy_damping_j"][0] == pytest.approx(damping_work, rel=1e-8)
    assert result.figures["energy_inertia_j"][0] == pytest.approx(inertia_work, rel=1e-8)
