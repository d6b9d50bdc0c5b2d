"""Names of the files a tab downloads or the studio writes, made from a motion's name.

A motion's name is free text ("walk of 4 steps", a keyframe motion's typed name, a project's):
every file named after it goes through `file_slug`, so the CSVs a tab downloads for one motion
share one stem and never carry spaces, slashes or dots that lead.
"""

from __future__ import annotations

import re


def file_slug(name: str, fallback: str = "motion") -> str:
    """`name` with every run of characters outside [A-Za-z0-9._-] replaced by "_", without
    leading or trailing dots and underscores; `fallback` when nothing is left."""
    return re.sub(r"[^A-Za-z0-9._-]+", "_", name).strip("._") or fallback
