"""cvt synthesize --kind curves / auto and cvt autocomplete: real runs and bad input."""

from pathlib import Path

import pytest

from cvt.cli import main

ROOT = Path(__file__).resolve().parents[1]
WAVES = ROOT / "cvt" / "exemplars" / "curves" / "waves.svg"
CIRCUIT = ROOT / "cvt" / "exemplars" / "curves" / "circuit.svg"
NS = "xmlns='http://www.w3.org/2000/svg'"
FAST = ["--levels", "2", "--iterations", "2"]


def test_synthesize_curves_auto_with_preview(tmp_path, capsys):
    out, png = tmp_path / "o.svg", tmp_path / "o.png"
    assert main(["synthesize", str(WAVES), "-o", str(out), "--scale", "1.2", *FAST,
                 "--preview", str(png)]) == 0
    assert "curves" in capsys.readouterr().out
    text = out.read_text()
    assert text.count("<path") >= 5 and 'fill="none"' in text and " C" in text
    assert png.read_bytes()[:4] == b"\x89PNG"


def test_curves_and_elements_coexist(tmp_path):
    out = tmp_path / "c.svg"
    assert main(["synthesize", str(CIRCUIT), "-o", str(out), "--scale", "1", *FAST]) == 0
    text = out.read_text()
    assert "<circle" in text and "<path" in text  # pads (elements) beside traces (curves)


def test_kind_elements_keeps_the_element_synthesis(tmp_path, capsys):
    out = tmp_path / "e.svg"
    assert main(["synthesize", str(WAVES), "-o", str(out), "--scale", "1", "--kind",
                 "elements", *FAST, "--quiet"]) == 0
    assert "elements" in capsys.readouterr().out


def test_domain_svg(tmp_path):
    dom = tmp_path / "d.svg"
    dom.write_text(f"<svg {NS} viewBox='0 0 200 200'><circle cx='100' cy='100' r='60'/></svg>")
    out = tmp_path / "o.svg"
    assert main(["synthesize", str(WAVES), "-o", str(out), "--scale", "1", "--domain",
                 str(dom), *FAST]) == 0
    nums = [float(v) for d in out.read_text().split(' d="')[1:] for v in
            d.split('"')[0].translate(str.maketrans("MCZ,", "    ")).split()]
    xs, ys = nums[0::2], nums[1::2]
    assert min(xs) > 30 and max(xs) < 170 and min(ys) > 30 and max(ys) < 170


def test_domain_shape_covering_most_of_the_canvas(tmp_path):
    # the SVG parser splits such a shape off as background; it is still the domain
    dom = tmp_path / "d.svg"
    dom.write_text(f"<svg {NS} viewBox='0 0 200 200'><circle cx='100' cy='100' r='96'/></svg>")
    out = tmp_path / "o.svg"
    assert main(["synthesize", str(WAVES), "-o", str(out), "--scale", "1", "--domain",
                 str(dom), *FAST]) == 0
    nums = [float(v) for d in out.read_text().split(' d="')[1:] for v in
            d.split('"')[0].translate(str.maketrans("MCZ,", "    ")).split()]
    xy = zip(nums[0::2], nums[1::2], strict=True)
    r = [((x - 100) ** 2 + (y - 100) ** 2) ** 0.5 for x, y in xy]
    assert max(r) < 100 and len(r) > 20


def test_autocomplete(tmp_path, capsys):
    part = tmp_path / "p.svg"
    part.write_text(f"<svg {NS} viewBox='0 0 200 200'><path d='M0 40 C 50 30, 80 50, 120 40' "
                    "fill='none' stroke='#1d3557' stroke-width='2'/></svg>")
    out, png = tmp_path / "a.svg", tmp_path / "a.png"
    assert main(["autocomplete", str(part), "--exemplar", str(WAVES), "-o", str(out),
                 "--preview", str(png), "--iterations", "3"]) == 0
    assert "predicted samples" in capsys.readouterr().out
    assert "viewBox=\"0 0 200 200\"" in out.read_text() and png.exists()
    only = tmp_path / "n.svg"
    assert main(["autocomplete", str(part), "--exemplar", str(WAVES), "-o", str(only),
                 "--only-new", "--region", "0", "0", "200", "120", "--iterations", "2"]) == 0
    assert only.read_text().count("<path") >= 1


@pytest.mark.parametrize("body, msg", [
    ("<path d='M5 5 L5 5' stroke='black' fill='none'/>", "no strokes"),
    ("<path d='M5 5' stroke='black' fill='none'/>", "no"),
    ("<path d='M5 5 L50 50' stroke='none' fill='none'/>", "no drawable"),
    ("<circle cx='5' cy='5' r='3'/>", "no strokes"),
])
def test_bad_curve_input_exit_2(tmp_path, capsys, body, msg):
    bad = tmp_path / "bad.svg"
    bad.write_text(f"<svg {NS} viewBox='0 0 100 100'>{body}</svg>")
    out = tmp_path / "o.svg"
    assert main(["synthesize", str(bad), "-o", str(out), "--scale", "1", "--kind", "curves"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("cvt: error:") and msg in err and err.count("\n") == 1
    assert not out.exists()
    assert main(["autocomplete", str(bad), "--exemplar", str(WAVES), "-o", str(out)]) == 2
    assert not out.exists()


def test_bad_options_exit_2(tmp_path, capsys):
    out = tmp_path / "o.svg"
    for args in (["synthesize", str(WAVES), "-o", str(out), "--scale", "1", "--method",
                  "spectral"],
                 ["synthesize", str(WAVES), "-o", str(out), "--scale", "1", "--domain",
                  str(WAVES)],
                 ["synthesize", str(WAVES), "-o", str(out), "--scale", "19"],
                 ["synthesize", str(WAVES), "-o", str(out), "--scale", "1", "--w-l", "2"],
                 ["autocomplete", str(WAVES), "--exemplar", str(WAVES), "-o", str(out),
                  "--margin", "-1"],
                 ["autocomplete", str(WAVES), "--exemplar", str(tmp_path / "none.svg"), "-o",
                  str(out)]):
        assert main(args) == 2, args
        assert capsys.readouterr().err.startswith("cvt: error:")
    assert not out.exists()
