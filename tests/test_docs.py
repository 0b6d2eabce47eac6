"""The docs check: every command in a ```bash block of README.md, MODEL.md and docs/*.md is
valid as written. ``neuraltex``/``cvt`` command lines parse with the real parsers, ``python -m
train`` overrides compose with the real configs, and every option given to a script exists in
that script. (The commands themselves run in the CLI, training and corpus tests.)"""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", ROOT / "MODEL.md", *sorted((ROOT / "docs").glob("*.md"))]
SKIP = ("pip", "pytest", "M=", "export", "cd", "cp")


def _commands() -> list[tuple[str, list[str]]]:
    found = []
    for doc in DOCS:
        for block in re.findall(r"```bash\n(.*?)```", doc.read_text(), flags=re.S):
            for line in block.replace("\\\n", " ").splitlines():
                for part in line.split("&&"):
                    argv = shlex.split(part.replace("$M", ""), comments=True)
                    if argv and not argv[0].startswith(SKIP):
                        found.append((f"{doc.name}: {' '.join(argv)}"[:150], argv))
    return found


COMMANDS = _commands()


def test_the_docs_hold_commands():
    assert len(COMMANDS) >= 30
    assert {argv[0] for _, argv in COMMANDS} >= {"neuraltex", "cvt", "python"}


@pytest.mark.parametrize("argv", [pytest.param(a, id=i) for i, a in COMMANDS])
def test_command_is_valid_as_written(argv):
    if argv[0] == "torchrun":
        argv = ["python", *argv[argv.index("-m"):]]
    if argv[0] == "neuraltex":
        from neuraltex.cli import build_parser

        build_parser().parse_args(argv[1:])
    elif argv[0] == "cvt":
        from cvt.cli import build_parser

        with pytest.raises(SystemExit) if "--help" in argv else _nothing():
            build_parser().parse_args(argv[1:])
    elif argv[:3] == ["python", "-m", "train"]:
        _compose([a for a in argv[3:] if not a.startswith("-")])
    elif argv[0] == "python":
        module = argv[1]
        if argv[1] == "-m":  # a package runs its __main__.py, a module itself
            module = argv[2].replace(".", "/")
            module += "/__main__.py" if (ROOT / module).is_dir() else ".py"
        source = (ROOT / module).read_text()
        missing = [opt for opt in (a.split("=")[0] for a in argv if a.startswith("--"))
                   if f'"{opt}"' not in source]
        if missing:  # options a script shares with another one: ask its own parser
            import subprocess
            import sys

            shown = subprocess.run([sys.executable, str(ROOT / module), "--help"],
                                   capture_output=True, text=True, cwd=ROOT).stdout
            for opt in missing:
                assert re.search(rf"{re.escape(opt)}\b", shown), f"{module} has no option {opt}"
    else:
        pytest.fail(f"unknown command {argv[0]} in the docs")


def _compose(overrides: list[str]) -> None:
    from hydra import compose, initialize_config_dir

    with initialize_config_dir(config_dir=str(ROOT / "configs"), version_base="1.3"):
        compose(config_name="train", overrides=overrides)


class _nothing:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False
