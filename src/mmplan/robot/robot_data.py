"""Where the URDFs of real robots are: ``example-robot-data`` (optional extra ``robots``).

``pip install 'mmplan[robots]'`` installs ``example-robot-data-loaders``, whose files live under
``<prefix>/share/example-robot-data/robots/`` (``<prefix>`` is ``cmeel.prefix`` in
site-packages). Nothing is downloaded at run time.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

from mmplan.errors import InputError
from mmplan.extras import install_command

_SUBDIR = Path("share") / "example-robot-data" / "robots"


def _candidates() -> list[Path]:
    out = []
    spec = importlib.util.find_spec("example_robot_data")
    if spec is not None and spec.origin is not None:
        # <prefix>/lib/pythonX.Y/site-packages/example_robot_data/__init__.py
        out.append(Path(spec.origin).resolve().parents[4] / _SUBDIR)
    for entry in sys.path:
        out.append(Path(entry or ".") / "cmeel.prefix" / _SUBDIR)
        out.append(Path(entry or ".").parent.parent.parent / _SUBDIR)
    return out


def robot_data_dir() -> Path:
    """The ``example-robot-data/robots`` folder.

    Raises:
        InputError: the package is not installed (one line saying how to install it).
    """
    for path in _candidates():
        if path.is_dir():
            return path
    raise InputError("robot", f"the real robots' URDFs (example-robot-data) are not installed: "
                     f"{install_command('robots')}")


def robot_data_file(relative: str) -> Path:
    """A file below ``example-robot-data/robots``, e.g. ``tiago_description/robots/tiago.urdf``.

    Raises:
        InputError: the package or the file is missing.
    """
    path = robot_data_dir() / relative
    if not path.is_file():
        raise InputError("robot", f"{relative} is missing from example-robot-data at "
                         f"{path.parent}: {install_command('robots')}")
    return path
