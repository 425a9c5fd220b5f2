"""splatphys_stage1: per-image features and query embeddings for splatphys' semantic selection.

Two steps, both optional at run time (the Rust side only reads their files):

* ``extract``: a SAM mask generator, MaskCLIP-style dense CLIP features pooled over each mask
  (Feature Splatting's object-level features) and DINOv2 patch features, for every training
  image; writes ``<out>/<image stem>.npy`` (H'×W'×D float16, unit rows) and
  ``<out>/dino/<image stem>.npy``.
* ``encode-text``: CLIP text embeddings of the query, the canonical phrases ("object",
  "things") and negatives, as the JSON or ``.npy`` file that ``select.embeddings`` names.

The pipeline works on small encoder protocols (:mod:`splatphys_stage1.encoders`), so it runs
and is tested with stub encoders; the real models (torch, open_clip, segment_anything,
transformers) are imported only when a real encoder is built. See docs/guide/feature-extraction.md.
"""

from .encode_text import CANONICAL, write_embeddings
from .errors import Stage1Error
from .extract import extract_dir

__all__ = ["CANONICAL", "Stage1Error", "extract_dir", "write_embeddings"]
