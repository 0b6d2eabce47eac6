"""The model subcommands of `neuraltex` on a tiny untrained export and tiny images."""

import numpy as np
import pytest
import torch
from PIL import Image

from neuraltex.checkpoint import export_model
from neuraltex.cli import main
from neuraltex.model import build_model
from neuraltex.model_config import ModelConfig
from neuraltex.textons_file import load_textons

CONFIG = ModelConfig(preset="tiny", image_size=32)


@pytest.fixture(scope="module")
def ckpt(tmp_path_factory):
    torch.manual_seed(0)
    path = tmp_path_factory.mktemp("model") / "tiny.safetensors"
    export_model(path, build_model(CONFIG).state_dict(), CONFIG, {"steps": 0})
    return str(path)


@pytest.fixture(scope="module")
def images(tmp_path_factory):
    d = tmp_path_factory.mktemp("img")
    rng = np.random.default_rng(0)
    rgb = (rng.random((24, 32, 3)) * 255).astype(np.uint8)
    Image.fromarray(rgb).save(d / "rgb.png")
    Image.fromarray(rgb).convert("L").save(d / "gray.png")
    Image.fromarray(rgb).convert("RGBA").save(d / "rgba.png")
    Image.fromarray(rgb).convert("P").save(d / "palette.png")
    Image.fromarray((rng.random((24, 32)) * 65535).astype(np.uint16)).save(d / "deep.png")
    (d / "corrupt.png").write_bytes(b"\x89PNG\r\n\x1a\nnot really")
    return d


def test_encode_decode_reconstruct_overlay(tmp_path, ckpt, images):
    t = tmp_path / "t.json"
    assert main(["encode", str(images / "rgb.png"), "-o", str(t), "--checkpoint", ckpt,
                 "--overlay", str(tmp_path / "ov.png")]) == 0
    textons = load_textons(t)
    assert textons.canvas == pytest.approx((32 / 24, 1.0))
    assert main(["decode", str(t), "-o", str(tmp_path / "d.png"), "--checkpoint", ckpt,
                 "--size", "48"]) == 0
    assert Image.open(tmp_path / "d.png").size == (64, 48)
    assert main(["reconstruct", str(images / "rgb.png"), "-o", str(tmp_path / "r.jpg"),
                 "--checkpoint", ckpt]) == 0
    assert Image.open(tmp_path / "r.jpg").size == (32, 24)
    assert main(["overlay", str(images / "rgb.png"), "-o", str(tmp_path / "o.png"),
                 "--svg", str(tmp_path / "o.svg"), "--checkpoint", ckpt]) == 0
    assert Image.open(tmp_path / "o.png").size == (64, 48)
    assert (tmp_path / "o.svg").read_text().startswith("<svg")


@pytest.mark.parametrize("name", ["gray.png", "rgba.png", "palette.png", "deep.png"])
def test_odd_image_modes_are_converted(tmp_path, ckpt, images, name):
    out = tmp_path / "r.png"
    assert main(["reconstruct", str(images / name), "-o", str(out), "--checkpoint", ckpt]) == 0
    assert Image.open(out).mode == "RGB"


def test_bad_inputs_exit_2_with_one_line_and_no_output(tmp_path, ckpt, images, capsys):
    cases = [
        ["reconstruct", str(images / "corrupt.png"), "-o", str(tmp_path / "x.png"),
         "--checkpoint", ckpt],
        ["reconstruct", str(images / "missing.png"), "-o", str(tmp_path / "x.png"),
         "--checkpoint", ckpt],
        ["reconstruct", str(images / "rgb.png"), "-o", str(tmp_path / "x.bmpx"),
         "--checkpoint", ckpt],
        ["reconstruct", str(images / "rgb.png"), "-o", str(tmp_path / "x.png"),
         "--checkpoint", str(images / "corrupt.png")],
        ["decode", str(images / "rgb.png"), "-o", str(tmp_path / "x.png"), "--checkpoint", ckpt],
    ]
    for argv in cases:
        capsys.readouterr()
        assert main(argv) == 2, argv
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith("neuraltex: error:"), err
    assert not list(tmp_path.iterdir())


def test_tampered_checkpoint_is_rejected(tmp_path, ckpt, images, capsys):
    blob = bytearray(open(ckpt, "rb").read())
    blob[-3] ^= 0x55
    bad = tmp_path / "bad.safetensors"
    bad.write_bytes(bytes(blob))
    assert main(["reconstruct", str(images / "rgb.png"), "-o", str(tmp_path / "x.png"),
                 "--checkpoint", str(bad)]) == 2
    assert "checksum" in capsys.readouterr().err
    assert not (tmp_path / "x.png").exists()


def test_large_images_are_downscaled_with_a_notice(tmp_path, ckpt, capsys):
    big = tmp_path / "big.png"
    Image.new("RGB", (200, 100), (120, 30, 60)).save(big)
    out = tmp_path / "r.png"
    assert main(["reconstruct", str(big), "-o", str(out), "--checkpoint", ckpt,
                 "--max-side", "64"]) == 0
    assert "downscaled" in capsys.readouterr().err
    assert Image.open(out).size == (64, 32)


def test_model_plugs_into_the_texton_benchmark(ckpt):
    from neuraltex.baselines import get_segmenter
    from neuraltex.data.generator import generate
    from neuraltex.metrics import texton_scores

    sample = generate(0, 0, 32)
    labels = get_segmenter("model", checkpoint=ckpt)(sample.image)
    assert labels.shape == (32, 32) and labels.min() >= 0
    scores = texton_scores(labels, sample.mask)
    assert 0 <= scores["miou"] <= 1
