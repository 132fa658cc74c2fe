"""Reading TOML files (experiment descriptions, calibration configurations, stereology sidecars)
with the project's error messages."""

from __future__ import annotations

import tomllib
from pathlib import Path

from bayestissue._validation import ValidationError

__all__ = ["read_toml"]


def read_toml(path: str | Path, what: str) -> dict:
    """The parsed TOML file ``path``; ``what`` names the kind of file in the messages.

    Raises
    ------
    FileNotFoundError
        ``"<what> file '<path>' does not exist"``.
    ValidationError
        ``"<what> <name>: expected valid TOML, got '<parser message>'"``.
    """
    path = Path(path)
    if path.is_dir():
        raise ValidationError(f"{what} file", str(path), "a TOML file (this is a folder)")
    if not path.is_file():
        raise FileNotFoundError(f"{what} file {str(path)!r} does not exist")
    raw = path.read_bytes()
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ValidationError(f"{what} {path.name}", f"byte 0x{raw[exc.start]:02x} at position {exc.start}",
                              "UTF-8 text (a TOML file; is this a binary file?)") from None  # fmt: skip
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ValidationError(f"{what} {path.name}", str(exc), "valid TOML") from None
