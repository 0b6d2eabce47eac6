"""The cvt command line: a real run, and one-line exit-code-2 errors for bad input."""

import subprocess
import sys
from pathlib import Path

import pytest

from cvt.cli import main

ROOT = Path(__file__).resolve().parents[1]
STARS = ROOT / "cvt" / "exemplars" / "stars.svg"
NS = "xmlns='http://www.w3.org/2000/svg'"
LAUGHS = ("<?xml version='1.0'?><!DOCTYPE lolz [<!ENTITY lol 'lol'>"
          "<!ENTITY lol2 '&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;'>"
          "<!ENTITY lol3 '&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;'>]>"
          f"<svg {NS}><text>&lol3;</text></svg>")


def _cvt(*args, cwd=ROOT):
    return subprocess.run([sys.executable, "-m", "cvt.cli", *map(str, args)], cwd=cwd,
                          capture_output=True, text=True, timeout=120)


@pytest.mark.slow
def test_synthesize_and_inspect_end_to_end(tmp_path):
    out, png = tmp_path / "out.svg", tmp_path / "out.png"
    r = _cvt("synthesize", STARS, "-o", out, "--scale", "1.5", "--levels", "2",
             "--iterations", "2", "--seed", "3", "--preview", png, "--debug-dir",
             tmp_path / "dbg")
    assert r.returncode == 0, r.stderr
    assert "level 2/2" in r.stderr and "energy=" in r.stderr  # tqdm progress
    assert out.read_text().startswith("<?xml") and png.read_bytes()[:4] == b"\x89PNG"
    assert (tmp_path / "dbg" / "energy.png").exists()
    assert (tmp_path / "dbg" / "level1_iter1.png").exists()
    r = _cvt("inspect", STARS, "--png", tmp_path / "s.png")
    assert r.returncode == 0, r.stderr
    assert "30 elements" in r.stdout and "level 2" in r.stdout
    assert (tmp_path / "s.png").exists()


CASES = {
    "malformed": f"<svg {NS}><g></svg",
    "empty": f"<svg {NS} viewBox='0 0 10 10'><g/></svg>",
    "text_image": f"<svg {NS} viewBox='0 0 10 10'><text>x</text><image href='a.png'/></svg>",
    "absurd_viewbox": f"<svg {NS} viewBox='0 0 1e12 1e12'><rect width='1' height='1'/></svg>",
    "billion_laughs": LAUGHS,
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_bad_svg_exits_2_with_one_line(tmp_path, case, capsys):
    path = tmp_path / f"{case}.svg"
    path.write_text(CASES[case])
    out = tmp_path / "out.svg"
    assert main(["synthesize", str(path), "-o", str(out), "--scale", "2", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("cvt: error: ") and err.count("\n") == 1
    assert not out.exists()


@pytest.mark.parametrize("args", [
    ["--scale", "1000"],
    ["--width", "-5", "--height", "10"],
    ["--width", "nan", "--height", "10"],
    ["--width", "100"],
    ["--scale", "2", "--levels", "9"],
    ["--width", "1", "--height", "1"],
])
def test_bad_sizes_exit_2(tmp_path, args, capsys):
    assert main(["synthesize", str(STARS), "-o", str(tmp_path / "o.svg"), *args]) == 2
    assert capsys.readouterr().err.count("\n") == 1


def test_small_outputs_still_work():
    from cvt import load_svg, synthesize

    res = synthesize(load_svg(STARS), (3.0, 3.0))  # below one patch: random init, 1 level on
    assert len(res.placements) >= 1


def test_missing_file_exits_2(tmp_path, capsys):
    assert main(["inspect", str(tmp_path / "nope.svg"), "--no-png"]) == 2
    assert "cannot read" in capsys.readouterr().err


def test_module_entry_point_reports_errors_in_one_line(tmp_path):
    bad = tmp_path / "bad.svg"
    bad.write_text(LAUGHS)
    r = _cvt("synthesize", bad, "-o", tmp_path / "o.svg", "--scale", "2")
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and "DOCTYPE" in r.stderr


def test_method_and_weight_flags(tmp_path, capsys):
    out = tmp_path / "r.svg"
    assert main(["synthesize", str(STARS), "-o", str(out), "--scale", "1.2", "--method",
                 "random", "--quiet"]) == 0
    assert out.read_text().count("<g transform=") > 10
    assert main(["synthesize", str(STARS), "-o", str(out), "--scale", "2", "--w-l", "-1"]) == 2
    assert "--w-l" in capsys.readouterr().err


def test_tileable_lattice_says_its_snapped_size(tmp_path, capsys):
    src = ROOT / "data" / "cvt_real" / "hero_ticTacToe.svg"
    out = tmp_path / "tile.svg"
    assert main(["synthesize", str(src), "-o", str(out), "--scale", "1.7", "--tileable"]) == 0
    err = capsys.readouterr().err
    assert "output size 326.4 x 326.4 snapped to 320 x 320 (whole periods 64 x 64)" in err
    assert 'viewBox="0 0 320 320"' in out.read_text()
