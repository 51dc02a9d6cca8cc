"""``python -m mmplan.cli``."""

from mmplan.cli.main import main

main()
