"""scripts/eval_cvt_wrap.py: elements at the wrap lines of a tile, counted from its SVG."""

import sys
from pathlib import Path

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
    from eval_cvt_wrap import tile_elements, wrap_counts

    # one square across x = 0 drawn on both sides, three squares inside
    path = _tile(tmp_path, [(-5, 40, 10, 10), (95, 40, 10, 10), (30, 20, 10, 10),
                            (60, 70, 10, 10), (45, 5, 10, 10)])
    centres, half, size = tile_elements(path)
    assert len(centres) == 4 and size.tolist() == [100, 100]
    assert [0.0, 45.0] in centres.tolist()
    (vertical, horizontal), near, expected = wrap_counts(path)
    # vertical lines: 1 element crosses the wrap band's lines, 4 x 10 / 100 = 0.4 a line
    assert abs(vertical - 1 / 0.4) < 0.05
    assert near == 1  # the square on the seam (centre x = 0); the one at y = 10 is 10 % off
    assert abs(expected - 4 * (1 - 0.88 ** 2)) < 1e-9
