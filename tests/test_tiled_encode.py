"""neuraltex.tiled_encode: textons of a picture from E_s run on zoomed, overlapping tiles."""

from pathlib import Path

import numpy as np
import pytest
import torch
from skimage.measure import label

from neuraltex.model import build_model
from neuraltex.model_config import ModelConfig
from neuraltex.tiled_encode import encode_image, encode_tiled, mask_labels, segment_count

NATIVE, EST = 64, 32  # the model's training size and estimation size: 2 px per mask pixel
SIDE, SQUARE = 128, 20  # the picture and its squares


def _picture() -> tuple[torch.Tensor, list[tuple[float, float]]]:
    """(1, 3, SIDE, SIDE) squares of distinct colours on black, several cut by tile borders,
    and their centres (x, y) in canvas units (short side 1)."""
    rng = np.random.default_rng(0)
    x = torch.zeros(1, 3, SIDE, SIDE)
    centres = []
    for top in (6, 54, 100):
        for left in (8, 52, 98):
            x[0, :, top:top + SQUARE, left:left + SQUARE] = torch.tensor(
                rng.random(3) * 0.6 + 0.4, dtype=torch.float32)[:, None, None]
            centres.append(((left + SQUARE / 2) / SIDE, (top + SQUARE / 2) / SIDE))
    return x, centres


class Oracle:
    """E_s that knows the answer: the black ground is one segment, each square (a connected
    non-black region of the input, sampled at the mask resolution) another; with ``split``
    each square comes in two halves (left, right of its middle column), as E_s cuts large
    elements seen zoomed in; regions beyond the n queries are lumped into the last. Returns
    softmax-like masks (T, n, s / 2, s / 2)."""

    def __init__(self, n: int):
        self.n, self.split = n, False

    def __call__(self, image: torch.Tensor) -> torch.Tensor:
        masks = []
        for tile in image:
            small = tile[:, ::2, ::2].sum(0).numpy() > 0.1  # (s/2, s/2) at the mask resolution
            parts = label(small, connectivity=1)
            if self.split:
                for k in range(1, parts.max() + 1):
                    cols = np.nonzero((parts == k).any(0))[0]
                    right = (parts == k) & (np.arange(small.shape[1]) > cols.mean())
                    parts[right] = parts.max() + 1
            parts = np.minimum(parts, self.n - 1)  # more regions than queries: lumped
            onehot = np.eye(self.n, dtype=np.float32)[parts]  # (s/2, s/2, n); 0 = the ground
            masks.append(torch.from_numpy(onehot).permute(2, 0, 1) * 0.99 + 0.01 / self.n)
        return torch.stack(masks)


@pytest.fixture(scope="module")
def model():
    torch.manual_seed(0)
    config = ModelConfig(preset="tiny", num_queries=24, image_size=NATIVE, estimation_size=EST)
    m = build_model(config).eval()
    m.segment = Oracle(config.num_queries)
    return m


def _found(enc) -> tuple[int, np.ndarray]:
    """(existing textons, their centres (k, 2) in canvas units)."""
    exists = enc.textons.delta[0] > 0.5
    return int(exists.sum()), enc.textons.mu[0, exists].numpy()


@torch.no_grad()
def test_one_texton_per_square_with_split_pieces_joined(model):
    """Tiles cut squares and E_s halves them; the textons still hold one texton per square
    at its centre (+ the ground), because the whole-picture run holds both halves in one
    segment and no edge runs between them."""
    x, centres = _picture()
    whole = model.encode(x)  # the squares whole, 10 px at the training size
    assert segment_count(whole) == 1 + len(centres)
    model.segment.split = True
    try:
        enc = encode_tiled(model, x, whole=whole)
        unvouched = encode_tiled(model, x, whole=model.encode(x))  # the coarse run split too
    finally:
        model.segment.split = False
    count, mu = _found(enc)
    assert count == 1 + len(centres)
    for c in centres:  # a texton within a pixel of each square's centre
        assert np.linalg.norm(mu - np.array(c), axis=1).min() < 1.5 / SIDE
    assert enc.textons.delta[0, 0] == 0 and enc.textons.p[0, 0] == 0  # "no segment" texton
    assert enc.textons.canvas == (1.0, 1.0)
    assert enc.masks.shape == (1, enc.textons.num_textons, 2 * EST, 2 * EST)  # zoom 2
    assert _found(unvouched)[0] == 1 + 2 * len(centres)  # nothing vouched: halves stay
    image = model.decode(enc.textons, (SIDE, SIDE))
    assert image.shape == (1, 3, SIDE, SIDE) and torch.isfinite(image).all()


@torch.no_grad()
def test_tiles_exceed_the_query_count_and_keep_the_canvas(model):
    """A picture with more squares than E_s has queries: the whole run keeps 24 segments at
    most, the tiles find every square. A 2:1 picture keeps its canvas."""
    x = torch.zeros(1, 3, SIDE, 2 * SIDE)
    for top in range(4, SIDE - 8, 16):
        for left in range(4, 2 * SIDE - 8, 16):
            x[0, :, top:top + 8, left:left + 8] = 0.8
    squares = label(x[0, 0].numpy() > 0).max()
    assert squares > 40
    whole = model.encode(x)
    assert segment_count(whole) <= 24
    enc = encode_tiled(model, x, whole=whole)
    assert _found(enc)[0] == 1 + squares  # each its own texton, and the ground
    assert enc.textons.canvas == (2.0, 1.0)
    labels = mask_labels(enc, (SIDE, 2 * SIDE)).numpy()
    truth = label(x[0, 0].numpy() > 0)
    ground = np.bincount(labels[truth == 0]).argmax()
    mains = set()  # each square mostly one segment of its own (edge pixels may be ground)
    for k in range(1, squares + 1):
        values, counts = np.unique(labels[truth == k], return_counts=True)
        assert counts.max() > 0.5 * counts.sum() and values[counts.argmax()] != ground
        mains.add(values[counts.argmax()])
    assert len(mains) == squares


@torch.no_grad()
def test_encode_image_tiles_dense_pictures_only(model):
    x, _ = _picture()
    count = segment_count(model.encode(x))
    off = encode_image(model, x, "off")
    assert off.masks.shape[1] == 24  # E_s's queries: the whole-picture encoding
    sparse = encode_image(model, x, "auto", dense_from=count + 1)
    assert torch.equal(sparse.textons.mu, off.textons.mu)
    dense = encode_image(model, x, "auto", dense_from=count)
    on = encode_image(model, x, "on")
    assert dense.masks.shape[1] == on.masks.shape[1] == 1 + count  # "no segment" + segments
    assert torch.equal(dense.textons.mu, on.textons.mu)
    with pytest.raises(ValueError, match="tile must be"):
        encode_image(model, x, "sometimes")
    with pytest.raises(ValueError, match="one image"):
        encode_tiled(model, x.expand(2, -1, -1, -1))


def test_shipped_model_finds_the_bricks_of_a_photograph_from_tiles():
    """The real case tiles are for (MODEL.md, "Patch-wise encoding"): on a photograph of 71
    bricks the whole-picture run gives a brick its own texton for 10 % of them; encoded as
    the commands do by default, more than 70 %."""
    import sys

    root = Path(__file__).resolve().parents[1]
    sys.path.insert(0, str(root / "scripts"))
    import probe_bricks

    from neuraltex.baselines import get_segmenter
    from neuraltex.imageio import load_image

    photo = load_image(root / "data" / "real_textures" / "brick.png").permute(1, 2, 0).numpy()
    bricks, ids = probe_bricks.photo_bricks(photo.mean(2))
    assert len(ids) == 71
    whole = probe_bricks.own_segments(get_segmenter("model")(photo), bricks, ids)
    tiled = probe_bricks.own_segments(get_segmenter("model", tile="auto")(photo), bricks, ids)
    assert whole < 0.2 * len(ids) and tiled > 0.7 * len(ids)


def test_cli_tile_option_encodes_a_dense_photograph_from_tiles(tmp_path, capsys):
    """``neuraltex encode --tile``: the brick photograph whole gives at most E_s's 100
    textons; from tiles (on, and auto: it is dense) more than that, all in one canvas."""
    from neuraltex.cli import main
    from neuraltex.textons_file import load_textons

    photo = Path(__file__).resolve().parents[1] / "data" / "real_textures" / "brick.png"
    effective = {}
    for tile in ("off", "on", "auto"):
        out = tmp_path / f"{tile}.json"
        assert main(["encode", str(photo), "-o", str(out), "--tile", tile]) == 0
        t = load_textons(out)
        effective[tile] = int(t.num_effective()[0])
        assert t.canvas == (1.0, 1.0)
    assert effective["off"] <= 100 < effective["on"] == effective["auto"]
    assert main(["encode", str(photo), "-o", str(tmp_path / "x.json"), "--tile", "maybe"]) == 2
    assert "--tile" in capsys.readouterr().err


def test_bench_script_times_both_encodings(capsys):
    """scripts/bench_tiled_encode.py on one real texture: a row per encoding, the whole run
    tiles no picture, --tile on tiles it and finds more textons."""
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
    import bench_tiled_encode

    assert bench_tiled_encode.main(["--limit", "1", "--sizes", "128", "--repeats", "1"]) == 0
    rows = [line.split("|") for line in capsys.readouterr().out.splitlines()
            if line.startswith("| 128 |")]
    by = {r[2].strip(): r for r in rows}
    assert set(by) == {"whole", "tile on", "tile auto"}
    assert by["whole"][6].strip() == "0 / 1" and by["tile on"][6].strip() == "1 / 1"
    assert int(by["tile on"][4]) > int(by["whole"][4])


@pytest.mark.slow
def test_tiled_pictures_script_draws_both_rows(tmp_path):
    """scripts/tiled_pictures.py on a small crop of the brick photograph, a short synthesis:
    a picture of two rows (whole, patch-wise), each the photograph, its overlay and the
    synthesis."""
    import sys

    from PIL import Image

    root = Path(__file__).resolve().parents[1]
    sys.path.insert(0, str(root / "scripts"))
    import tiled_pictures

    crop = tmp_path / "crop.png"
    Image.open(root / "data" / "real_textures" / "brick.png").crop((0, 0, 96, 96)).save(crop)
    out = tmp_path / "pic.png"
    assert tiled_pictures.main(["--image", str(crop), "-o", str(out), "--scale", "1.5",
                                "--levels", "1", "--iterations", "1"]) == 0
    pic = Image.open(out)
    assert pic.height == 2 * (96 + 16 + 4) and pic.width >= 3 * 96


def test_at_most_keeps_the_largest_segments_and_fills_the_rest(model, monkeypatch):
    """Textons are capped (noise gives thousands of segments): the largest kept, the pixels of
    the others to the nearest kept segment, "no segment" left alone."""
    import neuraltex.tiled_encode as te

    labels = np.array([[1, 1, 2, 0], [1, 1, 3, 3], [4, 4, 3, 3]])
    capped = te._at_most(labels, 2)
    assert set(np.unique(capped)) == {0, 1, 2} and capped[0, 3] == 0
    assert capped[2, 0] == capped[0, 0]  # segment 4 went to its neighbour 1
    assert np.array_equal(te._at_most(labels, 4), labels)
    x = torch.zeros(1, 3, SIDE, 2 * SIDE)
    x[..., 4:SIDE - 8:16, :] = 0.8  # stripes: one segment each
    monkeypatch.setattr(te, "MOST", 3)
    with torch.no_grad():
        enc = te.encode_tiled(model, x)
    assert _found(enc)[0] == 3 and enc.masks.shape[1] <= 4
