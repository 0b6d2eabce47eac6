"""The reliability corpus (tests/corpus/, written by scripts/make_corpus.py): every ``neuraltex``
subcommand over odd and hostile images, texton files, weights, edit lists, arguments and
output paths, and ``cvt synthesize`` / ``inspect`` / ``autocomplete`` over hostile SVGs, in-process.
Each case must end as the corpus says: "ok" (exit 0, output written) or "error" (exit 2,
exactly one ``<prog>: error:`` line, no traceback, no file left in the output folder), within
60 s; the process's peak memory stays under 2 GB. No picture written for an SVG with external
references shows the corpus's pure red secret.png, and no command opens a file outside the
corpus, its output folders and the Python installation.

About one case in six runs with ``pytest -m "not slow"`` (never those marked "slow" in
cases.json); plain ``pytest`` (CI) runs every case except the SVG cases marked ``"ci": false``
(each SVG goes through one command in CI); ``python scripts/run_corpus.py`` runs them all.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import resource
import signal
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from cvt.cli import main as cvt_main
from neuraltex.cli import main

CORPUS = Path(__file__).parent / "corpus"
CASES = json.loads((CORPUS / "cases.json").read_text())
TIME_CAP_S = 60
MEMORY_CAP_MB = 2048
SILENT = ("textons", "model-info")  # commands that write no file
MAINS = {"neuraltex": main, "cvt": cvt_main}
ALL = os.environ.get("CORPUS_ALL") == "1"  # also the cases marked "ci": false
_peaks: dict[str, float] = {}


def _params():
    for i, case in enumerate(CASES):
        if case.get("ci") is False and not ALL:
            continue  # python scripts/run_corpus.py runs these too
        marks = () if i % 6 == 0 and not case.get("slow") else (pytest.mark.slow,)
        yield pytest.param(case, id=case["id"], marks=marks)


def _argv(argv: list[str], tmp: Path) -> list[str]:
    out, ro, afile = tmp / "out", tmp / "ro", tmp / "afile"
    out.mkdir()
    ro.mkdir(mode=0o555)
    afile.write_text("a file, not a folder")
    subs = {"{c}": str(CORPUS), "{o}": str(out), "{ro}": str(ro), "{file}": str(afile)}
    result = []
    for a in argv:
        for k, v in subs.items():
            a = a.replace(k, v)
        result.append(a)
    return result


class _Timeout(Exception):
    pass


def _run(argv: list[str], prog: str = "neuraltex") -> tuple[int, str, str, float]:
    """(exit code, stdout, stderr, seconds) of ``<prog> argv`` in this process."""

    def alarm(signum, frame):
        raise _Timeout(f"over {TIME_CAP_S} s")

    out, err = io.StringIO(), io.StringIO()
    previous = signal.signal(signal.SIGALRM, alarm)
    signal.alarm(TIME_CAP_S)
    t0 = time.perf_counter()
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            rc = MAINS[prog](argv)
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    return rc, out.getvalue(), err.getvalue(), time.perf_counter() - t0


@pytest.mark.parametrize("case", _params())
def test_case(case, tmp_path):
    if any("{ro}" in a for a in case["argv"]) and os.geteuid() == 0:
        pytest.skip("root can write into a read-only folder")
    argv = _argv(case["argv"], tmp_path)
    prog = case.get("prog", "neuraltex")
    with _file_reads() as opened:
        rc, out, err, seconds = _run(argv, prog)
    _peaks[case["id"]] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    written = [p for p in (tmp_path / "out").rglob("*") if p.is_file()]
    assert "Traceback" not in err and "pickled code ran" not in out, err
    outside = [p for p in opened if not p.startswith(_ALLOWED + (str(tmp_path),))]
    assert not outside, f"opened {outside}"
    if case["expect"] == "error":
        lines = err.strip().splitlines()
        assert rc == 2, (rc, err)
        assert len(lines) == 1 and lines[0].startswith(f"{prog}: error:"), lines
        assert not written, written
    else:
        assert rc == 0, err
        assert written or case["argv"][0] in SILENT or "--no-png" in argv
    if case.get("no_red"):
        for png in (p for p in written if p.suffix == ".png"):
            rgb = np.asarray(Image.open(png).convert("RGB")).astype(int)
            red = (rgb[..., 0] > 240) & (rgb[..., 1] < 16) & (rgb[..., 2] < 16)
            assert not red.any(), f"{png.name} shows the referenced secret.png"
    assert seconds < TIME_CAP_S


_ALLOWED = tuple(str(Path(p).resolve()) for p in (
    Path(__file__).parents[1], sys.prefix, sys.base_prefix, *(p for p in sys.path if p)))
_ALLOWED += ("/dev/", "/proc/", "/sys/", "/usr/", "/etc/ld.so", "/tmp/torchinductor",
             tempfile.gettempdir())


@contextlib.contextmanager
def _file_reads():
    """Paths this process opens (Python's audit events) while the block runs."""
    opened: list[str] = []
    active = [True]

    def hook(event, args):
        if active[0] and event == "open" and isinstance(args[0], str | bytes):
            opened.append(os.path.abspath(os.fsdecode(args[0])))

    _hooks.append(hook)
    try:
        yield opened
    finally:
        active[0] = False
        _hooks.remove(hook)


_hooks: list = []
sys.addaudithook(lambda event, args: [h(event, args) for h in list(_hooks)])


def test_peak_memory_under_cap():
    """Runs after the cases (file order): the process's peak resident memory so far."""
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    assert peak < MEMORY_CAP_MB, f"peak {peak:.0f} MB"


def test_corpus_is_large_and_covers_every_subcommand():
    from cvt.cli import build_parser as cvt_parser
    from neuraltex.cli import build_parser

    for prog, parser in (("neuraltex", build_parser()), ("cvt", cvt_parser())):
        commands = {c["argv"][0] for c in CASES if c.get("prog", "neuraltex") == prog}
        sub = next(a for a in parser._actions if a.dest == "command")
        assert set(sub.choices) <= commands, prog
    assert len(CASES) >= 300
    assert sum(c.get("prog") == "cvt" for c in CASES) >= 100
