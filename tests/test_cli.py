"""The neuraltex and cvt entry points as subprocesses (one test per entry point), and the
texton-file commands in-process."""

import importlib
import subprocess
import sys

import pytest

from neuraltex import __version__
from neuraltex.cli import main
from neuraltex.textons_file import load_textons, save_textons


def run(*args: str, module: str = "neuraltex.cli") -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", module, *args], capture_output=True, text=True)


@pytest.mark.parametrize("module, prog", [("neuraltex.cli", "neuraltex"), ("cvt.cli", "cvt")])
def test_version_and_help(module, prog, capsys):
    out = run("--version", module=module)  # the entry point itself, as a user starts it
    assert out.returncode == 0 and out.stdout.splitlines()[0] == f"{prog} {__version__}"
    if prog == "neuraltex":  # also names the default model (or says none is shipped)
        assert out.stdout.splitlines()[1].startswith("default model: ")
    with pytest.raises(SystemExit) as exit_:
        importlib.import_module(module).main(["--help"])
    assert exit_.value.code == 0 and f"usage: {prog}" in capsys.readouterr().out


def test_textons_summary_and_conversion(tmp_path, textons, capsys):
    src, dst = tmp_path / "t.pt", tmp_path / "t.json"
    save_textons(textons, src)
    assert main(["textons", str(src), "--to", str(dst)]) == 0
    assert "2 set(s) x 5 textons" in capsys.readouterr().out
    assert load_textons(dst).mu.equal(textons.mu)


@pytest.mark.parametrize("content, message", [
    (None, "no such file"),
    (b"{not json", "not valid JSON"),
    (b'{"format": "neuraltex.textons", "version": 7}', "version 7"),
    (b"\x89PNG\r\n\x1a\n garbage", "not valid JSON"),
])
def test_bad_texton_files_exit_2_with_one_line(tmp_path, content, message, capsys):
    path = tmp_path / "bad.json"
    if content is not None:
        path.write_bytes(content)
    assert main(["textons", str(path), "--to", str(tmp_path / "out.json")]) == 2
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("neuraltex: error:") and message in lines[0]
    assert "Traceback" not in err
    assert not (tmp_path / "out.json").exists()
