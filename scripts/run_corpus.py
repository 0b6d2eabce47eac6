"""Run the whole reliability corpus (tests/test_corpus.py), including the SVG cases that CI
leaves out (marked ``"ci": false`` in tests/corpus/cases.json: each SVG through every ``cvt``
command, not just one). Extra arguments go to pytest.

    python scripts/run_corpus.py            # every case, ~1,095
    python scripts/run_corpus.py -k svg/    # only the SVG cases
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

if __name__ == "__main__":
    root = Path(__file__).resolve().parents[1]
    env = {**os.environ, "CORPUS_ALL": "1"}
    cmd = [sys.executable, "-m", "pytest", "-q", "tests/test_corpus.py", *sys.argv[1:]]
    raise SystemExit(subprocess.call(cmd, cwd=root, env=env))
