"""scripts/eval_segmenter_swap.py: the default model with another export's E_s."""

import sys
from pathlib import Path

import numpy as np
import torch
from PIL import Image

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))

import eval_segmenter_swap  # noqa: E402


def test_swapping_in_the_same_segmenter_changes_nothing(tmp_path, capsys):
    from neuraltex.model import DEFAULT_MODEL

    g = np.random.default_rng(0)
    Image.fromarray(g.integers(0, 255, (40, 56, 3), dtype=np.uint8)).save(tmp_path / "a.png")
    assert eval_segmenter_swap.main(["--segmenter", str(DEFAULT_MODEL), "--procedural", "2",
                                     "--textures", str(tmp_path)]) == 0
    out = capsys.readouterr().out.splitlines()
    for line, n in zip(out, (2, 1), strict=True):
        shipped, swapped = (float(v.split(" dB")[0]) for v in line.split("PSNR shipped ")[1]
                            .split(", with the new E_s "))  # the same model: equal PSNR
        assert f"{n} images" in line and shipped == swapped and "better on 0" in line


def test_the_swap_takes_every_segmenter_tensor_and_nothing_else(tmp_path):
    from safetensors import safe_open
    from safetensors.torch import load_file, save_file

    from neuraltex.checkpoint import tensor_digest
    from neuraltex.model import DEFAULT_MODEL, load_model

    with safe_open(str(DEFAULT_MODEL), "pt") as f:
        meta = f.metadata()
    donor = {k: v + 1 if k.startswith("segmenter.") and v.is_floating_point() else v
             for k, v in load_file(str(DEFAULT_MODEL)).items()}  # another E_s, the same rest
    save_file(donor, str(tmp_path / "d.safetensors"),
              metadata={**meta, "sha256": tensor_digest(donor)})
    mixed = eval_segmenter_swap.with_segmenter(str(DEFAULT_MODEL),
                                               str(tmp_path / "d.safetensors")).state_dict()
    base = load_model(str(DEFAULT_MODEL)).state_dict()
    for k, v in mixed.items():
        moved = k.startswith("segmenter.") and v.is_floating_point()
        assert torch.equal(v, base[k] + 1) if moved else torch.equal(v, base[k]), k


def test_a_whole_model_compared_with_the_default(tmp_path, capsys):
    from neuraltex.model import DEFAULT_MODEL

    Image.fromarray(np.full((32, 32, 3), 90, np.uint8)).save(tmp_path / "flat.png")
    Image.fromarray(np.full((32, 32, 3), 200, np.uint8)).save(tmp_path / "light.png")
    sheet = tmp_path / "out" / "sheet.png"
    assert eval_segmenter_swap.main(["--model", str(DEFAULT_MODEL), "--procedural", "1",
                                     "--textures", str(tmp_path), "--pictures", str(sheet)]) == 0
    out = capsys.readouterr().out
    assert "with the new model" in out and "better on 0" in out
    pic = np.asarray(Image.open(sheet).convert("RGB")).astype(int)
    assert pic.shape == (2 + 130, 2 + 6 * 130, 3)  # two triplets of 128 px tiles in one row
    tile = pic[2:130, 2:130]  # the first input, resized to 128 px: flat grey 90
    assert np.abs(tile - 90).max() <= 1
    assert np.abs(pic[2:130, 2 + 3 * 130:130 + 3 * 130] - 200).max() <= 1  # the second input
    # the same model twice: its two reconstructions are the same picture
    assert np.array_equal(pic[2:130, 132:260], pic[2:130, 262:390])


def test_a_missing_model_is_one_line_and_exit_2(capsys):
    assert eval_segmenter_swap.main(["--segmenter", "/nonexistent.safetensors"]) == 2
    assert "no model at" in capsys.readouterr().err
