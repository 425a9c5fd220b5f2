"""Extraction pipeline, image handling and the command line, with stub encoders."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from stubs import (
    CELL,
    D,
    DINO_D,
    StubDenseClip,
    StubDino,
    StubMasks,
    colour_class,
    dense_cells,
    scene_image,
    write_png,
)

from splatphys_stage1 import Stage1Error, extract_dir
from splatphys_stage1.__main__ import main
from splatphys_stage1.extract import mask_means, paint_masks
from splatphys_stage1.images import feature_size, load_image, resize_bilinear, resize_mask

PACKAGE_ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def images(tmp_path):
    """Two scene images, a text file and a sub-folder (both to be skipped)."""
    d = tmp_path / "images"
    d.mkdir()
    write_png(d / "r_0.png", scene_image())
    write_png(d / "r_1.png", scene_image()[:, ::-1].copy())
    (d / "notes.txt").write_text("not an image")
    (d / "sub").mkdir()
    write_png(d / "sub" / "r_9.png", scene_image())
    return d


def run(images, out, **kw):
    lines = []
    kw.setdefault("mask_generator", StubMasks())
    kw.setdefault("dense_clip", StubDenseClip())
    kw.setdefault("feature_height", 32 // CELL)
    meta = extract_dir(images, out, progress=lambda i, line: lines.append(line), **kw)
    return meta, lines


def expected_features(image: np.ndarray) -> np.ndarray:
    """Hand-computed output for a scene image at the cell grid (no resizing involved)."""
    dense = dense_cells(image).astype(np.float64)
    cls = colour_class(image)[::CELL, ::CELL]
    red, green, blue = (dense[cls == k].mean(axis=0) for k in range(3))
    table = dense[(cls == 0) | (cls == 1)].mean(axis=0)
    out = dense.copy()  # grey: no mask, dense feature kept
    out[cls == 0] = (red + table) / 2
    out[cls == 1] = (green + table) / 2
    out[cls == 2] = blue
    return out / np.linalg.norm(out, axis=-1, keepdims=True)


def test_mask_means_are_the_mean_inside_each_mask():
    rng = np.random.default_rng(3)
    dense = rng.normal(size=(6, 7, 5)).astype(np.float32)
    masks = rng.random((4, 6, 7)) < 0.4
    masks[:, 0, 0] = True
    got = mask_means(dense, masks)
    assert got.shape == (4, 5) and got.dtype == np.float32
    for m, g in zip(masks, got):
        np.testing.assert_allclose(g, dense[m].mean(axis=0), rtol=1e-6, atol=1e-7)


def test_paint_averages_covering_masks_and_keeps_uncovered_pixels():
    dense = np.array([[[1.0, 0.0], [2.0, 2.0], [5.0, 7.0]]], dtype=np.float32)
    masks = np.array([[[True, True, False]], [[False, True, False]]])
    means = np.array([[10.0, 0.0], [0.0, 4.0]], dtype=np.float32)
    got = paint_masks(dense, masks, means)
    np.testing.assert_array_equal(got[0], [[10.0, 0.0], [5.0, 2.0], [5.0, 7.0]])


def test_resize_bilinear_identity_and_linear_ramp():
    a = np.random.default_rng(0).normal(size=(5, 6, 3)).astype(np.float32)
    np.testing.assert_array_equal(resize_bilinear(a, (5, 6)), a)
    ramp = np.tile(np.arange(8, dtype=np.float32)[None, :, None], (2, 1, 1))
    # Half-pixel centres: output column i samples source x = 2i + 0.5.
    np.testing.assert_allclose(resize_bilinear(ramp, (2, 4))[0, :, 0], [0.5, 2.5, 4.5, 6.5])
    assert resize_bilinear(ramp, (3, 16)).shape == (3, 16, 1)


def test_resize_mask_nearest_and_feature_size():
    mask = np.zeros((8, 8), dtype=bool)
    mask[:4, :4] = True
    small = resize_mask(mask, (2, 2))
    np.testing.assert_array_equal(small, [[True, False], [False, False]])
    assert feature_size(480, 640, None) == (60, 80)
    assert feature_size(480, 640, 30) == (30, 40)
    with pytest.raises(Stage1Error, match="2-D"):
        resize_mask(np.zeros((2, 2, 2)), (1, 1))


def test_extract_writes_pooled_unit_features(images, tmp_path):
    out = tmp_path / "features"
    meta, lines = run(images, out, dino=StubDino())
    names = sorted(p.name for p in out.iterdir())
    assert names == ["dino", "features.json", "r_0.npy", "r_1.npy"]
    assert sorted(p.name for p in (out / "dino").iterdir()) == ["r_0.npy", "r_1.npy"]
    for stem, image in (("r_0", scene_image()), ("r_1", scene_image()[:, ::-1])):
        feat = np.load(out / f"{stem}.npy")
        assert feat.dtype == np.float16 and feat.shape == (8, 12, D)
        # float16 rounds each unit-vector component to within 2^-11 ≈ 5e-4; 2e-3 covers it.
        norms = np.linalg.norm(feat.astype(np.float32), axis=-1)
        np.testing.assert_allclose(norms, 1.0, atol=2e-3)
        np.testing.assert_allclose(feat.astype(np.float64), expected_features(image), atol=2e-3)
        dino = np.load(out / "dino" / f"{stem}.npy")
        assert dino.dtype == np.float16 and dino.shape == (8, 12, DINO_D)
        assert (dino == 3.0).all()
    on_disk = json.loads((out / "features.json").read_text())
    assert on_disk == meta
    assert meta["clip_dim"] == D and meta["dino_dim"] == DINO_D
    assert meta["clip_model"] == "stub-clip" and meta["mask_generator"] == "stub-masks"
    assert meta["dino_model"] == "stub-dino" and meta["dtype"] == "float16"
    assert meta["images"] == [
        {"image": "r_0.png", "stem": "r_0", "feature_size": [8, 12]},
        {"image": "r_1.png", "stem": "r_1", "feature_size": [8, 12]},
    ]
    assert lines == ["r_0.png: 8x12 features", "r_1.png: 8x12 features"]


def test_default_feature_height_is_an_eighth_and_no_masks_keep_dense(images, tmp_path):
    class NoMasks:
        name = "none"

        def generate(self, image):
            return []

    out = tmp_path / "f"
    meta, _ = run(images, out, mask_generator=NoMasks(), feature_height=None)
    assert meta["images"][0]["feature_size"] == [4, 6] and meta["dino_model"] is None
    assert not (out / "dino").exists()
    dense = resize_bilinear(dense_cells(scene_image()), (4, 6))
    want = dense / np.linalg.norm(dense, axis=-1, keepdims=True)
    np.testing.assert_allclose(np.load(out / "r_0.npy").astype(np.float32), want, atol=2e-3)


def test_resume_skips_existing_outputs(images, tmp_path):
    out = tmp_path / "f"
    masks, clip = StubMasks(), StubDenseClip()
    run(images, out, mask_generator=masks, dense_clip=clip, dino=StubDino())
    assert clip.calls == 2
    before = {p: p.read_bytes() for p in out.rglob("*.npy")}
    meta, lines = run(images, out, mask_generator=masks, dense_clip=clip, dino=StubDino())
    assert clip.calls == 2 and masks.calls == 2
    assert lines == ["r_0.png: exists, skipped", "r_1.png: exists, skipped"]
    assert {p: p.read_bytes() for p in out.rglob("*.npy")} == before
    assert meta["images"][1]["feature_size"] == [8, 12] and meta["dino_dim"] == DINO_D
    (out / "dino" / "r_1.npy").unlink()  # a missing DINO map redoes that image only
    _, lines = run(images, out, mask_generator=masks, dense_clip=clip, dino=StubDino())
    assert clip.calls == 3 and lines[1] == "r_1.png: 8x12 features"
    run(images, out, mask_generator=masks, dense_clip=clip, overwrite=True)
    assert clip.calls == 5
    assert not list(out.rglob("*.tmp"))


def test_resume_refuses_other_models_or_dimensions(images, tmp_path):
    out = tmp_path / "f"
    run(images, out)
    moved = r"features\.json: clip_model was 'stub-clip'.*--overwrite"
    with pytest.raises(Stage1Error, match=moved):
        run(images, out, dense_clip=StubDenseClip(name="other-clip"))
    (out / "r_1.npy").unlink()
    with pytest.raises(Stage1Error, match=r"r_1\.npy: clip_dim has D = 24.*D = 16"):
        run(images, out, dense_clip=StubDenseClip(dim=24))
    assert not (out / "r_1.npy").exists()
    meta, _ = run(images, out, dense_clip=StubDenseClip(dim=24, name="other"), overwrite=True)
    assert meta["clip_dim"] == 24
    (out / "r_0.npy").write_bytes(b"not an array")
    with pytest.raises(Stage1Error, match=r"r_0\.npy: unreadable earlier output"):
        run(images, out, dense_clip=StubDenseClip(dim=24, name="other"))


def test_unreadable_image_names_the_file(images, tmp_path):
    (images / "r_2.png").write_bytes(b"\x89PNG\r\n\x1a\n garbage")
    with pytest.raises(Stage1Error, match=r"r_2\.png: cannot read image"):
        run(images, tmp_path / "f")
    good = (images / "r_0.png").read_bytes()
    (images / "r_2.png").write_bytes(good[: len(good) // 2])  # truncated
    with pytest.raises(Stage1Error, match=r"r_2\.png: cannot read image"):
        run(images, tmp_path / "f")


def test_bad_folders_are_reported(tmp_path):
    with pytest.raises(Stage1Error, match="not a folder"):
        run(tmp_path / "missing", tmp_path / "f")
    (tmp_path / "empty").mkdir()
    with pytest.raises(Stage1Error, match="no image files"):
        run(tmp_path / "empty", tmp_path / "f")
    d = tmp_path / "dup"
    d.mkdir()
    write_png(d / "a.png", scene_image())
    write_png(d / "a.jpg", scene_image())
    with pytest.raises(Stage1Error, match="share the stem 'a'"):
        run(d, tmp_path / "f")


def test_encoder_output_of_wrong_shape_names_encoder_and_image(images, tmp_path):
    class Flat(StubDenseClip):
        def features(self, image):
            return np.zeros((4, 4), dtype=np.float32)

    with pytest.raises(Stage1Error, match=r"r_0\.png: stub-clip returned shape \(4, 4\)"):
        run(images, tmp_path / "f", dense_clip=Flat())

    class BadMask(StubMasks):
        def generate(self, image):
            return [np.zeros((2, 2, 2), dtype=bool)]

    with pytest.raises(Stage1Error, match=r"r_0\.png: stub-masks: a mask must be 2-D"):
        run(images, tmp_path / "g", mask_generator=BadMask())


def test_alpha_is_composited_over_the_background(tmp_path):
    rgba = np.zeros((2, 2, 4), dtype=np.uint8)
    rgba[0, 0] = (10, 20, 30, 255)
    from PIL import Image

    Image.fromarray(rgba, "RGBA").save(tmp_path / "a.png")
    black = load_image(tmp_path / "a.png", "black")
    white = load_image(tmp_path / "a.png", "white")
    assert black.dtype == np.uint8 and black.shape == (2, 2, 3)
    assert tuple(black[0, 0]) == (10, 20, 30) and tuple(white[0, 0]) == (10, 20, 30)
    assert tuple(black[1, 1]) == (0, 0, 0) and tuple(white[1, 1]) == (255, 255, 255)


def _cli(*args):
    env = dict(os.environ, PYTHONPATH=str(PACKAGE_ROOT))
    return subprocess.run(
        [sys.executable, "-m", "splatphys_stage1", *args],
        capture_output=True, text=True, env=env, cwd=PACKAGE_ROOT,
    )


def test_cli_help_has_examples_and_imports_no_model_package():
    for args in ([], ["extract"], ["encode-text"]):
        r = _cli(*args, "--help")
        assert r.returncode == 0, r.stderr
        assert "examples:" in r.stdout and "encode-text --out" in r.stdout
    code = "import sys, splatphys_stage1.encoders, splatphys_stage1.__main__; " \
        "print(sorted(m for m in ('torch', 'open_clip', 'segment_anything', 'transformers') " \
        "if m in sys.modules))"
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       env=dict(os.environ, PYTHONPATH=str(PACKAGE_ROOT)))
    assert r.returncode == 0 and r.stdout.strip() == "[]", r.stderr


def test_cli_reports_missing_inputs_before_loading_models(images, tmp_path, capsys):
    base = ["extract", "--out", str(tmp_path / "f"), "--sam-checkpoint", str(tmp_path / "no.pth")]
    assert main([*base, "--images", str(tmp_path / "nothing")]) == 2
    assert "nothing: not a folder of images" in capsys.readouterr().err
    assert main([*base, "--images", str(images)]) == 2
    assert "no.pth: SAM checkpoint file not found" in capsys.readouterr().err
    sam = tmp_path / "sam.pth"
    sam.write_bytes(b"")
    args = ["extract", "--images", str(images), "--out", str(tmp_path / "f"),
            "--sam-checkpoint", str(sam)]
    assert main([*args, "--clip-pretrained", str(tmp_path / "c.bin")]) == 2
    assert "c.bin: CLIP checkpoint file not found" in capsys.readouterr().err
    assert main([*args, "--dino-weights", str(tmp_path / "d.pth")]) == 2
    assert "d.pth: DINOv2 checkpoint file not found" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main([*args, "--feature-height", "0"])
    assert "'0' is not a positive integer" in capsys.readouterr().err
