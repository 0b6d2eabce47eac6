"""Backbones of E_s (neuraltex/backbones.py): local ResNet-50 weights, never downloaded."""

from __future__ import annotations

import pytest
import torch
import torchvision

from neuraltex.backbones import ResNet50Backbone

pytestmark = pytest.mark.usefixtures("one_thread", "seeded")


def test_resnet50_backbone_loads_local_weights_only(tmp_path):
    ref = torchvision.models.resnet50(weights=None)
    path = tmp_path / "r50.pt"
    torch.save(ref.state_dict(), path)
    bb = ResNet50Backbone(weights_path=str(path))
    assert torch.equal(bb.stages[3][0].conv1.weight, ref.layer4[0].conv1.weight)
    assert bb.out_channels == (256, 512, 1024, 2048)
