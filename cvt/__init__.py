"""cvt: Clustered Vector Textures (seed 000) -- SVG exemplar in, larger SVG pattern out.

All sample state (positions, cluster ids, existence, z, shape-context features) lives in
torch tensors; see seed 000 sections 4-6. Public API (imported lazily, so ``import cvt``
and the CLI's input checks do not pay for torch)::

    from cvt import load_svg, synthesize, SynthesisConfig, result_svg
    ex = load_svg("cvt/exemplars/stars.svg")
    res = synthesize(ex, (400, 400), SynthesisConfig(seed=1))
    open("out.svg", "w").write(result_svg(ex, res))
"""

from neuraltex import __version__

_API = {
    "load_svg": "cvt.svg", "parse_svg": "cvt.svg", "to_svg": "cvt.svg", "Exemplar": "cvt.svg",
    "synthesize": "cvt.synthesis", "SynthesisConfig": "cvt.synthesis",
    "SynthesisResult": "cvt.synthesis", "LevelState": "cvt.synthesis",
    "result_svg": "cvt.synthesis", "sample_exemplar": "cvt.sampling", "Samples": "cvt.sampling",
    "Matches": "cvt.search",
}

__all__ = ["__version__", *_API]


def __getattr__(name: str):
    if name in _API:
        import importlib

        return getattr(importlib.import_module(_API[name]), name)
    raise AttributeError(f"module 'cvt' has no attribute {name!r}")
