"""G (neuraltex/generator.py): shapes, range, any resolution, options, the F_max input."""

from __future__ import annotations

import pytest
import torch

from conftest import BATCHES, SIZES
from neuraltex.generator import SPADEGenerator, level_sizes

pytestmark = pytest.mark.usefixtures("one_thread", "seeded")


@pytest.mark.parametrize("b", BATCHES)
@pytest.mark.parametrize("hw", SIZES)
def test_generator_shapes_and_range(tiny, b, hw):
    gen = SPADEGenerator.from_config(tiny.generator)
    img = gen(torch.rand(b, tiny.generator.feature_channels, *hw), torch.rand(b, 1, *hw))
    assert img.shape == (b, 3, *hw)
    assert img.min() >= -1 and img.max() <= 1


def test_generator_resolution_independent(tiny):
    gen = SPADEGenerator.from_config(tiny.generator)
    c = tiny.generator.feature_channels
    gen(torch.rand(2, c, 32, 32), torch.rand(2, 1, 32, 32))  # "training" resolution
    gen.eval()
    for hw in [(64, 64), (40, 56), (17, 23)]:
        img = gen(torch.rand(1, c, *hw), torch.rand(1, 1, *hw))
        assert img.shape == (1, 3, *hw) and torch.isfinite(img).all()
    assert level_sizes((17, 23), 3) == [(5, 6), (9, 12), (17, 23)]


@pytest.mark.parametrize("kw", [{"spade_kernel": 1}, {"norm": "instance"},
                                {"use_spectral_norm": False, "output_activation": "sigmoid"}])
def test_generator_options(kw):
    gen = SPADEGenerator(feature_channels=6, channels=(8, 8, 8), spade_hidden=8, **kw)
    img = gen(torch.rand(2, 6, 24, 20), torch.rand(2, 1, 24, 20))
    assert img.shape == (2, 3, 24, 20)
    assert img.min() >= (0 if kw.get("output_activation") == "sigmoid" else -1)


def test_generator_uses_max_opacity_input():
    gen = SPADEGenerator(feature_channels=6, channels=(8, 8, 8), spade_hidden=8,
                         concat_features=False).eval()
    f = torch.rand(1, 6, 32, 32)
    a = gen(f, torch.zeros(1, 1, 32, 32))
    b = gen(f, torch.rand(1, 1, 32, 32))
    assert not torch.allclose(a, b)
    with pytest.raises(ValueError):
        gen(f, torch.rand(1, 1, 16, 16))
