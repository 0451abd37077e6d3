"""Interface definitions of other teams, loaded from a folder laid out as ROS 2 packages are.

``<folder>/<package>/msg/*.msg``, ``.../srv/*.srv`` and ``.../action/*.action``: what a team's repository holds, so
the dashboard can decode and hash (schemas.type_hash) types pitchside does not ship, without a ROS 2 install.
"""

from __future__ import annotations

from pathlib import Path

from rosbags.interfaces.typing import Typesdict

from schemas.definitions import file_texts, parse_texts

KINDS = ("msg", "srv", "action")


class InterfaceFolderError(Exception):
    """A definition file in the folder does not parse (the message names the file)."""


def interface_files(folder: Path) -> list[Path]:
    """Every definition file under folder, in a fixed order (package, kind, name)."""
    return sorted(path for kind in KINDS for path in folder.glob(f"*/{kind}/*.{kind}"))


def load_interfaces(folder: Path) -> Typesdict:
    """rosbags field definitions of every type defined under folder, by full ROS 2 type name."""
    if not folder.is_dir():
        raise InterfaceFolderError(f"{folder} is not a folder of ROS 2 interface packages")
    types: Typesdict = {}
    for path in interface_files(folder):
        try:
            types.update(parse_texts(file_texts(path)))
        except Exception as exc:  # rosbags raises its own parse errors; name the file the user must fix
            raise InterfaceFolderError(f"{path}: {exc}") from exc
    return types


def register_interfaces(folder: Path) -> list[str]:
    """Adds the folder's message types to the process's typestore (schemas.codec), so they decode, hash and show
    like pitchside's own; returns the names added. A type the store already has (a standard type, pitchside's) is
    never redefined: the folder's copy is left out."""
    from schemas.codec import typestore

    store = typestore()
    new = {name: fields for name, fields in load_interfaces(folder).items() if name not in store.fielddefs}
    try:
        store.register(new)
    except Exception as exc:  # rosbags' TypesysError: a definition refers to a type no one defines
        raise InterfaceFolderError(f"{folder}: {exc}") from exc
    return sorted(new)
