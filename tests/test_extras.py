"""The install command of an optional extra names where mmplan was installed from."""

from __future__ import annotations

import json
from typing import Any

import pytest

from mmplan import extras


class _Dist:
    def __init__(self, direct_url: dict[str, Any] | None) -> None:
        self.text = None if direct_url is None else json.dumps(direct_url)

    def read_text(self, name: str) -> str | None:
        return self.text if name == "direct_url.json" else None


@pytest.mark.parametrize(
    ("found", "command"),
    [
        ([], "pip install 'mmplan[robots]'"),  # not installed: the package index
        ([_Dist(None)], "pip install 'mmplan[robots]'"),  # from the index (or a source tree)
        ([_Dist(None), _Dist({"url": "file:///home/u/my%20mmplan", "dir_info": {}})],
         "pip install '/home/u/my mmplan[robots]'"),  # a checkout, installed
        ([_Dist({"url": "file:///work/mmplan", "dir_info": {"editable": True}})],
         "pip install -e '/work/mmplan[robots]'"),  # a checkout, editable
        ([_Dist({"url": "https://example.org/mmplan-0.1.tar.gz", "archive_info": {}})],
         "pip install 'mmplan[robots] @ https://example.org/mmplan-0.1.tar.gz'"),
        ([_Dist({"url": "https://example.org/u/mmplan.git",
                 "vcs_info": {"vcs": "git", "commit_id": "abc123"}})],
         "pip install 'mmplan[robots] @ git+https://example.org/u/mmplan.git@abc123'"),
        ([_Dist({"url": "file://server/share/mmplan", "dir_info": {}})],
         "pip install '//server/share/mmplan[robots]'"),  # a network share keeps its host
    ],
)
def test_the_install_command_names_the_checkout(
    monkeypatch: pytest.MonkeyPatch, found: list[_Dist], command: str
) -> None:
    monkeypatch.setattr(extras.metadata, "distributions", lambda name: iter(found))
    extras._source.cache_clear()
    try:
        assert extras.install_command("robots") == command
    finally:
        extras._source.cache_clear()
