"""MkDocs hooks: pages generated from pen itself, so they cannot drift from it.

- ``commands/<command>.md``: one page per command and command group, holding the command's own ``--help``;
- ``reference/parameters.md``: every parameter key with its kind, unit, range and meaning, from the one
  parameter definition (:mod:`pencli.params.definitions`);
- ``getting-started.md``: the README's set-up and tour, so the two never differ.

The pages are added to the build as generated files and to the navigation under "Commands".
"""

from __future__ import annotations

import os
from pathlib import Path

from mkdocs.structure.files import File


def _command_paths():
    from typer.main import get_command

    from pencli.cli import app

    def walk(command, path=()):
        subcommands = getattr(command, "commands", None)
        if path:
            yield path, command
        for name, sub in sorted((subcommands or {}).items()):
            yield from walk(sub, path + (name,))

    return list(walk(get_command(app)))


def _help(path: tuple[str, ...]) -> str:
    from typer.testing import CliRunner

    from pencli.cli import app

    os.environ["COLUMNS"] = "100"
    result = CliRunner().invoke(app, [*path, "--help"], terminal_width=100)
    if result.exit_code != 0:
        raise RuntimeError(f"pen {' '.join(path)} --help failed: {result.output}")
    return result.output.replace("Usage: root", "Usage: pen").rstrip()


def _slug(path: tuple[str, ...]) -> str:
    return "-".join(path)


def _command_page(path: tuple[str, ...], command) -> str:
    title = f"pen {' '.join(path)}"
    summary = (command.help or "").strip().split("\n\n")[0].replace("\n", " ")
    return (f"# {title}\n\n{summary}\n\nThis page is `{title} --help`, generated from the command itself.\n\n"
            f"```text\n{_help(path)}\n```\n")


def _parameters_page() -> str:
    from pencli.params.definitions import KINDS, PARAMETERS, VARIANTS, choices_of

    lines = ["# Parameter keys", "",
             "Every key of the three parameter files (penetrator, material, energizing), generated from pen's one "
             "definition of each parameter: the same definition validates the YAML files, writes the JSON Schemas "
             "(`pen params schema`), names the `--set` and `--vary` keys and writes the help text. A value outside "
             "its documented range is refused unless `--allow-out-of-range` is given; the hard limits always hold.",
             ""]
    for kind in KINDS:
        lines += [f"## {kind}", ""]
        for c in choices_of(kind):
            held = f" ({' and '.join(c.geometries)} files only)" if c.geometries else ""
            lines += [f"`{c.key}`{held}: {c.meaning}; one of", ""]
            lines += [f"- `{o}`{' (default)' if o == c.default else ''}: {h}" for o, h in zip(c.options, c.option_help)]
            lines.append("")
        shaped = any(p.geometries for p in PARAMETERS if p.kind == kind)
        variants = {"geometry": "geometries", "drive": "drives"}[VARIANTS[kind][0]] if kind in VARIANTS else ""
        if shaped:
            lines += [f"A key whose *{variants}* column names some is held by files of those {variants} only "
                      f"(another's key is an error); its *required* holds within them.", ""]
        lines += ["| key | symbol | unit | documented range | hard limits | required | " +
                  (f"{variants} | " if shaped else "") + "meaning |",
                  "|---|---|---|---|---|---|" + ("---|" if shaped else "") + "---|"]
        for p in (p for p in PARAMETERS if p.kind == kind):
            required = "yes" if p.required else (f"no (default {p.default:g})" if p.default is not None else "no")
            held = f"{', '.join(p.geometries) or 'all'} | " if shaped else ""
            lines.append(f"| `{p.key}` | {p.symbol} | {p.unit} | {p.range_text} | {p.hard_text} | {required} | "
                         f"{held}{p.meaning.replace('|', '/')} |")
        lines.append("")
    return "\n".join(lines)


def _getting_started(readme: Path) -> str:
    text = readme.read_text(encoding="utf-8")
    start, end = text.index("## Set up"), text.index("## Where everything is documented")
    body = text[start:end].replace("## Set up", "## Install", 1).replace("## A five-minute tour", "## The tour", 1)
    body = body.replace("](docs/", "](")  # the README's links into docs/ as the site's pages see them
    return "# Getting started\n\n" + body


def on_config(config):
    commands = [{f"pen {' '.join(path)}": f"commands/{_slug(path)}.md"} for path, _ in _command_paths()]
    nav = config["nav"]
    for entry in nav:
        if isinstance(entry, dict) and "Commands" in entry:
            entry["Commands"] = [{"All commands": "commands/index.md"}, *commands]
    return config


def on_files(files, config):
    pages = {f"commands/{_slug(path)}.md": _command_page(path, command) for path, command in _command_paths()}
    index = ["# Commands", "", "Every command, with its own help text (units, defaults, an example).", "",
             "| command | what it does |", "|---|---|"]
    for path, command in _command_paths():
        summary = (command.help or "").strip().split("\n")[0]
        index.append(f"| [pen {' '.join(path)}]({_slug(path)}.md) | {summary} |")
    pages["commands/index.md"] = "\n".join(index) + "\n"
    pages["reference/parameters.md"] = _parameters_page()
    pages["getting-started.md"] = _getting_started(Path(config["config_file_path"]).parent / "README.md")
    for uri, content in pages.items():
        files.append(File.generated(config, uri, content=content))
    return files
