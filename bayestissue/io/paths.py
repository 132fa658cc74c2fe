"""Output paths checked before any work: a command that will write a file or a folder finds out at once, not after
minutes of computing, that the path is a folder, lies under a file, or cannot be written."""

from __future__ import annotations

import os
from pathlib import Path

from bayestissue._validation import ValidationError

__all__ = ["check_output_file", "check_output_dir"]


def _creatable(field: str, path: Path) -> None:
    """Raise unless ``path``'s nearest existing ancestor is a writable folder (where the rest can be created)."""
    parent = path.parent
    while not parent.exists():
        parent = parent.parent
    if not parent.is_dir():
        raise ValidationError(field, str(path), "a path under a folder", f"{parent} is a file")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise ValidationError(field, str(path), "a path in a writable folder", f"{parent} is not writable")


def check_output_file(field: str, path: str | Path) -> Path:
    """``path`` as a Path; raise unless a file can be written there (replacing an existing file is allowed)."""
    path = Path(path)
    if path.is_dir():
        raise ValidationError(field, str(path), "a file name (this is a folder)")
    if path.exists():
        if not os.access(path, os.W_OK):
            raise ValidationError(field, str(path), "a writable file")
        return path
    _creatable(field, path)
    return path


def check_output_dir(field: str, path: str | Path) -> Path:
    """``path`` as a Path; raise unless it is, or can be created as, a writable folder."""
    path = Path(path)
    if path.exists():
        if not path.is_dir():
            raise ValidationError(field, str(path), "a folder (an existing file is in the way)")
        if not os.access(path, os.W_OK | os.X_OK):
            raise ValidationError(field, str(path), "a writable folder")
        return path
    _creatable(field, path)
    return path
