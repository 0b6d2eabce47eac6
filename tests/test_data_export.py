import json

import numpy as np
from PIL import Image

from neuraltex.data.__main__ import main
from neuraltex.data.export import contact_sheet, overlay, read_mask
from neuraltex.data.generator import generate


def test_export_cli(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["--out", str(out), "--n", "3", "--size", "32", "--families", "dots,scales",
                 "--sheet", "2", "--columns", "2"]) == 0
    rows = [json.loads(line) for line in (out / "meta.jsonl").read_text().splitlines()]
    assert [r["family"] for r in rows] == ["dots", "scales", "dots"]
    s = generate(1, 0, 32, family="scales")
    np.testing.assert_array_equal(read_mask(out / "masks" / "000001.png"), s.mask)
    image = np.asarray(Image.open(out / "images" / "000001.png"))
    assert image.shape == (32, 32, 3)
    assert np.abs(image / 255.0 - s.image).max() <= 0.5 / 255 + 1e-6
    assert rows[1]["count"] == s.count and len(rows[1]["centers"]) == s.count
    assert Image.open(out / "contact_sheet.png").size[0] > 2 * 2 * 32
    assert "wrote 3 samples" in capsys.readouterr().out


def test_export_cli_bad_input(tmp_path, capsys):
    assert main(["--out", str(tmp_path), "--n", "0"]) == 2
    assert main(["--out", str(tmp_path), "--families", "nope"]) == 2
    assert main(["--out", str(tmp_path), "--seed", "1000001"]) == 2
    err = capsys.readouterr().err
    assert err.count("error:") == 3 and "Traceback" not in err


def test_overlay_tints_textons_outlines_them_and_keeps_the_background():
    image = np.full((12, 12, 3), 0.5, np.float32)
    mask = np.zeros((12, 12), np.int32)
    mask[4:9, 4:9] = 1  # one texton, a 5 x 5 square
    o = overlay(image, mask)
    assert o.shape == image.shape
    assert np.array_equal(o[0, 0], image[0, 0]) and np.array_equal(o[11, 11], image[11, 11])
    assert not np.allclose(o[6, 6], image[6, 6])  # inside the texton: tinted
    assert np.allclose(o[4, 6], 1.0) and np.allclose(o[6, 4], 1.0)  # its boundary: white
    s = generate(0, 0, 32, family="discs")
    assert contact_sheet([s, s, s], columns=2).size[1] > 2 * 32
