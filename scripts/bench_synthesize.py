"""Seconds of the whole ``neuraltex synthesize`` command on the real textures, as a user runs it.

For each texture of data/real_textures: its texture file (``neuraltex fit --steps N``, cached
as scripts/eval_synthesis.py caches it), then ``neuraltex synthesize X.ntex --source X.png -o
OUT --size H W --seed 0 --quiet --threads T`` in a fresh process for each thread count T,
timed from the outside: wall seconds (start-up and import included), the process's CPU
seconds (user + sys) and its peak resident memory. The pictures of T = 1 and T = 2 are
compared byte for byte (the arrangements side by side must not change the result). Prints
one row per texture, then mean / max and how many meet the target (<= 30 s at 512 x 512 on
2 cores). Wall seconds mean something only on an otherwise idle machine: the load average
is printed before and after.

    python scripts/bench_synthesize.py --cache /tmp/eval_synthesis --threads 2 1
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from PIL import Image

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))

TARGET_S = 30.0


def timed(cmd: list[str]) -> tuple[float, float, float]:
    """(wall s, CPU s of the child, its peak RSS in GiB) of one command run to completion."""
    t = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t
    err = proc.stderr.read().decode(errors="replace") if proc.stderr else ""
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode:
        raise SystemExit(f"{' '.join(cmd)} failed ({proc.returncode}): {err.strip()[-400:]}")
    return wall, usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 2**20


def main() -> None:
    from eval_synthesis import add_texture_options, texture_file

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_texture_options(p)
    p.add_argument("--size", type=int, nargs=2, default=(512, 512), metavar=("H", "W"))
    p.add_argument("--threads", type=int, nargs="+", default=[2, 1],
                   help="thread counts to time (--threads of the command)")
    p.add_argument("--only", nargs="+", help="texture names (default: all)")
    args = p.parse_args()
    names = args.only or sorted(f.stem for f in args.textures.glob("*.png"))
    print(f"load average before: {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    print(f"{'texture':12s} " + " ".join(f"T={t}: wall s  CPU s  GiB " for t in args.threads)
          + " same picture")
    rows = {t: [] for t in args.threads}
    with tempfile.TemporaryDirectory() as tmp:
        for name in names:
            image = args.textures / f"{name}.png"
            ntex = texture_file(image, args.cache, args.steps)
            cells, digests = [], set()
            for t in args.threads:
                out = Path(tmp) / f"{name}_{t}.png"
                wall, cpu, gib = timed([sys.executable, "-m", "neuraltex.cli", "synthesize",
                                        str(ntex), "--source", str(image), "-o", str(out),
                                        "--size", *map(str, args.size), "--seed", "0",
                                        "--quiet", "--threads", str(t)])
                rows[t].append(wall)
                digests.add(np.asarray(Image.open(out)).tobytes())
                cells.append(f"{wall:10.1f} {cpu:6.1f} {gib:4.2f}")
            print(f"{name:12s} " + "  ".join(cells) + f"  {len(digests) == 1}", flush=True)
    for t in args.threads:
        w = np.array(rows[t])
        print(f"T={t}: wall mean {w.mean():.1f} s, max {w.max():.1f} s "
              f"({names[int(w.argmax())]}); <= {TARGET_S:g} s on {(w <= TARGET_S).sum()}/{len(w)}")
    print(f"load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
