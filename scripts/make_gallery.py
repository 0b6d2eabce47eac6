"""One picture per editing operation (seed 003, 4.4): inputs -> outputs, for the README.

    python scripts/make_gallery.py                                  # the shipped model
    python scripts/make_gallery.py --checkpoint runs/<date>/model.safetensors --out /tmp/g

Inputs are procedural textures from :mod:`neuraltex.data` (clear families: discs, bricks,
scales, leaves, stones). Writes ``edit_<op>.png`` for transfer, reshuffle, interpolate, vary,
edit, propagate, animate, stylize and overlay, plus ``edit_animate_<flow>.gif``. Pictures from an
untrained model are noise: commit them to docs/ only from the trained default model.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import torch
from PIL import Image, ImageDraw

from neuraltex.imageio import stack_rows
from neuraltex.model import DEFAULT_MODEL

SIZE = 128
LABEL_H = 14


def texture(index: int, family: str, size=(SIZE, SIZE)) -> torch.Tensor:
    from neuraltex.data.generator import generate

    return torch.from_numpy(generate(index, 0, size, family=family).image).permute(2, 0, 1)


def to_pil(x) -> Image.Image:
    if isinstance(x, Image.Image):
        return x.convert("RGB")
    x = x[0] if x.dim() == 4 else x
    arr = (x.detach().clamp(0, 1).permute(1, 2, 0).cpu().numpy() * 255).round()
    return Image.fromarray(arr.astype(np.uint8))


def strip(tiles: list[tuple[str, object]], height: int = SIZE) -> Image.Image:
    """Labelled pictures side by side, scaled to one height."""
    pics = []
    for _, x in tiles:
        p = to_pil(x)
        pics.append(p.resize((round(p.width * height / p.height), height), Image.LANCZOS))
    out = Image.new("RGB", (sum(p.width for p in pics) + 4 * (len(pics) - 1),
                            height + LABEL_H), "white")
    draw, x0 = ImageDraw.Draw(out), 0
    for (label, _), p in zip(tiles, pics, strict=True):
        out.paste(p, (x0, LABEL_H))
        draw.text((x0 + 2, 1), label, fill="black")
        x0 += p.width + 4
    return out


class Gallery:
    def __init__(self, model, out: Path) -> None:
        self.model, self.out = model, out

    def enc(self, x: torch.Tensor):
        return self.model.encode(x[None]).textons

    def dec(self, t, size=(SIZE, SIZE)) -> torch.Tensor:
        return self.model.decode(t, size)

    def save(self, name: str, picture: Image.Image) -> None:
        picture.save(self.out / f"edit_{name}.png")
        print(f"wrote {self.out / f'edit_{name}.png'}")

    def transfer(self) -> None:
        from neuraltex.edit.transfer import transfer

        s, a = texture(0, "scales"), texture(1, "bricks")
        ts, ta = self.enc(s), self.enc(a)
        self.save("transfer", strip([("structure", s), ("appearance", a),
                                     ("mean", self.dec(transfer(ts, ta))),
                                     ("replace", self.dec(transfer(ts, ta, "replace")))]))

    def reshuffle(self) -> None:
        """As ``neuraltex reshuffle`` does on a plain image (--by textons): appearance
        features trade places within texton kinds, the background keeping its own."""
        from neuraltex.reshuffle import reshuffle
        from neuraltex.texton_kinds import texton_kinds

        x = texture(2, "discs")
        t = self.enc(x)
        kinds = texton_kinds(t, channels=self.model.generator.feature_channels - 2)
        self.save("reshuffle", strip([("input", x), ("reconstruction", self.dec(t))]
                                     + [(f"seed {i}", self.dec(reshuffle(t, seed=i, kinds=kinds)))
                                        for i in range(3)]))

    def interpolate(self) -> None:
        from neuraltex.edit.interpolate import interpolate, interpolate_spatially

        a, b = texture(3, "discs"), texture(4, "stones")
        ta, tb = self.enc(a), self.enc(b)
        tiles = [("A", a)] + [(f"t={t}", self.dec(interpolate(ta, tb, t)))
                              for t in (0.25, 0.5, 0.75)] + [("B", b)]
        wa, wb = texture(3, "discs", (SIZE, 3 * SIZE)), texture(4, "stones", (SIZE, 3 * SIZE))
        wide = self.dec(interpolate_spatially(self.enc(wa), self.enc(wb)), (SIZE, 3 * SIZE))
        rows = [strip(tiles), strip([("spatial, A -> B", wide)])]
        self.save("interpolate", stack_rows(rows, gap=4))

    def vary(self) -> None:
        from neuraltex.edit.vary import vary

        x = texture(5, "leaves")
        t = self.enc(x)
        tiles = [("input", x)] + [(f"{n}={v}", self.dec(vary(t, **{k: v})))
                                  for n, k in (("l_f", "appearance"), ("l_U", "shape"))
                                  for v in (0.0, 2.0)]
        self.save("vary", strip(tiles))

    def edit(self) -> None:
        from neuraltex.edit.texton_edits import apply_edit_list
        from neuraltex.overlay import draw_overlay

        x = texture(6, "discs")
        enc = self.model.encode(x[None])
        edits = [{"select": {"region": [0, 0, 0.5, 1]}, "op": "scale", "by": 1.5},
                 {"select": {"region": [0.5, 0, 1, 1]}, "op": "rotate", "degrees": 45},
                 {"select": {"point": [0.5, 0.5]}, "op": "delete"}]
        t = apply_edit_list(enc.textons, edits)
        self.save("edit", strip([("input", x), ("textons", draw_overlay(x, enc.textons,
                                                                         enc.masks[0])),
                                 ("left x1.5, right 45deg", self.dec(t)),
                                 ("edited textons", draw_overlay(self.dec(t)[0], t))]))

    def propagate(self) -> None:
        from neuraltex.edit.propagate import propagate_edit

        x = texture(7, "discs")
        t = self.enc(x)
        i = int(t.exists()[0].nonzero()[0, 0])
        cx, cy = (t.mu[0, i] * SIZE).round().long().tolist()
        edited = x.clone()
        edited[:, max(cy - 3, 0):cy + 3, max(cx - 3, 0):cx + 3] = 1.0  # a white dot
        out = propagate_edit(x, edited, t, threshold=0.8)
        self.save("propagate", strip([("original", x), ("user edit", edited),
                                      (f"propagated ({int(out.targets.sum())})", out.image)]))

    def animate(self) -> None:
        from neuraltex.edit.animation import animate
        from neuraltex.imageio import save_frames

        x = texture(8, "bricks")
        t = self.enc(x)
        rows = []
        for flow in ("shear", "vortex"):
            frames = [self.dec(f)[0] for f in animate(t, flow, 16)]
            save_frames(frames, self.out / f"edit_animate_{flow}.gif", fps=8)
            rows.append(strip([(f"{flow} t={4 * k / 16:g}", frames[k]) for k in (0, 4, 8, 12)]))
        self.save("animate", stack_rows(rows, gap=4))

    def stylize(self) -> None:
        from neuraltex.edit.stylize import stylize

        content = texture(9, "stones", (2 * SIZE, 3 * SIZE))
        style = texture(10, "scales")
        patch = self.model.config.image_size or SIZE
        tiles = [("content", content), ("texture", style)]
        for scale in (0.5, 1.0, 2.0):
            out = stylize(self.model, content, self.enc(style), patch, scale)
            tiles.append((f"scale {scale}", out))
        self.save("stylize", strip(tiles, height=2 * SIZE))

    def overlay(self) -> None:
        from neuraltex.overlay import draw_overlay

        x = texture(11, "scales")
        enc = self.model.encode(x[None])
        self.save("overlay", strip([("input", x), ("textons", draw_overlay(
            x, enc.textons, enc.masks[0], scale=2))]))




OPS = ("transfer", "reshuffle", "interpolate", "vary", "edit", "propagate", "animate",
       "stylize", "overlay")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--checkpoint", type=Path, default=DEFAULT_MODEL,
                    help=f"model .safetensors (default: {DEFAULT_MODEL})")
    ap.add_argument("--out", type=Path, default=Path("docs"))
    ap.add_argument("--only", nargs="+", choices=OPS, help="render only these pictures")
    args = ap.parse_args()
    if not args.checkpoint.exists():
        raise SystemExit(f"{args.checkpoint}: no such model; pass --checkpoint")
    from neuraltex.model import load_model

    torch.manual_seed(0)
    args.out.mkdir(parents=True, exist_ok=True)
    gallery = Gallery(load_model(args.checkpoint), args.out)
    with torch.no_grad():
        for op in args.only or OPS:
            getattr(gallery, op)()


if __name__ == "__main__":
    main()
