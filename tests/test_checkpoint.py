import random

import numpy as np
import pytest
import torch

from neuraltex.checkpoint import (
    CheckpointError,
    export_model,
    load_exported_model,
    load_training_checkpoint,
    save_training_checkpoint,
    set_rng_state,
)
from neuraltex.model_config import ModelConfig


def _draws():
    return random.random(), float(np.random.rand()), float(torch.rand(()))


def test_training_checkpoint_round_trip_restores_rng_and_states(tmp_path):
    net = torch.nn.Linear(3, 2)
    opt = torch.optim.Adam(net.parameters(), lr=1e-3, betas=(0.5, 0.999))
    net(torch.rand(4, 3)).sum().backward()
    opt.step()
    path = tmp_path / "ckpt.pt"
    save_training_checkpoint(path, step=7, config={"model": {"name": "tiny"}},
                             modules={"model": net.state_dict()},
                             optimizers={"adam": opt.state_dict()})
    expected = _draws()
    data = load_training_checkpoint(path)
    assert data["step"] == 7 and data["config"]["model"]["name"] == "tiny"
    set_rng_state(data["rng"])
    assert _draws() == expected  # the RNG continues exactly where it was saved
    net2 = torch.nn.Linear(3, 2)
    net2.load_state_dict(data["modules"]["model"])
    assert torch.equal(net2.weight, net.weight)
    opt2 = torch.optim.Adam(net2.parameters())
    opt2.load_state_dict(data["optimizers"]["adam"])
    assert opt2.param_groups[0]["betas"] == (0.5, 0.999)


def test_export_round_trip_and_tamper_detection(tmp_path):
    state = {"a.weight": torch.randn(4, 3), "a.bias": torch.zeros(4)}
    path = tmp_path / "model.safetensors"
    export_model(path, state, ModelConfig(preset="small"), {"steps": 10})
    loaded, cfg, info = load_exported_model(path)
    assert torch.equal(loaded["a.weight"], state["a.weight"])
    assert ModelConfig.from_dict(cfg) == ModelConfig(preset="small") and info == {"steps": 10}
    blob = bytearray(path.read_bytes())
    blob[-5] ^= 0xFF  # flip bits inside the last tensor's data
    path.write_bytes(bytes(blob))
    with pytest.raises(CheckpointError, match="checksum"):
        load_exported_model(path)
    path.write_bytes(b"garbage" * 10)
    with pytest.raises(CheckpointError, match="not a readable"):
        load_exported_model(path)


def test_training_checkpoint_rejects_foreign_files(tmp_path):
    path = tmp_path / "x.pt"
    torch.save({"format": "something-else"}, path)
    with pytest.raises(CheckpointError, match="not a neuraltex training checkpoint"):
        load_training_checkpoint(path)
    torch.save({"format": "neuraltex.train-checkpoint", "version": 3}, path)
    with pytest.raises(CheckpointError, match="version 3"):
        load_training_checkpoint(path)
    with pytest.raises(CheckpointError, match="no such"):
        load_training_checkpoint(tmp_path / "missing.pt")
