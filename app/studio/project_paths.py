"""Where projects are: the paths typed to save and open (checked against the allowed folders),
the project an autosave is of, and the clock times shown beside a project's name."""

from __future__ import annotations

from datetime import datetime
from pathlib import Path

from app.core.file_access import FileAccess
from app.core.projects.codec import ProjectError
from app.core.projects.files import SUFFIX
from app.core.projects.project import Project


class ProjectPaths:
    """The data folder's projects/ and the folders a tab may save to and open from."""

    def __init__(self, projects_dir: Path, access: FileAccess) -> None:
        self.projects_dir = projects_dir
        self.access = access

    def to_save(self, typed: str) -> Path:
        """The file to save to for a name or path typed in a tab (StudioError: why not)."""
        if not typed:
            raise ProjectError("type a name or a path for the project")
        path = Path(typed).expanduser()
        if path.suffix.lower() != SUFFIX:
            path = path.with_name(path.name + SUFFIX)
        if len(path.parts) == 1:  # a bare name: the data folder's projects/
            self.projects_dir.mkdir(parents=True, exist_ok=True)
            path = self.projects_dir / path
        return self.access.check(path)

    def to_open(self, typed: str, trusted: bool) -> Path:
        """The file to open for `typed` (a bare name: in projects/); `trusted` for a path
        given on the command line (not checked against the allowed folders, which guard paths
        typed in a browser). StudioError: why not."""
        path = Path(typed.strip()).expanduser()
        if len(path.parts) == 1 and not path.exists():
            path = self.projects_dir / path
            if path.suffix.lower() != SUFFIX:
                path = path.with_name(path.name + SUFFIX)
        return path.resolve() if trusted else self.access.check(path)


def origin(project: Project) -> tuple[str, Path | None]:
    """The name and file of the project an autosave is of ("", None for untitled work); a
    path that is not an absolute .bstudio path (a damaged or edited autosave) is dropped."""
    name = project.autosave_of.strip()
    if len(name) > 200 or not name.isprintable():
        name = ""
    typed = project.autosave_path
    path = Path(typed) if typed and "\x00" not in typed else None
    if path is not None and (not path.is_absolute() or path.suffix.lower() != SUFFIX):
        path = None
    if path is not None and not name:
        name = path.stem
    return name, path


def file_time(path: Path) -> str:
    """The local clock time `path` was last written ("" when it cannot be read)."""
    try:
        return datetime.fromtimestamp(path.stat().st_mtime).strftime("%H:%M:%S")
    except OSError:
        return ""


def saved_time(iso: str, fmt: str = "%H:%M:%S") -> str:
    """The local clock time of an ISO 8601 UTC stamp ("" when there is none)."""
    try:
        return datetime.fromisoformat(iso).astimezone().strftime(fmt)
    except ValueError:
        return ""
