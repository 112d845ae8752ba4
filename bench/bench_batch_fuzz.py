"""The batch simulator against the scalar one on a wide random fuzz: how every run ends, and the figures.

Run: python -m bench.bench_batch_fuzz [--designs N] [--seed S] [--spread F] [--documented]
Designs around the Appendix C blade in grill brick with w, T, S, P, K, ρ, k, stand-off and sprung mass each
spread log-uniformly over F× either way (default 30), half of them damped (C log-uniform over
10³ … 10⁸ Pa·s/m); ``--documented`` clips every value to its documented range (``pen params keys``).  The
scalar simulator (:func:`pencli.model.dynamics.simulate`, DOP853 at rtol 1e-10, events) is the reference;
designs it refuses (a force beyond 10³⁰ N, a CONTRACT §1 rule) must end ``overflow`` / ``invalid`` in the
batch.  Prints the count of ends that differ and the largest relative difference per figure (the sweep's
target is 1e-4); the damping and inertia work are compared relative to the run's energy budget (the work of
strength, friction and the rate terms plus the residual kinetic energy), since a term that took 10⁻⁷ of it
is known only to that share.
"""

from __future__ import annotations

import sys
import time
from dataclasses import fields, replace

import numpy as np

from pencli.errors import PenError
from pencli.model.design import Design, design_from_sets
from pencli.model.dynamics import simulate
from pencli.params.definitions import PARAMETERS
from pencli.params.load import load_preset
from pencli.predict.batch import design_arrays, simulate_batch

SPREAD = ("blade_width_m", "blade_thickness_m", "strength_pa", "sidewall_pressure_pa", "inertia_coefficient",
          "density_kg_m3", "spring_stiffness_n_m", "surface_offset_m", "sprung_mass_kg")
FIGURES = ("penetration_time_s", "final_depth_mm", "peak_resistance_n", "residual_ke_j", "contact_speed_m_s",
           "energy_damping_j", "energy_inertia_j")


def main() -> None:
    n = int(sys.argv[sys.argv.index("--designs") + 1]) if "--designs" in sys.argv else 4000
    seed = int(sys.argv[sys.argv.index("--seed") + 1]) if "--seed" in sys.argv else 1
    spread = float(sys.argv[sys.argv.index("--spread") + 1]) if "--spread" in sys.argv else 30.0
    ranges = {p.si_name: ((p.range_min if p.range_min is not None else -np.inf) * p.si_scale,
                          (p.range_max if p.range_max is not None else np.inf) * p.si_scale)
              for p in PARAMETERS if p.si_name} if "--documented" in sys.argv else {}
    base = design_from_sets(load_preset("appendix_c", "penetrator"), load_preset("grill_brick", "material"),
                            load_preset("appendix_c", "energizing"))
    rng = np.random.default_rng(seed)
    designs = []
    for i in range(n):
        values = {name: getattr(base, name) * spread ** rng.uniform(-1, 1) for name in SPREAD}
        values["damping_pa_s_m"] = 10 ** rng.uniform(3, 8) if i % 2 else 0.0
        values = {name: float(np.clip(value, *ranges[name])) if name in ranges else value
                  for name, value in values.items()}
        values["load_cell_mass_kg"] = min(base.load_cell_mass_kg, values["sprung_mass_kg"])
        if values["blade_thickness_m"] >= values["blade_width_m"]:  # CONTRACT §1 forbids it: draw again
            values["blade_thickness_m"] = values["blade_width_m"] * rng.uniform(0.005, 0.5)
        designs.append(replace(base, **values))
    arrays = {f.name: np.concatenate([design_arrays(d)[f.name] for d in designs]) for f in fields(Design)}
    t0 = time.perf_counter()
    batch = simulate_batch(arrays)
    batch_s = time.perf_counter() - t0
    ends, mismatched, worst, where = {}, [], dict.fromkeys(FIGURES, 0.0), dict.fromkeys(FIGURES, -1)
    t0 = time.perf_counter()
    for i, design in enumerate(designs):
        try:
            ref = simulate(design, output_rate_hz=1000.0).summary
            ref_end = ref.end
        except PenError:
            ref, ref_end = None, "refused"
        got = str(batch.end[i])
        ends[got] = ends.get(got, 0) + 1
        if ref is None:
            if got not in ("overflow", "invalid"):
                mismatched.append((i, "refused", got))
            continue
        if got != ref_end:
            mismatched.append((i, ref_end, got))
            continue
        budget = ref.energy_strength_j + ref.energy_friction_j + ref.energy_damping_j + ref.energy_inertia_j \
            + ref.residual_ke_j  # where the run's energy went
        for key in FIGURES:
            want, have = float(getattr(ref, key)), float(batch.figures[key][i])
            scale = max(abs(want), budget if key.startswith("energy_") else 0.0, 1e-12)
            if (want or have) and abs(have - want) / scale > worst[key]:
                worst[key], where[key] = abs(have - want) / scale, (i, ref_end)
    scalar_s = time.perf_counter() - t0
    print(f"{n:,} designs (seed {seed}, spread {spread:g}x{', clipped to the documented ranges' if ranges else ''}): "
          f"batch {batch_s:.2f} s, scalar simulator {scalar_s:.1f} s")
    print("ends in the batch: " + ", ".join(f"{k} {v}" for k, v in sorted(ends.items())))
    print(f"ends that differ from the scalar simulator: {len(mismatched)}" +
          "".join(f"; design {i}: scalar {ref}, batch {got}" for i, ref, got in mismatched[:10]))
    print("largest relative difference where both end alike: " +
          ", ".join(f"{k} {v:.1e}" for k, v in worst.items()) + "   (target 1e-4)")
    print("  at (design, end): " + ", ".join(f"{k} {where[k]}" for k in FIGURES))


if __name__ == "__main__":
    main()
