"""Bad arguments and bad output paths of the reliability corpus (scripts/make_corpus.py):
command lines over valid inputs that must each end in one line and exit code 2 (or succeed,
where a value is odd but allowed)."""

from __future__ import annotations

IMG = "{c}/images"

# (subcommand, extra arguments, expectation)
ARGUMENTS = [
    *[("reconstruct", ("--size", *s), "error") for s in (
        ("0", "0"), ("-1",), ("100000",), ("20000", "20000"), ("1", "2", "3"), ("nan",),
        ("1e3",), ("32", "4096"), ("2048", "2048"))],
    ("reconstruct", ("--size", "16", "24"), "error"),  # wider than the textons' canvas
    ("reconstruct", ("--size", "24", "24"), "ok"),
    ("reconstruct", ("--size", "8"), "ok"),
    *[("reconstruct", ("--seed", s), "error") for s in ("-1", str(2**64), "abc", "1.5", "")],
    ("reconstruct", ("--seed", str(2**32 - 1)), "ok"),
    *[("reconstruct", ("--device", d), "error") for d in (
        "cuda", "cuda:7", "", "gpu", "meta", "cpu:x", "mps", "xla", " ")],
    *[("reconstruct", (opt, v), "error") for opt in ("--max-side", "--max-pixels")
      for v in ("0", "-5", "1e9", "x")],
    *[("reconstruct", ("--max-aspect", v), "error") for v in ("0.5", "nan", "inf")],
    ("reconstruct", ("--max-side", "16"), "ok"),
    ("reconstruct", ("--max-pixels", "300"), "ok"),
    ("reconstruct", ("--unknown-option",), "error"),
    ("reconstruct", ("--checkpoint", "{c}/images/rgb.png"), "error"),
    ("reconstruct", ("--checkpoint", "{c}/missing.safetensors"), "error"),
    ("reconstruct", ("--checkpoint", ""), "ok"),  # empty: the shipped default
    *[("animate", ("--fps", v), "error") for v in ("0", "nan", "-5", "inf", "1e9")],
    *[("animate", ("--omega", v), "error") for v in ("inf", "nan", "1e300")],
    *[("animate", ("--velocity", v), "error") for v in ("1e300", "-inf")],
    *[("animate", ("--duration", v), "error") for v in ("0", "-1", "1e9")],
    *[("animate", ("--frames", v), "error") for v in ("0", "-3", "100000")],
    ("animate", ("--flow", "shear", "--velocity", "100"), "ok"),
    ("animate", ("--flow", "spiral"), "error"),
    *[("synthesize", ("--scale", v), "error") for v in ("0", "-1", "nan", "inf", "9")],
    *[("synthesize", s, "error") for s in (("--size", "64", "64"), ("--iterations", "0"),
                                           ("--preview-textons", "{o}/p.png"))],
    ("synthesize", (), "ok"),
    ("synthesize", ("--tileable", "--seed", "3"), "ok"),
    *[("stylize", ("--scale", v), "error") for v in ("0", "inf", "-1", "nan", "1e-9")],
    *[("stylize", ("--patch", v), "error") for v in ("-1", "0", "100000")],
    *[("stylize", ("--overlap", v), "error") for v in ("1", "-0.1", "0.95")],

    *[("interpolate", ("--t", v), "error") for v in ("1.5", "nan", "-0.1")],
    *[("interpolate", ("--frames", v), "error") for v in ("1", "0", "100000")],
    ("interpolate", ("--frames", "2", "--fps", "0"), "error"),
    ("interpolate", ("--t", "0.5", "--spatial"), "error"),
    *[("reshuffle", ("--count", v), "error") for v in ("0", "100000", "-1")],
    *[("vary", (opt, v), "error") for opt in ("--appearance", "--shape")
      for v in ("-1", "inf", "nan", "1e308")],
    ("vary", ("--appearance", "0", "--shape", "0"), "ok"),
    *[("propagate", ("--threshold", v), "error") for v in ("2", "nan")],
    *[("propagate", ("--radius", v), "error") for v in ("0", "inf", "-1")],
    *[("overlay", ("--scale", v), "error") for v in ("0", "-1", "100")],
    *[("vectorize", (opt, v), "error") for opt, v in (
        ("--kinds", "0"), ("--kinds", "1000000"), ("--level", "0"), ("--level", "inf"),
        ("--segmenter", "magic"))],
    ("vectorize", ("--mode", "ellipse", "--segmenter", "grid"), "error"),
    ("vectorize", ("--segmenter", "grid"), "ok"),
    ("transfer", ("--regions", "{c}/images/rgb.png"), "error"),
    ("transfer", ("--mode", "swap"), "error"),
    *[("fit", extra, "error") for extra in (
        ("--device", "cuda"), ("--device", "cuda:x"), ("--max-side", "0"), ("--steps", "-1"),
        ("--seconds", "nan"), ("--size", "0"), ("--size", "100000"), ("--max-textons", "0"),
        ("--segmenter", "magic"))],
]


def argument_cases(command) -> list[dict]:
    cases = [{"id": "arguments/stylize too many patches", "expect": "error",
              "argv": command("stylize", f"{IMG}/big600.png", ("--scale", "0.125",
                                                              "--overlap", "0.9"))}]
    for i, (cmd, extra, expect) in enumerate(ARGUMENTS):
        cases.append({"id": f"arguments/{i:03d}/{cmd} {' '.join(extra)}"[:120], "expect": expect,
                      "argv": command(cmd, f"{IMG}/rgb.png", extra)})
    return cases


# output paths: (subcommand, output, expectation)
OUTPUTS = [
    *[("reconstruct", o, "error") for o in (
        "", ".", "{o}", "{o}/", "{o}/x.svg", "{o}/x", "{o}/x.PNG.txt", "{file}/x.png",
        "{ro}/x.png", "{o}/" + "x" * 300 + ".png", "/proc/x.png", "{o}/a\x00b.png")],
    ("reconstruct", "{o}/new/deeper/x.png", "ok"),
    ("reconstruct", "{o}/x.jpg", "ok"),
    ("reconstruct", "{o}/x.webp", "ok"),
    *[("encode", o, "error") for o in ("{o}/t.png", "{o}/t", "{file}/t.json", "{ro}/t.pt")],
    ("encode", "{o}/t.pt", "ok"),
    *[("vectorize", o, "error") for o in ("{o}/v.png", "{file}/v.svg", "{ro}/v.svg")],
    *[("animate", o, "error") for o in ("{o}/a_{j}.png", "{o}/a_{i:q}.png",
                                        "{o}/a.avi", "{ro}/a.gif", "{o}/a_{i}.svg")],
    ("animate", "{o}/f_{i:03d}.png", "ok"),
    ("animate", "{o}/a.png", "ok"),  # numbered a_0.png, a_1.png
    *[("reshuffle", o, "error") for o in ("{o}/r_{i}.svg", "{o}/r_{}.png")],
]


def output_cases(command) -> list[dict]:
    cases = []
    for i, (cmd, out, expect) in enumerate(OUTPUTS):
        argv = command(cmd, f"{IMG}/rgb.png")
        argv[argv.index("-o") + 1] = out
        if cmd == "reshuffle":
            argv += ["--count", "2"]
        cases.append({"id": f"outputs/{i:03d}/{cmd} -o {out!r}"[:120], "expect": expect,
                      "argv": argv})
    return cases
