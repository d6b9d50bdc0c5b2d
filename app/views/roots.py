"""Scene roots that alternate between two names, and `NodeLayer`: nodes shown and removed together.

An overlay rebuilt for a new robot or motion must not be re-added under the name it was just
removed from (viser's client can keep the old nodes' poses), nor under a new name every time
(each removed node leaves a removal message in viser's replay buffer, which every new tab
replays: it would grow all day). Two names used in turn do neither: the next creation under a
name supersedes that name's removal message.
"""

from __future__ import annotations


class AlternatingRoot:
    def __init__(self, base: str) -> None:
        self._base = base
        self._count = 0

    def next(self) -> str:
        """The root for the next build: `base/a`, then `base/b`, then `base/a`, …"""
        name = f"{self._base}/{'ab'[self._count % 2]}"
        self._count += 1
        return name


class NodeLayer:
    """An overlay of scene nodes shown, hidden and removed together (`_nodes`, filled by the
    subclass)."""

    _nodes: list

    def set_visible(self, visible: bool) -> None:
        for node in self._nodes:
            node.visible = visible

    def remove(self) -> None:
        for node in self._nodes:
            node.remove()
        self._nodes = []
