"""Score texton extraction methods on the fixed benchmark split, per family and overall.

    python scripts/eval_textons.py                         # all baselines, default params
    python scripts/eval_textons.py --tune --markdown docs/baselines.md
    python scripts/eval_textons.py --method slic --param 150 --limit 60
    python scripts/eval_textons.py --method model --checkpoint runs/x/ckpt.pt

--tune picks each baseline's main parameter on the validation split (never on the
benchmark) and then scores the benchmark with it. The headline metric is the
Hungarian-matched mean IoU; ARI, count error and boundary F1 are in the summary.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from neuraltex.baselines import METHODS, MODEL_LABELS, get_segmenter  # noqa: E402
from neuraltex.data.families import FAMILY_NAMES  # noqa: E402
from neuraltex.data.splits import benchmark_split, validation_split  # noqa: E402
from neuraltex.errors import InputError, cli_entry  # noqa: E402
from neuraltex.evaluation import family_table, score, summary_table, tune  # noqa: E402
from neuraltex.fileio import write_text_atomic  # noqa: E402
from neuraltex.limits import MAX_TEXTONS  # noqa: E402
from neuraltex.mask_refinement import REACH, WEIGHT  # noqa: E402
from neuraltex.tiled_segments import DENSE, TILING  # noqa: E402

LEGEND = """\
Metrics (neuraltex/metrics.py): **miou** = Hungarian-matched mean IoU over ground-truth
textons (the headline); **ari** = adjusted Rand index on ground-truth foreground pixels (a
fixed grid already scores ~0.4-0.6 on it, never read it alone); **count_err** =
|predicted - true| / true texton count, counting segments that lie mostly on foreground;
**boundary_f1** = boundary F-measure at 0.75 % of the diagonal. Easy/hard/overall are
means over images. The grid ignores the image: it is the "no information" reference."""


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="eval_textons", description=__doc__.split("\n")[0])
    p.add_argument("--method", default="all",
                   help=f"comma list of {', '.join([*METHODS, 'model'])} or 'all' baselines")
    p.add_argument("--param", type=float, default=None,
                   help="main parameter value (only with a single baseline method)")
    p.add_argument("--checkpoint", default=None,
                   help="model for --method model (default: the shipped model)")
    p.add_argument("--model-labels", choices=MODEL_LABELS, default="masks",
                   help="--method model: pixel labels from the E_s masks (stride 4), the splats, "
                        "the masks refined to image edges by SLIC majority vote, or relabelled "
                        "pixel by pixel by each texton's colour (guided)")
    p.add_argument("--guided-weight", type=float, default=WEIGHT,
                   help="--model-labels guided: weight of each texton's colour log-likelihood "
                        "against its log mask (0: the masks' argmax)")
    p.add_argument("--guided-reach", type=float, default=REACH,
                   help="--model-labels guided: a texton is a candidate label where its mask "
                        "is at least this")
    p.add_argument("--num-queries", type=int, default=None,
                   help="--method model: resample E_s's query grid to this many queries "
                        "(no training; for dense textures, e.g. 196)")
    p.add_argument("--tile", choices=TILING, default="off",
                   help="--method model: encode the whole picture (off), from overlapping tiles "
                        "seen at twice the scale (on), or from tiles when the whole-picture run "
                        "is dense (auto; neuraltex/tiled_encode.py)")
    p.add_argument("--tile-from", type=int, default=None,
                   help="with --tile auto: a picture is dense from this many segments of the "
                        f"whole-picture run on (default {DENSE}, picked on the validation "
                        "split: neuraltex.tiled_segments.DENSE)")
    p.add_argument("--families", default=None,
                   help="comma list of families to score (default: all), e.g. discs,dots")
    p.add_argument("--tune", action="store_true",
                   help="tune each baseline's main parameter on the validation split first")
    p.add_argument("--split", choices=("benchmark", "validation"), default="benchmark")
    p.add_argument("--limit", type=int, default=None,
                   help="score only the first N items (round-robin keeps families balanced)")
    p.add_argument("--markdown", default=None, help="write the tables to this markdown file")
    p.add_argument("--json", default=None, help="write per-image scores to this JSON file")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    return p


def _methods(arg: str) -> list[str]:
    names = list(METHODS) if arg == "all" else [m.strip() for m in arg.split(",") if m.strip()]
    for n in names:
        if n not in METHODS and n != "model":
            raise InputError(f"unknown method {n!r}; choose from {', '.join([*METHODS, 'model'])}")
    return names


@cli_entry("eval_textons")
def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    names = _methods(args.method)
    if args.param is not None and (len(names) != 1 or names[0] == "model"):
        raise InputError("--param needs exactly one baseline --method")
    if args.num_queries is not None and not 1 <= args.num_queries <= MAX_TEXTONS:
        raise InputError(f"--num-queries must be in [1, {MAX_TEXTONS}]")
    if not (args.guided_weight >= 0 and 0 <= args.guided_reach <= 1):
        raise InputError("--guided-weight must be >= 0 and --guided-reach in [0, 1]")
    if args.limit is not None and args.limit < 1:
        raise InputError("--limit must be >= 1")
    if args.tile_from is not None and (args.tile != "auto" or args.tile_from < 1):
        raise InputError("--tile-from needs --tile auto and must be >= 1")
    progress = not args.quiet
    items = benchmark_split() if args.split == "benchmark" else validation_split()
    if args.families:
        wanted = [f.strip() for f in args.families.split(",") if f.strip()]
        unknown = sorted(set(wanted) - set(FAMILY_NAMES))
        if unknown:
            raise InputError(f"unknown families {', '.join(unknown)}; choose from "
                             f"{', '.join(FAMILY_NAMES)}")
        items = [it for it in items if it.family in wanted]
    items = items[: args.limit] if args.limit else items
    samples = [it.load() for it in items]
    validation = [it.load() for it in validation_split()] if args.tune else None

    results, params, curves = {}, {}, {}
    for name in names:
        t0 = time.perf_counter()
        if name == "model":
            segment = get_segmenter("model", checkpoint=args.checkpoint,
                                    model_labels=args.model_labels,
                                    num_queries=args.num_queries,
                                    guide=(args.guided_weight, args.guided_reach),
                                    tile=args.tile, tile_from=args.tile_from)
            params[name] = f"labels={args.model_labels}" + (
                f" weight={args.guided_weight:g} reach={args.guided_reach:g}"
                if args.model_labels == "guided" else "") + (
                f" queries={args.num_queries}" if args.num_queries else "") + (
                f" tile={args.tile}" if args.tile != "off" else "") + (
                f" from {args.tile_from} segments" if args.tile_from else "")
        else:
            m = METHODS[name]
            value = m.default if args.param is None else args.param
            if args.tune:
                value, curves[name] = tune(m, validation, progress)
            segment, params[name] = get_segmenter(name, value), f"{m.param}={value:g}"
        results[name] = score(segment, samples, f"score {name}", progress)
        print(f"{name}: {params[name]} scored {len(samples)} images in "
              f"{time.perf_counter() - t0:.0f} s", file=sys.stderr)

    sizes = sorted({s.mask.shape[0] for s in samples})
    command = " ".join(["python scripts/eval_textons.py", *(argv if argv is not None
                                                             else sys.argv[1:])])
    text = [f"# Texton extraction on the {args.split} split",
            "", f"Produced by `{command}`.", "",
            f"{len(samples)} images ({', '.join(f'{s}px' for s in sizes)}), families "
            "round-robin; parameters: "
            f"{', '.join(f'{k} {v}' for k, v in params.items())}.", "", LEGEND, "",
            "## Hungarian-matched mean IoU per family (headline)", "", family_table(results),
            "", "## All metrics (easy / hard / overall)", "", summary_table(results, params)]
    if curves:
        text += ["", "## Tuning on the validation split (overall matched mIoU)", ""]
        for name, curve in curves.items():
            text.append(f"- {name} ({METHODS[name].param}): "
                        + ", ".join(f"{v:g}: {c:.3f}" for v, c in curve.items()))
    report = "\n".join(text) + "\n"
    print(report)
    if args.markdown:
        write_text_atomic(args.markdown, report)
    if args.json:
        write_text_atomic(args.json, json.dumps(dict(params=params, results=results), indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
