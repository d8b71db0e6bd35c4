"""Every command's --help is complete: command lists never cut a sentence with "...", every option says
what it does."""

from __future__ import annotations

import click
from click.testing import CliRunner

from gradekit.cli import main


def commands(group: click.Group, path: tuple[str, ...] = ()):
    for name, cmd in group.commands.items():
        yield (*path, name), cmd
        if isinstance(cmd, click.Group):
            yield from commands(cmd, (*path, name))


def text(output: str) -> str:
    """The help without its usage line (where "[ARGS]..." is click's notation for more arguments)."""
    return "\n".join(line for line in output.splitlines() if not line.startswith("Usage:"))


def test_help_lists_whole_sentences_and_every_option_has_help() -> None:
    runner = CliRunner()
    for path in [(), *(p for p, c in commands(main) if isinstance(c, click.Group))]:
        r = runner.invoke(main, [*path, "--help"], terminal_width=80)
        assert r.exit_code == 0 and "..." not in text(r.output), path
    for path, cmd in commands(main):
        for param in cmd.params:
            if isinstance(param, click.Option):
                assert param.help, (path, param.name)
        r = runner.invoke(main, [*path, "--help"], terminal_width=80)
        assert r.exit_code == 0 and "..." not in text(r.output), path
