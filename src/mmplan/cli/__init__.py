"""The ``mmplan`` command line: a thin layer over the public API.

``main`` here is the program (:func:`mmplan.cli.program.run`: the command, then a quick
exit); the click group itself is :func:`mmplan.cli.main.main` (for ``CliRunner`` and code
that embeds the command).
"""

from mmplan.cli.program import run as main

__all__ = ["main"]
