import sys
from pathlib import Path

import numpy as np
import pytest

from neuraltex.baselines import METHODS, get_segmenter, grid_segmenter, kmeans
from neuraltex.data import generate
from neuraltex.errors import InputError
from neuraltex.metrics import matched_miou

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def discs():
    return [generate(i, 0, 64, family="discs") for i in range(3)]


@pytest.mark.parametrize("name", list(METHODS))
def test_segmenter_contract(name, discs):
    m = METHODS[name]
    assert m.default in m.grid
    pred = get_segmenter(name)(discs[0].image)
    assert pred.shape == (64, 64) and np.issubdtype(pred.dtype, np.integer)
    assert len(np.unique(pred)) >= 2


@pytest.mark.parametrize("name", ["slic", "felzenszwalb", "kmeans"])
def test_image_methods_beat_the_grid_on_flat_discs(name, discs):
    seg, grid = get_segmenter(name), get_segmenter("grid")
    ours = np.mean([matched_miou(seg(s.image), s.mask) for s in discs])
    blind = np.mean([matched_miou(grid(s.image), s.mask) for s in discs])
    assert ours > blind + 0.1


def test_grid_ignores_the_image():
    seg = grid_segmenter(4)
    a = seg(np.zeros((32, 48, 3)))
    np.testing.assert_array_equal(a, seg(np.random.default_rng(0).random((32, 48, 3))))
    assert len(np.unique(a[:, :32])) == 16  # 4 x 4 cells of 8 px on the short side


def test_kmeans_finds_two_colours():
    rng = np.random.default_rng(0)
    pts = np.concatenate([rng.normal(0, 0.1, (50, 3)), rng.normal(5, 0.1, (50, 3))])
    centres = kmeans(pts.astype(np.float32), 2)
    assert sorted(np.round(centres.mean(1)).tolist()) == [0.0, 5.0]


def test_bad_method_and_model_hook():
    with pytest.raises(InputError):
        get_segmenter("nope")
    with pytest.raises(InputError):
        get_segmenter("model", checkpoint="no/such/model.safetensors")
    assert callable(get_segmenter("model"))  # no checkpoint: the shipped default model
    with pytest.raises(ValueError):
        get_segmenter("grid")(np.zeros((8, 8)))


@pytest.mark.slow
def test_eval_script_end_to_end(tmp_path, capsys):
    sys.path.insert(0, str(ROOT / "scripts"))
    try:
        import eval_textons
    finally:
        sys.path.pop(0)
    md = tmp_path / "table.md"
    rc = eval_textons.main(["--method", "grid,kmeans", "--limit", "15", "--quiet",
                            "--markdown", str(md)])
    assert rc == 0
    text = md.read_text()
    for row in ("discs (easy)", "leaves (hard)", "**overall**", "k=5", "cells=12"):
        assert row in text
    assert eval_textons.main(["--method", "nope"]) == 2
    assert eval_textons.main(["--method", "model", "--limit", "1", "--checkpoint",
                              str(tmp_path / "none.safetensors")]) == 2
    assert "error" in capsys.readouterr().err


def test_eval_script_model_options(tmp_path, capsys):
    """--families, --model-labels refined / guided, --guided-weight and --num-queries (issue
    16), one image each."""
    sys.path.insert(0, str(ROOT / "scripts"))
    try:
        import eval_textons
    finally:
        sys.path.pop(0)
    md = tmp_path / "t.md"
    assert eval_textons.main(["--method", "model", "--model-labels", "refined", "--num-queries",
                              "144", "--families", "dots", "--limit", "1", "--quiet",
                              "--markdown", str(md)]) == 0
    text = md.read_text()
    assert "labels=refined queries=144" in text and "dots (easy)" in text
    assert eval_textons.main(["--method", "model", "--model-labels", "guided", "--guided-weight",
                              "1.5", "--families", "discs", "--limit", "1", "--quiet",
                              "--markdown", str(md)]) == 0
    assert "labels=guided weight=1.5 reach=0.01" in md.read_text()
    assert eval_textons.main(["--families", "nope"]) == 2
    assert eval_textons.main(["--method", "model", "--num-queries", "0"]) == 2
    assert eval_textons.main(["--method", "model", "--guided-weight", "-1"]) == 2
    assert "error" in capsys.readouterr().err


def test_colour_guided_labels_sharpen_the_model_on_flat_elements():
    """labels="guided" (neuraltex/mask_refinement.py) on easy benchmark images of flat-coloured
    elements: the model's stride-4 edges snap to the image's, so IoU and boundary F1 rise."""
    from neuraltex.baselines import model_segmenter
    from neuraltex.data.splits import benchmark_split
    from neuraltex.metrics import texton_scores

    samples = [it.load() for it in benchmark_split() if it.family == "polygons"][:2]
    plain, guided = model_segmenter("", labels="masks"), model_segmenter("", labels="guided")
    for s in samples:
        a, b = texton_scores(plain(s.image), s.mask), texton_scores(guided(s.image), s.mask)
        assert guided(s.image).shape == s.mask.shape
        assert b["miou"] > a["miou"] + 0.02 and b["boundary_f1"] > a["boundary_f1"]
