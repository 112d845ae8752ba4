"""Which derivative method? Error of velocity and acceleration against the simulated rig's true motion.

Run: python -m bench.bench_derivatives [--cones [--material NAME]]
For a set of simulated shots (two materials, three blades, 2/4/6 springs),
each method differentiates the quantised encoder record (0.16 mm counts at
30 kHz); errors are RMS over the penetration window against the true
motion, and the acceleration error is also shown as the force error it
causes (× load-cell mass) relative to the peak resistance.

``--cones``: instead, nine cones (25, 35.7 and 50 mm shafts, 30° half-angle; 2, 4 and 6 springs) into MPACS C
(or ``--material``),
four encoder phases each: the smoothing spline, the least-squares spline, and the least-squares spline joined
where the tip passes the cone's shoulder (the inertia stage's choice for a resistance with a corner,
``pencli.filter.inertia.method_for``); force error m_lc·(a − a_true) over the peak resistance, mean and RMS
inside the window and by distance from its edges.
"""

from __future__ import annotations

import itertools
import sys
import time
from dataclasses import replace

import numpy as np

from pencli.acquire.calibration import load_force_calibration, load_position_calibration
from pencli.acquire.drivers import ShotSetup
from pencli.acquire.rig import rig_from_mapping
from pencli.acquire.sim import SimRig
from pencli.filter.derivatives import CORNER_METHOD, DEFAULT_METHOD, METHODS
from pencli.filter.tare import detect_events
from pencli.model.geometry import corner_depths_m, geometry_of
from pencli.model.design import design_from_sets
from pencli.params.validate import validate_mapping
from pencli.testing.options import check_options
from pencli.filter.windows import FIT_EDGE_MARGINS_S, WINDOW_TRIM_S
from pencli.params.load import load_preset

SHOTS = [("grill_brick", "1", 2), ("grill_brick", "1.5", 4), ("grill_brick", "2", 6),
         ("mpacs_c", "1", 4), ("mpacs_c", "1.5", 6), ("mpacs_c", "2", 2)]


def shot(material, blade, springs, seed, phase=0.5):
    """A simulated shot of the bundled blade ``blade`` mm thick, or of the penetrator parameter set ``blade``."""
    rig = SimRig(rig_from_mapping({"seed": seed}), load_position_calibration(), load_force_calibration())
    p = blade if not isinstance(blade, str) else load_preset(f"al6061_{blade}mm", "penetrator")
    m, e = load_preset(material, "material"), load_preset(f"springs_{springs}", "energizing")
    rig.arm(ShotSetup(30000.0, 1.0, 0.2, p, m, e))
    rig.fire()
    motion = rig.motion
    pad = 6000  # 0.2 s of rest before the release and after the stop, as a recording keeps
    u_true = np.concatenate([np.zeros(pad), motion.displacement_m, np.full(pad, motion.displacement_m[-1])])
    t = (np.arange(u_true.size) - pad) / 30000.0
    counts = np.floor(u_true * 1e3 * 6.25 + phase)  # the grating's phase at rest: first count after 1 − phase
    x = counts / 6.25 * 1e-3 - e.values["surface_offset_mm"] * 1e-3
    events = detect_events(t, x, p.values["penetration_depth_mm"] * 1e-3)
    return motion, t, x, events, rig.world.true_load_cell_mass_kg, pad


CONE = {"kind": "penetrator", "name": "cone", "geometry": "cone", "cone_half_angle_deg": 30.0,
        "penetration_depth_mm": 133.0, "sprung_mass_kg": 2.443, "load_cell_mass_kg": 0.389}
"""The cones of ``--cones`` (a shaft diameter is added per shot)."""


def cones() -> None:
    """The three ways on nine cones × four encoder phases (see the module docstring)."""
    from pencli.filter.derivatives import derivatives
    from pencli.filter.inertia import corner_times, motion_breaks, motion_joins

    ways = {"spline": ("spline", False), "lsq_spline": ("lsq_spline", False),
            f"{CORNER_METHOD} joined": (CORNER_METHOD, True)}
    rows = {name: {"inside": [], "contact": [], "stop": []} for name in ways}
    chosen = sys.argv[sys.argv.index("--material") + 1] if "--material" in sys.argv else "mpacs_c"
    material = load_preset(chosen, "material")
    for i, (diameter, springs) in enumerate(itertools.product((25.0, 35.7, 50.0), (2, 4, 6))):
        penetrator = validate_mapping({**CONE, "shaft_diameter_mm": diameter}, "cone")
        corners = corner_depths_m(geometry_of(penetrator), design_from_sets(
            penetrator, material, load_preset(f"springs_{springs}", "energizing")))
        for phase in (0.5, 0.1, 0.35, 0.8):
            motion, t, x, events, m_lc, pad = shot(chosen, penetrator, springs, 100 + i, phase)
            c = int(np.searchsorted(t, events.contact_s))
            s = min(int(np.searchsorted(t, events.stop_s)), pad + motion.acceleration_m_s2.size)
            window, truth = slice(c, s), slice(c - pad, s - pad)
            for name, (method, joined) in ways.items():
                ev = replace(events, corners_s=corner_times(t, x, events, corners)) if joined else events
                _, a = derivatives(x, 30000.0, motion_breaks(t, ev), method, count_m=0.16e-3,
                                   joins=motion_joins(t, ev))
                error = (a[window] - motion.acceleration_m_s2[truth]) * m_lc / np.max(motion.resistance_n[truth])
                after, before = t[window] - events.contact_s, events.stop_s - t[window]
                inside = (after > FIT_EDGE_MARGINS_S[0]) & (before > FIT_EDGE_MARGINS_S[1])
                rows[name]["inside"].append((np.mean(error[inside]), np.mean(error[inside] ** 2)))
                rows[name]["contact"].append(_profile(after, error))
                rows[name]["stop"].append(_profile(before, error))
    print(f"force error m_lc*(a - a_true) / peak R on 9 cones x 4 encoder phases ({chosen}): mean (a bias the "
          f"records share) | RMS; inside = {1e3 * FIT_EDGE_MARGINS_S[0]:g} ms after contact to "
          f"{1e3 * FIT_EDGE_MARGINS_S[1]:g} ms before the stop (the fit's rows)")
    print(f"{'':22s} {'inside':>14s}   by distance from the window's edges: "
          + " ".join(f"{f'{lo:g}-{hi:g} ms':>13s}" for lo, hi in zip(EDGE_BINS_MS[:-1], EDGE_BINS_MS[1:])))
    for name, parts in rows.items():
        inside = np.array(parts["inside"])
        for edge in ("contact", "stop"):
            arr = np.array(parts[edge])
            mean, rms = np.nanmean(arr[:, :, 0], axis=0), np.sqrt(np.nanmean(arr[:, :, 1], axis=0))
            head = (f"{100 * np.mean(inside[:, 0]):+6.3f}%|{100 * np.sqrt(np.mean(inside[:, 1])):5.3f}"
                    if edge == "contact" else "")
            print(f"{name if edge == 'contact' else '':22s} {head:>14s}   from {edge:7s} "
                  + " ".join(f"{100 * m:+6.2f}%|{100 * r:4.2f}" for m, r in zip(mean, rms)))


def main() -> None:
    """Each method as the pipeline calls it (breaks from the detected events, the stop's continuity for the
    least-squares spline), on 6 shots × 4 encoder phases; medians and worst cases."""
    from pencli.filter.derivatives import derivatives
    from pencli.filter.inertia import motion_breaks, motion_joins

    rows = {name: [] for name in METHODS}
    edges = {"contact": [], "stop": []}  # the default method's signed force error by distance from each edge
    phases = (0.5, 0.1, 0.35, 0.8)
    for i, (material, blade, springs) in enumerate(SHOTS):
        for phase in phases:
            motion, t, x, events, m_lc, pad = shot(material, blade, springs, i, phase)
            c = int(np.searchsorted(t, events.contact_s))
            s = int(np.searchsorted(t, events.stop_s))
            window = slice(c, s)  # the whole analysis window, edges included
            truth = slice(c - pad, s - pad)
            f0 = int(np.searchsorted(t, events.motion_start_s + 2e-3))
            flight = slice(f0, c - 15)
            flight_truth = slice(f0 - pad, c - 15 - pad)
            peak = np.max(motion.resistance_n[truth])
            for name in METHODS:
                t0 = time.perf_counter()
                v, a = derivatives(x, 30000.0, motion_breaks(t, events), name, count_m=0.16e-3,
                                   joins=motion_joins(t, events))
                ms = (time.perf_counter() - t0) * 1e3
                ev = np.sqrt(np.mean((v[window] - motion.velocity_m_s[truth]) ** 2))
                ea = np.sqrt(np.mean((a[window] - motion.acceleration_m_s2[truth]) ** 2))
                ef = np.sqrt(np.mean((a[flight] - motion.acceleration_m_s2[flight_truth]) ** 2))
                rows[name].append((ev, ea, ea * m_lc / peak, ef, ms))
    print(f"{'method':10s} {'v RMS [m/s]':>12s} {'a RMS [m/s2]':>13s} {'m_lc*a / peak R':>16s} "
          f"{'flight a [m/s2]':>16s} {'ms/run':>7s}   median | worst over {len(SHOTS)} shots x {len(phases)} "
          f"encoder phases (penetration window unless said)")
    for name, values in rows.items():
        arr = np.array(values)
        med, worst = np.median(arr, axis=0), np.max(arr, axis=0)
        print(f"{name:10s} {med[0]:6.4f}|{worst[0]:<7.4f} {med[1]:6.1f}|{worst[1]:<8.1f} "
              f"{100 * med[2]:6.2f}%|{100 * worst[2]:<7.2f}% {med[3]:6.1f}|{worst[3]:<8.1f} {med[4]:7.1f}")

    # the error by distance from the window's edges, on more shots: every blade and spring count of both materials
    for i, (material, blade, springs) in enumerate(itertools.product(("grill_brick", "mpacs_c"), ("1", "1.5", "2"),
                                                                      (2, 4, 6))):
        for phase in phases:
            motion, t, x, events, m_lc, pad = shot(material, blade, springs, 100 + i, phase)
            c = int(np.searchsorted(t, events.contact_s))
            s = int(np.searchsorted(t, events.stop_s))
            window, truth = slice(c, s), slice(c - pad, s - pad)
            _, a = derivatives(x, 30000.0, motion_breaks(t, events), DEFAULT_METHOD, count_m=0.16e-3)
            error = (a[window] - motion.acceleration_m_s2[truth]) * m_lc / np.max(motion.resistance_n[truth])
            edges["contact"].append(_profile(t[window] - events.contact_s, error))
            edges["stop"].append(_profile(events.stop_s - t[window], error))
    print(f"\n{DEFAULT_METHOD}: force error m_lc*(a - a_true) / peak R by distance from the window's edges, mean over "
          f"the {len(edges['stop'])} records (signed: a bias they share) and RMS")
    print(f"{'from':8s} " + " ".join(f"{f'{lo:g}-{hi:g} ms':>10s}" for lo, hi in zip(EDGE_BINS_MS[:-1], EDGE_BINS_MS[1:])))
    for edge, profiles in edges.items():
        arr = np.array(profiles)  # (records, bins, [mean, mean square])
        mean = np.nanmean(arr[:, :, 0], axis=0)
        rms = np.sqrt(np.nanmean(arr[:, :, 1], axis=0))
        print(f"{edge:8s} " + " ".join(f"{100 * m:+6.2f}%|{100 * r:4.2f}" for m, r in zip(mean, rms)))
    print(f"in use (pencli.filter.windows): the analysis window starts {1e3 * WINDOW_TRIM_S:g} ms after contact and "
          f"ends as long before the stop; the resistance fit leaves out {1e3 * FIT_EDGE_MARGINS_S[0]:g} ms after "
          f"contact and {1e3 * FIT_EDGE_MARGINS_S[1]:g} ms before the stop")


EDGE_BINS_MS = (0.0, 0.5, 1.0, 2.0, 3.0, 4.0, 6.0, 8.0)
"""Distances from an edge of the window the error profile is read in. [ms]"""


def _profile(distance_s: np.ndarray, error: np.ndarray) -> np.ndarray:
    """(bins, 2): the mean and the mean square of ``error`` in each bin of :data:`EDGE_BINS_MS`."""
    out = np.full((len(EDGE_BINS_MS) - 1, 2), np.nan)
    for i, (lo, hi) in enumerate(zip(EDGE_BINS_MS[:-1], EDGE_BINS_MS[1:])):
        inside = (distance_s >= lo * 1e-3) & (distance_s < hi * 1e-3)
        if inside.any():
            out[i] = np.mean(error[inside]), np.mean(error[inside] ** 2)
    return out


if __name__ == "__main__":
    check_options(__doc__, ("--cones", "--material"))
    cones() if "--cones" in sys.argv else main()
