"""Write the reliability corpus, tests/corpus/: odd and hostile inputs for every ``neuraltex``
subcommand (images, texton files, model weights, edit lists, arguments, output paths) and for
``cvt synthesize`` / ``inspect`` / ``autocomplete`` (SVGs: scripts/corpus_svg.py), and
``cases.json``, the command lines to run over them with what each must do: "ok" (exit 0,
outputs written) or "error" (exit 2, one line on stderr, no output file left). tests/test_corpus.py
runs every case in-process under a time and memory cap.

    python scripts/make_corpus.py   # rewrites tests/corpus/ (same content; safetensors
                                    # headers may list their keys in another order)

Placeholders in the command lines: {c} the corpus folder, {o} an empty output folder per case,
{ro} a read-only folder, {file} a regular file. Each new input class found later goes here.
"""

from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path

import torch

sys.path.insert(0, str(Path(__file__).parent))
from corpus_cases import argument_cases, output_cases  # noqa: E402
from corpus_cvt_cases import cvt_argument_cases, svg_cases  # noqa: E402
from corpus_files import images, texton_files  # noqa: E402
from corpus_svg import curve_file, reference_files, svg_files  # noqa: E402

ROOT = Path(__file__).resolve().parents[1] / "tests" / "corpus"
IMG, TEX, W, ED = "{c}/images", "{c}/textons", "{c}/weights", "{c}/edits"


def weights(d: Path) -> dict[str, str]:
    """Model exports with odd headers; the tensors are tiny, so a file whose header passes is
    still refused when its weights do not fit the model."""
    from safetensors.torch import save_file

    from neuraltex.checkpoint import tensor_digest

    d.mkdir(parents=True, exist_ok=True)
    tensors = {"w": torch.zeros(2)}
    config = {"preset": "tiny", "num_queries": 100, "image_size": 128}
    good = {"format": "neuraltex.model", "version": "1", "model_config": json.dumps(config),
            "info": "{}", "sha256": tensor_digest(tensors)}
    deep = "[" * 10000 + "]" * 10000
    variants = {
        "fits_nothing": {}, "info_null": {"info": "null"}, "info_string": {"info": '"x"'},
        "info_list": {"info": "[1, 2]"}, "info_number": {"info": "3"},
        "info_odd_types": {"info": json.dumps({"steps": [1], "wall_s": "x", "freeze": 5,
                                               "init_from": "y", "init_parts": [1]})},
        "info_deep": {"info": '{"a": ' + deep + "}"},
        "info_chain_deep": {"info": '{"init_from": {"info": ' * 200 + "{}" + "}}" * 200},
        "config_deep": {"model_config": deep}, "config_null": {"model_config": "null"},
        "config_list": {"model_config": "[]"}, "config_bad_json": {"model_config": "{"},
        "image_size_huge": {"model_config": json.dumps({**config, "image_size": 10**12})},
        "queries_3e7": {"model_config": json.dumps({**config, "num_queries": 3 * 10**7})},
        "queries_negative": {"model_config": json.dumps({**config, "num_queries": -5})},
        "queries_float": {"model_config": json.dumps({**config, "num_queries": 1.5})},
        "preset_number": {"model_config": json.dumps({**config, "preset": 7})},
        "preset_unknown": {"model_config": json.dumps({**config, "preset": "huge"})},
        "eps_nan": {"model_config": json.dumps({**config, "eps": float("nan")})},
        "unknown_key": {"model_config": json.dumps({**config, "x" * 5000: 1})},
        "no_config": {"model_config": None}, "version2": {"version": "2"},
        "version_text": {"version": "one"}, "no_format": {"format": None},
        "sha_wrong": {"sha256": "0" * 64},
    }
    for name, change in variants.items():
        meta = {k: v for k, v in {**good, **change}.items() if v is not None}
        save_file(tensors, str(d / f"{name}.safetensors"), metadata=meta)
    blob = (d / "fits_nothing.safetensors").read_bytes()
    (d / "truncated.safetensors").write_bytes(blob[: len(blob) // 2])
    (d / "empty.safetensors").write_bytes(b"")
    (d / "header_len_huge.safetensors").write_bytes((2**62).to_bytes(8, "little") + b"{}")
    (d / "not_safetensors.pt").write_bytes(b"x" * 64)
    names = [*(f"{n}.safetensors" for n in variants), "truncated.safetensors",
             "empty.safetensors", "header_len_huge.safetensors", "not_safetensors.pt"]
    return {n: "error" for n in names}


def edit_lists(d: Path) -> dict[str, str]:
    d.mkdir(parents=True, exist_ok=True)
    sel = {"index": [0]}
    lists = {
        "valid": ("ok", [{"select": sel, "op": "move", "by": [0.05, 0]},
                         {"select": {"point": [0.5, 0.5]}, "op": "scale", "by": 1.5},
                         {"select": {"region": [0, 0, 0.5, 1]}, "op": "rotate", "degrees": 30},
                         {"select": {"similar_to": 1}, "op": "delete"},
                         {"select": sel, "op": "duplicate", "offset": [0.1, 0.1]}]),
        "empty_list": ("ok", []),
        "bare_number": ("error", 5), "list_of_numbers": ("error", [1, 2]),
        "string": ("error", "move"), "object": ("error", {"select": sel, "op": "move"}),
        "no_select": ("error", [{"op": "delete"}]),
        "unknown_op": ("error", [{"select": sel, "op": "explode"}]),
        "index_out_of_range": ("error", [{"select": {"index": [10**6]}, "op": "delete"}]),
        "index_huge": ("error", [{"select": {"index": [10**30]}, "op": "delete"}]),
        "similar_inf": ("error", [{"select": {"similar_to": 1e400}, "op": "delete"}]),
        "point_strings": ("error", [{"select": {"point": ["a", "b"]}, "op": "delete"}]),
        "move_1e308": ("error", [{"select": sel, "op": "move", "by": [1e308, 1e308]}] * 2),
        "scale_1e308": ("error", [{"select": sel, "op": "scale", "by": 1e308}] * 2),
        "rotate_nan": ("error", [{"select": sel, "op": "rotate", "degrees": float("nan")}]),
        "by_missing": ("error", [{"select": sel, "op": "move"}]),
        "duplicate_x13": ("error", [{"select": {"region": [0, 0, 9, 9]}, "op": "duplicate"}] * 13),
        "edits_2000": ("error", [{"select": sel, "op": "move", "by": [0, 0]}] * 2000),
    }
    out = {}
    for name, (expect, data) in lists.items():
        (d / f"{name}.json").write_text(json.dumps(data))
        out[f"{name}.json"] = expect
    for name, text in {"nested_3000.json": "[" * 3000 + "]" * 3000, "truncated.json": '[{"sel',
                       "empty.json": ""}.items():
        (d / name).write_text(text)
        out[name] = "error"
    (d / "latin1.json").write_bytes('[{"op": "dé"}]'.encode("latin-1"))
    out["latin1.json"] = "error"
    return out


COMMANDS = ("encode", "reconstruct", "overlay", "vectorize", "transfer", "reshuffle",
            "interpolate", "vary", "edit", "propagate", "animate", "stylize", "fit")


def texture_files(d: Path, weights_dir: Path) -> dict[str, str]:
    """Broken texture files (.ntex, written by ``neuraltex fit``)."""
    d.mkdir(parents=True, exist_ok=True)
    (d / "empty.ntex").write_bytes(b"")
    (d / "garbage.ntex").write_bytes(bytes(range(256)) * 2)
    (d / "model_export.ntex").write_bytes((weights_dir / "fits_nothing.safetensors").read_bytes())
    (d / "deep_header.ntex").write_bytes((weights_dir / "info_deep.safetensors").read_bytes())
    names = ["empty.ntex", "garbage.ntex", "model_export.ntex", "deep_header.ntex",
             "missing.ntex"]
    return {n: "error" for n in names}


def command(name: str, src: str, extra: tuple = ()) -> list[str]:
    """A command line of subcommand ``name`` reading the texture ``src``, writing to {o}."""
    b, o = f"{IMG}/b.png", "{o}"
    argv = {
        "encode": ["encode", src, "-o", f"{o}/t.json"],
        "decode": ["decode", src, "-o", f"{o}/d.png", "--size", "32"],
        "reconstruct": ["reconstruct", src, "-o", f"{o}/r.png"],
        "overlay": ["overlay", src, "-o", f"{o}/ov.png"],
        "vectorize": ["vectorize", src, "-o", f"{o}/v.svg"],
        "transfer": ["transfer", src, b, "-o", f"{o}/tr.png", "--size", "32"],
        "reshuffle": ["reshuffle", src, "-o", f"{o}/rs.png", "--seed", "1", "--size", "32"],
        "interpolate": ["interpolate", src, b, "-o", f"{o}/in.png", "--size", "32"],
        "vary": ["vary", src, "-o", f"{o}/va.png", "--size", "32"],
        "edit": ["edit", src, f"{ED}/valid.json", "-o", f"{o}/ed.png", "--size", "32"],
        "propagate": ["propagate", src, src, "-o", f"{o}/pr.png"],
        "animate": ["animate", src, "-o", f"{o}/an.gif", "--frames", "2", "--size", "32"],
        "stylize": ["stylize", src, b, "-o", f"{o}/st.png", "--patch", "32"],
        "textons": ["textons", src],
        "fit": ["fit", src, "-o", f"{o}/f.ntex", "--steps", "2"],
        "synthesize": ["synthesize", src, "-o", f"{o}/sy.png", "--scale", "1.5",
                       "--iterations", "1", "--quiet"],
        "model-info": ["model-info"],
    }[name]
    return argv + list(extra)


# texton files that some commands accept: the summary reads any valid file; decode renders
# the first of several sets (the editing commands take exactly one)
ACCEPTED_BY = {"two_sets.pt": ("textons", "decode"), "wrong_channels.pt": ("textons",),
               "canvas_1x1000.pt": ("textons",), "canvas_1x1000.json": ("textons",)}


def file_cases(kind: str, files: dict[str, str], commands: tuple, ok_commands: tuple) -> list:
    """Every error file through ``commands``; every ok file through ``ok_commands``."""
    folder = {"images": IMG, "textons": TEX, "textures": "{c}/textures"}[kind]
    cases = []
    for name, expect in files.items():
        for cmd in commands if expect == "error" else ok_commands:
            ok = cmd in ACCEPTED_BY.get(name, ())
            cases.append({"id": f"{kind}/{name}/{cmd}", "expect": "ok" if ok else expect,
                          "argv": command(cmd, f"{folder}/{name}")})
    return cases


def main() -> None:
    shutil.rmtree(ROOT, ignore_errors=True)
    imgs = images(ROOT / "images")
    valid = _encoded(ROOT / "images" / "rgb.png")
    tex = texton_files(ROOT / "textons", valid)
    wts, eds = weights(ROOT / "weights"), edit_lists(ROOT / "edits")  # before textures
    cases = file_cases("images", imgs, COMMANDS, ("encode", "reconstruct"))
    cases += file_cases("textons", tex, ("decode", "textons", "vary"), ("decode", "textons"))
    ntex = texture_files(ROOT / "textures", ROOT / "weights")
    cases += file_cases("textures", ntex, ("vary", "reconstruct", "vectorize", "transfer"), ())
    for name in wts:
        for cmd in ("model-info", "reconstruct"):
            cases.append({"id": f"weights/{name}/{cmd}", "expect": "error",
                          "argv": command(cmd, f"{IMG}/rgb.png",
                                          ("--checkpoint", f"{W}/{name}"))})
    for name, expect in eds.items():
        argv = ["edit", f"{IMG}/rgb.png", f"{ED}/{name}", "-o", "{o}/e.png", "--size", "32"]
        cases.append({"id": f"edits/{name}", "expect": expect, "argv": argv})
    cases += argument_cases(command) + output_cases(command)
    svgs = svg_files(ROOT / "svg")
    curve_file(ROOT / "svg")
    cases += svg_cases(svgs, set(reference_files())) + cvt_argument_cases()
    (ROOT / "cases.json").write_text(json.dumps(cases, indent=0) + "\n")
    (ROOT / "README.md").write_text(
        "Generated by `python scripts/make_corpus.py`; run by tests/test_corpus.py. "
        "Every file here was made by that script (no third-party data).\n")
    print(f"wrote {ROOT}: {len(cases)} cases")


def _encoded(image: Path) -> dict:
    """The .pt payload of ``image`` encoded by the shipped model (the valid texton file)."""
    import tempfile

    from neuraltex.cli import main as neuraltex

    with tempfile.TemporaryDirectory() as tmp:
        assert neuraltex(["encode", str(image), "-o", f"{tmp}/t.pt", "--seed", "0"]) == 0
        return torch.load(f"{tmp}/t.pt", weights_only=True)


if __name__ == "__main__":
    main()
