"""The ``mmplan`` command line: a thin layer over the public API."""

from mmplan.cli.main import main

__all__ = ["main"]
