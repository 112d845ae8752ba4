r"""The ``encoder_load_cell`` chain: the spring rig's encoder and six-axis load cell.

The encoder reads the tip's travel x; the load cell, tared, reads :math:`F = R + m_{lc}\,a` (the blade and
its mount, mass :math:`m_{lc}`, sit between the material and the sensor), so the chain reads v and a from
the encoder (:mod:`pencli.filter.derivatives`) and :math:`R = F - m_{lc}\,a`
(:func:`pencli.filter.inertia.subtract_inertia`, which also measures :math:`m_{lc}` in the free flight).
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from pencli.filter.inertia import subtract_inertia
from pencli.filter.tare import Events
from pencli.sensors import Reading


class EncoderLoadCell:
    """The rig's chain with ``load_cell_mass_kg`` below the sensor [kg] and the tared run's ``events``;
    ``method``: the derivative method (default: the run's); ``use_flight_mass``: subtract the mass the free flight
    measures instead of the file's."""

    name = "encoder_load_cell"
    channels = ("depth_m", "fz_n")

    def __init__(self, load_cell_mass_kg: float, events: Events, method: str | None = None,
                 use_flight_mass: bool = False) -> None:
        self.load_cell_mass_kg = float(load_cell_mass_kg)
        self.events = events
        self.method = method
        self.use_flight_mass = use_flight_mass

    def read(self, name: str, time_s: np.ndarray | None, channels: Mapping[str, np.ndarray]) -> Reading:
        if time_s is None:
            raise ValueError("no clock: the encoder's travel is differentiated over time")
        kin = subtract_inertia(time_s, channels["depth_m"], channels["fz_n"], self.events, self.load_cell_mass_kg,
                               method=self.method, use_flight_mass=self.use_flight_mass)
        return stored(name, time_s, channels["depth_m"], kin.velocity_m_s, kin.acceleration_m_s2, kin.resistance_n,
                      self.events, force_n=channels["fz_n"], account=kin)


def stored(name: str, time_s: np.ndarray, depth_m: np.ndarray, velocity_m_s: np.ndarray,
           acceleration_m_s2: np.ndarray | None, resistance_n: np.ndarray, events: Events, force_n=None,
           account=None) -> Reading:
    """A rig run's reading from its inertia stage's columns (what :meth:`EncoderLoadCell.read` wrote): the depth
    is the tip's below the surface (travel counted from it), contact and stop at the tare's events; ``force_n``
    the tared load-cell force F the resistance was read from. [SI]"""
    contact = int(np.searchsorted(time_s, events.contact_s))
    stop = int(np.searchsorted(time_s, events.stop_s, side="right")) - 1
    return Reading(name, EncoderLoadCell.name, depth_m, velocity_m_s, time_s, acceleration_m_s2, resistance_n,
                   channels={} if force_n is None else {"force_n": force_n}, contact=contact,
                   stop=max(stop, contact), account=account)


def unbroken_at_contact(time_s: np.ndarray, depth_m: np.ndarray, force_n: np.ndarray, events: Events,
                        load_cell_mass_kg: float, encoder_step_m: float, method: str
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(v, a, R = F − m_lc·a) with derivatives that do not break at contact, for a tip of no area at the surface
    (a sharp cone).  Its force rises from nothing, so its acceleration does not jump where it meets the block,
    and its force's onset lags the contact by however deep the tip goes before the force clears the noise: a
    break there (the inertia stage's, which the fit keeps) leaves an acceleration error at contact that a
    simulated replicate, whose motion has no jump there, does not share.  The contact is then the position's
    alone. [SI]"""
    from pencli.filter.derivatives import derivatives
    from pencli.filter.inertia import motion_breaks, motion_joins, rest_mask

    t = time_s
    rate = (t.size - 1) / (t[-1] - t[0])
    v, a = derivatives(depth_m, rate, motion_breaks(t, events, False), method, count_m=encoder_step_m,
                       joins=motion_joins(t, events, False), at_rest=rest_mask(t, events))
    return v, a, force_n - load_cell_mass_kg * a


def encoder_reading(travel_m: np.ndarray, step_m: float, phases: np.ndarray, first_m: float,
                    position_error_m: np.ndarray | None = None) -> np.ndarray:
    """What the encoder records of true travels ``travel_m`` (n × k: k motions): each motion's travel shifted by
    its phase (``phases``, k fractions of a count) and its position error where given (n × k) [m], rounded to the
    count ``step_m`` and shifted back, x̃ = s·round((x + f·s)/s) − f·s, then zeroed so that its first reading is
    ``first_m`` (the encoder is zeroed at rest). [m]"""
    shifts = step_m * phases
    moved = travel_m + shifts
    if position_error_m is not None:
        moved = moved + position_error_m
    recorded = step_m * np.round(moved / step_m) - shifts
    recorded -= recorded[:1] - first_m
    return recorded


def load_cell_reading(resistance_n: np.ndarray, load_cell_mass_kg: float, accel_error_m_s2: np.ndarray,
                      noise_n: np.ndarray) -> np.ndarray:
    """What the chain reads as the resistance of a motion whose true resistance is ``resistance_n`` (n,) [N]: the
    load cell reads F = R + m_lc·a* plus its noise (n × k) [N], and the chain subtracts m_lc·ã with the
    acceleration ã it derived from the encoder, off the true a* by ``accel_error_m_s2`` = ã − a* (n × k), so
    R̃ = R − m_lc·(ã − a*) + noise. [N]"""
    return resistance_n[:, None] - load_cell_mass_kg * accel_error_m_s2 + noise_n
