"""The hostile and odd input files of the reliability corpus (tests/corpus/): images, texton
files, model weights and edit lists. Each writer returns {file name: expectation}, where the
expectation is "ok" (a command taking it succeeds) or "error" (one line, exit code 2).

Used by scripts/make_corpus.py; every file is tiny (the whole corpus is well under 1 MB).
"""

from __future__ import annotations

import io
import json
import struct
import zlib
from pathlib import Path

import numpy as np
import torch
from PIL import Image


def _rgb(h: int, w: int, seed: int = 0) -> np.ndarray:
    return (np.random.default_rng(seed).random((h, w, 3)) * 255).astype(np.uint8)


def _png_with_size(w: int, h: int) -> bytes:
    """A 1x1 PNG whose header claims w x h (a decompression bomb that is never decoded)."""
    buf = io.BytesIO()
    Image.new("RGB", (1, 1)).save(buf, format="PNG")
    data = bytearray(buf.getvalue())
    ihdr = data[12:29]  # b"IHDR" + 13 bytes
    ihdr[4:12] = struct.pack(">II", w, h)
    data[12:29] = ihdr
    data[29:33] = struct.pack(">I", zlib.crc32(bytes(ihdr)))
    return bytes(data)


def images(d: Path) -> dict[str, str]:
    d.mkdir(parents=True, exist_ok=True)
    out: dict[str, str] = {}

    def pil(name: str, im: Image.Image, expect: str = "ok", **kw) -> None:
        im.save(d / name, **kw)
        out[name] = expect

    rgb = Image.fromarray(_rgb(32, 32))
    pil("rgb.png", rgb)
    pil("b.png", Image.fromarray(_rgb(32, 40, 1)))
    pil("gray.png", rgb.convert("L"))
    pil("palette.png", rgb.convert("P"))
    pil("rgba.png", rgb.convert("RGBA"))
    pil("la.png", rgb.convert("LA"))
    pil("cmyk.jpg", rgb.convert("CMYK"), format="JPEG")
    pil("gray16.png", Image.fromarray((np.arange(32 * 32).reshape(32, 32) * 60)
                                      .astype(np.uint16)))
    pil("rgb.bmp", rgb)
    pil("rgb.tif", rgb)
    pil("rgb.webp", rgb)
    pil("bw.png", rgb.convert("1"))
    pil("anim.gif", rgb, save_all=True, append_images=[rgb.rotate(90)])
    pil("tiny1x1.png", Image.new("RGB", (1, 1), "red"))
    pil("wide8.png", Image.fromarray(_rgb(8, 64, 2)))  # aspect 8: the limit, accepted
    ramp = np.linspace(0, 255, 600, dtype=np.uint8)
    big = np.stack(np.broadcast_arrays(ramp[:, None], ramp[None, :], ramp[None, ::-1]), -1)
    pil("big600.png", Image.fromarray(np.ascontiguousarray(big)))  # 600 x 600 smooth ramps
    pil("line3000x1.png", Image.fromarray(_rgb(1, 3000, 4)), "error")
    pil("line1x3000.png", Image.fromarray(_rgb(3000, 1, 5)), "error")
    pil("line300x1.png", Image.fromarray(_rgb(1, 300, 6)), "error")
    pil("wide9.png", Image.fromarray(_rgb(8, 72, 7)), "error")
    raw = (d / "rgb.png").read_bytes()
    for name, data in {
        "claims65535x1.png": _png_with_size(65535, 1),
        "claims65535x65535.png": _png_with_size(65535, 65535),
        "claims20000x20000.png": _png_with_size(20000, 20000),
        "claims12000x12000.png": _png_with_size(12000, 12000),
        "claims9000x9000.png": _png_with_size(9000, 9000),
        "truncated.png": raw[: len(raw) // 2],
        "header_only.png": raw[:33],
        "empty.png": b"",
        "garbage.png": bytes(np.random.default_rng(8).integers(0, 256, 4096, dtype=np.uint8)),
        "text.png": b"this is not an image\n",
        "svg_named.png": b'<svg xmlns="http://www.w3.org/2000/svg" width="9" height="9"/>',
        "jpeg_truncated.jpg": _jpeg(rgb)[:200],
    }.items():
        (d / name).write_bytes(data)
        out[name] = "error"
    (d / "folder.png").mkdir(exist_ok=True)
    (d / "folder.png" / ".keep").write_text("")
    out["folder.png"] = "error"
    out["missing.png"] = "error"
    return out


def _jpeg(im: Image.Image) -> bytes:
    buf = io.BytesIO()
    im.save(buf, format="JPEG")
    return buf.getvalue()


def texton_files(d: Path, valid: dict) -> dict[str, str]:
    """Texton files derived from ``valid`` (a loaded .pt payload of one encoded image)."""
    d.mkdir(parents=True, exist_ok=True)
    out: dict[str, str] = {}
    fields = ("mu", "cov", "v", "f", "p", "delta", "order")

    def pt(name: str, expect: str, **change) -> None:
        payload = {**valid, **change}
        torch.save({k: v for k, v in payload.items() if v is not None}, d / name)
        out[name] = expect

    pt("valid.pt", "ok")
    pt("float64.pt", "ok", **{k: valid[k].double() for k in fields if k != "order"})
    pt("float16.pt", "ok", **{k: valid[k].half() for k in fields if k != "order"})
    pt("bfloat16.pt", "ok", **{k: valid[k].bfloat16() for k in fields if k != "order"})
    pt("mixed_dtypes.pt", "ok", mu=valid["mu"].double(), f=valid["f"].half())
    pt("order_int32.pt", "ok", order=valid["order"].int())
    pt("sparse_mu.pt", "error", mu=valid["mu"].to_sparse())
    pt("meta_f.pt", "error", f=torch.empty_like(valid["f"], device="meta"))
    pt("int_mu.pt", "error", mu=valid["mu"].long())
    pt("complex_f.pt", "error", f=valid["f"].to(torch.complex64))
    pt("bool_p.pt", "error", p=valid["p"] > 0.5)
    pt("order_float.pt", "error", order=valid["order"].float())
    pt("nan_mu.pt", "error", mu=valid["mu"] * float("nan"))
    pt("inf_cov.pt", "error", cov=valid["cov"] * float("inf"))
    pt("negative_p.pt", "error", p=-valid["p"] - 0.1)
    pt("cov_not_pd.pt", "error", cov=-valid["cov"])
    pt("v_not_unit.pt", "error", v=valid["v"] * 3)
    pt("missing_mu.pt", "error", mu=None)
    pt("mu_list.pt", "error", mu=valid["mu"].tolist())
    pt("wrong_shape.pt", "error", mu=valid["mu"][..., :1])
    pt("canvas_tiny.pt", "error", canvas=[1e-300, 1.0])
    pt("canvas_1x1000.pt", "error", canvas=[1.0, 1000.0])
    pt("canvas_nan.pt", "error", canvas=[float("nan"), 1.0])
    pt("canvas_string.pt", "error", canvas="1 1")
    pt("two_sets.pt", "error", **{k: torch.cat([valid[k]] * 2) for k in fields})
    first = {k: valid[k][:, :1] for k in fields}  # one texton
    pt("many_sets.pt", "error", **{k: v.expand(1000, *v.shape[1:]).contiguous()
                                   for k, v in first.items()})
    pt("many_textons.pt", "error", **{k: v.expand(1, 4100, *v.shape[2:]).contiguous()
                                      for k, v in first.items()})
    pt("wrong_channels.pt", "error", f=valid["f"][..., :3])
    pt("wrong_format.pt", "error", format="something.else")
    pt("version2.pt", "error", version=2)
    torch.save([1, 2, 3], d / "a_list.pt")
    out["a_list.pt"] = "error"
    (d / "empty.pt").write_bytes(b"")
    (d / "garbage.pt").write_bytes(b"PK\x03\x04" + bytes(100))
    (d / "pickle_code.pt").write_bytes(_evil_pickle())
    out.update({"empty.pt": "error", "garbage.pt": "error", "pickle_code.pt": "error"})
    out.update(_json_texton_files(d, valid))
    return out


class _Evil:
    def __reduce__(self):
        return (print, ("pickled code ran",))


def _evil_pickle() -> bytes:
    buf = io.BytesIO()
    torch.save({"format": "neuraltex.textons", "x": _Evil()}, buf)
    return buf.getvalue()


def _json_texton_files(d: Path, valid: dict) -> dict[str, str]:
    from neuraltex.textons import Textons
    from neuraltex.textons_file import _to_json

    t = Textons(**{k: valid[k] for k in ("mu", "cov", "v", "f", "p", "delta", "order")},
                canvas=tuple(valid["canvas"]))
    base = _to_json(t)
    out: dict[str, str] = {}

    def js(name: str, expect: str, data=None, text: str | None = None) -> None:
        (d / name).write_text(text if text is not None else json.dumps(data), encoding="utf-8")
        out[name] = expect

    js("valid.json", "ok", base)
    js("float64.json", "ok", {**base, "dtype": "float64"})
    js("dtype_list.json", "error", {**base, "dtype": ["float32"]})
    js("dtype_unknown.json", "error", {**base, "dtype": "int8"})
    js("canvas_tiny.json", "error", {**base, "canvas": [1e-300, 1]})
    js("canvas_1x1000.json", "error", {**base, "canvas": [1, 1000]})
    js("canvas_bool.json", "error", {**base, "canvas": [True, "x"]})
    one = base["sets"][0]["textons"][:1]
    small = [{"p": 1, "delta": 1, "mu": [0, 0], "cov": [[1, 0], [0, 1]], "v": [1, 0],
              "order": 0, "f": [0]}]
    js("sets_1000.json", "error", {**base, "sets": [{"textons": small}] * 1000})
    js("textons_4100.json", "error", {**base, "sets": [{"textons": small * 4100}]})
    js("sets_empty.json", "error", {**base, "sets": []})
    js("sets_not_list.json", "error", {**base, "sets": 5})
    js("texton_not_dict.json", "error", {**base, "sets": [{"textons": [5]}]})
    js("f_strings.json", "error", {**base, "sets": [{"textons": [{**one[0], "f": ["a"]}]}]})
    js("mu_huge.json", "error", {**base, "sets": [{"textons": [{**one[0], "mu": [1e308, 1e309]}]}]})
    js("order_float.json", "error", {**base, "sets": [{"textons": [{**one[0], "order": 0.5}]}]})
    js("nan_p.json", "error", text=json.dumps({**base, "sets": [{"textons": [
        {**one[0], "p": float("nan")}]}]}))
    js("no_format.json", "error", {k: v for k, v in base.items() if k != "format"})
    js("version_string.json", "error", {**base, "version": "1"})
    js("top_list.json", "error", [base])
    js("bare_number.json", "error", 5)
    js("nested_3000.json", "error", text="[" * 3000 + "]" * 3000)
    js("nested_100000.json", "error", text="[" * 100000 + "]" * 100000)
    js("truncated.json", "error", text=json.dumps(base)[:300])
    js("empty.json", "error", text="")
    (d / "latin1.json").write_bytes(json.dumps(base).replace("neuraltex", "neuraltéx")
                                    .encode("latin-1"))
    out["latin1.json"] = "error"
    (d / "utf16.json").write_bytes(json.dumps(base).encode("utf-16"))
    out["utf16.json"] = "error"
    (d / "textons.txt").write_text("x")
    out["textons.txt"] = "error"
    return out
