"""Time of every editing operation (seed 003, 4.4) as the CLI runs it, on this machine.

    OMP_NUM_THREADS=1 python scripts/bench_edit.py                 # tiny config, 1 thread
    python scripts/bench_edit.py --checkpoint MODEL.safetensors --threads 2

A single-image edit is encode + edit + decode of a 256 x 256 procedural texture (what
``neuraltex <op>`` does after loading the model; start-up and file I/O are not counted), best
of ``--repeat``. Animation reports decoded frames per second at 256 x 256; stylization the
whole run on a 1024 x 768 content image (patches, merging, mean alignment, decoding).
Without ``--checkpoint`` the model is the tiny preset, untrained, with a sharpened mask head
so that images get effective textons (the untrained head gives none, which would make
merging and splatting unrealistically cheap). Target: <= 0.5 s per single-image edit.
"""

from __future__ import annotations

import argparse
import time

import torch


def tiny_model():
    from neuraltex.model import build_model
    from neuraltex.model_config import ModelConfig

    torch.manual_seed(0)
    model = build_model(ModelConfig(preset="tiny", image_size=64)).eval()
    with torch.no_grad():
        model.segmenter.mask_head.embed[4].weight.mul_(1e4)  # confident masks -> textons exist
        model.segmenter.mask_head.embed[4].bias.mul_(1e4)
    return model


def texture(index: int, size: tuple[int, int], family: str | None = None) -> torch.Tensor:
    from neuraltex.data.generator import generate

    return torch.from_numpy(generate(index, 0, size, family=family).image).permute(2, 0, 1)


def timed(fn) -> tuple[float, float]:
    """(wall seconds, CPU seconds of this process) of one call; on a machine shared with other
    work, CPU time at 1 thread is what a quiet machine's wall time would be."""
    w, c = time.perf_counter(), time.process_time()
    fn()
    return time.perf_counter() - w, time.process_time() - c


def best_of(fn, repeat: int) -> tuple[float, float]:
    return min((timed(fn) for _ in range(repeat)), key=lambda wc: wc[0])


def single_image_ops(model, a: torch.Tensor, b: torch.Tensor) -> dict:
    """name -> zero-argument function doing one full edit at a's size."""
    from neuraltex.edit.interpolate import interpolate, interpolate_spatially
    from neuraltex.edit.propagate import propagate_edit
    from neuraltex.edit.texton_edits import apply_edit_list
    from neuraltex.edit.transfer import transfer
    from neuraltex.edit.vary import vary
    from neuraltex.reshuffle import reshuffle

    size = tuple(a.shape[-2:])
    enc = lambda x: model.encode(x[None]).textons  # noqa: E731
    dec = lambda t: model.decode(t, size)  # noqa: E731
    edits = [{"select": {"point": [0.5, 0.5]}, "op": "move", "by": [0.1, 0.0]},
             {"select": {"region": [0, 0, 0.5, 1]}, "op": "rotate", "degrees": 30}]
    edited = a.clone()
    edited[:, 100:110, 100:110] = torch.tensor([1.0, 0.0, 0.0])[:, None, None]
    return {
        "reconstruct": lambda: dec(enc(a)),
        "transfer (mean)": lambda: dec(transfer(enc(a), enc(b))),
        "transfer (replace)": lambda: dec(transfer(enc(a), enc(b), "replace")),
        "reshuffle": lambda: dec(reshuffle(enc(a), seed=0)),
        "interpolate t=0.5": lambda: dec(interpolate(enc(a), enc(b), 0.5)),
        "interpolate spatial": lambda: dec(interpolate_spatially(enc(a), enc(b))),
        "vary (0.5, 1.5)": lambda: dec(vary(enc(a), 0.5, 1.5)),
        "edit (move + rotate)": lambda: dec(apply_edit_list(enc(a), edits)),
        "propagate": lambda: propagate_edit(a, edited, enc(a), threshold=0.5),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--checkpoint", help="model .safetensors (default: tiny preset, untrained)")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--frames", type=int, default=12, help="animation frames to time")
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    if args.checkpoint:
        from neuraltex.model import load_model

        model = load_model(args.checkpoint)
    else:
        model = tiny_model()
    a, b = texture(0, (256, 256), "discs"), texture(1, (256, 256), "bricks")
    print(f"torch threads: {torch.get_num_threads()}, model: {args.checkpoint or 'tiny'}")
    print("| operation (256 x 256) | wall s | CPU s |\n|---|---|---|")
    with torch.no_grad():
        model.decode(model.encode(a[None]).textons, (256, 256))  # warm-up
        for name, fn in single_image_ops(model, a, b).items():
            wall, cpu = best_of(fn, args.repeat)
            print(f"| {name} | {wall:.3f} | {cpu:.3f} |", flush=True)
        animation(model, a, args.frames)
        stylization(model, b)


def animation(model, a: torch.Tensor, frames: int) -> None:
    from neuraltex.edit.animation import animate

    for flow in ("vortex", "shear"):
        def run(flow=flow):
            for s in animate(model.encode(a[None]).textons, flow, frames):
                model.decode(s, (256, 256))

        wall, cpu = timed(run)
        print(f"| animate {flow}, {frames} frames incl. encode (frames/s) | "
              f"{frames / wall:.2f} | {frames / cpu:.2f} |", flush=True)


def stylization(model, style: torch.Tensor) -> None:
    from neuraltex.edit.stylize import stylize

    content = texture(7, (768, 1024), "stones")
    patch = model.config.image_size or 128
    style_textons = model.encode(style[None]).textons
    for scale in (1.0, 0.5, 2.0):
        wall, cpu = timed(lambda s=scale: stylize(model, content, style_textons, patch, s))
        print(f"| stylize 1024 x 768, patch {patch}, scale {scale} | {wall:.2f} | {cpu:.2f} |",
              flush=True)


if __name__ == "__main__":
    main()
