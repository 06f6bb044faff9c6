"""The ``pmmw`` console entry point (``python -m pmmw_cli`` too): `pmmw.interrupt.run` installs
the signal handlers, then the command line (`pmmw_cli.cli`, typer) is imported and run.

This module is the top of the import graph. The handlers come first because importing typer takes
about 0.1 s, during which a signal would otherwise end the process with a traceback (SIGINT) or
with no message at all (SIGTERM).
"""

from __future__ import annotations

from pmmw import interrupt


def _app() -> None:
    from pmmw_cli.cli import app

    app()


def main() -> None:
    """The ``pmmw`` command."""
    from pmmw.errors import show_warnings_as_lines

    show_warnings_as_lines()
    interrupt.run(_app)


if __name__ == "__main__":
    main()
