"""scripts/eval_cvt_wrap.py (elements at the wrap lines, counted from the SVG) and
scripts/eval_cvt_seam.py (the seam pooled over tiles) on tiny tiles."""

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def _tile(tmp_path, rects) -> Path:
    body = "".join(f'<rect x="{x}" y="{y}" width="{w}" height="{h}" fill="#c33"/>'
                   for x, y, w, h in rects)
    path = tmp_path / "t-full--tileable-1.svg"
    path.write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 100" '
                    f'width="100" height="100">{body}</svg>')
    return path


def test_an_element_across_the_seam_and_its_wrapped_copy_count_once(tmp_path):
    sys.path.insert(0, str(ROOT / "scripts"))
    from eval_cvt_wrap import crossings, tile_elements, wrap_ratio

    # one square across x = 0 drawn on both sides, three squares inside
    path = _tile(tmp_path, [(-5, 40, 10, 10), (95, 40, 10, 10), (30, 20, 10, 10),
                            (60, 70, 10, 10), (45, 5, 10, 10)])
    centres, half, size = tile_elements(path)
    assert len(centres) == 4 and size.tolist() == [100, 100]
    assert [0.0, 45.0] in centres.tolist()
    cross, near, expected = crossings(path)
    (vertical, horizontal), = wrap_ratio(cross[None], np.zeros((1, 2), int))
    # vertical lines: 1 element crosses the wrap band's lines, 4 x 10 / 100 = 0.4 a line
    assert abs(vertical - 1 / 0.4) < 0.05
    assert near == 1  # the square on the seam (centre x = 0); the one at y = 10 is 10 % off
    assert abs(expected - 4 * (1 - 0.88 ** 2)) < 1e-9


def test_a_wrapped_copy_written_with_six_digits_is_still_one_element(tmp_path):
    sys.path.insert(0, str(ROOT / "scripts"))
    from eval_cvt_wrap import crossings, tile_elements, wrap_ratio

    # cvt writes translations with 6 significant digits: a copy one period (1000) away
    # lands 0.004 off its element, across a rounding boundary of 2 decimals
    path = tmp_path / "t-full--tileable-1.svg"
    rect = '<rect x="0" y="0" width="10" height="10" transform="translate({},{})"/>'
    path.write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 1000 1000">'
                    + rect.format(-4.99551, 300) + rect.format(995.009, 300)
                    + rect.format(400, 600) + "</svg>")
    centres, _, _ = tile_elements(path)
    assert len(centres) == 2
    cross, _, _ = crossings(path)
    assert cross[0, 0] == 1  # the wrap line x = 0 is crossed by one element, not two
    # the seamless reference: the wrap line moved to every other line reads the mean
    lines = np.arange(cross.shape[-1])[:, None, None].repeat(2, 2)  # (L, 1, 2)
    assert np.isclose(wrap_ratio(cross[None].astype(float), lines).mean(0), 1).all()


def test_eval_cvt_seam_reads_a_seamless_tile_and_flags_its_plain_twin(tmp_path, capsys,
                                                                      monkeypatch):
    sys.path.insert(0, str(ROOT / "scripts"))
    import eval_cvt_seam

    rng = np.random.default_rng(0)
    for seed in (1, 2):
        body = plain = ""
        for x, y in rng.uniform(0, 100, (25, 2)):
            rect = '<rect x="{:.3f}" y="{:.3f}" width="12" height="12" fill="#c33"/>'
            plain += rect.format(x, y)
            body += "".join(rect.format(x + i, y + j) for i in (-100, 0) for j in (-100, 0))
        for name, content in ((f"t-full--tileable-{seed}.svg", body), (f"t-full-{seed}.svg",
                                                                        plain)):
            (tmp_path / name).write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 '
                                         f'0 100 100">{content}</svg>')
    monkeypatch.setattr(sys, "argv", ["eval_cvt_seam.py", str(tmp_path), "--width", "128",
                                      "--rolls", "50", "--measures", "colour step"])
    eval_cvt_seam.main()
    out = capsys.readouterr().out
    assert "- t: tiles" in out and "pooled over 1 exemplars, 2 tiles" in out
    tiles = float(out.split("- t: tiles ")[1].split()[0])
    plain = float(out.split("plain outputs ")[1].split()[0])
    assert tiles < 1.5 < plain  # the plain tile is cut at its border: a step all along it
