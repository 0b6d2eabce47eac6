"""``python -m train [overrides]``: train the Gaussian-texton autoencoder (a Hydra app).

Examples:
    python -m train                                   # tiny model on CPU, procedural data
    python -m train model=small trainer.max_steps=5000
    python -m train loss.mask_supervision=gt          # optional GT mask supervision
    python -m train trainer.resume=runs/.../last.pt   # continue a run exactly
    torchrun --nproc_per_node=2 -m train trainer.batch_size=4   # DDP (gloo on CPU)
"""

from __future__ import annotations

import hydra
from omegaconf import DictConfig

from train.loop import run


@hydra.main(version_base="1.3", config_path="../configs", config_name="train")
def main(cfg: DictConfig) -> None:
    run(cfg)


if __name__ == "__main__":
    main()
