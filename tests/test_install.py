"""A fresh-machine install: the wheel built from this tree works from another folder, with no
repository around it (configs, weights and exemplars ship inside the package)."""

from __future__ import annotations

import os
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("wheel")
    subprocess.run([sys.executable, "-m", "pip", "wheel", str(ROOT), "--no-deps",
                    "--no-build-isolation", "-q", "-w", str(out)], check=True, cwd=out,
                   capture_output=True)
    return next(out.glob("neuraltex-*.whl"))


@pytest.mark.slow
def test_wheel_ships_configs_weights_exemplars_and_licence(wheel):
    names = zipfile.ZipFile(wheel).namelist()
    assert "train/configs/train.yaml" in names
    assert "train/configs/experiment/default_segmenter.yaml" in names
    assert "neuraltex/weights/default.safetensors" in names
    assert any(n.startswith("cvt/exemplars/") and n.endswith(".svg") for n in names)
    assert any(n.endswith("licenses/LICENSE") for n in names)
    assert not any(n.startswith("tests/") for n in names)


@pytest.mark.slow
def test_installed_wheel_runs_from_another_folder(wheel, tmp_path):
    """Installed (without dependencies: they come from this environment) into a fresh venv;
    run from a folder that holds no repository."""
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--system-site-packages", str(venv)],
                   check=True)
    py = venv / "bin" / "python"
    subprocess.run([py, "-m", "pip", "install", "-q", "--no-deps", str(wheel)], check=True)
    work = tmp_path / "elsewhere"
    work.mkdir()
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"} | {"OMP_NUM_THREADS": "1"}

    def run(*argv: str) -> str:
        out = subprocess.run([str(a) for a in argv], cwd=work, env=env, capture_output=True,
                             text=True, timeout=300)
        assert out.returncode == 0, out.stderr[-2000:]
        return out.stdout

    where = run(py, "-c", "import neuraltex, train; print(neuraltex.__file__, train.__file__)")
    assert str(ROOT) not in where and str(venv) in where
    assert "shipped default" in run(venv / "bin" / "neuraltex", "model-info")
    exemplar = venv / "lib" / f"python{sys.version_info.major}.{sys.version_info.minor}" / \
        "site-packages" / "cvt" / "exemplars" / "hearts.svg"
    run(venv / "bin" / "cvt", "synthesize", exemplar, "-o", "out.svg", "--scale", "1.2",
        "--levels", "1", "--iterations", "1", "--quiet")
    assert (work / "out.svg").read_text().lstrip().startswith("<")
    run(py, "-m", "train", "debug=fast", "trainer.max_steps=1", "trainer.threads=1",
        "run_dir=r1")
    assert (work / "r1" / "last.pt").is_file() and (work / "r1" / "model.safetensors").is_file()
    help_text = run(py, "-m", "train", "--help")
    assert len(help_text.splitlines()) < 30 and "experiment" in help_text


def test_cpu_only_use_never_touches_cuda(tmp_path, capsys):
    """What a CPU-only install runs: the CLI on its default device never initializes CUDA."""
    import numpy as np
    import torch
    from PIL import Image

    from neuraltex.cli import main

    Image.fromarray((np.random.default_rng(0).random((24, 24, 3)) * 255).astype(np.uint8)).save(
        tmp_path / "a.png")
    assert main(["reconstruct", str(tmp_path / "a.png"), "-o", str(tmp_path / "r.png")]) == 0
    assert not torch.cuda.is_initialized()
    if not torch.cuda.is_available():
        assert main(["reconstruct", str(tmp_path / "a.png"), "-o", str(tmp_path / "r.png"),
                     "--device", "cuda"]) == 2
        assert capsys.readouterr().err.strip().count("\n") == 0
