"""The command that adds one of mmplan's optional extras to this installation."""

from __future__ import annotations

import json
import shlex
from functools import lru_cache
from importlib import metadata
from urllib.parse import unquote, urlparse


def install_command(extra: str) -> str:
    """``pip install 'mmplan[extra]'``, or ``pip install '/path/to/mmplan[extra]'`` when this
    mmplan was installed from a folder (a checkout; ``pip install -e ...`` when it was
    installed editable: pip records both in the distribution's ``direct_url.json``). Found by
    a new-user trial: the package-index form is no help to a user who installed from a
    checkout."""
    source, editable = _source()
    return f"pip install {'-e ' if editable else ''}{shlex.quote(f'{source}[{extra}]')}"


@lru_cache(maxsize=1)
def _source() -> tuple[str, bool]:
    """What pip installed mmplan from (a folder's path, else the name ``mmplan``) and
    whether it was installed editable."""
    for dist in metadata.distributions(name="mmplan"):  # a source tree's egg-info has none
        try:
            text = dist.read_text("direct_url.json")
            info = json.loads(text) if text else None
            url = urlparse(str(info.get("url", ""))) if info else None
        except (ValueError, AttributeError, OSError):
            continue
        if url is not None and url.scheme == "file" and url.path:
            editable = bool((info or {}).get("dir_info", {}).get("editable", False))
            return unquote(url.path), editable
        if url is not None:
            return "mmplan", False
    return "mmplan", False


__all__ = ["install_command"]
