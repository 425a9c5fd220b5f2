"""Stub encoders and test images: known colours, orthonormal class features, fixed phrases.

Images are 32 x 48 px of flat colour regions aligned to 4 px cells:

    cols  0-15  red                     (masked: "red", and "table" = red + green)
    cols 16-31  green (rows 0-15), blue (rows 16-31)   (masked: "green", "blue")
    cols 32-47  grey, covered by no mask

The dense CLIP stub returns one feature per 4 px cell (an 8 x 12 grid): the class vector of the
cell's colour plus small fixed noise, so with ``feature_height=8`` no resizing happens and the
expected pooled features can be computed by hand.
"""

from __future__ import annotations

import hashlib

import numpy as np
from PIL import Image

D = 16
DINO_D = 8
CELL = 4
RED, GREEN, BLUE, GREY = (220, 30, 30), (30, 200, 40), (40, 40, 210), (128, 128, 128)
COLOURS = [RED, GREEN, BLUE, GREY]
#: Orthonormal feature direction per colour class, rows in COLOURS order.
CLASS_VECTORS = np.linalg.qr(np.random.default_rng(7).normal(size=(D, D)))[0][:4].astype(
    np.float32
)


def scene_image(height: int = 32, width: int = 48) -> np.ndarray:
    """``[H][W][3]`` uint8 with the layout of the module docs (scaled to the size)."""
    img = np.empty((height, width, 3), dtype=np.uint8)
    third, half = width // 3, height // 2
    img[:, :third] = RED
    img[:half, third : 2 * third] = GREEN
    img[half:, third : 2 * third] = BLUE
    img[:, 2 * third :] = GREY
    return img


def write_png(path, image: np.ndarray) -> None:
    Image.fromarray(image).save(path)


def colour_class(image: np.ndarray) -> np.ndarray:
    """``[H][W]`` index into COLOURS of each pixel (exact colours)."""
    classes = np.full(image.shape[:2], -1)
    for k, c in enumerate(COLOURS):
        classes[(image == c).all(axis=-1)] = k
    assert (classes >= 0).all(), "unexpected colour"
    return classes


class StubMasks:
    """Masks from the colour-quantised image: one per coloured class except grey, plus
    "table" = red | green (overlapping both) when ``table``."""

    def __init__(self, table: bool = True, name: str = "stub-masks"):
        self.name = name
        self.table = table
        self.calls = 0

    def generate(self, image):
        self.calls += 1
        classes = colour_class(image)
        masks = [classes == k for k in range(3)]
        if self.table:
            masks.append((classes == 0) | (classes == 1))
        return masks


def dense_cells(image: np.ndarray, dim: int = D) -> np.ndarray:
    """The dense CLIP stub's output: ``[H/4][W/4][dim]`` float32."""
    cells = colour_class(image)[::CELL, ::CELL]
    noise = np.random.default_rng(1).normal(scale=0.05, size=(*cells.shape, dim))
    vectors = np.zeros((4, dim), dtype=np.float32)
    vectors[:, : min(dim, D)] = CLASS_VECTORS[:, : min(dim, D)]
    return (vectors[cells] + noise).astype(np.float32)


class StubDenseClip:
    def __init__(self, dim: int = D, name: str = "stub-clip"):
        self.name = name
        self.dim = dim
        self.calls = 0

    def features(self, image):
        self.calls += 1
        return dense_cells(image, self.dim)


class StubDino:
    """Constant 3.0 on an 8 px patch grid: any bilinear resize of it is exactly 3.0."""

    name = "stub-dino"

    def features(self, image):
        h, w = image.shape[0] // 8, image.shape[1] // 8
        return np.full((h, w, DINO_D), 3.0, dtype=np.float32)


def phrase_vector(phrase: str, dim: int = D) -> np.ndarray:
    """Fixed unit vector per phrase: "icing" = red class, "object" = green, "things" = blue,
    "grey wall" = grey, anything else a vector seeded by the phrase's hash."""
    fixed = {"icing": 0, "object": 1, "things": 2, "grey wall": 3}
    if phrase in fixed and dim == D:
        return CLASS_VECTORS[fixed[phrase]]
    seed = int.from_bytes(hashlib.sha256(phrase.encode()).digest()[:8], "little")
    v = np.random.default_rng(seed).normal(size=dim).astype(np.float32)
    return v / np.linalg.norm(v)


class StubText:
    def __init__(self, dim: int = D, name: str = "stub-clip", scale: float = 1.0):
        self.name = name
        self.dim = dim
        self.scale = scale
        self.seen: list[str] = []

    def encode(self, phrases):
        self.seen.extend(phrases)
        return np.stack([phrase_vector(p, self.dim) * self.scale for p in phrases])
