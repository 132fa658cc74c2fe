"""Serial micrographs on disk: a folder of PNG/TIFF sections or one multi-page TIFF, plus the
phantom's truth (JSON).

A folder is read in natural sort order of the file names (``s2.png`` before ``s10.png``); every
section must have the same size and the same number of channels.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import imageio.v3 as iio
import numpy as np
import tifffile

from bayestissue._validation import ValidationError

__all__ = ["IMAGE_SUFFIXES", "read_micrographs", "write_micrographs", "write_truth", "read_truth"]

IMAGE_SUFFIXES = (".png", ".tif", ".tiff")


def _natural_key(path: Path):
    return [int(t) if t.isdigit() else t.lower() for t in re.split(r"(\d+)", path.name)]


def _to_uint8(img: np.ndarray, name: str) -> np.ndarray:
    a = np.asarray(img)
    if a.dtype == np.uint8:
        return a
    if a.dtype == np.uint16:
        return (a // 257).astype(np.uint8)
    if np.issubdtype(a.dtype, np.floating) and np.nanmin(a) >= 0 and np.nanmax(a) <= 1:
        return np.round(a * 255).astype(np.uint8)
    raise ValidationError(name, f"dtype {a.dtype}", "8-bit, 16-bit or [0, 1] float images")


#: The first bytes of each accepted format (a file whose bytes do not start so is not that image, whatever its suffix).
_SIGNATURES = {
    ".png": (b"\x89PNG\r\n\x1a\n",),
    ".tif": (b"II*\x00", b"MM\x00*", b"II+\x00", b"MM\x00+"),
    ".tiff": (b"II*\x00", b"MM\x00*", b"II+\x00", b"MM\x00+"),
}


def _read_image(path: Path) -> np.ndarray:
    """One image file's pixels; a file that is not an image of its suffix's format is refused by name (checked by
    its signature first: imageio would otherwise try every plugin on it and leave files open)."""
    kind = path.suffix.lower()
    with path.open("rb") as fh:
        head = fh.read(8)
    expected = f"a readable {kind.lstrip('.').upper()} image"
    if not head.startswith(_SIGNATURES.get(kind, (b"",))):
        raise ValidationError(f"image {path}", f"a file starting {head[:4]!r}", expected)
    try:
        if kind in (".tif", ".tiff"):
            return tifffile.imread(path)
        return iio.imread(path, plugin="pillow")
    except Exception as exc:  # a damaged file: the readers raise OSError, ValueError, their own errors and more
        raise ValidationError(f"image {path}", f"unreadable ({type(exc).__name__})", expected) from None


def read_micrographs(source: str | Path) -> tuple[np.ndarray, list[str]]:
    """Read a stack of sections from a folder of PNG/TIFF files or a multi-page TIFF.

    Parameters
    ----------
    source : folder, or a .tif/.tiff file whose pages (or first axis) are the sections.

    Returns
    -------
    images : (n, H, W, C) or (n, H, W) uint8 ndarray (C = 3 for RGB; an alpha channel is dropped).
    names : the file (or page) name of each section.

    Raises
    ------
    FileNotFoundError if ``source`` does not exist; ValidationError for an empty folder, images of
    different sizes or channel counts, or unsupported pixel types.
    """
    src = Path(source)
    if not src.exists():
        raise FileNotFoundError(f"micrograph source {str(src)!r} does not exist")
    if src.is_dir():
        files = sorted((p for p in src.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES), key=_natural_key)
        if not files:
            raise ValidationError("source", str(src), f"a folder with {'/'.join(IMAGE_SUFFIXES)} section images")
        imgs, names = [], []
        for p in files:
            imgs.append(_to_uint8(_read_image(p), p.name))
            names.append(p.name)
    elif src.suffix.lower() in (".tif", ".tiff"):
        a = _read_image(src)
        if a.ndim == 2 or (a.ndim == 3 and a.shape[-1] in (3, 4) and a.shape[0] > 4):
            a = a[None]  # a single page
        imgs = [_to_uint8(x, f"{src.name} page {k}") for k, x in enumerate(a)]
        names = [f"{src.name}[{k}]" for k in range(len(imgs))]
    else:
        raise ValidationError("source", str(src), "a folder of PNG/TIFF sections or a multi-page .tif/.tiff file")
    shapes = [im.shape for im in imgs]
    if len(set(shapes)) != 1:
        k = next(i for i, s in enumerate(shapes) if s != shapes[0])
        raise ValidationError(
            "section size",
            f"{names[k]} is {shapes[k]}",
            f"every section the size of {names[0]}, {shapes[0]}",
            "crop or pad the images to one size before registering",
        )
    stack = np.stack(imgs)
    if stack.ndim == 4 and stack.shape[-1] == 4:
        stack = stack[..., :3]
    return stack, names


def write_micrographs(
    folder: str | Path, images: np.ndarray, *, fmt: str = "png", prefix: str = "section"
) -> list[Path]:
    """Write a stack as ``<prefix>_000.png ...`` (``fmt="png"``) or one multi-page TIFF
    (``fmt="tiff"``: ``<prefix>s.tif``). Returns the written paths."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    images = np.asarray(images)
    if fmt == "png":
        paths = []
        for i, im in enumerate(images):
            p = folder / f"{prefix}_{i:03d}.png"
            iio.imwrite(p, im)
            paths.append(p)
        return paths
    if fmt == "tiff":
        p = folder / f"{prefix}s.tif"
        tifffile.imwrite(p, images, photometric="rgb" if images.ndim == 4 else "minisblack")
        return [p]
    raise ValidationError("fmt", fmt, "'png' or 'tiff'")


def write_truth(path: str | Path, truth: dict) -> Path:
    """Write the phantom's ground truth as JSON (must say ``"synthetic": true``)."""
    if not truth.get("synthetic"):
        raise ValidationError("truth", "no 'synthetic': true entry", "a synthetic truth record")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(truth, indent=1))
    return path


def read_truth(path: str | Path) -> dict:
    """Read a truth JSON written by :func:`write_truth`."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"truth file {str(path)!r} does not exist")
    return json.loads(path.read_text())
