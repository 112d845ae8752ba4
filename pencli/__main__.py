"""``python -m pencli`` runs the ``pen`` command."""

from pencli.cli import main

if __name__ == "__main__":  # pragma: no cover
    main()
