"""``python -m train [overrides]``: train the Gaussian-texton autoencoder (a Hydra app).

Examples:
    python -m train                                   # tiny model on CPU, procedural data
    python -m train model=small trainer.max_steps=5000
    python -m train loss.mask_supervision=gt          # optional GT mask supervision
    python -m train trainer.resume=runs/.../last.pt   # continue a run exactly
    torchrun --nproc_per_node=2 -m train trainer.batch_size=4   # DDP (gloo on CPU)

A user error (a missing earlier stage, a bad file) is one ``train: error:`` line and exit code
2; Ctrl-C saves a checkpoint and exits with one line (code 130); a launch that fails leaves no
empty run folder behind.
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import hydra
from omegaconf import DictConfig

from neuraltex.errors import InputError, one_line
from train.loop import Interrupted, run

# configs/ ships inside the package as train/configs (a link to the repository's configs/)
CONFIGS = "configs"


@hydra.main(version_base="1.3", config_path=CONFIGS, config_name="train")
def main(cfg: DictConfig) -> None:
    run_dir = Path(cfg.run_dir)
    fresh = not run_dir.exists() or not any(run_dir.iterdir())
    try:
        run(cfg)
    except Interrupted as stop:
        where = f"; saved {stop.checkpoint}" if stop.checkpoint else ""
        print(f"\ntrain: interrupted at step {stop.step}{where}", file=sys.stderr)
        sys.exit(130)
    except (InputError, FileNotFoundError) as exc:
        _remove_if_new(run_dir, fresh)
        print(f"train: error: {one_line(exc)}", file=sys.stderr)
        sys.exit(2)
    except BaseException:
        _remove_if_new(run_dir, fresh)
        raise


def _remove_if_new(run_dir: Path, fresh: bool) -> None:
    """Remove the run folder of a failed launch when this launch made it and it holds no
    checkpoint (Hydra creates it before the run starts)."""
    if fresh and run_dir.is_dir() and not (run_dir / "last.pt").exists():
        shutil.rmtree(run_dir, ignore_errors=True)
        try:
            run_dir.parent.rmdir()  # runs/ itself, when this was its only run
        except OSError:
            pass


if __name__ == "__main__":
    main()
