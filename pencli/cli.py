"""The ``pen`` command: assembles the subcommands; :func:`main` is the entry point."""

from __future__ import annotations

import typer

from pencli import __version__
from pencli.commands import acquire as acquire_cmd
from pencli.commands import condition as condition_cmd
from pencli.commands import diagnose as diagnose_cmd
from pencli.commands import drops as drops_cmd
from pencli.commands import fit as fit_cmd
from pencli.commands import params as params_cmd
from pencli.commands import predict as predict_cmd
from pencli.commands import records as records_cmd
from pencli.commands import report as report_cmd
from pencli.commands import runs as runs_cmd
from pencli.commands import snow as snow_cmd
from pencli.commands import soundings as soundings_cmd
from pencli.commands import sweep as sweep_cmd
from pencli.commands.common import PenTyper

app = PenTyper(
    name="pen",
    help="Penetration mechanics of thin blades in porous, brittle materials (successor of JPL's BAM).",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,  # plain help, and a usage error's message on one line (not wrapped in a box)
)
app.add_typer(params_cmd.app, name="params")
app.add_typer(runs_cmd.runs_app, name="runs")
app.add_typer(soundings_cmd.soundings_app, name="soundings")
app.add_typer(snow_cmd.snow_app, name="snow")
app.add_typer(drops_cmd.drops_app, name="drops")
for module in (predict_cmd, runs_cmd, records_cmd, acquire_cmd, condition_cmd, fit_cmd, diagnose_cmd, sweep_cmd, report_cmd):
    app.registered_commands.extend(module.app.registered_commands)


def _version(value: bool) -> None:
    if value:
        typer.echo(f"pen {__version__}")
        raise typer.Exit()


@app.callback()
def root(
    version: bool = typer.Option(False, "--version", callback=_version, is_eager=True, help="Print the version."),
) -> None:
    """pen: penetration mechanics of thin blades in porous, brittle materials."""


def main() -> None:
    """Console-script entry point."""
    app()
