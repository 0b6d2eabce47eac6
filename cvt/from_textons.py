"""Raster texture -> vector exemplar for the synthesis: the bridge from textons to cvt.

The image is vectorized (:mod:`neuraltex.vectorize`: one element per texton or segment), then
parsed back with :func:`cvt.svg.parse_svg` like any exemplar. The background group becomes a
backdrop instead of an element (a rectangle as large as the exemplar cannot be rearranged), and
the elements' ``data-kind`` labels become appearance attributes A(s) (seed 000 sec. 4.2): a
one-hot kind per element, so the neighborhood distance prefers matching samples of the same kind.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, replace

import numpy as np

from cvt.svg import SVG_NS, Exemplar, parse_svg


@dataclass
class ImageExemplar:
    exemplar: Exemplar  # texton elements only, with .appearance (one-hot kinds)
    backdrop: str  # fill colour of the background layer ("#rrggbb")
    svg: str  # the vectorized image (background included)
    # (2, 2) rows a, b: the picture's lattice in SVG units (neuraltex.raster_lattice), or None
    lattice: np.ndarray | None = None


def vectorize_image(image_path, segmenter: str = "model", checkpoint=None, source: str = "masks",
                    max_side: int = 256, kinds: int = 4, device: str = "cpu",
                    tile: str = "auto") -> str:
    """SVG text of a raster image, or of a texture file (.ntex: its fitted segments coloured by
    its tuned reconstruction; ``checkpoint`` is then its base model) (``neuraltex vectorize``
    as a function)."""
    return vectorize_picture(image_path, segmenter, checkpoint, source, max_side, kinds,
                             device, tile)[0]


def vectorize_picture(image_path, segmenter: str = "model", checkpoint=None,
                      source: str = "masks", max_side: int = 256, kinds: int = 4,
                      device: str = "cpu", tile: str = "auto") -> tuple[str, np.ndarray]:
    """(:func:`vectorize_image`'s SVG, the picture it vectorized (H, W, 3) in [0, 1], one
    pixel per SVG user unit). ``tile``: how the model encodes the picture
    (:func:`neuraltex.tiled_encode.encode_image`)."""
    from pathlib import Path

    from neuraltex.imageio import load_image
    from neuraltex.segments import drop_background, from_texture, segment_image
    from neuraltex.vectorize import VectorizeParams, to_svg, vectorize

    model = None
    texture_file = Path(image_path).suffix.lower() == ".ntex"
    if segmenter == "model" or texture_file:
        from neuraltex.model import DEFAULT_MODEL, load_model

        model = load_model(checkpoint or DEFAULT_MODEL, device=device)
    if texture_file:
        from neuraltex.texture_file import load_texture

        image, seg = from_texture(load_texture(image_path, model), model)
        seg = drop_background(seg)
    else:
        image = load_image(image_path, max_side=max_side).to(device)
        seg, _ = segment_image(image, segmenter, model, source, tile=tile)
    params = VectorizeParams(kinds=kinds)
    picture = image.permute(1, 2, 0).cpu().numpy()
    return to_svg(vectorize(picture, seg, params), seg, params.seam), picture


def image_exemplar(svg: str) -> ImageExemplar:
    """Split a vectorized image into the synthesis exemplar and its backdrop colour."""
    from neuraltex.errors import InputError

    full = parse_svg(svg.encode())
    backdrop = "#ffffff"
    keep = []
    for e in full.background + full.elements:  # parse_svg splits canvas-covering layers off
        if e.node.get("data-background") == "1":
            fills = [n.get("fill") for n in e.node.iter() if n.get("fill")]
            backdrop = fills[0] if fills else backdrop
        else:
            keep.append(e)
    if not keep:
        raise InputError("the image gave no elements to synthesize (one flat segment?)")
    keep = [replace(e, index=i) for i, e in enumerate(keep)]
    kinds = [e.node.get("data-kind", "k0") for e in keep]
    names = sorted(set(kinds))
    onehot = np.eye(len(names))[[names.index(k) for k in kinds]]  # (E, kinds)
    return ImageExemplar(replace(full, elements=keep, appearance=onehot, background=[]),
                         backdrop, svg)


def with_backdrop(svg: str, colour: str) -> str:
    """Insert a rectangle covering the viewBox, in ``colour``, under everything else."""
    root = ET.fromstring(re.sub(r"^<\?xml[^>]*\?>\s*", "", svg))
    x, y, w, h = (float(v) for v in root.get("viewBox").split())
    rect = ET.Element(f"{{{SVG_NS}}}rect", {"x": f"{x:g}", "y": f"{y:g}", "width": f"{w:g}",
                                             "height": f"{h:g}", "fill": colour})
    rect.tail = "\n"
    first = 1 if len(root) and root[0].tag == f"{{{SVG_NS}}}defs" else 0
    root.insert(first, rect)
    ET.register_namespace("", SVG_NS)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"

