"""The command that adds one of mmplan's optional extras to this installation."""

from __future__ import annotations

import json
import shlex
from functools import lru_cache
from importlib import metadata
from typing import Any
from urllib.parse import urlparse
from urllib.request import url2pathname


def install_command(extra: str) -> str:
    """The pip command that adds ``extra`` to this mmplan, from where pip installed it (the
    distribution's ``direct_url.json``): ``pip install '/path/to/mmplan[extra]'`` for a
    folder (``pip install -e ...`` when editable), ``pip install 'mmplan[extra] @ <url>'`` for
    a VCS checkout (at its commit) or an archive, ``pip install 'mmplan[extra]'`` otherwise.
    Found by a new-user trial: the package-index form is no help to a user who installed
    from a checkout."""
    kind, where, editable = _source()
    if kind == "folder":
        requirement = f"{where}[{extra}]"
    elif kind == "url":
        requirement = f"mmplan[{extra}] @ {where}"
    else:
        requirement = f"mmplan[{extra}]"
    return f"pip install {'-e ' if editable else ''}{shlex.quote(requirement)}"


@lru_cache(maxsize=1)
def _source() -> tuple[str, str, bool]:
    """(kind, where, editable): ("folder", its path, editable), ("url", a direct reference,
    False) or ("index", "", False) (the package index, or no record)."""
    for dist in metadata.distributions(name="mmplan"):  # a source tree's egg-info has none
        try:
            text = dist.read_text("direct_url.json")
            info = json.loads(text) if text else None
        except (ValueError, OSError):
            continue
        if isinstance(info, dict) and isinstance(info.get("url"), str):
            return _where(info)
    return "index", "", False


def _where(info: dict[str, Any]) -> tuple[str, str, bool]:
    url = str(info["url"])
    parsed = urlparse(url)
    dir_info = info.get("dir_info")
    if parsed.scheme == "file" and isinstance(dir_info, dict):  # a folder
        path = url2pathname(parsed.path)
        if parsed.netloc and parsed.netloc != "localhost":  # a network share
            path = f"//{parsed.netloc}{path}"
        return "folder", path, bool(dir_info.get("editable", False))
    vcs = info.get("vcs_info")
    if isinstance(vcs, dict) and vcs.get("vcs"):
        commit = vcs.get("commit_id") or vcs.get("requested_revision")
        return "url", f"{vcs['vcs']}+{url}" + (f"@{commit}" if commit else ""), False
    return "url", url, False  # an archive (a wheel or sdist, local or remote)


__all__ = ["install_command"]
