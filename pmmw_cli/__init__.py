"""The ``pmmw`` command line: the typer app (`cli`), its entry point with signal handling
(`__main__`), and the commands' own modules (`bench`, `bench_po`, `validation`: the validation
document's generator). The library is `pmmw`; nothing in it imports this package."""

from pmmw import __version__

__all__ = ["__version__"]
