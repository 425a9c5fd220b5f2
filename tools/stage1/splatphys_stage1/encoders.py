"""Encoder protocols used by the pipeline, and their real implementations.

The pipeline (:mod:`.extract`, :mod:`.encode_text`) only calls the four protocols below, so
tests pass small stub objects. The real classes import torch, open_clip, segment_anything or
transformers inside ``__init__`` (never at module import) and take every model name, weight
path and the device as arguments: nothing here downloads unless a name, not a path, is given.
"""

from __future__ import annotations

import importlib
from pathlib import Path
from typing import Any, Protocol, Sequence

import numpy as np

from .errors import Stage1Error

#: CLIP's image normalisation (open_clip's OPENAI_DATASET_MEAN/STD), used when the model
#: does not carry its own.
CLIP_MEAN = (0.48145466, 0.4578275, 0.40821073)
CLIP_STD = (0.26862954, 0.26130258, 0.27577711)
#: ImageNet normalisation, used by DINOv2.
IMAGENET_MEAN = (0.485, 0.456, 0.406)
IMAGENET_STD = (0.229, 0.224, 0.225)
#: Suffixes that mark a model argument as a checkpoint file.
CHECKPOINT_SUFFIXES = frozenset({".bin", ".pt", ".pth", ".safetensors"})


class MaskGenerator(Protocol):
    """Class-agnostic segmentation of a whole image."""

    #: Recorded in features.json.
    name: str

    def generate(self, image: np.ndarray) -> list[np.ndarray]:
        """Masks for ``image`` ``[H][W][3]`` uint8 RGB: boolean ``[Hm][Wm]`` arrays, all the same
        size, covering the whole image (``Hm × Wm`` may be a downscaled ``H × W``)."""
        ...


class DenseClip(Protocol):
    """Dense CLIP image features in the joint image-text space."""

    name: str

    def features(self, image: np.ndarray) -> np.ndarray:
        """``[h][w][D]`` float features (a patch grid, any resolution) for ``[H][W][3]`` uint8."""
        ...


class ClipText(Protocol):
    """CLIP text tower of the same model as the :class:`DenseClip` in use."""

    name: str

    def encode(self, phrases: Sequence[str]) -> np.ndarray:
        """``[P][D]`` float32, one L2-normalised row per phrase, in order."""
        ...


class Dino(Protocol):
    """Self-supervised patch features (DINOv2)."""

    name: str

    def features(self, image: np.ndarray) -> np.ndarray:
        """``[h][w][Dd]`` float patch features for ``[H][W][3]`` uint8."""
        ...


def require(module: str) -> Any:
    """Imports ``module`` or raises a :class:`Stage1Error` saying how to install it."""
    try:
        return importlib.import_module(module)
    except ImportError as e:
        raise Stage1Error(
            f"the real encoders need the Python package providing {module!r} ({e}); install "
            "them with: python3 -m pip install 'tools/stage1[models]' (see docs/guide/feature-extraction.md)"
        ) from e


def _image_tensor(image: np.ndarray, long_edge: int, patch: int, mean, std, device: str):
    """``[1][3][h][w]`` float32 tensor of ``image`` resized (bilinear, antialiased) so that its
    longer side is about ``long_edge`` and both sides are multiples of ``patch``, normalised."""
    torch = require("torch")
    height, width = image.shape[:2]
    scale = long_edge / max(height, width)
    size = tuple(max(1, round(n * scale / patch)) * patch for n in (height, width))
    x = torch.from_numpy(np.array(image, dtype=np.uint8)).to(device)  # a writable copy
    x = x.permute(2, 0, 1)[None].float() / 255
    x = torch.nn.functional.interpolate(
        x, size=size, mode="bilinear", align_corners=False, antialias=True
    )
    m = torch.tensor(mean, device=device).view(1, 3, 1, 1)
    s = torch.tensor(std, device=device).view(1, 3, 1, 1)
    return (x - m) / s


def looks_like_path(value: str) -> bool:
    """Whether a model argument names a file rather than a registry tag or id."""
    return value.startswith(("/", ".", "~")) or Path(value).suffix in CHECKPOINT_SUFFIXES


def clip_label(model_name: str, pretrained: str) -> str:
    """The name recorded for a CLIP model: model and tag, or model and checkpoint file name (so
    features and text embeddings made on different machines compare equal)."""
    weights = Path(pretrained).name if looks_like_path(pretrained) else pretrained
    return f"open_clip:{model_name}:{weights}"


def load_open_clip(model_name: str, pretrained: str, device: str):
    """An open_clip model in eval mode. ``pretrained`` is a tag of ``open_clip.list_pretrained()``
    (downloaded into the Hugging Face / torch cache on first use) or a local checkpoint file."""
    open_clip = require("open_clip")
    if looks_like_path(pretrained) and not Path(pretrained).expanduser().is_file():
        raise Stage1Error(f"{pretrained}: CLIP checkpoint file not found")
    if looks_like_path(pretrained):
        pretrained = str(Path(pretrained).expanduser())
    try:
        model, _, _ = open_clip.create_model_and_transforms(
            model_name, pretrained=pretrained, device=device
        )
    except (RuntimeError, OSError, ValueError) as e:
        raise Stage1Error(
            f"open_clip model {model_name!r} with weights {pretrained!r} did not load ({e}); "
            "offline, pass the checkpoint file as --clip-pretrained"
        ) from e
    return model.eval()


class OpenClipText:
    """:class:`ClipText` with an open_clip model's text tower."""

    def __init__(self, model_name: str, pretrained: str, device: str = "cuda"):
        open_clip = require("open_clip")
        self.name = clip_label(model_name, pretrained)
        self.device = device
        self.model = load_open_clip(model_name, pretrained, device)
        self.tokenizer = open_clip.get_tokenizer(model_name)

    def encode(self, phrases: Sequence[str]) -> np.ndarray:
        torch = require("torch")
        with torch.no_grad():
            e = self.model.encode_text(self.tokenizer(list(phrases)).to(self.device)).float()
            e = torch.nn.functional.normalize(e, dim=-1)
        return e.cpu().numpy()


class OpenClipDense:
    """:class:`DenseClip` by MaskCLIP (Zhou et al. 2022) on an open_clip ViT image tower.

    The image runs through the ViT at ``long_edge`` (positional embeddings bicubically
    interpolated to the patch grid); in the last block only the value path is kept: the
    block's LayerNorm output goes through the attention's value projection and output
    projection (no query-key mixing, no residual, no MLP), then the tower's final LayerNorm and
    projection into the joint space. Each patch token so becomes a CLIP embedding of its own
    region, comparable with text embeddings.
    """

    def __init__(
        self, model_name: str, pretrained: str, device: str = "cuda", long_edge: int = 672
    ):
        self.name = clip_label(model_name, pretrained)
        self.device = device
        self.long_edge = long_edge
        self.model = load_open_clip(model_name, pretrained, device)
        visual = self.model.visual
        needed = ("conv1", "positional_embedding", "transformer", "ln_post", "proj")
        missing = any(getattr(visual, a, None) is None for a in needed)
        if missing or getattr(visual, "attn_pool", None) is not None:
            raise Stage1Error(
                f"CLIP model {model_name!r}: MaskCLIP features need a plain open_clip ViT image "
                "tower (class token, learned positional embedding, projection), e.g. ViT-B-16"
            )
        attn = visual.transformer.resblocks[-1].attn
        if getattr(attn, "in_proj_weight", None) is None:
            raise Stage1Error(
                f"CLIP model {model_name!r}: the last attention has no packed in_proj_weight"
            )
        patch = visual.conv1.kernel_size
        self.patch = patch[0] if isinstance(patch, tuple) else int(patch)
        self.mean = getattr(visual, "image_mean", None) or CLIP_MEAN
        self.std = getattr(visual, "image_std", None) or CLIP_STD

    def _positional_embedding(self, grid: tuple[int, int]):
        """The tower's positional embedding ``[1 + gh*gw][C]`` resampled to ``grid``."""
        torch = require("torch")
        pos = self.model.visual.positional_embedding
        n = pos.shape[0] - 1
        g0, g1 = getattr(self.model.visual, "grid_size", None) or (round(n**0.5), round(n**0.5))
        if (g0, g1) == grid:
            return pos
        patches = pos[1:].reshape(1, g0, g1, -1).permute(0, 3, 1, 2)
        patches = torch.nn.functional.interpolate(
            patches, size=grid, mode="bicubic", align_corners=False
        )
        return torch.cat([pos[:1], patches.permute(0, 2, 3, 1).reshape(grid[0] * grid[1], -1)])

    def features(self, image: np.ndarray) -> np.ndarray:
        torch = require("torch")
        F = torch.nn.functional
        visual = self.model.visual
        x = _image_tensor(image, self.long_edge, self.patch, self.mean, self.std, self.device)
        grid = (x.shape[2] // self.patch, x.shape[3] // self.patch)
        last = visual.transformer.resblocks[-1]
        captured = {}
        hook = last.ln_1.register_forward_hook(lambda _m, _i, out: captured.__setitem__("x", out))
        original = visual.positional_embedding
        try:
            with torch.no_grad():
                visual.positional_embedding = torch.nn.Parameter(
                    self._positional_embedding(grid), requires_grad=False
                )
                visual(x.to(original.dtype))
                # A batch of one: [L, 1, C] (sequence-first) and [1, L, C] both flatten to [L, C].
                tokens = captured["x"].reshape(-1, captured["x"].shape[-1])
                attn = last.attn
                c = attn.in_proj_weight.shape[1]
                bias = None if attn.in_proj_bias is None else attn.in_proj_bias[2 * c :]
                v = attn.out_proj(F.linear(tokens, attn.in_proj_weight[2 * c :], bias))
                v = getattr(last, "ls_1", torch.nn.Identity())(v)
                feats = visual.ln_post(v[1:]) @ visual.proj
        finally:
            hook.remove()
            visual.positional_embedding = original
        if feats.shape[0] != grid[0] * grid[1]:
            raise Stage1Error(f"{self.name}: {feats.shape[0]} patch tokens for a {grid} grid")
        return feats.float().reshape(grid[0], grid[1], -1).cpu().numpy()


class SamMasks:
    """:class:`MaskGenerator` with Segment Anything's automatic mask generator.

    The image is downscaled so that its longer side is at most ``long_edge`` before SAM runs
    (SAM's encoder works at 1024 anyway); masks come back at that size.
    """

    def __init__(
        self,
        checkpoint: Path,
        model_type: str = "vit_h",
        device: str = "cuda",
        long_edge: int = 1024,
        points_per_side: int = 32,
    ):
        if not Path(checkpoint).is_file():
            raise Stage1Error(f"{checkpoint}: SAM checkpoint file not found")
        sam_pkg = require("segment_anything")
        if model_type not in sam_pkg.sam_model_registry:
            known = ", ".join(sorted(sam_pkg.sam_model_registry))
            raise Stage1Error(f"SAM model type {model_type!r} unknown (one of {known})")
        self.name = f"segment_anything:{model_type}:{Path(checkpoint).name}"
        self.long_edge = long_edge
        sam = sam_pkg.sam_model_registry[model_type](checkpoint=str(checkpoint))
        sam.to(device=device)
        self.generator = sam_pkg.SamAutomaticMaskGenerator(sam, points_per_side=points_per_side)

    def generate(self, image: np.ndarray) -> list[np.ndarray]:
        from PIL import Image

        height, width = image.shape[:2]
        scale = self.long_edge / max(height, width)
        if scale < 1:
            size = (max(1, round(width * scale)), max(1, round(height * scale)))
            image = np.asarray(Image.fromarray(image).resize(size, Image.BILINEAR))
        return [m["segmentation"] for m in self.generator.generate(image)]


class Dinov2:
    """:class:`Dino` with DINOv2 from a local torch.hub checkout or through transformers.

    ``source`` is one of:

    * a folder holding ``hubconf.py`` (a clone of facebookresearch/dinov2): loaded with
      ``torch.hub.load(folder, arch, source="local")``; ``weights`` is then the checkpoint file
      (e.g. ``dinov2_vits14_pretrain.pth``), else the hub's own download/cache is used;
    * ``facebookresearch/dinov2``: the same from GitHub (needs network or torch's hub cache);
    * anything else: a transformers model folder (``config.json`` + weights) or a Hugging Face
      id such as ``facebook/dinov2-small`` (from the HF cache; ``HF_HUB_OFFLINE=1`` for no
      network).
    """

    def __init__(
        self,
        source: str,
        device: str = "cuda",
        arch: str = "dinov2_vits14",
        weights: Path | None = None,
        long_edge: int = 644,
    ):
        torch = require("torch")
        self.device = device
        self.long_edge = long_edge
        folder = Path(source).expanduser()
        if weights is not None and not Path(weights).is_file():
            raise Stage1Error(f"{weights}: DINOv2 checkpoint file not found")
        local_hub = (folder / "hubconf.py").is_file()
        try:
            if local_hub or source == "facebookresearch/dinov2":
                where = {"source": "local"} if local_hub else {"trust_repo": True}
                repo = str(folder) if local_hub else source
                model = torch.hub.load(repo, arch, pretrained=weights is None, **where)
                if weights is not None:
                    model.load_state_dict(torch.load(weights, map_location="cpu"))
                self.patch = model.patch_size
                self.backend = "hub"
                weights_name = Path(weights).name if weights else "hub weights"
                self.name = f"torch.hub:{arch}:{weights_name}"
            else:
                if looks_like_path(source) and not folder.is_dir():
                    raise Stage1Error(f"{source}: DINOv2 model folder not found")
                transformers = require("transformers")
                model = transformers.AutoModel.from_pretrained(
                    str(folder) if folder.is_dir() else source
                )
                self.patch = model.config.patch_size
                self.backend = "transformers"
                self.name = f"transformers:{folder.name if folder.is_dir() else source}"
        except (RuntimeError, OSError, ValueError) as e:
            raise Stage1Error(
                f"DINOv2 {source!r} did not load ({e}); offline, pass a local model folder "
                "as --dino (see docs/guide/feature-extraction.md)"
            ) from e
        self.model = model.to(device).eval()

    def features(self, image: np.ndarray) -> np.ndarray:
        torch = require("torch")
        x = _image_tensor(
            image, self.long_edge, self.patch, IMAGENET_MEAN, IMAGENET_STD, self.device
        )
        grid = (x.shape[2] // self.patch, x.shape[3] // self.patch)
        with torch.no_grad():
            if self.backend == "hub":
                tokens = self.model.forward_features(x)["x_norm_patchtokens"][0]
            else:
                # [1, 1 + registers + gh*gw, C]: the patch tokens are the last gh*gw.
                tokens = self.model(pixel_values=x).last_hidden_state[0, -grid[0] * grid[1] :]
        return tokens.float().reshape(grid[0], grid[1], -1).cpu().numpy()
