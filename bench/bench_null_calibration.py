"""Calibration of the diagnosis's family-wise decision on nulls of known shape.

Run: python -m bench.bench_null_calibration [TRIALS] [SEED] [--engine]

Each trial draws 61 rows (the data, then 60 null replicates) of 11 families' held-out improvements, all from
the same null law, so the data holds no effect; the data is a false alarm when its largest standardised
improvement beats the threshold.  Printed per law: the false-alarm rate of pen's rule
(:func:`pencli.diagnose.engine.familywise_threshold`, replicates standardised out of sample) beside the
rule that standardises the replicates by the scale they helped set (the rule pen does not use), in the same run, on the same draws, at a stated rate of 1 %.  The laws: normal, χ²₁ (skewed), t₃
(heavy-tailed), and a point mass at 0 with 5 % χ²₁ (a sign-bounded family at its bound).

``--engine``: the rate the diagnosis actually states for its effect test (its default false-alarm rate shared by
three tests, :data:`pencli.diagnose.FALSE_ALARM` / 3), pen's rule with 60 replicates (an older default) beside the current default (:data:`pencli.diagnose.BOOTSTRAP`), each on its own
draws of the same laws.  The Gumbel tail is extrapolated further at that rate, and from fewer points with 60.
"""

from __future__ import annotations

import sys

import numpy as np

from pencli.diagnose import BOOTSTRAP, FALSE_ALARM
from pencli.diagnose.engine import _standardise, familywise_threshold
from pencli.diagnose.null import gumbel_quantile
from pencli.testing.nulls import largest_z, point_mass

FAMILIES, REPLICATES, ALPHA = 11, 60, 0.01


LAWS = {
    "normal": lambda rng, shape: rng.normal(size=shape),
    "chi2(1)": lambda rng, shape: rng.chisquare(1, shape),
    "t(3)": lambda rng, shape: rng.standard_t(3, shape),
    "point mass + 5 % chi2(1)": point_mass,
}


def _in_sample_threshold(improvements: np.ndarray, floor: float, alpha: float) -> float:
    z = []
    for k in range(improvements.shape[1]):
        _, centre, scale = _standardise(improvements[:, k], floor)
        z.append((improvements[1:, k] - centre) / scale)
    return gumbel_quantile(np.max(np.array(z), axis=0), alpha)


def main(trials: int = 300, seed: int = 0) -> None:
    rng = np.random.default_rng(seed)
    print(f"{trials} trials per law, {FAMILIES} families, {REPLICATES} replicates, stated rate {ALPHA:.0%}")
    print(f"{'null law':28s} {'pen (out of sample)':>22s} {'in sample (before)':>20s}")
    for name, draw in LAWS.items():
        alarms = np.zeros(2)
        for _ in range(trials):
            values = draw(rng, (REPLICATES + 1, FAMILIES))
            data = largest_z(values)
            alarms += [data > familywise_threshold(values, 1e-9, ALPHA),
                       data > _in_sample_threshold(values, 1e-9, ALPHA)]
        rate = alarms / trials
        print(f"{name:28s} {rate[0]:>21.1%} {rate[1]:>20.1%}")


def engine_rate(trials: int = 3000, seed: int = 0) -> None:
    """False-alarm rate of pen's rule at the effect test's own rate, 60 replicates beside the default."""
    rng = np.random.default_rng(seed)
    alpha = FALSE_ALARM / 3.0
    counts = (60, BOOTSTRAP)
    print(f"{trials} trials per law and count, {FAMILIES} families, stated rate {alpha:.2%} (the effect test's)")
    print(f"{'null law':28s} " + " ".join(f"{f'{n} replicates':>16s}" for n in counts))
    for name, draw in LAWS.items():
        rates = []
        for n in counts:
            alarms = 0
            for _ in range(trials):
                values = draw(rng, (n + 1, FAMILIES))
                alarms += largest_z(values) > familywise_threshold(values, 1e-9, alpha)
            rates.append(alarms / trials)
        print(f"{name:28s} " + " ".join(f"{r:>16.2%}" for r in rates), flush=True)


if __name__ == "__main__":
    numbers = [int(a) for a in sys.argv[1:] if not a.startswith("--")]
    (engine_rate if "--engine" in sys.argv else main)(*numbers[:2])
