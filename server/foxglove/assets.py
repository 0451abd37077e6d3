"""The endpoint's asset handler: the mesh files a robot description names by ``package://`` URI, and nothing else.

Foxglove's 3D panel loads the robot's URDF from ``/<robot>/robot_description`` and fetches each mesh it names, such as
``package://wolfgang_description/urdf/ankle.stl``, through the Foxglove connection. A URI is answered only with a file
inside the folders the server was given for the robots' descriptions (``--package NAME=DIR``, and the folder of each
URDF and the one above it for packages not named), resolved with symlinks and ``..`` followed
(server.security.AllowedFolders), and only mesh and texture files: ``package://x/../../etc/passwd``, ``file://``
URIs and anything not a mesh get "not found", whether or not such a file exists.
"""

from __future__ import annotations

import logging
from pathlib import Path
from urllib.parse import unquote

from server.config import RobotDescription
from server.security import AllowedFolders, FolderError

log = logging.getLogger(__name__)
SCHEME = "package://"
MESH_SUFFIXES = frozenset({".stl", ".dae", ".obj", ".glb", ".gltf", ".ply", ".png", ".jpg", ".jpeg"})
MAX_ASSET_BYTES = 64 << 20  # a detailed mesh is a few MB; beyond this it is no mesh of a kid-size robot


class RobotAssets:
    """``package://`` URI -> file bytes, or None (the SDK then answers the client with an error)."""

    def __init__(self, descriptions: list[RobotDescription]) -> None:
        self.packages: dict[str, list[Path]] = {}
        self.fallback: list[Path] = []  # for packages no --package names: around each URDF
        for description in descriptions:
            for name, folder in description.packages.items():
                self.packages.setdefault(name, []).append(Path(folder))
            urdf_dir = Path(description.urdf).parent
            self.fallback += [urdf_dir, urdf_dir.parent]
        self.served = 0
        self.refused = 0

    def __call__(self, uri: str) -> bytes | None:
        try:
            path = self.resolve(uri)
            if path.stat().st_size > MAX_ASSET_BYTES:
                raise FolderError(f"{uri}: larger than {MAX_ASSET_BYTES >> 20} MB")
            data = path.read_bytes()
        except (FolderError, OSError, ValueError) as exc:
            self.refused += 1
            log.info("foxglove: asset %r not served: %s", uri[:200], exc)
            return None
        self.served += 1
        return data

    def resolve(self, uri: str) -> Path:
        """The file a ``package://`` URI names inside the allowed folders; FolderError otherwise."""
        if not uri.startswith(SCHEME):
            raise FolderError("only package:// URIs of the robot descriptions are served")
        package, _, rest = unquote(uri[len(SCHEME):]).partition("/")
        if not package or not rest or Path(rest).suffix.lower() not in MESH_SUFFIXES:
            raise FolderError("only mesh and texture files of the robot descriptions are served")
        for folder in self.packages.get(package) or self.fallback:
            try:
                path = AllowedFolders([folder], "assets").resolve(rest)
            except FolderError:
                continue
            if path.is_file():
                return path
        raise FolderError("no such mesh in the robot descriptions' folders")
