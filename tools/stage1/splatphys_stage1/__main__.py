"""Command line: ``python -m splatphys_stage1 {extract,encode-text} ...`` (see ``--help``)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .errors import Stage1Error
from .images import BACKGROUNDS, list_images

EXAMPLES = """\
examples:
  # per-image features of a capture's training images (GPU, weights on local disk)
  python -m splatphys_stage1 extract --images data/cake/images --out data/cake/features \\
      --sam-checkpoint weights/sam_vit_h_4b8939.pth \\
      --clip-pretrained weights/open_clip_vit_b_16_laion2b.bin \\
      --dino weights/dinov2-small

  # query embeddings for the scene file's semantic selection (same CLIP model)
  python -m splatphys_stage1 encode-text --out data/cake/emb.json --positive icing \\
      --negative plate --negative table \\
      --clip-pretrained weights/open_clip_vit_b_16_laion2b.bin --features data/cake/features

See docs/guide/feature-extraction.md for installing the models and feeding `splatphys uplift`.
"""


def _positive_int(text: str) -> int:
    """argparse type: an integer >= 1."""
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r} is not a positive integer")
    return value


def _clip_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--clip-model", default="ViT-B-16", help="open_clip model name (ViT-B-16)")
    p.add_argument(
        "--clip-pretrained",
        default="laion2b_s34b_b88k",
        help="open_clip pretrained tag (laion2b_s34b_b88k, downloaded or from the cache) or a "
        "local checkpoint file",
    )


def parser() -> argparse.ArgumentParser:
    """The argument parser of both subcommands."""
    top = argparse.ArgumentParser(
        prog="python -m splatphys_stage1",
        description="Stage-1 features for splatphys: per-image SAM-pooled CLIP and DINOv2 "
        "feature maps, and CLIP text embeddings of the selection query.",
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = top.add_subparsers(dest="command", required=True, metavar="{extract,encode-text}")

    ex = sub.add_parser(
        "extract",
        help="write <out>/<image stem>.npy (H'xW'xD float16) and <out>/dino/<stem>.npy",
        description="Runs SAM, MaskCLIP-style dense CLIP (pooled over each SAM mask) and DINOv2 "
        "on every image of --images; writes <out>/<stem>.npy, <out>/dino/<stem>.npy and "
        "<out>/features.json. Images already done are skipped unless --overwrite.",
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ex.add_argument("--images", type=Path, required=True, help="folder of training images")
    ex.add_argument("--out", type=Path, required=True, help="output feature folder")
    ex.add_argument("--sam-checkpoint", type=Path, required=True,
                    help="SAM checkpoint file (sam_vit_h_4b8939.pth)")
    ex.add_argument("--sam-model", default="vit_h", help="SAM model type: vit_h, vit_l, vit_b")
    ex.add_argument("--sam-points-per-side", type=_positive_int, default=32,
                    help="SAM automatic generator point grid (32)")
    ex.add_argument("--sam-size", type=_positive_int, default=1024,
                    help="longest image side given to SAM, px (1024)")
    _clip_options(ex)
    ex.add_argument("--clip-size", type=_positive_int, default=672,
                    help="longest image side given to CLIP, px, snapped to the patch size (672)")
    ex.add_argument("--dino", default="facebook/dinov2-small",
                    help="DINOv2: a transformers folder or Hugging Face id, a local clone of "
                    "facebookresearch/dinov2 (has hubconf.py), or facebookresearch/dinov2")
    ex.add_argument("--dino-arch", default="dinov2_vits14", help="torch.hub entry (dinov2_vits14)")
    ex.add_argument("--dino-weights", type=Path,
                    help="torch.hub checkpoint file (dinov2_vits14_pretrain.pth)")
    ex.add_argument("--dino-size", type=_positive_int, default=644,
                    help="longest image side given to DINOv2, px, snapped to 14 (644)")
    ex.add_argument("--no-dino", action="store_true", help="skip the DINOv2 maps")
    ex.add_argument("--feature-height", type=_positive_int,
                    help="feature map height H' (default: image height / 8); W' keeps the aspect")
    ex.add_argument("--background", choices=sorted(BACKGROUNDS), default="black",
                    help="colour under transparent pixels, as the 3DGS training used (black)")
    ex.add_argument("--device", default="cuda", help="torch device: cuda, cuda:1, cpu (cuda)")
    ex.add_argument("--overwrite", action="store_true", help="recompute existing outputs")

    te = sub.add_parser(
        "encode-text",
        help="write the query embeddings file (JSON or .npy) for select.embeddings",
        description="Encodes the positive phrase(s), the canonical phrases 'object' and "
        "'things', and the negatives with CLIP's text tower. JSON: {phrase: [D floats]}; "
        ".npy: float32 rows positive, object, things, negatives... (one positive).",
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    te.add_argument("--out", type=Path, required=True, help="output .json or .npy")
    te.add_argument("--positive", action="append", default=[], required=True,
                    help="query phrase (repeatable for .json)")
    te.add_argument("--negative", action="append", default=[],
                    help="negative phrase (repeatable)")
    _clip_options(te)
    te.add_argument("--features", type=Path,
                    help="feature folder: check that its features.json has the same model and D")
    te.add_argument("--device", default="cpu", help="torch device (cpu)")
    return top


def _extract(args: argparse.Namespace) -> None:
    from .encoders import Dinov2, OpenClipDense, SamMasks, looks_like_path
    from .extract import extract_dir

    # Fail on a bad folder or a missing file before spending minutes loading models.
    list_images(args.images)
    if not args.sam_checkpoint.is_file():
        raise Stage1Error(f"{args.sam_checkpoint}: SAM checkpoint file not found")
    clip_file = Path(args.clip_pretrained).expanduser()
    if looks_like_path(args.clip_pretrained) and not clip_file.is_file():
        raise Stage1Error(f"{args.clip_pretrained}: CLIP checkpoint file not found")
    if args.dino_weights is not None and not args.dino_weights.is_file():
        raise Stage1Error(f"{args.dino_weights}: DINOv2 checkpoint file not found")
    masks = SamMasks(args.sam_checkpoint, args.sam_model, args.device, args.sam_size,
                     args.sam_points_per_side)
    clip = OpenClipDense(args.clip_model, args.clip_pretrained, args.device, args.clip_size)
    dino = None
    if not args.no_dino:
        dino = Dinov2(args.dino, args.device, args.dino_arch, args.dino_weights, args.dino_size)
    meta = extract_dir(args.images, args.out, masks, clip, dino, args.feature_height,
                       args.overwrite, args.background)
    print(f"{len(meta['images'])} images, D = {meta['clip_dim']}: {args.out}")


def _encode_text(args: argparse.Namespace) -> None:
    from .encode_text import check_request, write_embeddings
    from .encoders import OpenClipText

    check_request(args.out, args.positive, args.negative)  # before loading CLIP
    text = OpenClipText(args.clip_model, args.clip_pretrained, args.device)
    phrases = write_embeddings(args.out, text, args.positive, args.negative, args.features)
    print(f"{len(phrases)} phrases ({', '.join(phrases)}): {args.out}")


def main(argv: list[str] | None = None) -> int:
    """Runs the command line; returns the exit status (2 on a :class:`Stage1Error`)."""
    args = parser().parse_args(argv)
    try:
        (_extract if args.command == "extract" else _encode_text)(args)
    except Stage1Error as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
