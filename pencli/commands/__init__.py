"""The ``pen`` subcommands: parse, one call into :mod:`pencli.api`, render."""
