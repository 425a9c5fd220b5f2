"""Query embeddings: file formats as semantic.rs reads them, checks, and the selection rule."""

from __future__ import annotations

import ast
import json
from pathlib import Path

import numpy as np
import pytest
from stubs import (
    CELL,
    D,
    StubDenseClip,
    StubMasks,
    StubText,
    colour_class,
    phrase_vector,
    scene_image,
    write_png,
)

from splatphys_stage1 import CANONICAL, Stage1Error, extract_dir, write_embeddings
from splatphys_stage1.__main__ import main


def load_like_semantic_rs(path: Path, query: str, negatives=None):
    """Mirror of ``QueryEmbeddings::load`` (sim-core/src/selection/semantic.rs):
    returns (positive, canonical, negatives) as lists of float lists."""
    if path.suffix == ".npy":
        raw = path.read_bytes()
        assert raw[:6] == b"\x93NUMPY"
        hlen_size = 2 if raw[6] == 1 else 4
        hlen = int.from_bytes(raw[8 : 8 + hlen_size], "little")
        header = ast.literal_eval(raw[8 + hlen_size : 8 + hlen_size + hlen].decode("latin1"))
        assert header["descr"] in ("<f4", "<f2") and header["fortran_order"] is False
        rows, dim = header["shape"]  # a 2-D array, C order
        assert rows >= 3 and dim > 0
        data = np.frombuffer(raw[8 + hlen_size + hlen :], dtype=header["descr"])
        m = data.reshape(rows, dim).astype(np.float32).tolist()
        return m[0], m[1:3], m[3:]
    table = json.loads(path.read_text())  # BTreeMap<String, Vec<f32>>
    assert isinstance(table, dict)
    assert all(isinstance(v, list) and all(isinstance(x, float) for x in v) for v in table.values())
    positive = table[query]
    canonical = [table[c] for c in CANONICAL]
    if negatives is None:
        negatives = [k for k in sorted(table) if k != query and k not in CANONICAL]
    return positive, canonical, [table[n] for n in negatives]


def positive_probability(features: np.ndarray, pos, canonical, negatives, tau=0.05):
    """Mirror of semantic.rs ``positive_probability`` for features ``[N][D]``."""
    f = features / np.linalg.norm(features, axis=-1, keepdims=True)
    e = np.array([pos, *canonical, *negatives], dtype=np.float64)
    e /= np.linalg.norm(e, axis=-1, keepdims=True)
    logits = f @ e.T / tau
    logits -= logits.max(axis=1, keepdims=True)
    p = np.exp(logits)
    return p[:, 0] / p.sum(axis=1)


def test_json_has_canonical_and_every_phrase_in_order(tmp_path):
    out = tmp_path / "emb.json"
    text = StubText(scale=3.0)
    phrases = write_embeddings(out, text, ["icing", "cake"], ["plate", "table"])
    assert phrases == ["icing", "cake", "object", "things", "plate", "table"]
    assert text.seen == phrases
    table = json.loads(out.read_text())
    assert list(table) == phrases
    for p, v in table.items():
        assert len(v) == D
        np.testing.assert_allclose(v, phrase_vector(p), rtol=1e-6, atol=1e-7)
        assert abs(np.linalg.norm(v) - 1) < 1e-6  # re-normalised (the stub scales by 3)
    pos, canon, neg = load_like_semantic_rs(out, "icing")
    assert len(canon) == 2 and len(neg) == 3  # cake, plate, table: every other phrase
    assert all(len(v) == len(pos) for v in (*canon, *neg))
    _, _, neg = load_like_semantic_rs(out, "cake", ["plate"])
    np.testing.assert_allclose(neg[0], phrase_vector("plate"), atol=1e-7)


def test_npy_rows_are_positive_object_things_negatives(tmp_path):
    out = tmp_path / "emb.npy"
    phrases = write_embeddings(out, StubText(), ["icing"], ["plate", "table"])
    assert phrases == ["icing", "object", "things", "plate", "table"]
    arr = np.load(out)
    assert arr.dtype == np.dtype("<f4") and arr.shape == (5, D) and arr.flags.c_contiguous
    for row, p in zip(arr, phrases):
        np.testing.assert_allclose(row, phrase_vector(p), rtol=1e-6, atol=1e-7)
    pos, canon, neg = load_like_semantic_rs(out, "ignored for .npy")
    np.testing.assert_allclose(pos, phrase_vector("icing"), atol=1e-7)
    np.testing.assert_allclose(canon, [phrase_vector("object"), phrase_vector("things")], atol=1e-7)
    assert len(neg) == 2


@pytest.mark.parametrize(
    "positives, negatives, message",
    [
        ([], [], "no positive phrase"),
        ([""], [], "empty phrase"),
        (["icing"], ["   "], "empty phrase"),
        (["icing"], ["object"], "'object' is canonical"),
        (["things"], [], "'things' is canonical"),
        (["icing"], ["plate", "plate"], "'plate' is given twice"),
        (["icing "], [], "leading or trailing spaces"),
    ],
)
def test_bad_phrase_lists_are_refused(tmp_path, positives, negatives, message):
    text = StubText()
    with pytest.raises(Stage1Error, match=message):
        write_embeddings(tmp_path / "emb.json", text, positives, negatives)
    assert text.seen == [] and not (tmp_path / "emb.json").exists()


def test_bad_outputs_and_encoders_are_refused(tmp_path):
    with pytest.raises(Stage1Error, match=r"emb\.txt: .* \.json or \.npy"):
        write_embeddings(tmp_path / "emb.txt", StubText(), ["icing"])
    with pytest.raises(Stage1Error, match="exactly one positive"):
        write_embeddings(tmp_path / "emb.npy", StubText(), ["icing", "cake"])

    class Short(StubText):
        def encode(self, phrases):
            return super().encode(phrases)[:-1]

    with pytest.raises(Stage1Error, match=r"returned shape \(2, 16\) for 3 phrases"):
        write_embeddings(tmp_path / "emb.json", Short(), ["icing"])


def test_embeddings_are_checked_against_the_features(tmp_path):
    images = tmp_path / "images"
    images.mkdir()
    write_png(images / "a.png", scene_image())
    feats = tmp_path / "features"
    extract_dir(images, feats, StubMasks(), StubDenseClip(), progress=lambda i, s: None)
    with pytest.raises(Stage1Error, match=r"features\.json: features have D = 16, .* D = 12"):
        write_embeddings(tmp_path / "e.json", StubText(dim=12), ["icing"], features_dir=feats)
    with pytest.raises(Stage1Error, match=r"features come from 'stub-clip'.*'other'"):
        write_embeddings(tmp_path / "e.json", StubText(name="other"), ["icing"], features_dir=feats)
    with pytest.raises(Stage1Error, match="cannot read feature metadata"):
        write_embeddings(tmp_path / "e.json", StubText(), ["icing"], features_dir=tmp_path)
    assert not (tmp_path / "e.json").exists()
    write_embeddings(tmp_path / "e.json", StubText(), ["icing"], features_dir=feats)


def test_extracted_features_select_the_query_region(tmp_path):
    """End to end with stubs: "icing" is the red class, the canonical phrases green and blue;
    Feature Splatting's rule (τ = 0.05, threshold 0.6) keeps exactly the red pixels."""
    images = tmp_path / "images"
    images.mkdir()
    write_png(images / "a.png", scene_image())
    extract_dir(images, tmp_path / "f", StubMasks(), StubDenseClip(), feature_height=8,
                progress=lambda i, s: None)
    write_embeddings(tmp_path / "e.json", StubText(), ["icing"], ["grey wall"])
    feats = np.load(tmp_path / "f" / "a.npy").astype(np.float64).reshape(-1, D)
    prob = positive_probability(feats, *load_like_semantic_rs(tmp_path / "e.json", "icing"))
    red = (colour_class(scene_image())[::CELL, ::CELL] == 0).reshape(-1)
    assert (prob[red] > 0.6).all() and (prob[~red] < 0.6).all()


def test_cli_refuses_bad_phrases_before_loading_clip(tmp_path, capsys):
    assert main(["encode-text", "--out", str(tmp_path / "e.json"), "--positive", " "]) == 2
    assert "empty phrase" in capsys.readouterr().err
    args = ["encode-text", "--out", str(tmp_path / "e.json"), "--positive", "x",
            "--negative", "things"]
    assert main(args) == 2
    assert "'things' is canonical" in capsys.readouterr().err
    args = ["encode-text", "--out", str(tmp_path / "e.npy"), "--positive", "a", "--positive", "b"]
    assert main(args) == 2
    assert "exactly one positive" in capsys.readouterr().err
