"""The benches' command lines: usage on ``-h``/``--help``, and an unknown option refused before a long run starts.

The diagnosis benches run for 10 to 60 minutes; without this a mistyped option (``--no-lader``) or ``--help``
was ignored and the bench ran on its defaults.
"""

from __future__ import annotations

import sys
from collections.abc import Iterable
from pathlib import Path


def check_options(doc: str | None, options: Iterable[str], argv: list[str] | None = None) -> None:
    """Print ``doc`` and exit 0 when ``argv`` (default: ``sys.argv[1:]``) asks for help; exit 2 naming the
    first ``--option`` that is not among ``options``, with the ones that are."""
    args = sys.argv[1:] if argv is None else argv
    if "-h" in args or "--help" in args:
        print((doc or "").strip())
        raise SystemExit(0)
    known = sorted(set(options))
    unknown = [a for a in args if a.startswith("--") and a not in known]
    if unknown:
        print(f"{Path(sys.argv[0]).stem}: unknown option {unknown[0]}; expected "
              f"{', '.join(known) if known else 'no options'} (--help for usage)", file=sys.stderr)
        raise SystemExit(2)
