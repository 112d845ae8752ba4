"""One definition per parameter of the three YAML kinds (CONTRACT §1).

Everything that speaks about a parameter is derived from :data:`PARAMETERS`:
the YAML validation (:mod:`pencli.params.validate`), the JSON Schemas in
``schema/`` (:mod:`pencli.params.schema`), the ``--set`` keys, sweep variable
names and the CLI help text.  To add a parameter, add one :class:`Param`
here (and its SI field to :class:`pencli.model.design.Design`).

Two kinds of bound:

- *hard* bounds are physical impossibilities (a negative width, an
  efficiency above 100 %) and are always an error;
- the *documented range* is what the model was built and checked for; a
  value outside it is an error unless the caller explicitly allows it
  (``--allow-out-of-range``).

Pure data and pure functions: no I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable, Literal

Kind = Literal["penetrator", "material", "energizing"]
KINDS: tuple[Kind, ...] = ("penetrator", "material", "energizing")


@dataclass(frozen=True)
class Param:
    """The one definition of a parameter.

    Attributes
    ----------
    key
        Name in the YAML file (dotted for nested keys), unit in the name.
    kind
        Which of the three parameter files holds it.
    symbol
        Symbol in the paper (Eq. 9 and Table 1).
    meaning
        One line, what it is.
    unit
        Unit of the file value, as printed in help text.
    si_name
        Field of :class:`pencli.model.design.Design` holding the SI value.
    si_scale
        Factor from the file unit to SI (``mm`` -> ``m`` is 1e-3).
    dtype
        ``float`` or ``int``.
    hard_min, hard_max
        Physical bounds, always enforced.  ``None`` for unbounded.
    hard_min_exclusive, hard_max_exclusive
        Whether the hard bound itself is excluded.
    range_min, range_max
        Documented range; outside it is an error unless explicitly allowed.
    required
        A file of this kind must give it.
    default
        Value used when an optional key is absent (``None``: stays absent).
    geometries, builds
        Which penetrator geometries hold the key, and what its value builds (below).
    """

    key: str
    kind: Kind
    symbol: str
    meaning: str
    unit: str
    si_name: str
    si_scale: float = 1.0
    dtype: type = float
    hard_min: float | None = None
    hard_max: float | None = None
    hard_min_exclusive: bool = False
    hard_max_exclusive: bool = False
    range_min: float | None = None
    range_max: float | None = None
    required: bool = True
    default: float | None = None
    geometries: tuple[str, ...] = ()
    """The penetrator geometries (:data:`GEOMETRY_NAMES`) or launcher drives (:data:`DRIVE_NAMES`) whose files
    hold this key; empty: every file of its kind.  A key of one geometry (drive) in another's file is an error,
    and its ``required`` holds within the geometry (drive)."""
    builds: str = "design"
    """What the SI value fills: ``design`` (the field ``si_name`` of :class:`pencli.model.design.Design`),
    ``geometry`` (the keyword ``si_name`` of the geometry's class in :data:`pencli.model.geometry.GEOMETRIES`) or
    ``drive`` (likewise of the drive's class in :data:`pencli.model.drive.DRIVES`)."""
    absent: float = math.nan
    """The SI value a design takes when its file's geometry or drive does not hold the key (a drop has no
    springs: their count, stiffness and mass are 0); NaN: the simulator must not use it."""

    def belongs_to(self, variant: str) -> bool:
        """Whether a file of ``variant`` (its geometry or drive) may hold this key."""
        return not self.geometries or variant in self.geometries

    @property
    def hard_text(self) -> str:
        """The hard bounds as text, e.g. ``> 0`` or ``> 0 and <= 100``."""
        parts = []
        if self.hard_min is not None:
            parts.append(f"{'>' if self.hard_min_exclusive else '>='} {_fmt(self.hard_min)}")
        if self.hard_max is not None:
            parts.append(f"{'<' if self.hard_max_exclusive else '<='} {_fmt(self.hard_max)}")
        return " and ".join(parts) if parts else "any number"

    @property
    def range_text(self) -> str:
        """The documented range as text, e.g. ``[0.1, 50] mm``."""
        lo = "-inf" if self.range_min is None else _fmt(self.range_min)
        hi = "inf" if self.range_max is None else _fmt(self.range_max)
        return f"[{lo}, {hi}] {self.unit}".rstrip()

    @property
    def help(self) -> str:
        """One line of help: meaning, unit, documented range."""
        opt = "" if self.required else (
            f", optional (default {_fmt(self.default)})" if self.default is not None else ", optional")
        return f"{self.symbol}: {self.meaning} [{self.unit}]; range {self.range_text}{opt}"

    def hard_violation(self, value):
        """True where ``value`` breaks a hard bound or is not finite: a bool for a float, elementwise for a
        numpy array (a sweep's column is checked in one pass)."""
        bad = (value != value) | (abs(value) == math.inf)
        if self.hard_min is not None:
            bad = bad | (value < self.hard_min) | ((value == self.hard_min) & self.hard_min_exclusive)
        if self.hard_max is not None:
            bad = bad | (value > self.hard_max) | ((value == self.hard_max) & self.hard_max_exclusive)
        return bad

    def outside_range(self, value: float) -> bool:
        """True when ``value`` is outside the documented range."""
        return ((self.range_min is not None and value < self.range_min)
                or (self.range_max is not None and value > self.range_max))


def _fmt(value: float | None) -> str:
    if value is None:
        return "none"
    return f"{value:g}"


GEOMETRY_NAMES: tuple[str, ...] = ("blade", "cone", "tapered_blade")
"""The penetrator geometries a file's ``geometry:`` may name (default ``blade``, CONTRACT §2's); each is a class
in :data:`pencli.model.geometry.GEOMETRIES` (a test checks the two agree)."""
DEFAULT_GEOMETRY = "blade"
DRIVE_NAMES: tuple[str, ...] = ("springs", "free_fall", "constant_rate")
"""The drives a launcher (energizing) file's ``drive:`` may name (default ``springs``, CONTRACT §2's); each is a
class in :data:`pencli.model.drive.DRIVES` (a test checks the two agree)."""
DEFAULT_DRIVE = "springs"
_BLADES = ("blade", "tapered_blade")
_SPRINGS = ("springs",)


@dataclass(frozen=True)
class Choice:
    """A parameter whose value is one of a few names (the geometry, a cone's area convention).

    ``si_name`` is the keyword of the geometry's class it fills (empty: the geometry itself)."""

    key: str
    kind: Kind
    meaning: str
    options: tuple[str, ...]
    default: str
    option_help: tuple[str, ...]
    """One line per option, in ``options``' order."""
    geometries: tuple[str, ...] = ()
    si_name: str = ""

    def belongs_to(self, geometry: str) -> bool:
        return not self.geometries or geometry in self.geometries

    @property
    def help(self) -> str:
        described = "; ".join(f"{o}: {h}" for o, h in zip(self.options, self.option_help))
        return f"{self.meaning}: one of {described} (default {self.default})"


CHOICES: list[Choice] = [
    Choice("geometry", "penetrator", "the penetrator's shape", GEOMETRY_NAMES, DEFAULT_GEOMETRY,
           ("a rectangular blade (Eq. 9)", "a cone tip on a cylindrical shaft",
            "a blade whose thickness grows from its tip over a taper")),
    Choice("cone_area", "penetrator", "which area a cone's strength acts on", ("projected", "mantle"), "projected",
           ("the frontal area times (sin α + μ·cos α), the blade's convention",
            "the face normal to it, with friction along it (a flat tip presses with the strength alone)"),
           geometries=("cone",), si_name="area"),
    Choice("drive", "energizing", "what drives the body into the material", DRIVE_NAMES, DEFAULT_DRIVE,
           ("the spring launcher (CONTRACT §2)",
            "a free fall from a height through a fluid (air, water): weight, buoyancy, drag to the surface, added "
            "mass", "a push at a set rate from the surface to full depth (a cone penetration test): the motion is "
            "prescribed, the push is what it takes")),
]
"""The named-choice parameters, by kind; values are the option names as written (a list: a variant registered
by :func:`register_variant` adds its own)."""

CHOICE_BY_KEY: dict[str, Choice] = {c.key: c for c in CHOICES}

VARIANTS: dict[str, tuple[str, tuple[str, ...], str]] = {
    "penetrator": ("geometry", GEOMETRY_NAMES, DEFAULT_GEOMETRY),
    "energizing": ("drive", DRIVE_NAMES, DEFAULT_DRIVE),
}
"""Kinds whose files come in variants, each holding its own keys: kind → (the choice naming the variant, the
variants, the default)."""


_P = Param
PARAMETERS: list[Param] = [
    # --- penetrator: the blade and the moving body ---------------------------
    _P("blade_width_mm", "penetrator", "w", "rectangular blade width", "mm",
       "blade_width_m", 1e-3, hard_min=0, hard_min_exclusive=True, range_min=5, range_max=1000, geometries=_BLADES),
    _P("blade_thickness_mm", "penetrator", "T", "blade thickness", "mm",
       "blade_thickness_m", 1e-3, hard_min=0, hard_min_exclusive=True, range_min=0.1, range_max=50,
       geometries=_BLADES),
    _P("tip_angle_deg", "penetrator", "θ", "leading-edge angle from vertical (90 = flat edge)", "deg",
       "tip_angle_rad", math.pi / 180, hard_min=0, hard_max=90, range_min=0, range_max=90, geometries=_BLADES),
    _P("tip_thickness_mm", "penetrator", "T_tip", "a tapered blade's thickness at its tip", "mm",
       "tip_thickness_m", 1e-3, hard_min=0, range_min=0, range_max=50, geometries=("tapered_blade",),
       builds="geometry"),
    _P("taper_length_mm", "penetrator", "L_t", "depth over which a tapered blade reaches its full thickness", "mm",
       "taper_length_m", 1e-3, hard_min=0, hard_min_exclusive=True, range_min=0.1, range_max=1000,
       geometries=("tapered_blade",), builds="geometry"),
    _P("cone_half_angle_deg", "penetrator", "α", "a cone's half-angle at its apex (30 for a 60° CPT cone)", "deg",
       "half_angle_rad", math.pi / 180, hard_min=0, hard_max=90, hard_min_exclusive=True, hard_max_exclusive=True,
       range_min=5, range_max=85, geometries=("cone",), builds="geometry"),
    _P("shaft_diameter_mm", "penetrator", "D", "a cone's base and shaft diameter (35.7 for a 10 cm² CPT cone)",
       "mm", "shaft_radius_m", 0.5e-3, hard_min=0, hard_min_exclusive=True, range_min=1, range_max=1000,
       geometries=("cone",), builds="geometry"),
    _P("tip_flat_diameter_mm", "penetrator", "d_t", "diameter of a blunted cone's flat tip (0: sharp)", "mm",
       "tip_radius_m", 0.5e-3, hard_min=0, range_min=0, range_max=1000, required=False, default=0.0,
       geometries=("cone",), builds="geometry"),
    _P("penetration_depth_mm", "penetrator", "d", "full penetration depth (hard stops)", "mm",
       "penetration_depth_m", 1e-3, hard_min=0, hard_min_exclusive=True, range_min=1, range_max=1000),
    _P("sprung_mass_kg", "penetrator", "m", "accelerated body, blade included", "kg",
       "sprung_mass_kg", 1.0, hard_min=0, hard_min_exclusive=True, range_min=0.05, range_max=200),
    _P("load_cell_mass_kg", "penetrator", "m_lc", "blade + mount below the force sensor", "kg",
       "load_cell_mass_kg", 1.0, hard_min=0, range_min=0, range_max=50),
    # --- material: measured properties -------------------------------------------
    _P("density_kg_m3", "material", "ρ", "bulk density", "kg/m³",
       "density_kg_m3", 1.0, hard_min=0, hard_min_exclusive=True, range_min=1, range_max=3000),
    _P("microstructure_strength_kpa", "material", "S", "microstructure strength", "kPa",
       "strength_pa", 1e3, hard_min=0, range_min=0, range_max=1e6),
    _P("friction_coefficient", "material", "μ", "blade–material friction coefficient", "–",
       "friction_coefficient", 1.0, hard_min=0, range_min=0, range_max=2),
    _P("gravity_m_s2", "material", "g", "gravitational acceleration along the penetration axis", "m/s²",
       "gravity_m_s2", 1.0, hard_min=0, range_min=0, range_max=30, required=False, default=9.81),
    # --- material: the four Eq. 9 coefficients (what `pen fit` produces) -------
    _P("coefficients.strength_factor", "material", "Cs", "S correction factor", "–",
       "strength_factor", 1.0, hard_min=0, range_min=0, range_max=20, required=False),
    _P("coefficients.sidewall_pressure_kpa", "material", "P", "sidewall pressure", "kPa",
       "sidewall_pressure_pa", 1e3, hard_min=0, range_min=0, range_max=1e5, required=False),
    _P("coefficients.damping_kpa_s_m", "material", "C", "damping per unit area", "kPa·s/m",
       "damping_pa_s_m", 1e3, hard_min=0, range_min=0, range_max=1e5, required=False),
    _P("coefficients.inertia_coefficient", "material", "K", "inertia (drag) coefficient", "–",
       "inertia_coefficient", 1.0, hard_min=0, range_min=0, range_max=1000, required=False),
    # --- energizing: the spring launcher --------------------------------------------
    _P("spring_count", "energizing", "n", "number of parallel springs (2, 4 or 6 on the reference rig)",
       "–", "spring_count", 1.0, dtype=int, hard_min=1, range_min=1, range_max=12,
       geometries=_SPRINGS, absent=0.0),
    _P("spring_stiffness_kn_m", "energizing", "k", "stiffness per spring", "kN/m",
       "spring_stiffness_n_m", 1e3, hard_min=0, hard_min_exclusive=True, range_min=0.01, range_max=1000,
       geometries=_SPRINGS, absent=0.0),
    _P("spring_mass_kg", "energizing", "m_s", "mass per spring", "kg",
       "spring_mass_kg", 1.0, hard_min=0, range_min=0, range_max=50,
       geometries=_SPRINGS, absent=0.0),
    _P("spring_nominal_length_mm", "energizing", "L0", "spring free length", "mm",
       "nominal_length_m", 1e-3, hard_min=0, hard_min_exclusive=True, range_min=1, range_max=5000,
       geometries=_SPRINGS, absent=0.0),
    _P("spring_compressed_length_mm", "energizing", "Lc", "spring length at release", "mm",
       "compressed_length_m", 1e-3, hard_min=0, hard_min_exclusive=True, range_min=1, range_max=5000,
       geometries=_SPRINGS, absent=0.0),
    _P("spring_length_at_contact_mm", "energizing", "Lc + s0",
       "spring length when the tip reaches the surface (BAM's input): give it or spring_compressed_length_mm, "
       "never both; compressed length = this − surface_offset_mm", "mm",
       "", 1e-3, hard_min=0, hard_min_exclusive=True, range_min=1, range_max=5000, required=False,
       geometries=_SPRINGS, absent=0.0),
    _P("surface_offset_mm", "energizing", "s0", "tip to surface at release (stand-off; a drop's height above the "
                                                "bed)", "mm",
       "surface_offset_m", 1e-3, hard_min=0, range_min=0, range_max=2000),
    _P("propulsion_efficiency_pct", "energizing", "η", "propulsion efficiency", "%",
       "efficiency", 1e-2, hard_min=0, hard_max=100, hard_min_exclusive=True, range_min=1, range_max=100,
       geometries=_SPRINGS, absent=0.0),
    # --- energizing: a free fall through a fluid --------------------------------------
    _P("fluid_density_kg_m3", "energizing", "ρ_f", "density of the fluid the body falls through (1.2 air, 1025 "
       "seawater, 0 a vacuum)", "kg/m³", "fluid_density_kg_m3", 1.0, hard_min=0, range_min=0, range_max=1100,
       geometries=("free_fall",), builds="drive"),
    _P("drag_coefficient", "energizing", "C_D", "the body's drag coefficient in the fluid, on its largest frontal "
       "area (acts until the tip meets the surface)", "–", "drag_coefficient", 1.0, hard_min=0, range_min=0,
       range_max=3, geometries=("free_fall",), builds="drive"),
    _P("added_mass_coefficient", "energizing", "C_a", "fluid carried along by the body, as a share of the fluid "
       "mass it displaces", "–", "added_mass_coefficient", 1.0, hard_min=0, range_min=0, range_max=2,
       required=False, default=0.0, geometries=("free_fall",), builds="drive"),
    _P("displaced_volume_l", "energizing", "V", "the body's volume, which the fluid buoys and accelerates", "L",
       "displaced_volume_m3", 1e-3, hard_min=0, range_min=0, range_max=1000, geometries=("free_fall",),
       builds="drive"),
    _P("tether_force_n", "energizing", "T", "tension of a line the body pays out as it falls (a spool's drag), "
       "constant from release to rest", "N", "tether_force_n", 1.0, hard_min=0, range_min=0, range_max=1000,
       required=False, default=0.0, geometries=("free_fall",), builds="drive"),
    _P("bed_density_kg_m3", "energizing", "ρ_b", "bulk density of the bed the body enters (saturated, under "
       "water): below the surface the body is buoyed by (ρ_b − ρ_f)·g times its embedded volume; 0 leaves this "
       "soil buoyancy out", "kg/m³", "bed_density_kg_m3", 1.0, hard_min=0, range_min=0, range_max=3000,
       required=False, default=0.0, geometries=("free_fall",), builds="drive"),
    # --- energizing: a push at a constant rate ----------------------------------------
    _P("push_rate_mm_s", "energizing", "v", "the rate the rig pushes the body at, from the surface to full depth "
       "(20 for a standard CPT)", "mm/s", "rate_m_s", 1e-3, hard_min=0, hard_min_exclusive=True, range_min=0.1,
       range_max=1000, geometries=("constant_rate",), builds="drive"),
]

EITHER_OR: dict[str, tuple[str, Callable[[dict[str, float]], float]]] = {
    "spring_compressed_length_mm": (
        "spring_length_at_contact_mm", lambda v: v["spring_length_at_contact_mm"] - v["surface_offset_mm"]),
}
"""A required key that may instead be given through an alternative (CONTRACT §1), and how it follows from it."""

BY_KEY: dict[str, Param] = {p.key: p for p in PARAMETERS}
"""Every parameter by its YAML key (dotted for ``coefficients.*``)."""

COEFFICIENT_KEYS: tuple[str, ...] = tuple(p.key for p in PARAMETERS if p.key.startswith("coefficients."))
COEFFICIENT_NAMES: tuple[str, ...] = tuple(key.split(".", 1)[1] for key in COEFFICIENT_KEYS)
"""The Eq. 9 coefficients by the names a material file's ``coefficients:`` gives them."""

TERM_COEFFICIENT: dict[str, str] = {
    "strength": "coefficients.strength_factor",
    "friction": "coefficients.sidewall_pressure_kpa",
    "damping": "coefficients.damping_kpa_s_m",
    "inertia": "coefficients.inertia_coefficient",
}
"""Which coefficient each Eq. 9 term needs."""

OPTIONAL_TOP_KEYS: dict[str, str] = {
    "notes": "free text: where the values come from (string)",
}
"""Keys pen adds to every kind beyond CONTRACT §1 (allowed: 'add freely')."""

RANGE_KEYS: dict[str, str] = {
    "contact_speed_m_s": "m/s", "depth_mm": "mm", "blade_thickness_mm": "mm", "blade_width_mm": "mm",
    "microstructure_strength_kpa": "kPa",
}
"""``fitted_ranges:`` of a material file written by ``pen fit``: [min, max] of what the fit saw."""

COVARIANCE_KEY = "coefficient_covariance"
"""The key of a material file written by ``pen fit`` that holds the fitted coefficients' covariance: a mapping of
coefficient → coefficient → value in the product of their file units (the ``coefficients:`` names; the
coefficients the fit held are absent).  ``pen predict --plot`` draws a prediction band from it."""


def params_of(kind: Kind, geometry: str | None = None) -> tuple[Param, ...]:
    """The parameters of one kind, in definition order; with ``geometry`` (a penetrator's geometry or a launcher's
    drive, :data:`VARIANTS`), those a file of it holds."""
    return tuple(p for p in PARAMETERS if p.kind == kind and (geometry is None or p.belongs_to(geometry)))


def choices_of(kind: Kind, geometry: str | None = None) -> tuple[Choice, ...]:
    """The named-choice parameters of one kind; with ``geometry``, those a file of it holds."""
    return tuple(c for c in CHOICES if c.kind == kind and (geometry is None or c.belongs_to(geometry)))


@dataclass(frozen=True)
class Registration:
    """A variant added by :func:`register_variant`; :meth:`undo` takes it out again (also as a context manager)."""

    kind: Kind
    name: str

    def undo(self) -> None:
        _set_variants(self.kind, tuple(n for n in VARIANTS[self.kind][1] if n != self.name),
                      drop=lambda item: item.geometries == (self.name,))

    def __enter__(self) -> "Registration":
        return self

    def __exit__(self, *exc) -> None:
        self.undo()


def register_variant(kind: Kind, name: str, help: str, params: tuple[Param, ...] = (),
                     choices: tuple[Choice, ...] = ()) -> Registration:
    """Add a penetrator geometry or a launcher drive named ``name`` (``help``: one line for the variant choice's
    option) with the keys its files hold: each of ``params`` and ``choices`` belongs to this variant alone.

    Everything derived from this module sees it at once: validation, the JSON Schema, ``pen params keys``, the
    ``--set`` and sweep keys.  :func:`pencli.model.geometry.register_geometry` calls it with the geometry's class.
    """
    if kind not in VARIANTS:
        raise ValueError(f"{kind} files come in no variants; variants: {', '.join(VARIANTS)}")
    if name in VARIANTS[kind][1]:
        raise ValueError(f"a {VARIANTS[kind][0]} named {name!r} is already registered")
    taken = sorted({*BY_KEY, *CHOICE_BY_KEY} & {item.key for item in (*params, *choices)})
    if taken:
        raise ValueError(f"{name}: key {taken[0]} is already defined")
    wrong = [item.key for item in (*params, *choices) if item.kind != kind]
    if wrong:
        raise ValueError(f"{name}: key {wrong[0]} is not a {kind} key")
    PARAMETERS.extend(replace(p, geometries=(name,)) for p in params)
    CHOICES.extend(replace(c, geometries=(name,)) for c in choices)
    choice = CHOICE_BY_KEY[VARIANTS[kind][0]]
    _set_variants(kind, (*VARIANTS[kind][1], name), helps=(*choice.option_help, help))
    return Registration(kind, name)


def _set_variants(kind: Kind, names: tuple[str, ...], helps: tuple[str, ...] | None = None, drop=None) -> None:
    """Rebuild the variant choice of ``kind`` with ``names`` (and the tables derived from the lists), dropping
    the parameters and choices ``drop`` selects."""
    if drop is not None:
        PARAMETERS[:] = [p for p in PARAMETERS if not drop(p)]
        CHOICES[:] = [c for c in CHOICES if not drop(c)]
    key, _, default = VARIANTS[kind]
    old = next(c for c in CHOICES if c.key == key)
    if helps is None:
        helps = tuple(h for o, h in zip(old.options, old.option_help) if o in names)
    CHOICES[CHOICES.index(old)] = replace(old, options=names, option_help=helps)
    VARIANTS[kind] = (key, names, default)
    BY_KEY.clear()
    BY_KEY.update((p.key, p) for p in PARAMETERS)
    CHOICE_BY_KEY.clear()
    CHOICE_BY_KEY.update((c.key, c) for c in CHOICES)


@dataclass(frozen=True)
class Rule:
    """A check across parameters of one kind.

    ``check(values)`` receives the file-unit values by key and says whether
    the rule holds; ``message`` says what is valid.  ``keys`` lists the
    parameters the rule speaks of; the first is the one named in the error.
    """

    kind: Kind
    keys: tuple[str, ...]
    message: str
    check: Callable[[dict[str, float]], bool]

    def holds(self, values: dict[str, float]) -> bool:
        """Whether the rule holds (a rule whose keys are absent holds)."""
        if not all(k in values for k in self.keys):
            return True
        return bool(self.check(values))


RULES: tuple[Rule, ...] = (
    Rule("penetrator", ("blade_thickness_mm", "blade_width_mm"), "must be less than blade_width_mm",
         lambda v: v["blade_thickness_mm"] < v["blade_width_mm"]),
    Rule("penetrator", ("tip_thickness_mm", "blade_thickness_mm"), "must not exceed blade_thickness_mm",
         lambda v: v["tip_thickness_mm"] <= v["blade_thickness_mm"]),
    Rule("penetrator", ("tip_flat_diameter_mm", "shaft_diameter_mm"), "must be less than shaft_diameter_mm",
         lambda v: v["tip_flat_diameter_mm"] < v["shaft_diameter_mm"]),
    Rule("penetrator", ("load_cell_mass_kg", "sprung_mass_kg"),
         "must not exceed sprung_mass_kg (it is part of the moving body)",
         lambda v: v["load_cell_mass_kg"] <= v["sprung_mass_kg"]),
)
"""Springs at or beyond their free length at release are a valid design (CONTRACT §2 puts the spring force
at 0 while L ≥ L0): a gravity drop."""
