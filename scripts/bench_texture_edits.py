"""Seconds of every editing command on texture files (.ntex), as a user runs them.

    python scripts/bench_texture_edits.py CACHE/brick.ntex CACHE/coins.ntex
    python scripts/bench_texture_edits.py /tmp/cache/*.ntex --repeat 3 --threads 1

Each command is the real CLI (``neuraltex.cli.main``) called in this process, so the Python
and torch import is paid once (the start-up, printed on its own line) and every timed call
includes what a user's call does after it: reading the texture file(s), the edit, decoding
with the tuned decoder and writing the output. Files are taken in pairs for the two-texture
commands (transfer, interpolate: A with B, B with the next, ...). Wall and CPU seconds of
this process, the best of ``--repeat`` calls. Target of the texture-tuning issue: any edit
with a texture file <= 1 s at 256 px after start-up; animate and interpolate write several
frames, their per-frame cost is printed beside them.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from functools import partial
from pathlib import Path

FRAMES = 8  # frames of animate and interpolate --frames


def commands(a: Path, b: Path, out: Path, edits: Path) -> dict[str, list[str]]:
    """name -> argv of one call (A edited, B the second texture)."""
    return {
        "reconstruct": ["reconstruct", str(a), "-o", str(out / "r.png")],
        "reshuffle": ["reshuffle", str(a), "-o", str(out / "s.png"), "--seed", "1"],
        "vary": ["vary", str(a), "-o", str(out / "v.png"), "--appearance", "0.5",
                 "--shape", "1.5"],
        "edit": ["edit", str(a), str(edits), "-o", str(out / "e.png")],
        "transfer": ["transfer", str(a), str(b), "-o", str(out / "t.png")],
        "interpolate": ["interpolate", str(a), str(b), "-o", str(out / "i.png"), "--t", "0.5"],
        "interpolate --spatial": ["interpolate", str(a), str(b), "-o", str(out / "p.png"),
                                  "--spatial"],
        f"interpolate --frames {FRAMES}": ["interpolate", str(a), str(b), "-o",
                                           str(out / "i.gif"), "--frames", str(FRAMES)],
        f"animate --frames {FRAMES}": ["animate", str(a), "-o", str(out / "a.gif"), "--frames",
                                       str(FRAMES)],
        "vectorize": ["vectorize", str(a), "-o", str(out / "x.svg")],
    }


def run(argv: list[str]) -> None:
    """One ``neuraltex`` call in this process; a failed one stops the benchmark."""
    from neuraltex.cli import main

    code = main(argv)
    if code:
        raise SystemExit(f"neuraltex {' '.join(argv)} exited with {code}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("files", nargs="+", type=Path, help="texture files (.ntex) to edit")
    ap.add_argument("--repeat", type=int, default=2, help="calls per command; the best counts")
    ap.add_argument("--threads", type=int, default=1, help="torch threads (default 1)")
    args = ap.parse_args(argv)
    w0 = time.perf_counter()
    import torch

    import neuraltex.cli  # noqa: F401  (the start-up a CLI call pays once)

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from bench_edit import best_of  # (wall, CPU) seconds of the best of N calls

    torch.set_num_threads(args.threads)
    print(f"start-up (import torch + neuraltex): {time.perf_counter() - w0:.2f} s; "
          f"{args.threads} torch thread(s), best of {args.repeat}")
    rows: dict[str, list[tuple[float, float]]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        edits = out / "edits.json"
        edits.write_text(json.dumps(
            [{"select": {"point": [0.5, 0.5]}, "op": "move", "by": [0.1, 0.0]},
             {"select": {"region": [0, 0, 0.5, 1]}, "op": "rotate", "degrees": 30}]))
        for i, a in enumerate(args.files):
            b = args.files[(i + 1) % len(args.files)]
            for name, cmd in commands(a, b, out, edits).items():
                rows.setdefault(name, []).append(best_of(partial(run, cmd), args.repeat))
            print(f"  {a.name}: " + ", ".join(f"{k} {v[-1][0]:.2f} s" for k, v in rows.items()),
                  file=sys.stderr, flush=True)
    print(f"| command ({len(args.files)} texture files) | wall s mean | wall s max | "
          "CPU s mean | <= 1 s |\n|---|---:|---:|---:|---|")
    for name, t in rows.items():
        wall, cpu = [w for w, _ in t], [c for _, c in t]
        per = ""
        if "--frames" in name:
            per = f" ({statistics.mean(wall) / FRAMES:.2f} s a frame)"
        ok = "yes" if max(wall) <= 1 else "no"
        if "--frames" in name and max(wall) > 1:
            ok = "per frame" if max(wall) / FRAMES <= 1 else "no"
        print(f"| {name} | {statistics.mean(wall):.2f}{per} | {max(wall):.2f} | "
              f"{statistics.mean(cpu):.2f} | {ok} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
