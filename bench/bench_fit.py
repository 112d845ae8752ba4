"""Time of a 12-run fit in each mode beside scipy least_squares over per-run solve_ivp simulations.

Run: python -m bench.bench_fit
Targets: resistance mode under 1 s, dynamic mode under 20 s.
The baseline is what a straightforward port of BAM would do: resistance
mode, Eq. 9 evaluated sample by sample in Python inside least_squares;
dynamic mode, for every candidate coefficient vector, integrate each run with
solve_ivp (RK45, rtol 1e-6) and compare force and position with the same
weights as pen.
"""

from __future__ import annotations

import math
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import least_squares

from pencli import api
from pencli.fit.dynamic import fit_dynamic
from pencli.fit.resistance import fit_resistance, windows
from pencli.testing.campaigns import make_campaign


def baseline_resistance(series, x0):
    def residuals(theta):
        cs, p_kpa, c_kpa, k = theta
        out = []
        for s in series:
            d = s.design
            for x, v, r in zip(s.depth_m, s.velocity_m_s, s.resistance_n):
                vp = max(v, 0.0)
                model = d.blade_width_m * d.blade_thickness_m * (
                    cs * d.strength_pa * (math.sin(d.tip_angle_rad) + d.friction_coefficient * math.cos(d.tip_angle_rad))
                    + d.friction_coefficient * p_kpa * 1e3 * 2 * x / d.blade_thickness_m + c_kpa * 1e3 * vp
                    + k * d.density_kg_m3 * vp * vp)
                out.append((model - r) / math.sqrt(len(s.time_s)))
        return np.array(out)

    return least_squares(residuals, x0, bounds=(0, np.inf)).x


def baseline_dynamic(series, x0):
    def simulate(s, theta):
        d = s.design
        cs, p_kpa, c_kpa, k = theta
        m = d.effective_mass_kg
        kd, stroke, s0 = d.drive_stiffness_n_m, d.stroke_m, d.surface_offset_m
        a0 = d.blade_width_m * d.blade_thickness_m * cs * d.strength_pa * (
            math.sin(d.tip_angle_rad) + d.friction_coefficient * math.cos(d.tip_angle_rad))

        def rhs(t, y):
            x, v = y
            spring = kd * (stroke - x - s0) if x + s0 < stroke else 0.0
            vp = max(v, 0.0)
            r = (a0 + 2 * d.friction_coefficient * p_kpa * 1e3 * d.blade_width_m * x
                 + d.blade_width_m * d.blade_thickness_m * (c_kpa * 1e3 * vp + k * d.density_kg_m3 * vp * vp)) if x > 0 else 0.0
            return [v, (spring + m * d.gravity_m_s2 - r) / m]

        def arrest(t, y):
            return y[1] if y[0] > 0 else 1.0

        arrest.terminal, arrest.direction = True, -1
        sol = solve_ivp(rhs, (0, s.time_s[-1] + 0.01), [-s0, 0.0], method="RK45", rtol=1e-6, dense_output=True,
                        events=arrest)
        t = np.clip(s.time_s, 0, sol.t[-1])
        x, v = sol.sol(t)
        vp = np.maximum(v, 0.0)
        r = np.where(x > 0, a0 + 2 * d.friction_coefficient * p_kpa * 1e3 * d.blade_width_m * x
                     + d.blade_width_m * d.blade_thickness_m * (c_kpa * 1e3 * vp + k * d.density_kg_m3 * vp * vp), 0.0)
        return x, r

    def residuals(theta):
        parts = []
        for s in series:
            x, r = simulate(s, theta)
            w = 1 / math.sqrt(len(s.time_s))
            parts += [(x - s.depth_m) / 1e-3 * w, (r - s.resistance_n) / (0.02 * s.resistance_n.max()) * w]
        return np.concatenate(parts)

    return least_squares(residuals, x0, bounds=(0, np.inf), diff_step=1e-4).x


def timed(fn):
    t0 = time.perf_counter()
    out = fn()
    return time.perf_counter() - t0, out


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        db = make_campaign(Path(tmp), "mpacs_c", seed=21)
        api.tare_runs(db, ["all"])
        api.subtract_inertia_runs(db, ["all"])
        runs = api.load_campaign(db, ["all"])
        series = windows(runs)  # the analysis windows the baselines read
        t_res, res = timed(lambda: fit_resistance(runs, "mpacs_c", bootstrap=0, leave_one_out=False))
        t_res_full, _ = timed(lambda: fit_resistance(runs, "mpacs_c"))
        x0 = np.array([1.0, 10.0, 1.0, 10.0])
        t_base_res, base_res = timed(lambda: baseline_resistance(series, x0))
        t_dyn, dyn = timed(lambda: fit_dynamic(runs, "mpacs_c", res.values()))
        t_base_dyn, base_dyn = timed(lambda: baseline_dynamic(series, np.array(list(res.values().values()))))
    print("12-run MPACS C campaign from the simulated rig (truth Cs 0.6, P 31.6 kPa, C 0, K 34.4):")
    print(f"  resistance mode, pen:            {t_res:7.3f} s   (target < 1 s)  K = {res.values()['inertia_coefficient']:.2f}")
    print(f"    with 200-run bootstrap + LORO: {t_res_full:7.3f} s")
    print(f"    baseline least_squares:        {t_base_res:7.3f} s   ratio {t_base_res / t_res:.0f}x  K = {base_res[3]:.2f}")
    print(f"  dynamic mode, pen:               {t_dyn:7.3f} s   (target < 20 s) K = {dyn.values()['inertia_coefficient']:.2f}")
    print(f"    baseline least_squares+RK45:   {t_base_dyn:7.3f} s   ratio {t_base_dyn / t_dyn:.1f}x  K = {base_dyn[3]:.2f}")


if __name__ == "__main__":
    main()
