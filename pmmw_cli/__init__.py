"""pmmw: passive millimetre-wave imaging simulator."""

__version__ = "0.1.0"
