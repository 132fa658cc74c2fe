"""Serial micrographs on disk: a folder of PNG/JPEG/TIFF sections or one multi-page TIFF, plus the
phantom's truth (JSON).

A folder is read in natural sort order of the file names (``s2.png`` before ``s10.png``); every
section must have the same size and the same number of channels. The pixel size can come from a
TIFF's own metadata (:func:`tiff_pixel_size_um`: the resolution tags, or ImageJ's unit).
"""

from __future__ import annotations

import contextlib
import json
import logging
import re
from pathlib import Path

import imageio.v3 as iio
import numpy as np
import tifffile

from bayestissue._validation import ValidationError

__all__ = [
    "IMAGE_SUFFIXES",
    "read_micrographs",
    "tiff_pixel_size_um",
    "PIXEL_RANGE_UM",
    "WRITER_DPI",
    "section_files",
    "stack_files",
    "write_micrographs",
    "write_truth",
    "read_truth",
]

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff")


def _natural_key(path: Path):
    return [int(t) if t.isdigit() else t.lower() for t in re.split(r"(\d+)", path.name)]


def section_files(folder: str | Path) -> list[Path]:
    """The section images of ``folder`` in natural sort order of their names (``s2.png`` before ``s10.png``)."""
    files = (p for p in Path(folder).iterdir() if p.suffix.lower() in IMAGE_SUFFIXES and p.is_file())
    return sorted(files, key=_natural_key)


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
    ".jpg": (b"\xff\xd8\xff",),
    ".jpeg": (b"\xff\xd8\xff",),
    ".tif": (b"II*\x00", b"MM\x00*", b"II+\x00", b"MM\x00+"),
    ".tiff": (b"II*\x00", b"MM\x00*", b"II+\x00", b"MM\x00+"),
}


def _check_signature(path: Path) -> None:
    """Refuse, by name, a file whose first bytes are not those of its suffix's image format."""
    with path.open("rb") as fh:
        head = fh.read(8)
    if not head.startswith(_SIGNATURES.get(path.suffix.lower(), (b"",))):
        raise ValidationError(f"image {path}", f"a file starting {head[:4]!r}", _expected(path))


def _expected(path: Path) -> str:
    return f"a readable {path.suffix.lower().lstrip('.').upper()} image"


def _read_image(path: Path) -> np.ndarray:
    """One image file's pixels; a file that is not an image of its suffix's format is refused by name (checked by
    its signature first: imageio would otherwise try every plugin on it and leave files open)."""
    _check_signature(path)
    with _refusing_damage(path):
        if path.suffix.lower() in (".tif", ".tiff"):
            return tifffile.imread(path)
        return iio.imread(path, plugin="pillow")


@contextlib.contextmanager
def _refusing_damage(path: Path):
    """Read ``path`` inside this block: a damaged file is refused by name in one line. The readers raise OSError,
    ValueError, their own errors and more ("unreadable"); tifffile also logs what it cannot parse (tags or pages
    pointing past the file's end) and reads on: its first such record refuses the file ("damaged") instead of
    printing log lines."""
    records: list[logging.LogRecord] = []
    handler = logging.Handler(logging.ERROR)
    handler.emit = records.append
    log = tifffile.logger()
    log.addHandler(handler)
    propagate, log.propagate = log.propagate, False  # not also to handlers configured on the root logger
    try:
        yield
    except Exception as exc:
        raise ValidationError(f"image {path}", f"unreadable ({type(exc).__name__})", _expected(path)) from None
    finally:
        log.removeHandler(handler)
        log.propagate = propagate
    if records:
        what = records[0].getMessage().split("\n")[0][:120]
        raise ValidationError(f"image {path}", f"damaged ({what})", _expected(path))


def stack_files(source: str | Path) -> list[Path]:
    """The files a stack is read from, checked before any pixel is read: a folder's section images in reading
    order, or the one multi-page TIFF. Refused by name: a source that does not exist (FileNotFoundError); an empty
    folder, a file that is no TIFF, a file whose first bytes are not its suffix's format (ValidationError)."""
    src = Path(source)
    if not src.exists():
        raise FileNotFoundError(f"micrograph source {str(src)!r} does not exist")
    if src.is_dir():
        files = section_files(src)
        if not files:
            raise ValidationError("source", str(src), f"a folder with {'/'.join(IMAGE_SUFFIXES)} section images")
    elif src.suffix.lower() in (".tif", ".tiff"):
        files = [src]
    else:
        raise ValidationError("source", str(src), "a folder of PNG/JPEG/TIFF sections or a multi-page .tif/.tiff file")
    for p in files:
        _check_signature(p)
    return files


#: micrometres per unit of the TIFF ResolutionUnit tag (2 inch, 3 centimetre) and of ImageJ's ``unit`` entry
_UNIT_UM = {
    2: 25400.0, 3: 10000.0, "micron": 1.0, "microns": 1.0, "um": 1.0, "\u00b5m": 1.0, "\\u00b5m": 1.0,
    "micrometer": 1.0, "micrometre": 1.0, "nm": 1e-3, "mm": 1e3, "cm": 1e4, "m": 1e6, "inch": 25400.0,
}  # fmt: skip


#: Inch resolutions that image writers put in by default (screen 72 and 96 dpi, print 150 to 1200 dpi): with no
#: ImageJ unit beside them they are not a calibration (300 dpi would read as 85 um pixels).
WRITER_DPI = (72.0, 96.0, 150.0, 200.0, 300.0, 600.0, 1200.0)
#: The pixel sizes a stated calibration may give (um): from electron-microscope scales to a whole-slide overview.
PIXEL_RANGE_UM = (1e-4, 1e3)


def tiff_pixel_size_um(path: str | Path, *, check: bool = True) -> float | None:
    """The pixel size (um) a TIFF states, or None if it states none.

    From the XResolution and YResolution tags (pixels per ResolutionUnit: inch or centimetre), or, where the unit is
    "none" (as ImageJ writes it), from ImageJ's ``unit`` entry in the image description (micron, nm, mm ...). An inch
    resolution among :data:`WRITER_DPI` with no ImageJ unit is a writer's default, not a measurement: None. Refused:
    pixels that are not square (X and Y differ), and sizes outside :data:`PIXEL_RANGE_UM` (unless ``check`` is
    False: then the X size as stated, for a note beside a size the user gave).
    """
    path = Path(path)
    with _refusing_damage(path):
        stated = _stated_pixel_size(path)
    if stated is None:
        return None
    x, y = stated
    if not check:
        return x
    if abs(x - y) > 1e-6 * max(x, y):
        raise ValidationError(f"{path.name} pixel size", f"{x:.6g} um (X) x {y:.6g} um (Y)",
                              "square pixels (the same X and Y resolution)", "or give --pixel-size-um")  # fmt: skip
    lo, hi = PIXEL_RANGE_UM
    if not lo <= x <= hi:
        raise ValidationError(f"{path.name} pixel size", f"{x:.6g} um", f"a pixel size in [{lo:g}, {hi:g}] um",
                              "the resolution tags say so; give --pixel-size-um")  # fmt: skip
    return x


def _stated_pixel_size(path) -> tuple[float, float] | None:
    with tifffile.TiffFile(path) as tif:
        page = tif.pages[0]
        tags = page.tags
        if "XResolution" not in tags:
            return None
        per = []
        for key in ("XResolution", "YResolution" if "YResolution" in tags else "XResolution"):
            num, den = tags[key].value
            if not num or not den:
                return None
            per.append(num / den)
        unit = int(tags["ResolutionUnit"].value) if "ResolutionUnit" in tags else 2
        ij = tif.imagej_metadata or {}
        if unit in (2, 3):
            if unit == 2 and "unit" not in ij and any(abs(per[0] - d) < 1e-6 for d in WRITER_DPI):
                return None
            return _UNIT_UM[unit] / per[0], _UNIT_UM[unit] / per[1]
        name = str(ij.get("unit", "")).strip().lower()
        return (_UNIT_UM[name] / per[0], _UNIT_UM[name] / per[1]) if name in _UNIT_UM else None


def read_micrographs(source: str | Path) -> tuple[np.ndarray, list[str]]:
    """Read a stack of sections from a folder of PNG/JPEG/TIFF files or a multi-page TIFF.

    Parameters
    ----------
    source : folder of PNG, JPEG or TIFF sections, or a .tif/.tiff file whose pages (or first axis) are the
        sections.

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
    files = stack_files(src)
    if src.is_dir():
        imgs = [_to_uint8(_read_image(p), p.name) for p in files]
        names = [p.name for p in files]
    else:
        a = _read_image(src)
        if a.ndim == 2 or (a.ndim == 3 and a.shape[-1] in (3, 4) and a.shape[0] > 4):
            a = a[None]  # a single page
        imgs = [_to_uint8(x, f"{src.name} page {k}") for k, x in enumerate(a)]
        names = [f"{src.name}[{k}]" for k in range(len(imgs))]
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
