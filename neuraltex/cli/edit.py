"""The editing subcommands of ``neuraltex`` (seed 003, 4.4): transfer, reshuffle, interpolate,
vary, edit, propagate, animate, stylize.

Each reads images (or texton files, .json/.pt, or texture files, .ntex, wherever a texture is
expected), edits textons with :mod:`neuraltex.edit` and decodes them with the model (a texture
file's own tuned decoder when one is given). Outputs are checked before any work,
so bad input never leaves a partial file. Heavy imports happen inside the commands.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from neuraltex.cli import args as types
from neuraltex.cli import common
from neuraltex.cli.common import IMAGE_OUT
from neuraltex.errors import InputError
from neuraltex.limits import MAX_COUNT, MAX_PATCHES

FRAMES_OUT = ".gif, .mp4 or a picture pattern such as out_{i}.png"
FPS = types.number(0, 1000, open_lo=True)


def _load(args: argparse.Namespace):
    return common.load(args.checkpoint, args.device, args.seed)


def _texture(args: argparse.Namespace, model, path: Path) -> common.Texture:
    """One texture: an image, a texton file or a texture file (.ntex, with its decoder)."""
    return common.textons_of(model, path, common.limits(args), args.device, args.tile)


def _decode(args: argparse.Namespace, model, textons, default_short: int):
    """One texton set -> image (3, H, W) at --size (default: the source's short side)."""
    size = common.output_size(args.size, textons.canvas, default_short, common.limits(args))
    return common.decode(model, textons, size, args.device)[0]


def _decode_frames(args: argparse.Namespace, model, frames: list, default_short: int) -> list:
    return [_decode(args, model, t, default_short) for t in _progress("frames")(frames)]


def _progress(desc: str):
    from tqdm import tqdm

    return lambda it: tqdm(it, desc=desc, leave=False, disable=None)  # no bar unless a tty


def _save_frames(frames: list, path: Path, fps: float) -> None:
    from neuraltex.imageio import save_frames

    written = save_frames(frames, path, fps)
    where = written[0] if len(written) == 1 else f"{written[0]} .. {written[-1]}"
    print(f"wrote {where} ({len(frames)} frames)")


def _regions(path: Path | None, count: int, lim):
    """(H, W) int64 region labels from a colour-coded mask: colours sorted by RGB (black first)
    number the regions; there must be one colour per appearance texture."""
    import numpy as np
    import torch

    from neuraltex.imageio import load_image

    if path is None:
        if count > 1:
            raise InputError("several appearance textures need --regions MASK")
        return None
    rgb = (load_image(path, limits=lim) * 255).round().to(torch.int64)  # (3, H, W)
    flat = rgb.flatten(1).T.numpy()
    colours, labels = np.unique(flat, axis=0, return_inverse=True)
    if len(colours) != count:
        raise InputError(f"{path}: {len(colours)} region colours for {count} appearance "
                         "texture(s); use one colour per texture")
    return torch.from_numpy(labels.reshape(rgb.shape[1:]))


def _with_appearance(structure, apps: list, regions, mode: str, seed: int):
    from neuraltex.edit.transfer import transfer, transfer_regions

    if regions is None:
        return transfer(structure, apps[0], mode, seed)
    return transfer_regions(structure, apps, regions.to(structure.device), mode, seed)


def cmd_transfer(args: argparse.Namespace) -> int:
    """Texture transfer (4.4.2): the structure (textons) of the first texture with the
    appearance of the others; several appearances go to the regions of --regions. Between
    texture files (the default mode there, ``palette``): the structure's reconstruction by
    its own tuned decoder, each texton recoloured with the appearance's texton colour of the
    same luminance rank (:mod:`neuraltex.edit.palette`) — a tuned decoder given another
    texture's layout paints smudges."""
    from neuraltex.imageio import check_output_path

    check_output_path(args.output)
    regions = _regions(args.regions, len(args.appearance), common.limits(args))
    model = _load(args)
    source = _texture(args, model, args.structure)
    apps = [_texture(args, model, p) for p in args.appearance]
    tuned = all(t.decoder is not None for t in (source, *apps))
    mode = args.mode or ("palette" if tuned else "mean")
    if mode == "palette":
        if not tuned:
            raise InputError("--mode palette takes texture files (.ntex, from `neuraltex "
                             "fit`) for the structure and every appearance")
        out = _palette(args, source, apps, regions)
        common.save(out, args.output)
        return 0
    # the appearance's tuned decoder renders its own features (it was tuned on them)
    decoder, (*features, structure) = common.decoder_for(model, *apps, source)
    out = _with_appearance(structure, features, regions, mode, args.seed or 0)
    common.save(_decode(args, decoder, out, source.short), args.output)
    return 0


def _palette(args: argparse.Namespace, source, apps: list, regions):
    """The structure texture file's reconstruction in the colours of the appearance texture
    file(s) (one per region of ``regions``, by texton centre) -> (3, H, W)."""
    import torch

    from neuraltex.edit.palette import rank_colours, recolour, texton_colours

    with torch.no_grad():
        picture = _decode(args, source.decoder, source.textons, source.short).cpu()
        colours, area = texton_colours(picture, source.labels, source.textons.num_textons)
        target = colours.copy()
        for r, app in enumerate(apps):
            own = common.decode(app.decoder, app.textons, tuple(app.labels.shape),
                                args.device)[0].cpu()
            new = rank_colours(colours, area, *texton_colours(own, app.labels))
            region = (slice(None) if regions is None else source.textons.in_region(
                regions.to(source.textons.mu.device) == r)[0].cpu().numpy())
            target[region] = new[region]
        return recolour(picture, source.labels, colours, target)


def cmd_reshuffle(args: argparse.Namespace) -> int:
    """Texture diversification (4.4.1). A texture file's elements (whole objects: coins,
    bricks, stones) trade places with elements of their shape in the reconstruction (or,
    with --source, in the picture the file was fitted to), each fitted to its new place
    (--by elements, the default for texture files:
    :mod:`neuraltex.element_swap`); otherwise appearance features are permuted among
    effective textons of the same kind (size and appearance), the background layer keeping
    its own, and the result is decoded (--by textons)."""
    import random

    from neuraltex.element_swap import swap_and_count
    from neuraltex.imageio import numbered
    from neuraltex.reshuffle import reshuffle
    from neuraltex.texton_elements import SIZE_RATIO
    from neuraltex.texton_kinds import texton_kinds

    paths = numbered(args.output, args.count)
    model = _load(args)
    tex = _texture(args, model, args.image)
    decoder, (textons,) = common.decoder_for(model, tex)
    plain = decoder.generator.feature_channels - 2  # [f_a, d]; detail sprites after
    by_elements = args.by == "elements" and tex.elements is not None
    if args.by == "elements" and tex.elements is None and tex.labels is not None:
        print(f"{args.image}: this texture file has no elements (fit it again to move whole "
              "elements); reshuffling textons")
    kinds = None if by_elements else texton_kinds(textons, channels=plain)
    rec, plan_on = _reshuffled_picture(args, decoder, textons, tex, by_elements)
    for i, path in enumerate(paths):
        seed = None if args.seed is None else args.seed + i
        if by_elements:
            ratio = args.size_ratio or SIZE_RATIO
            seed = random.randrange(2**31) if seed is None else seed  # one draw for both
            out, moved, total = swap_and_count(rec, tex.labels, tex.elements, seed=seed,
                                               size_ratio=ratio, plan_on=plan_on)
            print(f"{path}: {moved} of {total} elements trade places (the others have no "
                  f"partner of their outline, of their size within --size-ratio {ratio:g} "
                  "and on a ground like theirs; the background stays)")
        else:
            out = _decode(args, decoder, reshuffle(textons, seed=seed, kinds=kinds), tex.short)
        common.save(out, path)
    return 0


def _reshuffled_picture(args: argparse.Namespace, decoder, textons, tex: common.Texture,
                        by_elements: bool):
    """(picture, plan_on): the picture (3, H, W) whose elements trade places (--by elements),
    the texture file's --source (checked) resampled to the output size, else its
    reconstruction; and the picture the swaps are planned on: the reconstruction, so that a
    source moves what the reconstruction's reshuffle moves (None: the picture itself).
    (None, None) for --by textons, which decodes."""
    source = None
    if args.source is not None:
        source = common.source_picture(args.source, tex, args.image, common.limits(args))
        if not by_elements:
            raise InputError("--source goes with --by elements (whole elements move in the "
                             "picture; --by textons decodes, and moves no pixels)")
    if not by_elements:
        return None, None
    rec = _decode(args, decoder, textons, tex.short)
    if source is None:
        return rec, None
    from neuraltex.texton_synthesis import source_pixels

    return source_pixels(source, rec.shape[-2:]), rec


def cmd_interpolate(args: argparse.Namespace) -> int:
    """Texture interpolation (4.4.4): at --t, as --frames from A to B, or --spatial (t grows
    from 0 on the left to 1 on the right)."""
    from neuraltex.edit.interpolate import interpolate, interpolate_frames, interpolate_spatially
    from neuraltex.imageio import check_output_path, check_sequence_output

    (check_sequence_output if args.frames else check_output_path)(args.output)
    model = _load(args)
    ta, tb = _texture(args, model, args.image), _texture(args, model, args.other)
    seed, short = args.seed or 0, ta.short
    if ta.decoder is not None and tb.decoder is not None and not (
            args.spatial and args.size and len(args.size) == 2):
        return _palette_interpolate(args, ta, tb)
    if args.frames:
        _, (a, b) = common.decoder_for(model, ta, tb)
        frames = interpolate_frames(a, b, args.frames, seed)
        ts = [i / (args.frames - 1) for i in range(args.frames)]
        images = [_decode(args, common.decoder_for(model, ta, tb, t=t)[0], f, short)
                  for f, t in _progress("frames")(list(zip(frames, ts, strict=True)))]
        _save_frames(images, args.output, args.fps)
        return 0
    if args.spatial and args.size and len(args.size) == 2:  # a wide (or tall) picture:
        ta, tb = (_grown(args, model, t) for t in (ta, tb))  # textons synthesized to fill it
    decoder, (a, b) = common.decoder_for(model, ta, tb, t=0.5 if args.spatial else args.t)
    out = interpolate_spatially(a, b, seed) if args.spatial else interpolate(a, b, args.t, seed)
    common.save(_decode(args, decoder, out, short), args.output)
    return 0


def _palette_interpolate(args: argparse.Namespace, ta, tb) -> int:
    """Interpolation between two texture files, each rendered sharp by its own tuned decoder
    and brought to one palette (:func:`neuraltex.edit.palette.palette_blend`): a decoder
    blended between two tunings paints noise. B is rendered at A's picture size (cropped to
    A's aspect first)."""
    import torch

    from neuraltex.edit.palette import palette_blend

    with torch.no_grad():
        a = _decode(args, ta.decoder, ta.textons, ta.short).cpu()
        b = _fitted(_decode(args, tb.decoder, tb.textons, ta.short).cpu(), a.shape[-2:])
        H, W = a.shape[-2:]
        if args.frames:
            ts = [i / (args.frames - 1) for i in range(args.frames)]
            frames = [palette_blend(a, ta.labels, b, tb.labels, t)
                      for t in _progress("frames")(ts)]
            _save_frames(frames, args.output, args.fps)
            return 0
        t = (torch.linspace(0, 1, W).expand(H, W) if args.spatial else args.t)
        common.save(palette_blend(a, ta.labels, b, tb.labels, t), args.output)
    return 0


def _fitted(picture, size):
    """A picture (3, h, w) cropped about its centre to the aspect of ``size`` (H, W) and
    resampled to it."""
    import torch.nn.functional as F

    H, W = size
    h, w = picture.shape[-2:]
    ch, cw = min(h, round(w * H / W)), min(w, round(h * W / H))
    y, x = (h - ch) // 2, (w - cw) // 2
    crop = picture[:, y:y + ch, x:x + cw]
    if (ch, cw) == (H, W):
        return crop
    return F.interpolate(crop[None], size=(H, W), mode="bilinear", antialias=True,
                         align_corners=False)[0].clamp(0, 1)


def _grown(args: argparse.Namespace, model, tex: common.Texture) -> common.Texture:
    """The texture with its textons arranged (neuraltex synthesize) over the canvas of
    ``--size H W`` (short side = the canvas's), so the whole picture has textons."""
    from dataclasses import replace

    from neuraltex.texton_synthesis import (
        ArrangeSettings,
        arrange,
        picture_lattice,
        reconstruction,
        source_pixels,
        texton_colours,
    )

    h, w = args.size
    s = min(tex.textons.canvas) / min(h, w)
    decoder = tex.decoder or model
    recon = reconstruction(decoder, tex.textons, tex.short)
    colours = texton_colours(decoder, tex.textons, tex.short, recon)
    pixels = recon if tex.image is None else source_pixels(tex.image, recon.shape[-2:])
    arr = arrange(tex.textons, (w * s, h * s), colours, ArrangeSettings(seed=args.seed or 0),
                  lattice=picture_lattice(pixels, tex.short))
    return replace(tex, textons=arr.textons)


def cmd_vary(args: argparse.Namespace) -> int:
    """Modify texture variations (4.4.3): scale the appearance (lambda_f) and shape (lambda_U)
    variation around the mean; 1 keeps the texture, 0 makes every texton the mean one."""
    from neuraltex.edit.vary import vary
    from neuraltex.imageio import check_output_path

    check_output_path(args.output)
    model = _load(args)
    tex = _texture(args, model, args.image)
    tuned = tex.decoder is not None  # a texture file: vary d and sprites, keep f_a
    out = vary(tex.textons, args.appearance, args.shape,
               keep=model.generator.feature_channels - 2 if tuned else 0)
    common.save(_decode(args, tex.decoder or model, out, tex.short), args.output)
    return 0


def cmd_edit(args: argparse.Namespace) -> int:
    """Texton edits (4.4.5.1) from a JSON edit list: select by point, index, region or
    similarity, then move, scale, rotate, delete or duplicate (see neuraltex.edit.texton_edits)."""
    from neuraltex.edit.texton_edits import apply_edit_list
    from neuraltex.imageio import check_output_path
    from neuraltex.textons_file import save_textons

    check_output_path(args.output)
    if args.textons_out:
        common.check_textons_out(args.textons_out)
    model = _load(args)
    tex = _texture(args, model, args.image)
    decoder = tex.decoder or model
    edited = apply_edit_list(tex.textons, args.edits, decoder.generator.feature_channels - 2)
    image = _decode(args, decoder, edited, tex.short)
    if args.textons_out:
        save_textons(edited, args.textons_out)
        print(f"wrote {args.textons_out}")
    common.save(image, args.output)
    return 0


def cmd_propagate(args: argparse.Namespace) -> int:
    """Edit propagation (4.4.5.2): the change between ORIGINAL and EDITED, made on one texton,
    is repeated on every similar texton (pixel space, aligned by their Gaussians). ORIGINAL
    may be a texture file (.ntex): then EDITED is an edit of its reconstruction (`neuraltex
    reconstruct T.ntex`), and its fitted textons say what is similar."""
    from neuraltex.edit.propagate import propagate_edit
    from neuraltex.imageio import check_output_path, load_image

    check_output_path(args.output)
    edited = load_image(args.edited, limits=common.limits(args)).to(args.device)
    model = _load(args)
    original, textons, channels = _original(args, model, tuple(edited.shape[-2:]))
    if edited.shape != original.shape:
        raise InputError(f"{args.edited}: {edited.shape[2]}x{edited.shape[1]}, but the original "
                         f"is {original.shape[2]}x{original.shape[1]}")
    out = propagate_edit(original, edited, textons, args.threshold, args.radius,
                         channels=channels)
    print(f"edited texton {out.source}; propagated to {int(out.targets.sum())} similar textons")
    common.save(out.image, args.output)
    return 0


def _original(args: argparse.Namespace, model, size: tuple[int, int]):
    """(original image (3, H, W), its textons, feature channels to compare) for propagate:
    an image encoded by the model, or a texture file's reconstruction at the edited size."""
    if args.image.suffix.lower() != common.TEXTURE_FILE:
        original, enc = common.encode(model, args.image, common.limits(args), args.device,
                                      args.tile)
        return original, enc.textons, None
    tex = _texture(args, model, args.image)
    w, h = tex.textons.canvas
    if abs(size[1] / size[0] - w / h) > 0.02 * w / h:
        raise InputError(f"{args.edited}: {size[1]}x{size[0]} does not have the aspect of "
                         f"{args.image} ({w / h:.3f}); edit its reconstruction")
    original = common.decode(tex.decoder, tex.textons, size, args.device)[0]
    return original, tex.textons, tex.decoder.generator.feature_channels - 2


def cmd_animate(args: argparse.Namespace) -> int:
    """Texture animation (4.4.6, appendix 7.7.3): textons carried by a perturbed shear flow or a
    vortex flow; frame 0 is the reconstruction."""
    from neuraltex.edit.animation import animate
    from neuraltex.imageio import check_sequence_output

    check_sequence_output(args.output)
    model = _load(args)
    tex = _texture(args, model, args.image)
    frames = animate(tex.textons, args.flow, args.frames, args.duration, args.seed or 0,
                     args.velocity, args.omega)
    _save_frames(_decode_frames(args, tex.decoder or model, frames, tex.short), args.output,
                 args.fps)
    return 0


def cmd_stylize(args: argparse.Namespace) -> int:
    """Image stylization (4.4.2): a content image of any size encoded by overlapping patches,
    given the appearance of a texture (several: one per --regions colour); --scale < 1 makes
    smaller textons, > 1 larger ones."""
    from neuraltex.edit.stylize import content_textons
    from neuraltex.imageio import check_output_path, load_image

    check_output_path(args.output)
    regions = _regions(args.regions, len(args.texture), common.limits(args))
    content = load_image(args.image, limits=common.limits(args)).to(args.device)
    model = _load(args)
    apps = [_texture(args, model, p) for p in args.texture]
    patch = args.patch or model.config.image_size or 128
    _check_patches(content.shape[-2:], patch, args.scale, args.overlap)
    textons = content_textons(model, content, patch, args.scale, args.overlap, args.seed or 0,
                              progress=_progress("patches"))
    decoder, (*features, structure) = common.decoder_for(
        model, *apps, common.Texture(textons, min(content.shape[-2:])))
    out = _with_appearance(structure, features, regions, args.mode, args.seed or 0)
    common.save(_decode(args, decoder, out, min(content.shape[-2:])), args.output)
    return 0


def _check_patches(shape, patch: int, scale: float, overlap: float) -> None:
    """InputError when stylize would encode more than MAX_PATCHES patches."""
    from neuraltex.edit.stylize import patch_starts

    side = max(4, round(scale * patch))
    stride = max(1, round(side * (1 - overlap)))
    n = len(patch_starts(shape[0], side, stride)) * len(patch_starts(shape[1], side, stride))
    if n > MAX_PATCHES:
        raise InputError(f"stylize: {n} patches (more than {MAX_PATCHES}); use a larger "
                         "--scale, a smaller --overlap or a smaller image")


def add_commands(sub) -> None:
    """Register the editing subcommands on the ``neuraltex`` subparsers."""
    cmd = common.model_command
    img = IMAGE_OUT
    p = cmd(sub, "transfer", cmd_transfer, "structure of one texture, appearance of another",
            "structure", img)
    p.add_argument("appearance", type=Path, nargs="+", help="appearance texture(s)")
    _mode_and_regions(p, palette=True)

    p = cmd(sub, "reshuffle", cmd_reshuffle, "diversify: permute texton appearances", "image",
            f"{img}; with --count > 1 a pattern such as out_{{i}}.png")
    p.add_argument("--count", type=types.integer(1, MAX_COUNT), default=1,
                   help=f"number of variations, at most {MAX_COUNT} (default 1)")
    p.add_argument("--by", choices=("elements", "textons"), default="elements",
                   help="elements: whole objects of a texture file trade places (default; "
                   "images and texton files have no elements and use textons); textons: "
                   "appearance features trade places between textons of one kind")
    p.add_argument("--size-ratio", type=types.number(1, 4), default=None,
                   help="with --by elements: elements trade places only with elements whose "
                   "area is within this factor, 1 to 4 (default 1.1; larger moves more objects, "
                   "each scaled to the place it takes, and shows more seams)")
    common.add_source_option(p, "with --by elements, the elements move")

    p = cmd(sub, "interpolate", cmd_interpolate, "blend two textures", "image",
            f"{img}; with --frames {FRAMES_OUT}")
    p.add_argument("other", type=Path, help="the texture at t = 1")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--t", type=types.number(0, 1), default=0.5,
                   help="blend weight in [0, 1] (default 0.5)")
    g.add_argument("--frames", type=types.integer(2, MAX_COUNT),
                   help=f"a sequence of N frames from t = 0 to 1 (2 to {MAX_COUNT})")
    g.add_argument("--spatial", action="store_true", help="t from 0 (left) to 1 (right); "
                   "with --size H W of another aspect, both textures are first grown to it")
    p.add_argument("--fps", type=FPS, default=8, help="frames per second, 0 < fps <= 1000 "
                   "(default 8)")

    p = cmd(sub, "vary", cmd_vary, "scale appearance / shape variations", "image", img)
    p.add_argument("--appearance", type=types.number(0, 100), default=1.0,
                   help="lambda_f in [0, 100] (default 1)")
    p.add_argument("--shape", type=types.number(0, 100), default=1.0,
                   help="lambda_U in [0, 100] (default 1)")

    p = cmd(sub, "edit", cmd_edit, "move, scale, rotate, delete, duplicate textons", "image",
            img)
    p.add_argument("edits", type=Path, help="JSON edit list")
    p.add_argument("--textons-out", type=Path, help="also write the edited textons")

    p = cmd(sub, "propagate", cmd_propagate, "repeat an edit on similar textons", "image", img)
    p.add_argument("edited", type=Path, help="the image after the user's edit")
    p.add_argument("--threshold", type=types.number(-1, 1), default=0.9,
                   help="feature cosine similarity of targets, in [-1, 1] (default 0.9)")
    p.add_argument("--radius", type=types.number(0, 100, open_lo=True), default=3.0,
                   help="edit kept within this Mahalanobis distance of the texton, in (0, 100] "
                   "(default 3)")

    p = cmd(sub, "animate", cmd_animate, "animate a texture with a flow field", "image",
            FRAMES_OUT)
    p.add_argument("--flow", choices=("shear", "vortex"), default="vortex",
                   help="shear: a perturbed shear flow; vortex (default): a rotating flow")
    p.add_argument("--frames", type=types.integer(1, MAX_COUNT), default=24,
                   help=f"number of frames, 1 to {MAX_COUNT} (default 24)")
    p.add_argument("--fps", type=FPS, default=12,
                   help="frames per second, 0 < fps <= 1000 (default 12)")
    p.add_argument("--duration", type=types.number(0, 1e3, open_lo=True), default=4.0,
                   help="flow time covered, in (0, 1000] (default 4)")
    p.add_argument("--velocity", type=types.number(-100, 100), default=0.5,
                   help="shear speed in [-100, 100] (default 0.5)")
    p.add_argument("--omega", type=types.number(-100, 100), default=2 * math.pi / 4,
                   help="vortex angular speed in [-100, 100] (default 2 pi / 4: one turn in 4)")

    p = cmd(sub, "stylize", cmd_stylize, "a large image in the style of a texture", "image",
            img)
    p.add_argument("texture", type=Path, nargs="+", help="texture(s) giving the appearance")
    p.add_argument("--scale", type=types.number(0.125, 8), default=1.0,
                   help="texton scale in [0.125, 8] (default 1)")
    p.add_argument("--patch", type=types.integer(16, 1024),
                   help="model input size, 16 to 1024 (default: its training size)")
    p.add_argument("--overlap", type=types.number(0, 0.9), default=0.25,
                   help="patch overlap in [0, 0.9] (default 0.25)")
    _mode_and_regions(p)


def _mode_and_regions(p: argparse.ArgumentParser, palette: bool = False) -> None:
    if palette:
        p.add_argument("--mode", choices=("palette", "mean", "replace"), default=None,
                       help="palette: texture files only, the structure's tuned decoder with "
                       "the appearance's texton colours by luminance rank (default for "
                       "texture files); mean: shift feature means (default otherwise); "
                       "replace: draw features")
    else:
        p.add_argument("--mode", choices=("mean", "replace"), default="mean",
                       help="mean: shift feature means (default); replace: draw features")
    p.add_argument("--regions", type=Path,
                   help="colour-coded mask, one colour per appearance (sorted by RGB)")
