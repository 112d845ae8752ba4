"""Compute time of one `pen predict` beside scipy solve_ivp (RK45, rtol 1e-6), same design, same run.

Run: python -m bench.bench_predict
Prints the median of repeated timings for both and their ratio, plus the
accuracy of each against a tight independent integration (pencli/testing/reference.py).
Target: pen under 20 ms per prediction.
"""

from __future__ import annotations

import math
import statistics
import time

from scipy.integrate import solve_ivp

from pencli.model.design import design_from_sets
from pencli.model.dynamics import simulate
from pencli.params.load import load_preset
from pencli.testing.reference import reference_run

DESIGNS = [("appendix_c", "grill_brick", "appendix_c"), ("figure10", "figure10", "figure10"),
           ("al6061_1mm", "mpacs_c", "springs_4")]


def baseline_rk45(d):
    """What a MATLAB ode45 loop does: RK45 at rtol 1e-6 from release, events for contact/arrest/depth."""
    m = d.effective_mass_kg
    kd, stroke, s0 = d.drive_stiffness_n_m, d.stroke_m, d.surface_offset_m
    a0 = d.blade_width_m * d.blade_thickness_m * d.strength_factor * d.strength_pa * (
        math.sin(d.tip_angle_rad) + d.friction_coefficient * math.cos(d.tip_angle_rad))
    a1 = 2 * d.friction_coefficient * d.sidewall_pressure_pa * d.blade_width_m
    b = d.blade_width_m * d.blade_thickness_m * d.damping_pa_s_m
    dd = d.blade_width_m * d.blade_thickness_m * d.inertia_coefficient * d.density_kg_m3

    def rhs(t, y):
        x, v = y
        spring = kd * (stroke - x - s0) if x + s0 < stroke else 0.0
        vp = max(v, 0.0)
        r = a0 + a1 * x + b * vp + dd * vp * vp if x > 0 else 0.0
        return [v, (spring + m * d.gravity_m_s2 - r) / m]

    def depth(t, y):
        return y[0] - d.penetration_depth_m

    def arrest(t, y):
        return y[1] if y[0] > 0 else 1.0

    def surface(t, y):
        return y[0]

    depth.terminal = arrest.terminal = True
    arrest.direction = -1
    sol = solve_ivp(rhs, (0, 5), [-s0, 0.0], method="RK45", rtol=1e-6, events=[depth, arrest, surface])
    t_contact = sol.t_events[2][0]
    return {"penetration_time_s": sol.t[-1] - t_contact, "final_depth_mm": sol.y[0, -1] * 1e3}


def timed(fn, repeat=30):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def main() -> None:
    print(f"{'design':40s} {'pen ms':>7s} {'RK45 ms':>8s} {'RK45/pen':>8s}  "
          f"{'pen err':>8s} {'RK45 err':>8s}  (max rel. error in penetration time and final depth "
          f"vs a Radau rtol 1e-12 reference)")
    for p, m, e in DESIGNS:
        sets = [load_preset(p, "penetrator"), load_preset(m, "material"), load_preset(e, "energizing")]
        design = design_from_sets(*sets)
        simulate(design)  # warm-up
        t_pen, result = timed(lambda: simulate(design))
        t_base, base = timed(lambda: baseline_rk45(design))
        ref = reference_run(*[s.to_mapping() for s in sets])
        summary = result.summary.to_dict()
        keys = ("penetration_time_s", "final_depth_mm")
        pen_err = max(abs(summary[k] / ref[k] - 1) for k in keys)
        base_err = max(abs(base[k] / ref[k] - 1) for k in keys)
        print(f"{p + ' / ' + m + ' / ' + e:40s} {t_pen * 1e3:7.2f} {t_base * 1e3:8.2f} {t_base / t_pen:8.2f}  "
              f"{pen_err:8.1e} {base_err:8.1e}")
    print("target: pen under 20 ms per prediction (trajectory sampled at 50 kHz included)")


if __name__ == "__main__":
    main()
