"""Image listing and loading, array resizing and atomic ``.npy`` writes (numpy + Pillow only)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .errors import Stage1Error

#: File suffixes treated as images (case-insensitive); everything else in the folder is skipped.
IMAGE_SUFFIXES = frozenset({".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp"})

#: Background colours for compositing images that carry alpha (RGB, 0-255).
BACKGROUNDS = {"black": (0, 0, 0), "white": (255, 255, 255)}


def list_images(images_dir: Path) -> list[Path]:
    """Image files directly inside ``images_dir``, sorted by name.

    Files with other suffixes and sub-folders are skipped. Output files are named by stem, so
    two images sharing a stem (``a.png``, ``a.jpg``) are an error.

    Raises:
        Stage1Error: the folder is missing, holds no image, or two images share a stem.
    """
    if not images_dir.is_dir():
        raise Stage1Error(f"{images_dir}: not a folder of images")
    paths = sorted(
        p for p in images_dir.iterdir() if p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES
    )
    if not paths:
        suffixes = ", ".join(sorted(IMAGE_SUFFIXES))
        raise Stage1Error(f"{images_dir}: no image files ({suffixes})")
    seen: dict[str, Path] = {}
    for p in paths:
        if p.stem in seen:
            raise Stage1Error(
                f"{p} and {seen[p.stem]} share the stem {p.stem!r}; outputs are named by stem"
            )
        seen[p.stem] = p
    return paths


def load_image(path: Path, background: str = "black") -> np.ndarray:
    """Reads an image as RGB ``[H][W][3]`` uint8.

    Images with alpha are composited over ``background`` ("black" or "white"), as 3DGS
    training does (its default background is black, ``--white_background`` makes it white).

    Raises:
        Stage1Error: naming ``path``, when Pillow cannot read or decode it.
    """
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as im:
            im.load()
            if im.mode in ("RGBA", "LA", "PA") or (im.mode == "P" and "transparency" in im.info):
                rgba = im.convert("RGBA")
                canvas = Image.new("RGBA", rgba.size, BACKGROUNDS[background] + (255,))
                rgb = Image.alpha_composite(canvas, rgba).convert("RGB")
            else:
                rgb = im.convert("RGB")
    except (OSError, UnidentifiedImageError, ValueError) as e:
        raise Stage1Error(f"{path}: cannot read image ({e})") from e
    return np.asarray(rgb, dtype=np.uint8)


def feature_size(height: int, width: int, feature_height: int | None) -> tuple[int, int]:
    """Feature-map size ``(H', W')`` for an image ``height × width``.

    ``feature_height`` ``None`` means one eighth of the image height. The width keeps the
    image's aspect ratio (rounded, at least 1).
    """
    h = feature_height if feature_height is not None else max(1, round(height / 8))
    if h < 1:
        raise Stage1Error(f"feature height must be >= 1, got {h}")
    return h, max(1, round(width * h / height))


def _linear_taps(n_in: int, n_out: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Source indices ``lo``, ``hi`` and weights of ``hi`` for half-pixel-centred resampling."""
    x = (np.arange(n_out, dtype=np.float64) + 0.5) * (n_in / n_out) - 0.5
    x = np.clip(x, 0.0, n_in - 1)
    lo = np.floor(x).astype(np.intp)
    hi = np.minimum(lo + 1, n_in - 1)
    return lo, hi, x - lo


def resize_bilinear(a: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """Bilinear resize of ``a`` ``[h][w][C]`` to ``[H][W][C]`` float32.

    Half-pixel centres with edge clamping (torch's ``interpolate(mode="bilinear",
    align_corners=False)``); no antialiasing, so downscaling by large factors aliases, as in
    Feature Splatting. Resizing to the same size returns the values unchanged.
    """
    a = np.asarray(a, dtype=np.float32)
    ylo, yhi, wy = _linear_taps(a.shape[0], size[0])
    xlo, xhi, wx = _linear_taps(a.shape[1], size[1])
    wy = wy.astype(np.float32)[:, None, None]
    wx = wx.astype(np.float32)[None, :, None]
    rows = a[ylo] * (1 - wy) + a[yhi] * wy
    return rows[:, xlo] * (1 - wx) + rows[:, xhi] * wx


def resize_mask(mask: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """Nearest-neighbour resize of a boolean mask ``[h][w]`` to ``[H][W]`` (pixel centres)."""
    mask = np.asarray(mask, dtype=bool)
    if mask.ndim != 2:
        raise Stage1Error(f"a mask must be 2-D, got shape {mask.shape}")
    ys = np.minimum(((np.arange(size[0]) + 0.5) * mask.shape[0] / size[0]).astype(np.intp),
                    mask.shape[0] - 1)
    xs = np.minimum(((np.arange(size[1]) + 0.5) * mask.shape[1] / size[1]).astype(np.intp),
                    mask.shape[1] - 1)
    return mask[ys[:, None], xs[None, :]]


def save_npy(path: Path, array: np.ndarray) -> None:
    """Writes ``array`` to ``path`` through a temporary file and a rename, so an interrupted run
    never leaves a partial file that a resumed run would take as done."""
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "wb") as f:
        np.save(f, np.ascontiguousarray(array))
    os.replace(tmp, path)
