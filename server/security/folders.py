"""Paths that come from clients (a log to replay, an animation folder a robot names) stay in allowed folders.

A path is resolved (symlinks and ``..`` followed) before it is compared, so neither ``../../etc/passwd`` nor a
link inside the folder that points out of it gets through. A refused path is answered without saying whether
it exists.
"""

from __future__ import annotations

from pathlib import Path


class FolderError(PermissionError):
    """A path outside every allowed folder; the text names the folders, not what is outside."""


class AllowedFolders:
    """A few folders; ``resolve`` maps a name or path from a client to a file inside one of them."""

    def __init__(self, folders: list[Path] | tuple[Path, ...], what: str = "files") -> None:
        self.folders = [Path(f).expanduser().resolve() for f in folders]
        self.what = what

    def contains(self, path: Path) -> bool:
        resolved = Path(path).expanduser().resolve()
        return any(resolved == f or resolved.is_relative_to(f) for f in self.folders)

    def resolve(self, name: str) -> Path:
        """A bare or relative name is looked up in each folder in turn; an absolute path must lie inside one.

        FolderError if the path leads outside every folder (the result need not exist)."""
        if "\0" in name:
            raise FolderError(f"{self.what}: a path must not contain NUL")
        path = Path(name).expanduser()
        candidates = [path] if path.is_absolute() else [folder / path for folder in self.folders]
        inside = [c.resolve() for c in candidates if self.contains(c)]
        if not inside:
            raise FolderError(f"{self.what} are opened only from {self.describe()}")
        return next((p for p in inside if p.exists()), inside[0])

    def describe(self) -> str:
        return ", ".join(str(f) for f in self.folders) or "(no folder)"
