"""Per-image feature maps: SAM masks, MaskCLIP dense features pooled per mask, DINOv2.

For each training image (Feature Splatting's object-level features, Qiu et al. 2024, §3.1):

1. the mask generator segments the image into (overlapping) masks;
2. dense CLIP features ``[h][w][D]`` are resized (bilinear) to the feature resolution
   ``[H'][W']`` and the masks (nearest) to the same grid;
3. each mask's feature is the mean of the dense features inside it;
4. every pixel covered by masks takes the average of the means of the masks covering it;
   pixels no mask covers keep their dense feature;
5. features are L2-normalised per pixel and written as float16.

DINOv2 patch features are resized to the same ``[H'][W']`` and written unnormalised.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from .encoders import DenseClip, Dino, MaskGenerator
from .errors import Stage1Error
from .images import feature_size, list_images, load_image, resize_bilinear, resize_mask, save_npy

#: Name of the metadata file written next to the feature maps.
METADATA = "features.json"
#: Sub-folder of the output holding the DINOv2 maps.
DINO_DIR = "dino"


def mask_stack(masks: Sequence[np.ndarray], size: tuple[int, int]) -> np.ndarray:
    """Masks resized (nearest) to ``size``, as ``[M][H'][W']`` bool; masks left empty at that
    resolution (smaller than a feature cell) are dropped."""
    if not masks:
        return np.zeros((0, *size), dtype=bool)
    stack = np.stack([resize_mask(m, size) for m in masks])
    return stack[stack.any(axis=(1, 2))]


def mask_means(dense: np.ndarray, masks: np.ndarray) -> np.ndarray:
    """Mean feature inside each mask: ``dense`` ``[H][W][D]``, ``masks`` ``[M][H][W]`` bool
    (none empty) → ``[M][D]`` float32 (accumulated in float64)."""
    flat = masks.reshape(len(masks), -1).astype(np.float64)
    sums = flat @ dense.reshape(-1, dense.shape[-1]).astype(np.float64)
    return (sums / flat.sum(axis=1, keepdims=True)).astype(np.float32)


def paint_masks(dense: np.ndarray, masks: np.ndarray, means: np.ndarray) -> np.ndarray:
    """Per-pixel features ``[H][W][D]`` float32 from mask means.

    A pixel covered by several masks takes the average of their means, as Feature Splatting
    does: SAM's automatic generator returns nested masks (whole object, part, sub-part), and
    averaging keeps both object and part context instead of letting one granularity win, and
    does not depend on mask order. Pixels no mask covers keep their ``dense`` feature.
    """
    flat = masks.reshape(len(masks), -1).astype(np.float64)
    count = flat.sum(axis=0)
    painted = (flat.T @ means.astype(np.float64)) / np.maximum(count, 1)[:, None]
    out = dense.reshape(-1, dense.shape[-1]).astype(np.float32)
    covered = count > 0
    out[covered] = painted[covered]
    return out.reshape(dense.shape)


def unit_rows(a: np.ndarray) -> np.ndarray:
    """``a`` divided by its L2 norm along the last axis; all-zero vectors stay zero."""
    norm = np.linalg.norm(a, axis=-1, keepdims=True)
    return a / np.where(norm > 0, norm, 1)


def _checked_map(name: str, path: Path, a: np.ndarray) -> np.ndarray:
    """``a`` as float32 ``[h][w][D]``, or an error naming the encoder and the image."""
    a = np.asarray(a, dtype=np.float32)
    if a.ndim != 3 or min(a.shape) == 0:
        raise Stage1Error(f"{path}: {name} returned shape {a.shape}, expected [h][w][D]")
    if not np.isfinite(a).all():
        raise Stage1Error(f"{path}: {name} returned non-finite values")
    return a


def clip_map(
    path: Path,
    image: np.ndarray,
    mask_generator: MaskGenerator,
    dense_clip: DenseClip,
    size: tuple[int, int],
) -> np.ndarray:
    """Mask-pooled, unit CLIP features ``[H'][W'][D]`` float16 for ``image`` ``[H][W][3]`` uint8
    (steps 1-5 of the module docs). ``path`` only names the image in errors."""
    dense = _checked_map(dense_clip.name, path, dense_clip.features(image))
    dense = resize_bilinear(dense, size)
    try:
        masks = mask_stack(mask_generator.generate(image), size)
    except Stage1Error as e:
        raise Stage1Error(f"{path}: {mask_generator.name}: {e}") from e
    if len(masks):
        dense = paint_masks(dense, masks, mask_means(dense, masks))
    return unit_rows(dense).astype(np.float16)


def dino_map(path: Path, image: np.ndarray, dino: Dino, size: tuple[int, int]) -> np.ndarray:
    """DINOv2 features ``[H'][W'][Dd]`` float16 (bilinear from the patch grid, unnormalised)."""
    return resize_bilinear(_checked_map(dino.name, path, dino.features(image)), size).astype(
        np.float16
    )


def _read_metadata(out_dir: Path) -> dict:
    path = out_dir / METADATA
    if not path.is_file():
        return {}
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError) as e:
        raise Stage1Error(f"{path}: unreadable ({e}); delete it or use --overwrite") from e


def _check_same_models(out_dir: Path, previous: dict, current: dict) -> None:
    """Resuming into a folder made with other models would mix incompatible features."""
    for key, now in current.items():
        before = previous.get(key)
        if now is not None and before is not None and before != now:
            raise Stage1Error(
                f"{out_dir / METADATA}: {key} was {before!r}, this run uses {now!r}; "
                "use --overwrite or another --out folder"
            )


def _check_dim(path: Path, what: str, dims: dict, dim: int) -> None:
    """All maps of a folder share one dimension; the first seen sets it."""
    expected = dims.setdefault(what, dim)
    if dim != expected:
        raise Stage1Error(
            f"{path}: {what} has D = {dim}, other maps in the folder have D = {expected}; "
            "use --overwrite or another --out folder"
        )


def _existing_shape(path: Path) -> tuple[int, ...]:
    """Shape of an output left by an earlier run (read from the header only)."""
    try:
        return np.load(path, mmap_mode="r").shape
    except (OSError, ValueError) as e:
        raise Stage1Error(
            f"{path}: unreadable earlier output ({e}); delete it or use --overwrite"
        ) from e


def _write_metadata(out_dir: Path, models: dict, dims: dict, entries: list) -> dict:
    """Writes features.json (through a temporary file) and returns its content."""
    metadata = {
        "format": "splatphys-stage1-features",
        "version": 1,
        **models,
        "clip_dim": dims["clip_dim"],
        "dino_dim": dims.get("dino_dim"),
        "dtype": "float16",
        "layout": "[H'][W'][D], row-major, one file per image: <stem>.npy, dino/<stem>.npy",
        "pooling": "mean of dense CLIP over each mask; pixels average the means of the masks "
        "covering them; uncovered pixels keep the dense feature; L2-normalised",
        "images": entries,
    }
    tmp = out_dir / (METADATA + ".tmp")
    tmp.write_text(json.dumps(metadata, indent=1) + "\n")
    os.replace(tmp, out_dir / METADATA)
    return metadata


def _progress_printer(total: int) -> Callable[[int, str], None]:
    """A per-image progress line: a tqdm bar when tqdm is installed, else a printed line."""
    try:
        from tqdm import tqdm
    except ImportError:
        return lambda i, line: print(f"[{i}/{total}] {line}", flush=True)
    bar = tqdm(total=total, unit="image")

    def show(i: int, line: str) -> None:
        bar.set_postfix_str(line)
        bar.update(1)
        if i == total:
            bar.close()

    return show


def extract_dir(
    images_dir: Path,
    out_dir: Path,
    mask_generator: MaskGenerator,
    dense_clip: DenseClip,
    dino: Dino | None = None,
    feature_height: int | None = None,
    overwrite: bool = False,
    background: str = "black",
    progress: Callable[[int, str], None] | None = None,
) -> dict:
    """Writes feature maps for every image of ``images_dir`` into ``out_dir``.

    Outputs: ``<out>/<stem>.npy`` (``[H'][W'][D]`` float16, unit vectors),
    ``<out>/dino/<stem>.npy`` (``[H'][W'][Dd]`` float16) when ``dino`` is given, and
    ``<out>/features.json`` (returned as a dict). ``H'`` is ``feature_height`` (default: an
    eighth of the image height), ``W'`` keeps the aspect ratio.

    Images whose outputs all exist are skipped (resume) unless ``overwrite``; resuming
    checks that the models and dimensions match what the folder already holds.
    ``progress(i, line)`` is called once per image (default: tqdm or a printed line).

    Raises:
        Stage1Error: naming the file, for unreadable images, encoder output of the wrong
            shape, or outputs inconsistent with the folder.
    """
    paths = list_images(images_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    if dino is not None:
        (out_dir / DINO_DIR).mkdir(exist_ok=True)
    models = {
        "mask_generator": mask_generator.name,
        "clip_model": dense_clip.name,
        "dino_model": dino.name if dino is not None else None,
    }
    if not overwrite:
        _check_same_models(out_dir, _read_metadata(out_dir), models)
    progress = progress or _progress_printer(len(paths))
    dims: dict[str, int] = {}
    entries = []
    for i, path in enumerate(paths, start=1):
        clip_path = out_dir / f"{path.stem}.npy"
        dino_path = out_dir / DINO_DIR / f"{path.stem}.npy" if dino is not None else None
        outputs = [p for p in (clip_path, dino_path) if p is not None]
        arrays = None
        if not overwrite and all(p.is_file() for p in outputs):
            shapes = [_existing_shape(p) for p in outputs]
            status = "exists, skipped"
        else:
            image = load_image(path, background)
            size = feature_size(image.shape[0], image.shape[1], feature_height)
            arrays = [clip_map(path, image, mask_generator, dense_clip, size)]
            if dino is not None:
                arrays.append(dino_map(path, image, dino, size))
            shapes = [a.shape for a in arrays]
            status = f"{size[0]}x{size[1]} features"
        for p, what, shape in zip(outputs, ("clip_dim", "dino_dim"), shapes):
            if len(shape) != 3:
                raise Stage1Error(f"{p}: shape {shape}, expected [H'][W'][D]")
            _check_dim(p, what, dims, shape[2])
        for p, a in zip(outputs, arrays or []):
            save_npy(p, a)
        entries.append({"image": path.name, "stem": path.stem, "feature_size": list(shapes[0][:2])})
        # Rewritten after every image, so an interrupted run leaves a folder a resumed run
        # can check against.
        metadata = _write_metadata(out_dir, models, dims, entries)
        progress(i, f"{path.name}: {status}")
    return metadata
