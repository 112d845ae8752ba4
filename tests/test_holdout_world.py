"""The hold-out truth world's own checks (pencli/testing/holdout_world.py; pen never imports it)."""

from __future__ import annotations

from pathlib import Path

from pencli.testing import holdout_world


def test_a_bessel_lag_shorter_than_the_sampling_shows_leaves_the_record_as_without_it(tmp_path: Path):
    """At 4 % of its drawn size, seed 900001's Bessel lag is 7 µs: its corner (23 kHz) lies past the Nyquist
    frequency of the 30 kHz record, where it passes all the record holds.  The world raised there (scipy refuses a
    digital corner past Nyquist) and stopped a hold-out ladder; its records must equal the same
    campaign's without the lag, sample for sample."""
    lagged = holdout_world.make_campaign(tmp_path / "lag", 900001, ["sensor_lag"], intensity=0.04)
    assert lagged.effects[0]["form"] == "bessel" and lagged.effects[0]["time_ms"] < 0.01
    plain = holdout_world.make_campaign(tmp_path / "plain", 900001, [], intensity=0.04)
    assert len(lagged.folders) == len(plain.folders) > 0
    for with_lag, without in zip(lagged.folders, plain.folders):
        assert (Path(with_lag) / "data.csv").read_text() == (Path(without) / "data.csv").read_text()
