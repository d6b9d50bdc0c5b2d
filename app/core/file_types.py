"""Types for the readers and writers that take a path or an open file."""

from __future__ import annotations

import os
from typing import IO, TypeAlias

TextPathOrFile: TypeAlias = str | os.PathLike[str] | IO[str]
"""A path, or a file opened in text mode."""
BinaryPathOrFile: TypeAlias = str | os.PathLike[str] | IO[bytes]
"""A path, or a file opened in binary mode."""
