"""Which derivative method? Error of velocity and acceleration against the simulated rig's true motion.

Run: python -m bench.bench_derivatives
For a set of simulated shots (two materials, three blades, 2/4/6 springs),
each method differentiates the quantised encoder record (0.16 mm counts at
30 kHz); errors are RMS over the penetration window against the true
motion, and the acceleration error is also shown as the force error it
causes (× load-cell mass) relative to the peak resistance.
"""

from __future__ import annotations

import time

import numpy as np

from pencli.acquire.calibration import load_force_calibration, load_position_calibration
from pencli.acquire.drivers import ShotSetup
from pencli.acquire.rig import rig_from_mapping
from pencli.acquire.sim import SimRig
from pencli.filter.derivatives import METHODS
from pencli.filter.tare import detect_events
from pencli.params.load import load_preset

SHOTS = [("grill_brick", "1", 2), ("grill_brick", "1.5", 4), ("grill_brick", "2", 6),
         ("mpacs_c", "1", 4), ("mpacs_c", "1.5", 6), ("mpacs_c", "2", 2)]


def shot(material, blade, springs, seed):
    rig = SimRig(rig_from_mapping({"seed": seed}), load_position_calibration(), load_force_calibration())
    p, m, e = load_preset(f"al6061_{blade}mm", "penetrator"), load_preset(material, "material"), \
        load_preset(f"springs_{springs}", "energizing")
    rig.arm(ShotSetup(30000.0, 1.0, 0.2, p, m, e))
    rig.fire()
    motion = rig.motion
    n = motion.time_s.size
    u_true = motion.displacement_m
    counts = np.round(u_true * 1e3 * 6.25)
    x = counts / 6.25 * 1e-3 - e.values["surface_offset_mm"] * 1e-3
    events = detect_events(motion.time_s, x, p.values["penetration_depth_mm"] * 1e-3)
    return motion, x, events, rig.world.true_load_cell_mass_kg, n


def main() -> None:
    rows = {name: [] for name in METHODS}
    for i, (material, blade, springs) in enumerate(SHOTS):
        motion, x, events, m_lc, n = shot(material, blade, springs, i)
        t = motion.time_s
        c = int(np.searchsorted(t, events.contact_s))
        s = int(np.searchsorted(t, events.stop_s))
        window = slice(c + 3, s - 3)
        peak = np.max(motion.resistance_n[window])
        for name, fn in METHODS.items():
            t0 = time.perf_counter()
            v, a = fn(x, 30000.0, [c, s + 1])
            ms = (time.perf_counter() - t0) * 1e3
            ev = np.sqrt(np.mean((v[window] - motion.velocity_m_s[window]) ** 2))
            ea = np.sqrt(np.mean((a[window] - motion.acceleration_m_s2[window]) ** 2))
            rows[name].append((ev, ea, ea * m_lc / peak, ms))
    print(f"{'method':8s} {'v RMS [m/s]':>12s} {'a RMS [m/s2]':>13s} {'m_lc*a / peak R':>16s} {'ms/run':>7s}"
          "  (medians over 6 shots, penetration window)")
    for name, values in rows.items():
        arr = np.array(values)
        med = np.median(arr, axis=0)
        print(f"{name:8s} {med[0]:12.4f} {med[1]:13.1f} {100 * med[2]:15.2f}% {med[3]:7.1f}")


if __name__ == "__main__":
    main()
