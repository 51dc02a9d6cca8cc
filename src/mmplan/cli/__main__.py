"""``python -m mmplan.cli``."""

from mmplan.cli.program import run

run()
