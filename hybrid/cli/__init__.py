"""Layer 9: the ``hybrid`` command line, one module per subcommand over shared helpers."""

from .main import main as main

__all__ = ["main"]
