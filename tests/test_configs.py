"""Every Hydra config composes, and each model config instantiates (paper: sizes only)."""

from pathlib import Path

import pytest
from hydra import compose, initialize_config_dir

from neuraltex.networks import NetworksConfig
from train.loss_config import LossConfig
from train.setup import loss_config, model_config

CONFIGS = Path(__file__).resolve().parents[1] / "configs"


def _compose(*overrides: str):
    with initialize_config_dir(config_dir=str(CONFIGS), version_base="1.3"):
        return compose(config_name="train", overrides=["run_dir=/tmp/unused", *overrides])


def _options(group: str) -> list[str]:
    return sorted(p.stem for p in (CONFIGS / group).glob("*.yaml"))


@pytest.mark.parametrize("group", ["model", "data", "loss", "trainer", "debug", "experiment"])
def test_every_option_composes(group):
    for option in _options(group):
        extra = ["data.root=/tmp"] if (group, option) == ("data", "folder") else []
        cfg = _compose(f"{group}={option}", *extra)
        assert cfg.trainer.max_steps > 0 and cfg.model.preset in ("tiny", "small", "paper")
        assert model_config(cfg).preset == cfg.model.preset  # typed: unknown keys would raise
        assert loss_config(cfg).mask_supervision == cfg.loss.mask_supervision


def test_typed_loss_defaults_are_the_default_yaml():
    assert loss_config(_compose("loss=default")) == LossConfig()
    with pytest.raises(ValueError, match="unknown loss settings: w_typo"):
        loss_config(_compose("loss=default", "+loss.w_typo=1"))


def test_overrides_work_as_users_expect():
    cfg = _compose("model=small", "trainer.max_steps=200", "loss.mask_supervision=gt")
    assert cfg.model.preset == "small" and cfg.trainer.max_steps == 200
    assert cfg.data.size == cfg.model.image_size == 128  # interpolation follows the model
    assert cfg.loss.mask_supervision == "gt"


def test_model_configs_instantiate_and_paper_sizes():
    from neuraltex.model import build_model

    for option in ("tiny", "small"):
        model = build_model(model_config(_compose(f"model={option}")))
        assert sum(p.numel() for p in model.parameters()) > 0
    paper = NetworksConfig.preset(_compose("model=paper").model.preset)
    assert paper.segmentation.num_queries == 100
    assert paper.encoder.appearance_channels + 2 == paper.generator.feature_channels == 384
    assert paper.segmentation.backbone == "resnet50"
