"""Training speed and inference latency of the texton autoencoder on this machine.

    python scripts/bench_model.py                      # tiny: steps/s at 64 and 128 px, batch 8
    python scripts/bench_model.py --latency-presets tiny paper

Training: full steps of the training program (all losses on: reconstruction + LPIPS, entropy,
compactness, reshuffle + texture + patch GAN, equivariance consistency + transformed
reconstruction, image GAN with lazy R1 every 16 steps, critic updates) on procedural images,
timed after 2 warm-up steps; peak RSS of the process. Inference: encode + decode of one 256 px
image (best of 3), no gradients. Baselines printed for comparison: the issue's targets
(>= 2 steps/s at 64 px batch 8; <= 0.3 s encode+decode at 256 px for tiny).
"""

from __future__ import annotations

import argparse
import resource
import time

import torch


def _images(n: int, size: int) -> torch.Tensor:
    from neuraltex.data.generator import generate

    return torch.stack([torch.from_numpy(generate(i, 0, size).image).permute(2, 0, 1)
                        for i in range(n)]).float()


def train_speed(preset: str, size: int, batch: int, steps: int) -> tuple[float, float]:
    from neuraltex.model import build_model
    from neuraltex.model_config import ModelConfig
    from train.loss_config import LossConfig, StepSettings
    from train.objective import CriticObjective, GeneratorObjective

    torch.manual_seed(0)
    model, d, dp = build_model(ModelConfig(preset=preset), with_critics=True)
    loss = LossConfig(lpips_backbone="random")
    critics = CriticObjective(d, dp, loss, image_size=size)
    gen = GeneratorObjective(model, critics, loss)
    opt_g = torch.optim.Adam(model.parameters(), lr=1e-4, betas=(0.5, 0.999))
    opt_d = torch.optim.Adam(critics.parameters(), lr=1e-4, betas=(0.5, 0.999))
    images = _images(batch, size)
    w = StepSettings(entropy=0.08, compact=1.0, csis=0.08, texture=0.01, gan=0.1, pgan=0.1,
                     mask=1.0, patch_size=2)

    def step(i: int) -> None:
        g = torch.Generator().manual_seed(i)
        critics.requires_grad_(False)
        out = gen(images, None, w, g)
        opt_g.zero_grad()
        out.loss.backward()
        opt_g.step()
        critics.requires_grad_(True)
        loss, _ = critics(images, out.recon.detach(), out.reshuffled.detach(), i, g)
        opt_d.zero_grad()
        loss.backward()
        opt_d.step()

    for i in range(2):
        step(i + 1)  # warm-up; odd steps skip R1
    t0 = time.perf_counter()
    for i in range(steps):
        step(i)  # includes one lazy-R1 step (i = 0)
    rate = steps / (time.perf_counter() - t0)
    return rate, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def latency(preset: str, size: int) -> float:
    from neuraltex.model import build_model
    from neuraltex.model_config import ModelConfig

    torch.manual_seed(0)
    model = build_model(ModelConfig(preset=preset)).eval()
    image = _images(1, size)
    best = float("inf")
    with torch.no_grad():
        for _ in range(3):
            t0 = time.perf_counter()
            model.decode(model.encode(image).textons, (size, size))
            best = min(best, time.perf_counter() - t0)
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--preset", default="tiny")
    ap.add_argument("--sizes", type=int, nargs="+", default=[64, 128])
    ap.add_argument("--batch", type=int, default=8)
    ap.add_argument("--steps", type=int, default=5)
    ap.add_argument("--latency-presets", nargs="*", default=["tiny"])
    ap.add_argument("--latency-size", type=int, default=256)
    args = ap.parse_args()
    print(f"torch {torch.__version__}, {torch.get_num_threads()} threads, CPU")
    print(f"training steps ({args.preset}, batch {args.batch}, all losses): target >= 2 steps/s "
          "at 64 px")
    for size in args.sizes:
        rate, rss = train_speed(args.preset, size, args.batch, args.steps)
        print(f"  {size:>4} px: {rate:6.2f} steps/s, peak RSS {rss:6.0f} MB")
    print(f"encode + decode latency at {args.latency_size} px (target <= 0.3 s for tiny)")
    for preset in args.latency_presets:
        print(f"  {preset:>6}: {latency(preset, args.latency_size):6.3f} s")


if __name__ == "__main__":
    main()
