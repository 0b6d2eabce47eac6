"""The ``cvt`` command lines of the reliability corpus (scripts/make_corpus.py): every hostile
SVG of scripts/corpus_svg.py through ``cvt inspect`` and ``cvt synthesize`` (with a preview PNG),
some through ``cvt autocomplete`` and ``--domain``, and bad arguments and output paths.

A case has ``"prog": "cvt"``; ``"no_red": true`` marks a file with external references: no
picture the command writes may show the corpus's pure red secret.png. ``"ci": false`` leaves a
case out of the default test run (``python scripts/run_corpus.py`` runs every case): CI runs one
command per SVG (synthesize with its preview for files with references, else inspect and
synthesize in turn) and every argument and output-path case.
"""

from __future__ import annotations

SVG = "{c}/svg"
CURVE = f"{SVG}/curve.svg"
VALID = f"{SVG}/valid.svg"
FAST = ("--levels", "1", "--iterations", "2")
DOMAIN_OK = {"element_1e4x_alone.svg"}  # one huge filled circle: a fine domain, no exemplar
SLOW = {"use_chain_1e4.svg", "huge_path.svg", "huge_curve_path.svg"}  # 3-9 s: never in CI


def cvt_command(name: str, src: str, extra: tuple = ()) -> list[str]:
    """A ``cvt`` command line of subcommand ``name`` reading the SVG ``src``, writing to {o}."""
    argv = {
        "inspect": ["inspect", src, "--png", "{o}/s.png"],
        "synthesize": ["synthesize", src, "-o", "{o}/s.svg", "--scale", "1.5", *FAST,
                       "--quiet", "--preview", "{o}/s.png"],
        "autocomplete": ["autocomplete", src, "--exemplar", CURVE, "-o", "{o}/a.svg", *FAST,
                         "--preview", "{o}/a.png"],
        "domain": ["synthesize", VALID, "-o", "{o}/d.svg", "--scale", "1.5", *FAST, "--quiet",
                   "--domain", src],
        "curves": ["synthesize", src, "-o", "{o}/c.svg", "--scale", "1.5", *FAST, "--quiet",
                   "--kind", "curves"],
    }[name]
    return argv + list(extra)


def _case(cid: str, expect: str, argv: list[str], **more) -> dict:
    return {"id": cid[:120], "prog": "cvt", "expect": expect, "argv": argv, **more}


def svg_cases(files: dict[str, str], references: set[str]) -> list[dict]:
    """Every SVG through inspect and synthesize; the odd ones also as a partial drawing, a
    domain and a curve exemplar (where they fail before the exemplar's kind matters)."""
    cases = []
    for k, (name, expect) in enumerate(files.items()):
        src = f"{SVG}/{name}"
        more = {"no_red": True} if name in references else {}
        more.update({"slow": True} if name in SLOW else {})
        ci = "synthesize" if name in references or k % 2 else "inspect"
        for cmd in ("inspect", "synthesize"):
            cases.append(_case(f"svg/{name}/{cmd}", expect, cvt_command(cmd, src),
                               **more, ci=cmd == ci and name not in SLOW))
        if expect == "error" or name in references:
            # as a drawing to complete or a domain: dots are no strokes / are a domain
            cases.append(_case(f"svg/{name}/autocomplete", "error",
                               cvt_command("autocomplete", src), **more, ci=False))
            dom = "ok" if name in DOMAIN_OK else expect
            cases.append(_case(f"svg/{name}/domain", dom, cvt_command("domain", src), **more,
                               ci=False))
    cases.append(_case("svg/curve.svg/autocomplete", "ok", cvt_command("autocomplete", CURVE)))
    cases.append(_case("svg/curve.svg/curves", "ok", cvt_command("curves", CURVE)))
    return cases


# (subcommand, extra arguments, expectation) over the valid SVG
ARGUMENTS = [
    *[("synthesize", (opt, v), "error") for opt in ("--w-f", "--w-l", "--w-s")
      for v in ("1e308", "inf", "nan", "-1")],
    ("synthesize", ("--w-f", "0", "--w-l", "0", "--w-s", "0"), "ok"),
    *[("synthesize", ("--scale", v), "error") for v in ("0", "inf", "nan", "-1", "1e308", "100",
                                                        "1e-9", "x")],
    *[("synthesize", ("--width", w, "--height", h), "error") for w, h in (
        ("0", "10"), ("nan", "10"), ("1e308", "1e308"), ("-5", "50"), ("100", "1e9"))],
    ("synthesize", ("--width", "120", "--height", "80"), "ok"),
    ("synthesize", ("--width", "120"), "error"),  # with --scale: one or the other
    *[("synthesize", ("--seed", v), "error") for v in ("-1", str(2**64), "abc", "1.5", "")],
    ("synthesize", ("--seed", str(2**32 - 1)), "ok"),
    *[("synthesize", ("--levels", v), "error") for v in ("0", "4", "-1", "x")],
    *[("synthesize", ("--iterations", v), "error") for v in ("0", "1000", "-3")],
    *[("synthesize", ("--threads", v), "error") for v in ("0", "-1", "100000")],
    *[("synthesize", (opt, v), "error") for opt, v in (
        ("--elements", "bogus"), ("--method", "magic"), ("--init", "x"), ("--kind", "lines"),
        ("--max-side", "0"), ("--max-elements", "0"), ("--max-elements", "x"),
        ("--from-image", "{c}/images/rgb.png"), ("--domain", "{c}/svg/missing.svg"),
        ("--domain", "{c}/images/rgb.png"), ("--debug-dir", "{file}"), ("--unknown", "1"))],
    ("synthesize", ("--method", "random"), "ok"),
    ("synthesize", ("--max-elements", "3"), "error"),
    *[("synthesize", ("--max-samples", v), "error") for v in ("10", "0", "1e9")],
    ("inspect", ("--levels", "0"), "error"),
    ("inspect", ("--levels", "9"), "error"),
    ("inspect", ("--no-png",), "ok"),
    ("inspect", ("--max-elements", "2"), "error"),
    *[("autocomplete", (opt, *v), "error") for opt, v in (
        ("--margin", ("0",)), ("--margin", ("inf",)), ("--margin", ("-1",)),
        ("--margin", ("1e308",)), ("--region", ("0", "0", "nan", "5")),
        ("--region", ("0", "0", "1e308", "1e308")), ("--region", ("0", "0", "-5", "5")),
        ("--levels", ("9",)), ("--iterations", ("0",)), ("--seed", ("-1",)),
        ("--exemplar", ("{c}/svg/missing.svg",)), ("--exemplar", ("{c}/svg/use_self.svg",)))],
    ("autocomplete", ("--only-new",), "ok"),
]

# output paths: (subcommand, option, value, expectation)
OUTPUTS = [
    *[("synthesize", "-o", o, "error") for o in (
        "", ".", "{o}", "{o}/", "{o}/x.png", "{o}/x", "{file}/x.svg", "{ro}/x.svg",
        "{o}/" + "x" * 300 + ".svg", "/proc/x.svg", "{o}/a\x00b.svg")],
    ("synthesize", "-o", "{o}/new/deeper/x.svg", "ok"),
    ("synthesize", "-o", "{o}/X.SVG", "ok"),
    *[("synthesize", "--preview", o, "error") for o in (
        "", "{o}/p.svg", "{file}/p.png", "{ro}/p.png", "{o}/" + "p" * 300 + ".png")],
    *[("synthesize", "--exemplar-out", o, "error") for o in ("{ro}/e.svg", "{o}/e.png")],
    *[("inspect", "--png", o, "error") for o in (
        "", "{o}/out.svg", "{o}", "{file}/s.png", "{ro}/s.png", "{o}/" + "s" * 300 + ".png")],
    ("inspect", "--png", "{o}/new/s.png", "ok"),
    *[("autocomplete", "-o", o, "error") for o in (
        "", "{o}/a.png", "{file}/a.svg", "{ro}/a.svg", "{o}/" + "a" * 300 + ".svg")],
    ("autocomplete", "--preview", "{o}/a.svg", "error"),
]


def cvt_argument_cases() -> list[dict]:
    image = ["synthesize", "--from-image", "{c}/images/gray16.png", "--segmenter", "felzenszwalb",
             "-o", "{o}/i.svg", "--scale", "1.5", *FAST, "--max-side", "64", "--quiet",
             "--exemplar-out", "{o}/e.svg"]
    cases = [_case("cvt-arguments/from-image fails late: no exemplar-out left", "error",
                   image + ["--max-samples", "1"]),
             _case("cvt-arguments/from-image with exemplar-out", "ok", image, ci=False)]
    for i, (cmd, extra, expect) in enumerate(ARGUMENTS):
        src = CURVE if cmd == "autocomplete" else VALID
        argv = cvt_command(cmd, src)
        if extra[0] == "--width" and len(extra) == 4:  # the size given as --width/--height
            del argv[argv.index("--scale"):argv.index("--scale") + 2]
        cases.append(_case(f"cvt-arguments/{i:03d}/{cmd} {' '.join(extra)}", expect,
                           argv + list(extra)))
    for i, (cmd, opt, value, expect) in enumerate(OUTPUTS):
        argv = cvt_command(cmd, CURVE if cmd == "autocomplete" else VALID)
        if opt in argv:
            argv[argv.index(opt) + 1] = value
        else:
            argv += [opt, value]
        cases.append(_case(f"cvt-outputs/{i:03d}/{cmd} {opt} {value!r}", expect, argv))
    return cases
