"""The editing subcommands of `neuraltex` on a tiny model and tiny images.

The model is the tiny preset, untrained, with its mask head sharpened so that the segmentation
is confident and images get effective textons (an untrained head gives none).
"""

import json

import numpy as np
import pytest
import torch
from PIL import Image

from neuraltex.checkpoint import export_model
from neuraltex.cli import main
from neuraltex.data.generator import generate
from neuraltex.model import build_model
from neuraltex.model_config import ModelConfig

CONFIG = ModelConfig(preset="tiny", image_size=32)


@pytest.fixture(scope="module")
def ckpt(tmp_path_factory):
    torch.manual_seed(0)
    model = build_model(CONFIG)
    with torch.no_grad():
        head = model.segmenter.mask_head.embed[4]
        head.weight.mul_(1e4)
        head.bias.mul_(1e4)
    path = tmp_path_factory.mktemp("model") / "sharp.safetensors"
    export_model(path, model.state_dict(), CONFIG, {"steps": 0})
    return str(path)


@pytest.fixture(scope="module")
def images(tmp_path_factory):
    d = tmp_path_factory.mktemp("img")
    for name, index in (("a.png", 0), ("b.png", 3)):
        pic = (generate(index, 0, (32, 40)).image * 255).round().astype(np.uint8)
        Image.fromarray(pic).save(d / name)
    mask = np.zeros((32, 40, 3), np.uint8)
    mask[:, 20:] = 255
    Image.fromarray(mask).save(d / "mask.png")
    edited = np.asarray(Image.open(d / "a.png")).copy()
    edited[10:14, 10:14] = (255, 0, 0)
    Image.fromarray(edited).save(d / "edited.png")
    (d / "edits.json").write_text(json.dumps(
        [{"select": {"point": [0.5, 0.5]}, "op": "move", "by": [0.1, 0.0]},
         {"select": {"region": [0, 0, 0.5, 1]}, "op": "rotate", "degrees": 30}]))
    (d / "corrupt.png").write_bytes(b"\x89PNG\r\n\x1a\nnot really")
    (d / "corrupt.json").write_text('{"format": "neuraltex.textons", "version": 1, "sets": 3}')
    return d


def _pixels(path):
    return np.asarray(Image.open(path).convert("RGB"), dtype=np.int16)


COMMANDS = {
    "transfer": ["transfer", "{a}", "{a}", "{b}", "--regions", "{mask}", "--mode", "replace"],
    "reshuffle": ["reshuffle", "{a}", "--count", "2", "--seed", "1"],
    "interpolate": ["interpolate", "{a}", "{b}", "--frames", "3"],
    "vary": ["vary", "{a}", "--appearance", "0.5", "--shape", "1.5"],
    "edit": ["edit", "{a}", "{edits}"],
    "propagate": ["propagate", "{a}", "{edited}"],
    "animate": ["animate", "{a}", "--flow", "shear", "--frames", "3"],
    "stylize": ["stylize", "{a}", "{b}", "--scale", "0.5"],
}
OUTPUTS = {"reshuffle": ["out_0.png", "out_1.png"], "interpolate": ["out.gif"],
           "animate": ["out.gif"]}


@pytest.mark.parametrize("name", COMMANDS)
def test_every_edit_subcommand_runs(tmp_path, ckpt, images, name, capsys):
    out = tmp_path / ("out.gif" if name in ("interpolate", "animate") else
                      "out_{i}.png" if name == "reshuffle" else "out.png")
    args = [a.format(a=images / "a.png", b=images / "b.png", mask=images / "mask.png",
                     edits=images / "edits.json", edited=images / "edited.png")
            for a in COMMANDS[name]]
    code = main([*args, "-o", str(out), "--checkpoint", ckpt])
    assert code == 0, capsys.readouterr().err
    for f in OUTPUTS.get(name, ["out.png"]):
        assert Image.open(tmp_path / f).size == (40, 32)
    if name in ("interpolate", "animate"):
        assert Image.open(out).n_frames == 3


def test_transfer_onto_itself_is_the_reconstruction(tmp_path, ckpt, images):
    a = str(images / "a.png")
    assert main(["reconstruct", a, "-o", str(tmp_path / "r.png"), "--checkpoint", ckpt]) == 0
    assert main(["transfer", a, a, "-o", str(tmp_path / "t.png"), "--checkpoint", ckpt]) == 0
    assert np.abs(_pixels(tmp_path / "t.png") - _pixels(tmp_path / "r.png")).max() <= 1


def test_animation_frame_zero_is_the_reconstruction(tmp_path, ckpt, images):
    a = str(images / "a.png")
    assert main(["reconstruct", a, "-o", str(tmp_path / "r.png"), "--checkpoint", ckpt]) == 0
    assert main(["animate", a, "-o", str(tmp_path / "f{i}.png"), "--frames", "2",
                 "--checkpoint", ckpt]) == 0
    assert np.array_equal(_pixels(tmp_path / "f0.png"), _pixels(tmp_path / "r.png"))
    assert not np.array_equal(_pixels(tmp_path / "f1.png"), _pixels(tmp_path / "r.png"))


def test_propagation_changes_more_than_the_user_did(tmp_path, ckpt, images, capsys):
    out = tmp_path / "p.png"
    assert main(["propagate", str(images / "a.png"), str(images / "edited.png"), "-o", str(out),
                 "--threshold", "0.0", "--checkpoint", ckpt]) == 0
    assert "propagated to" in capsys.readouterr().out
    changed = np.abs(_pixels(out) - _pixels(images / "a.png")).max(-1) > 2
    assert changed.sum() > 16  # the user's 4 x 4 dot plus its copies


def test_texton_files_are_accepted_and_written(tmp_path, ckpt, images):
    t = tmp_path / "t.json"
    assert main(["encode", str(images / "a.png"), "-o", str(t), "--checkpoint", ckpt]) == 0
    assert main(["edit", str(t), str(images / "edits.json"), "-o", str(tmp_path / "e.png"),
                 "--textons-out", str(tmp_path / "e.pt"), "--checkpoint", ckpt]) == 0
    assert main(["interpolate", str(t), str(tmp_path / "e.pt"), "--spatial", "--size", "24",
                 "-o", str(tmp_path / "i.webp"), "--checkpoint", ckpt]) == 0
    assert Image.open(tmp_path / "i.webp").size == (30, 24)


def _bad_cases(d, o):
    a, b = str(d / "a.png"), str(d / "b.png")
    return [
        ["transfer", a, str(d / "missing.png"), "-o", o],
        ["transfer", a, str(d / "corrupt.png"), "-o", o],
        ["transfer", a, str(d / "corrupt.json"), "-o", o],
        ["transfer", a, a, b, "-o", o],                                # no --regions
        ["transfer", a, a, b, a, "--regions", str(d / "mask.png"), "-o", o],  # 2 colours, 3
        ["reshuffle", a, "--count", "2", "-o", o.replace(".png", "_{j}.png")],
        ["interpolate", a, b, "--t", "1.5", "-o", o],
        ["interpolate", a, b, "--frames", "3", "-o", o.replace(".png", ".bmp")],
        ["vary", a, "--shape", "-1", "-o", o],
        ["edit", a, str(d / "corrupt.png"), "-o", o],
        ["propagate", a, a, "-o", o],                                  # nothing edited
        ["propagate", a, str(d / "mask.png").replace("mask", "missing"), "-o", o],
        ["animate", a, "--frames", "0", "-o", o.replace(".png", ".gif")],
        ["stylize", str(d / "corrupt.png"), b, "-o", o],
        ["stylize", a, b, "--scale", "0", "-o", o],
    ]


def test_bad_inputs_exit_2_with_one_line_and_no_output(tmp_path, ckpt, images, capsys):
    out = tmp_path / "out"
    out.mkdir()
    blob = bytearray(open(ckpt, "rb").read())
    blob[-3] ^= 0x55
    tampered = tmp_path / "tampered.safetensors"
    tampered.write_bytes(bytes(blob))
    cases = [[*argv, "--checkpoint", ckpt] for argv in _bad_cases(images, str(out / "x.png"))]
    cases.append(["stylize", str(images / "a.png"), str(images / "b.png"), "-o",
                  str(out / "x.png"), "--checkpoint", str(tampered)])
    for argv in cases:
        capsys.readouterr()
        assert main(argv) == 2, argv
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith("neuraltex: error:"), (argv, err)
    assert not list(out.iterdir())
