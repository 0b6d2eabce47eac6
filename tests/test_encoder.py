"""E_FC (neuraltex/encoder.py): shapes at any size, native stride, bad arguments."""

from __future__ import annotations

import pytest
import torch

from conftest import BATCHES, SIZES
from neuraltex.encoder import FCEncoder

pytestmark = pytest.mark.usefixtures("one_thread", "seeded")


@pytest.mark.parametrize("b", BATCHES)
@pytest.mark.parametrize("hw", SIZES)
def test_encoder_shapes(tiny, b, hw):
    enc = FCEncoder.from_config(tiny.encoder)
    f_a, v = enc(torch.rand(b, 3, *hw))
    assert f_a.shape == (b, tiny.encoder.appearance_channels, *hw)
    assert v.shape == (b, 2, *hw)


def test_encoder_native_stride_and_odd_size(tiny):
    enc = FCEncoder.from_config(tiny.encoder)
    f_a, v = enc(torch.rand(2, 3, 37, 50))
    assert f_a.shape[-2:] == v.shape[-2:] == (37, 50)
    enc.upsample_output = False
    f_a, v = enc(torch.rand(2, 3, 64, 48))
    assert enc.stride == 4 and f_a.shape[-2:] == (16, 12)


def test_encoder_bad_arguments_raise():
    with pytest.raises(ValueError):
        FCEncoder(down_channels=(8,), up_channels=(8,))
