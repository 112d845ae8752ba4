"""Sim-to-real gap diagnosis (pure core)."""

FALSE_ALARM = 0.01
"""Default probability that a campaign with no effect gets any verdict but ``none``."""
BOOTSTRAP = 200
"""Default number of null replicates.  The family-wise threshold extrapolates a Gumbel tail to the effect test's
rate (a third of the false-alarm rate, 0.33 %): from 60 replicates, nulls of known law with heavy tails were
called 1.7 % (t₃) and 8.2 % (a point mass with 5 % χ²₁) of the time, from 200 0.6 % and 1.4 %
(``python -m bench.bench_null_calibration 1500 7 --engine``, 1,500 trials each); about 1.5 × the time."""

SHUFFLES = 199
"""Default rotations that make the null of a drops diagnosis (:mod:`pencli.diagnose.drops`): the smallest p-value
they resolve is 1/200, a fifth of the false-alarm rate."""
SOUNDING_FALSE_ALARM = 0.002
"""Default probability that a site without a rate effect gets the verdict ``rate_effect``
(:mod:`pencli.diagnose.soundings`).  A site is one test, cheap to resolve finely (a thousand shuffles take a few
seconds), so the rate is set for a survey rather than a site: twenty sites without an effect all go
uncalled with probability 0.998²⁰ = 0.96."""
SOUNDING_SHUFFLES = 999
"""Default shuffles of the rates among a site's soundings (the smallest p-value they resolve is 1/1000, half of
:data:`SOUNDING_FALSE_ALARM`); a site whose soundings have no more orderings than this (up to six soundings) is
tested on all of them, exactly."""

WORKERS = 2
"""Default processes (and compiled threads) of a diagnosis: this machine class's two cores. [–]"""
MAX_WORKERS = 64
"""The most processes ``--workers`` or ``PEN_WORKERS`` may ask for. [–]"""


def params_text(params: dict) -> str:
    """An effect's parameters on one line, numbers to three significant digits (a per-run mapping as
    ``{run: value, …}``), as the CLI and the report print them."""
    def value(v) -> str:
        if isinstance(v, float):
            return f"{v:.3g}"
        if isinstance(v, dict):
            return "{" + ", ".join(f"{k}: {value(x)}" for k, x in v.items()) + "}"
        return str(v)
    return ", ".join(f"{k}={value(v)}" for k, v in params.items())
