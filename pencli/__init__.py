"""pen: penetration mechanics of thin blades in porous, brittle materials.

The open successor of JPL's BAM suite (Moreland et al., "Penetration Mechanics
Modeling & Validation of Blade Implements into Porous, Brittle Comet
Simulant").  Library first; the ``pen`` command is a thin layer over
:mod:`pencli.api`.

Layers (imports go one way, down):

- ``commands/``: typer + rich; parse, one call into ``api``, render.
- ``api``: the Python API the CLI maps onto one to one.
- edges: ``acquire/`` (rig drivers), ``store/`` (Parquet + DuckDB),
  ``io/`` (readers, writers), ``report/`` (figures, HTML).
- pure core: ``params/`` (definitions, validation), ``model/`` (Eq. 9,
  dynamics), ``filter/``, ``fit/``, ``predict/``, ``diagnose/``.
"""

__version__ = "0.1.0"
