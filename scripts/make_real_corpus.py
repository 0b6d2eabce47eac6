"""Regenerate the real-world cvt corpus (data/cvt_real/*.svg; sources in its SOURCES.md).

The SVG motifs are third-party art from three published packages; the layouts follow how they
are used. Fetch the packages first (development time only, nothing is downloaded at run time):

    mkdir -p /tmp/cvt_src && cd /tmp/cvt_src
    npm pack hero-patterns@2.1.0 @iconify-json/twemoji@1.2.5
    apt-get download inkscape && dpkg -x inkscape_*.deb ink
    for f in *.tgz; do mkdir -p ${f%.tgz}; tar xzf $f -C ${f%.tgz}; done
    node -e '<see HERO_EXPORT below>'      # writes hero/<name>.svg, one tile each
    python scripts/make_real_corpus.py --src /tmp/cvt_src

* web backgrounds (Hero Patterns, Steve Schoger, CC BY 4.0, via the npm package hero-patterns,
  MIT): the tile as a browser repeats it, 3 x 3 tiles as one compound path over a
  ``<rect>`` in the page's background colour (near-periodic lattices with a background);
* stock patterns (Inkscape 1.2 ``share/inkscape/paint/patterns.svg``, GPL-2+, via Debian):
  the pattern's tile contents repeated 3 x 3, some in an Inkscape layer over a ground layer;
* irregular layouts of grouped emoji (Twemoji, CC BY 4.0, via @iconify-json/twemoji): each
  emoji a ``<g>`` of several paths; no irregular emoji pattern is published, so these layouts
  are made here (dart throwing, fixed seeds): pairs sit on each other (a butterfly on a heart,
  a ladybug on a shamrock, leaves around a flower) over a background rectangle.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import svgelements as se

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "data" / "cvt_real"
SVG = "http://www.w3.org/2000/svg"
HERO_EXPORT = ("const h=require('./hero-patterns-2.1.0/package/dist/hero-patterns.cjs.js');"
               "const fs=require('fs');fs.mkdirSync('hero',{recursive:true});"
               "for(const[k,f]of Object.entries(h)){if(typeof f!=='function')continue;"
               "let s=f('#9C92AC',1);s=decodeURIComponent(s.slice(s.indexOf(',')+1,"
               "s.lastIndexOf(\"'\")));fs.writeFileSync('hero/'+k+'.svg',s);}")
HERO = {  # name: (page background colour, motif colour)
    "polkaDots": ("#dfdbe5", "#9c92ac"), "ticTacToe": ("#f4e9d8", "#b8860b"),
    "plus": ("#ffffff", "#6b8e23"), "xEquals": ("#1e2a38", "#8fb8de"),
    "bubbles": ("#e8f4fa", "#3a7ca5"), "iLikeFood": ("#fff5e6", "#c0392b"),
    "happyIntersection": ("#2b2d42", "#edf2f4"), "fourPointStars": ("#102040", "#ffd166"),
    "signal": ("#f0f0f0", "#555555"), "randomShapes": ("#fdf6e3", "#268bd2"),
    "lips": ("#ffe4ec", "#c2185b"), "glamorous": ("#eef7ee", "#2e7d32"),
    "deathStar": ("#1a1a1a", "#bdbdbd"), "overlappingCircles": ("#e0f2f1", "#00897b"),
}
INKSCAPE = ("Polkadots-small", "Polkadots-med", "Polkadots-large", "Packedcircles",
            "Checkerboard", "Camouflage")
LAYOUTS = {  # name: (background, [(emoji, companions [(emoji, dx, dy, scale)])], count, size)
    "butterflies_on_hearts": ("#fff8f0", [("red-heart", [("butterfly", 0.25, -0.3, 0.6)])], 22),
    "ladybugs_on_shamrocks": ("#f1f8e9", [("shamrock", [("lady-beetle", 0.2, -0.2, 0.45)])], 24),
    "flowers_with_leaves": ("#fffde7", [("hibiscus", [("leaf-fluttering-in-wind", -0.55, 0.4,
                                                       0.6), ("herb", 0.55, 0.45, 0.55)])], 14),
    "school_of_fish": ("#e3f2fd", [("tropical-fish", []), ("fish", [])], 40),
    "bees_and_blossoms": ("#fffaf0", [("blossom", [("honeybee", 0.3, -0.35, 0.5)]),
                                      ("tulip", [])], 20),
    "autumn_leaves": ("#fbe9e7", [("maple-leaf", []), ("fallen-leaf", []),
                                  ("mushroom", [("herb", -0.45, 0.25, 0.5)])], 28),
    "fruit_picnic": ("#fff3e0", [("cherries", []), ("strawberry", [("leaf-fluttering-in-wind",
                                                                     0.35, -0.4, 0.45)])], 24),
    "starry_night": ("#0d1b2a", [("glowing-star", []), ("star", []), ("snowflake", [])], 36),
}


def _write(name: str, root: ET.Element) -> None:
    ET.register_namespace("", SVG)
    ET.register_namespace("inkscape", "http://www.inkscape.org/namespaces/inkscape")
    text = '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode")
    (OUT / f"{name}.svg").write_text(text + "\n")


def _svg(w: float, h: float) -> ET.Element:
    return ET.Element(f"{{{SVG}}}svg", {"width": f"{w:g}", "height": f"{h:g}",
                                       "viewBox": f"0 0 {w:g} {h:g}"})


def _rect(parent, w, h, fill) -> None:
    ET.SubElement(parent, f"{{{SVG}}}rect", {"width": f"{w:g}", "height": f"{h:g}", "fill": fill})


def hero(src: Path, name: str, colours) -> None:
    tile = ET.parse(src / "hero" / f"{name}.svg").getroot()
    tw, th = (float(v) for v in tile.get("viewBox").split()[2:])
    root = _svg(3 * tw, 3 * th)
    _rect(root, 3 * tw, 3 * th, colours[0])
    for node in tile.iter():
        tag = node.tag.rsplit("}", 1)[-1]
        if tag not in ("path", "circle", "rect", "polygon"):
            continue
        attrs = {k: v for k, v in node.attrib.items() if k in ("fill-rule",)}
        attrs["fill"] = colours[1]
        geom = se.Path(_as_path(node))
        ds = [(geom * se.Matrix(f"translate({i * tw},{j * th})")).d(relative=False)
              for i in range(3) for j in range(3)]
        ET.SubElement(root, f"{{{SVG}}}path", {**attrs, "d": " ".join(ds)})
    _write(f"hero_{name}", root)


def _as_path(node: ET.Element) -> se.Path:
    tag = node.tag.rsplit("}", 1)[-1]
    a = node.attrib
    if tag == "path":
        return se.Path(a["d"])
    if tag == "circle":
        return se.Path(se.Circle(float(a.get("cx", 0)), float(a.get("cy", 0)), float(a["r"])))
    if tag == "rect":
        return se.Path(se.Rect(float(a.get("x", 0)), float(a.get("y", 0)), float(a["width"]),
                               float(a["height"])))
    return se.Path(se.Polygon(a["points"]))


def inkscape(src: Path, pid: str, k: int) -> None:
    doc = ET.parse(src / "ink/usr/share/inkscape/paint/patterns.svg").getroot()
    pat = next(p for p in doc.iter(f"{{{SVG}}}pattern") if p.get("id") == pid)
    m = re.search(r"scale\(([\d.]+)", pat.get("patternTransform", "")) or None
    s = float(m.group(1)) if m else 1.0
    tw, th = float(pat.get("width")) * s, float(pat.get("height")) * s
    reps = 3 if tw * th > 400 else 5
    root = _svg(reps * tw, reps * th)
    ground = ET.SubElement(root, f"{{{SVG}}}g", {
        "{http://www.inkscape.org/namespaces/inkscape}groupmode": "layer",
        "{http://www.inkscape.org/namespaces/inkscape}label": "ground"})
    _rect(ground, reps * tw, reps * th, ("#f3efe0", "#dde7f0", "#e8e0f0")[k % 3])
    layer = ET.SubElement(root, f"{{{SVG}}}g", {
        "{http://www.inkscape.org/namespaces/inkscape}groupmode": "layer",
        "{http://www.inkscape.org/namespaces/inkscape}label": "pattern"})
    seen = set()  # a motif crossing the tile edge sits in both tiles: the browser clips each
    for i in range(reps):  # tile, flattened tiles would stack the two copies, so keep one
        for j in range(reps):
            for child in pat:
                key = _spot(child, i * tw / s, j * th / s)
                if key is not None and key in seen:
                    continue
                seen.add(key)
                g = ET.SubElement(layer, f"{{{SVG}}}g", {
                    "transform": f"translate({i * tw:g},{j * th:g}) scale({s:g})"})
                g.append(child)
    _write(f"inkscape_{pid.replace('-', '_').lower()}", root)


def _spot(child: ET.Element, dx: float, dy: float) -> tuple | None:
    """Where a circle or rectangle of a pattern tile lands (tile units), for deduplication."""
    tag, a = child.tag.rsplit("}", 1)[-1], child.attrib
    if tag == "circle":
        return ("c", round(float(a.get("cx", 0)) + dx, 3), round(float(a.get("cy", 0)) + dy, 3),
                a.get("r"), a.get("style"), a.get("fill"))
    if tag == "rect":
        return ("r", round(float(a.get("x", 0)) + dx, 3), round(float(a.get("y", 0)) + dy, 3),
                a.get("width"), a.get("height"), a.get("style"), a.get("fill"))
    return None


def emoji_layout(src: Path, name: str, spec, seed: int) -> None:
    icons = json.loads((src / "iconify-json-twemoji-1.2.5/package/icons.json").read_text())
    icons = icons["icons"]
    bg, motifs, count = spec
    rng = np.random.default_rng(seed)
    w = h = 600.0
    size = 64.0
    root = _svg(w, h)
    _rect(root, w, h, bg)
    centres: list[np.ndarray] = []
    for _ in range(count * 200):
        if len(centres) == count:
            break
        c = rng.uniform(-0.2 * size, [w + 0.2 * size, h + 0.2 * size])
        if centres and np.linalg.norm(np.stack(centres) - c, axis=1).min() < 1.45 * size:
            continue
        centres.append(c)
    for k, c in enumerate(centres):
        main, companions = motifs[k % len(motifs)]
        _emoji(root, icons[main]["body"], c, size)
        for other, dx, dy, sc in companions:
            _emoji(root, icons[other]["body"], c + np.array([dx, dy]) * size, size * sc)
    _write(f"emoji_{name}", root)


def _emoji(parent, body: str, centre, size: float) -> None:
    s = size / 36
    g = ET.fromstring(f'<g xmlns="{SVG}">{body}</g>')
    g.set("transform", f"translate({centre[0] - size / 2:.2f},{centre[1] - size / 2:.2f}) "
                       f"scale({s:.4g})")
    parent.append(g)




def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--src", required=True, type=Path, help="folder with the unpacked packages")
    args = ap.parse_args()
    OUT.mkdir(parents=True, exist_ok=True)
    for name, colours in HERO.items():
        hero(args.src, name, colours)
    for k, pid in enumerate(INKSCAPE):
        inkscape(args.src, pid, k)
    for k, (name, spec) in enumerate(LAYOUTS.items()):
        emoji_layout(args.src, name, spec, seed=k + 1)
    print(f"wrote {len(list(OUT.glob('*.svg')))} SVGs to {OUT}", file=sys.stderr)


if __name__ == "__main__":
    main()
