"""Query embeddings for the semantic selection (``select.embeddings`` in a scene file).

Two formats, both read by ``QueryEmbeddings::load`` in sim-core/src/selection/semantic.rs:

* JSON ``{phrase: [D floats]}`` with the positive(s), the canonical phrases "object" and
  "things", and the negatives. The scene picks its ``query`` by name; without ``negatives``
  in the scene, every other phrase of the file is a negative (other positives included).
* ``.npy`` float32 ``[P][D]`` with rows, in this order: the positive, "object", "things",
  then the negatives (so exactly one positive).
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Sequence

import numpy as np

from .encoders import ClipText
from .errors import Stage1Error
from .extract import METADATA
from .images import save_npy

#: The canonical phrases of LERF / Feature Splatting, always written (semantic.rs CANONICAL).
CANONICAL = ("object", "things")


def phrase_order(positives: Sequence[str], negatives: Sequence[str] = ()) -> list[str]:
    """The phrases to encode: positives, then :data:`CANONICAL`, then negatives.

    Raises:
        Stage1Error: no positive, an empty phrase, a phrase given twice, or a canonical
            phrase given as a positive or negative.
    """
    if not positives:
        raise Stage1Error("no positive phrase to encode: give at least one --positive")
    phrases = [*positives, *CANONICAL, *negatives]
    seen: set[str] = set()
    for p in phrases:
        if not p.strip():
            raise Stage1Error("empty phrase: every --positive and --negative needs text")
        if p in seen:
            role = "canonical (always included)" if p in CANONICAL else "given twice"
            raise Stage1Error(f"phrase {p!r} is {role}; list each phrase once")
        if p != p.strip():
            raise Stage1Error(f"phrase {p!r} has leading or trailing spaces")
        seen.add(p)
    return phrases


def check_request(
    out: Path, positives: Sequence[str], negatives: Sequence[str] = ()
) -> list[str]:
    """Checks an embeddings request before any model is loaded; returns the phrase order.

    Raises:
        Stage1Error: an unknown suffix, several positives for ``.npy``, or bad phrases
            (see :func:`phrase_order`).
    """
    suffix = out.suffix.lower()
    if suffix not in (".json", ".npy"):
        raise Stage1Error(f"{out}: the embeddings file must end in .json or .npy")
    phrases = phrase_order(positives, negatives)
    if suffix == ".npy" and len(positives) != 1:
        raise Stage1Error(
            f"{out}: a .npy embeddings file holds exactly one positive (row 0), got "
            f"{len(positives)}; write .json for several queries"
        )
    return phrases


def encode_phrases(text: ClipText, phrases: Sequence[str]) -> np.ndarray:
    """``[P][D]`` float32 unit rows from ``text.encode``, checked for shape and values."""
    e = np.asarray(text.encode(list(phrases)), dtype=np.float32)
    if e.ndim != 2 or e.shape[0] != len(phrases) or e.shape[1] == 0:
        raise Stage1Error(
            f"{text.name} returned shape {e.shape} for {len(phrases)} phrases, expected [P][D]"
        )
    norm = np.linalg.norm(e, axis=1, keepdims=True)
    if not np.isfinite(e).all() or (norm == 0).any():
        raise Stage1Error(f"{text.name} returned a non-finite or zero embedding")
    return e / norm


def check_features(features_dir: Path, text_name: str, dim: int) -> None:
    """Checks the embeddings against a feature folder's features.json: same CLIP model, same D.

    Raises:
        Stage1Error: naming features.json, when it is unreadable or disagrees.
    """
    path = features_dir / METADATA
    try:
        meta = json.loads(path.read_text())
    except (OSError, ValueError) as e:
        raise Stage1Error(f"{path}: cannot read feature metadata ({e})") from e
    if meta.get("clip_dim") != dim:
        raise Stage1Error(
            f"{path}: features have D = {meta.get('clip_dim')}, the text embeddings D = {dim}; "
            "use the CLIP model the features were extracted with"
        )
    if meta.get("clip_model") != text_name:
        raise Stage1Error(
            f"{path}: features come from {meta.get('clip_model')!r}, the text encoder is "
            f"{text_name!r}; pass the same --clip-model and --clip-pretrained"
        )


def write_embeddings(
    out: Path,
    text: ClipText,
    positives: Sequence[str],
    negatives: Sequence[str] = (),
    features_dir: Path | None = None,
) -> list[str]:
    """Encodes the phrases and writes ``out`` (``.json`` or ``.npy``, see the module docs).

    With ``features_dir``, first checks that its features.json names the same CLIP model and
    dimension. Returns the phrases in the order written.

    Raises:
        Stage1Error: see :func:`check_request`, :func:`encode_phrases` and
            :func:`check_features`.
    """
    phrases = check_request(out, positives, negatives)
    rows = encode_phrases(text, phrases)
    if features_dir is not None:
        check_features(features_dir, text.name, rows.shape[1])
    out.parent.mkdir(parents=True, exist_ok=True)
    if out.suffix.lower() == ".npy":
        save_npy(out, rows.astype("<f4"))
    else:
        tmp = out.with_name(out.name + ".tmp")
        tmp.write_text(json.dumps({p: r.tolist() for p, r in zip(phrases, rows)}) + "\n")
        os.replace(tmp, out)
    return phrases
