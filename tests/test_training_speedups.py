"""The fast paths of the training step against plain references: E_s logits resampled from
stride 4, point-sampled mask loss, query-grid resampling for more queries."""

from __future__ import annotations

import pytest
import torch
import torch.nn.functional as F

from neuraltex import nn_utils
from neuraltex.model import build_model, load_model
from neuraltex.model_config import ModelConfig
from neuraltex.nn_utils import (
    argsort_last,
    bilinear_sample,
    resize,
    sort_last,
    upsample_crop_resize,
)
from neuraltex.query_grid import adapt_queries, grid_shape, resample_queries
from neuraltex.segmentation import SegmentationNet
from train.mask_supervision import mask_supervision_loss

pytestmark = pytest.mark.usefixtures("one_thread", "seeded")


def _reference(x, up, crop, out):
    y = resize(x, up)[..., : crop[0], : crop[1]]
    return F.interpolate(y, size=out, mode="bilinear", align_corners=False)


@pytest.mark.parametrize("shapes", [((8, 8), (32, 32), (32, 32), (16, 16)),
                                    ((7, 5), (28, 20), (25, 19), (13, 10)),
                                    ((4, 4), (16, 16), (16, 16), (16, 16))])
def test_upsample_crop_resize_equals_the_chain_forward_and_backward(shapes):
    hw, up, crop, out = shapes
    x = torch.randn(2, 3, *hw, dtype=torch.float64, requires_grad=True)
    fast, ref = upsample_crop_resize(x, up, crop, out), _reference(x, up, crop, out)
    assert fast.shape == (2, 3, *out) and torch.allclose(fast, ref, atol=1e-12)
    g = torch.randn_like(ref)
    (gf,), (gr,) = torch.autograd.grad(fast, x, g), torch.autograd.grad(ref, x, g)
    assert torch.allclose(gf, gr, atol=1e-12)
    with pytest.raises(ValueError):
        upsample_crop_resize(x, (2, 2), (2, 2), (2, 2))


@pytest.mark.parametrize("sizes", [((32, 32), (4, 4)), ((32, 32), (16, 16)), ((30, 33), (10, 11)),
                                   ((24, 30), (4, 5)), ((16, 16), (16, 16)), ((37, 50), (12, 25)),
                                   ((8, 8), (16, 16))])
def test_bilinear_sample_equals_interpolate_forward_and_backward(sizes):
    """Whole factors, even (a mean of two pixels) and odd (one pixel) per side, and sizes
    that fall back to F.interpolate: the same values and gradients."""
    (H, W), size = sizes
    x = torch.randn(2, 3, H, W, dtype=torch.float64, requires_grad=True)
    fast = bilinear_sample(x, size)
    ref = F.interpolate(x, size=size, mode="bilinear", align_corners=False)
    assert fast.shape == ref.shape and torch.allclose(fast, ref, atol=1e-12)
    g = torch.randn_like(ref)
    (gf,), (gr,) = torch.autograd.grad(fast, x, g), torch.autograd.grad(ref, x, g)
    assert torch.allclose(gf, gr, atol=1e-12)


@pytest.mark.parametrize("dtype", [torch.float32, torch.float64, torch.bfloat16])
def test_sort_last_equals_torch_sort_values_and_gradients(dtype):
    """numpy's order on CPU: the values of torch.sort, and (without ties) its gradients."""
    g = torch.Generator().manual_seed(0)
    x = torch.randn(3, 5, 301, generator=g).to(dtype)
    w = torch.randn(3, 5, 301, generator=g).to(dtype)
    strided = x.transpose(0, 1)  # a non-contiguous view sorts the same
    assert torch.equal(sort_last(strided), torch.sort(strided, dim=-1).values)
    out = sort_last(x)
    assert out.dtype == dtype and torch.equal(out, torch.sort(x, dim=-1).values)
    grads = []
    for fn in (sort_last, lambda t: torch.sort(t, dim=-1).values):
        leaf = x.clone().requires_grad_(True)
        (fn(leaf) * w).sum().backward()
        grads.append(leaf.grad)
    if dtype != torch.bfloat16:  # bfloat16's 256 levels tie; ties may take either order
        assert torch.equal(grads[0], grads[1])
    assert torch.equal(grads[0].sort(-1).values, grads[1].sort(-1).values)


def test_argsort_last_orders_like_torch_argsort():
    """The permutation that sorts (the mask loss's draw: rand values, which may tie), and
    without ties exactly torch's, also for float64 and strided views."""
    g = torch.Generator().manual_seed(1)
    x = torch.rand(8, 4096, generator=g)
    idx = argsort_last(x)
    assert idx.dtype == torch.long and torch.equal(x.gather(-1, idx), x.sort(-1).values)
    distinct = torch.randperm(8 * 4096, generator=g).reshape(8, 4096) / 4096
    for y in (distinct, distinct.double(), distinct.T):
        assert torch.equal(argsort_last(y), torch.argsort(y, dim=-1))


@pytest.mark.parametrize("threads", [1, 2, 3])
def test_sorts_split_over_threads_equal_one_sort(threads):
    """Arrays above the split size sort their rows in several threads: the same values and
    permutation as torch's, for 3-d, odd row counts, strided views and 1-d input."""
    g = torch.Generator().manual_seed(2)
    before = torch.get_num_threads()
    torch.set_num_threads(threads)
    try:
        x = torch.randperm(7 * 5 * 8000, generator=g).reshape(7, 5, 8000).float()
        assert x.numel() >= nn_utils._PARALLEL_SORT
        for y in (x, x.transpose(0, 1), x.flatten()):
            assert torch.equal(sort_last(y), torch.sort(y, dim=-1).values)
            assert torch.equal(argsort_last(y), torch.argsort(y, dim=-1))
        leaf = x.clone().requires_grad_(True)
        sort_last(leaf)[..., :10].sum().backward()  # the 10 smallest of each row get 1
        assert torch.equal(leaf.grad, (x.argsort(-1).argsort(-1) < 10).float())
    finally:
        torch.set_num_threads(before)


def test_segmenter_out_size_equals_resizing_its_full_size_logits(tiny):
    seg = SegmentationNet.from_config(tiny.segmentation).eval()
    x = torch.rand(2, 3, 40, 52)
    with torch.no_grad():
        full = seg(x).logits  # (B, n, 40, 52)
        small = seg(x, out_size=(20, 26)).logits
    ref = F.interpolate(full, size=(20, 26), mode="bilinear", align_corners=False)
    assert torch.allclose(small, ref, atol=1e-5)


def _labels_and_masks(B=2, n=6, hw=12):
    labels = torch.randint(0, 4, (B, hw, hw))
    logits = torch.randn(B, n, hw, hw, requires_grad=True)
    return labels, logits


def test_point_sampled_mask_loss():
    labels, logits = _labels_and_masks()
    full = mask_supervision_loss(logits.softmax(1), labels)
    assert torch.equal(full, mask_supervision_loss(logits.softmax(1), labels, points=144))
    g = torch.Generator().manual_seed(3)
    a = mask_supervision_loss(logits.softmax(1), labels, 40, g)
    b = mask_supervision_loss(logits.softmax(1), labels, 40, torch.Generator().manual_seed(3))
    assert torch.equal(a, b) and not torch.equal(a, full)
    with torch.no_grad():  # the sampled loss estimates the full one
        samples = torch.stack([mask_supervision_loss(logits.softmax(1), labels, 72, g)
                               for _ in range(40)])
    assert abs(float(samples.mean()) - float(full.detach())) < 0.1 * float(full.detach())
    a.backward()
    assert torch.isfinite(logits.grad).all() and logits.grad.abs().sum() > 0


def test_resample_queries_keeps_constant_and_row_major_layout():
    assert grid_shape(100) == (10, 10) and grid_shape(196) == (14, 14)
    assert grid_shape(16) == (4, 4) and grid_shape(20) == (4, 5)
    q = torch.full((100, 8), 0.3)
    assert torch.allclose(resample_queries(q, 196), torch.full((196, 8), 0.3))
    ramp = torch.arange(10.0).repeat(10)[:, None]  # x position of each anchor, row-major
    new = resample_queries(ramp, 196).reshape(14, 14)
    assert (new[:, 1:] >= new[:, :-1]).all() and torch.allclose(new[1:], new[:-1])
    assert torch.equal(resample_queries(q, 100), q)


def test_load_model_with_more_queries(tmp_path):
    from neuraltex.checkpoint import export_model

    cfg = ModelConfig(num_queries=16)
    model = build_model(cfg)
    export_model(tmp_path / "m.safetensors", model.state_dict(), cfg)
    more = load_model(tmp_path / "m.safetensors", num_queries=25)
    assert more.segmenter.num_queries == 25 and more.config.num_queries == 25
    assert more.segment(torch.rand(1, 3, 32, 32)).shape[1] == 25
    same = dict(more.named_parameters())
    for name, p in model.named_parameters():  # every weight but the queries is shared
        if "query_" not in name:
            assert torch.equal(p, same[name]), name
    with pytest.raises(KeyError):
        adapt_queries({"encoder.x": torch.zeros(1)}, 4)


def test_init_from_resamples_queries(tmp_path):
    from omegaconf import OmegaConf

    from neuraltex.checkpoint import export_model
    from train.setup import init_from

    src = build_model(ModelConfig(num_queries=16))
    export_model(tmp_path / "m.safetensors", src.state_dict(), ModelConfig(num_queries=16))
    dst = build_model(ModelConfig(num_queries=36))
    init_from(dst, tmp_path / "m.safetensors", OmegaConf.create({}))
    assert dst.segmenter.query_feat.shape[0] == 36
    theirs = src.state_dict()
    for name, p in dst.state_dict().items():
        if "query_" not in name:
            assert torch.equal(p, theirs[name]), name


def test_mask_upsampler_starts_as_bilinear_and_learns():
    from neuraltex.mask_upsampler import MaskUpsampler

    up = MaskUpsampler(3, 8, 2)
    feats, image = torch.randn(2, 8, 6, 5), torch.rand(2, 3, 24, 20)
    ref = F.interpolate(feats, size=(12, 10), mode="bilinear", align_corners=False)
    assert torch.equal(up(feats, image), ref)
    up(feats, image).square().sum().backward()
    assert up.fuse.weight.grad.abs().sum() > 0  # the zero-initialized correction learns
    with pytest.raises(ValueError):
        MaskUpsampler(3, 8, 3)


@pytest.mark.parametrize("stride", [1, 2])
def test_fine_mask_stride_segmenter(tiny, stride):
    from dataclasses import replace

    seg = SegmentationNet.from_config(replace(tiny.segmentation, mask_stride=stride))
    out = seg(torch.rand(2, 3, 40, 36), aux=True)
    assert out.logits.shape == (2, tiny.segmentation.num_queries, 40, 36)
    assert out.aux_logits[-1].shape[-2:] == (16, 16)  # deep supervision stays at stride 4
    out.logits.logsumexp(1).mean().backward()
    assert seg.upsampler.fuse.weight.grad.abs().sum() > 0


def test_mask_stride_is_a_model_setting_old_exports_default_to_4(tmp_path):
    from neuraltex.checkpoint import export_model
    from neuraltex.model import DEFAULT_MODEL

    assert load_model(DEFAULT_MODEL).segmenter.upsampler is None  # the shipped weights
    cfg = ModelConfig(mask_stride=2)
    model = build_model(cfg)
    export_model(tmp_path / "m.safetensors", model.state_dict(), cfg)
    back = load_model(tmp_path / "m.safetensors")
    assert back.segmenter.upsampler is not None and back.config.mask_stride == 2
    with pytest.raises(ValueError):
        ModelConfig.from_dict({"mask_stride": 3})


def test_profile_script_table_and_restores_what_it_labels(tmp_path):
    import sys
    from pathlib import Path

    import train.objective

    scripts = Path(__file__).resolve().parents[1] / "scripts"
    sys.path.insert(0, str(scripts))
    try:
        import profile_train
    finally:
        sys.path.pop(0)
    backward, loss = torch.Tensor.backward, train.objective.mask_supervision_loss
    md = tmp_path / "p.md"
    weights = Path(__file__).resolve().parents[1] / "neuraltex" / "weights" / "default.safetensors"
    threads = torch.get_num_threads()
    assert profile_train.main(["--recipes", "segmenter", "--sizes", "64", "--batch", "2",
                               "--steps", "1", "--set", "data.num_workers=0",
                               f"trainer.threads={threads + 1}",
                               "--init", str(weights), "--markdown", str(md)]) == 0
    assert torch.get_num_threads() == threads  # the caller's thread count is restored
    with pytest.raises(Exception, match="missing.safetensors"):  # --init is loaded
        profile_train.main(["--recipes", "segmenter", "--sizes", "64", "--batch", "2",
                            "--steps", "1", "--init", str(tmp_path / "missing.safetensors")])
    text = md.read_text()
    assert f"{threads + 1} thread(s)" in text  # the step ran on the threads it was given
    for row in ("| backward |", "| E_s transformer layers |", "| loss mask: pairwise cost |",
                "| optimizer |", "**other**"):
        assert row in text, row
    shares = [float(c.strip(" %")) for line in text.splitlines() if line.startswith("| ")
              and "%" in line for c in line.split("|")[2:-1] if c.strip()]
    assert abs(sum(shares) - 100) < 1.0  # exclusive shares add up
    assert torch.Tensor.backward is backward and train.objective.mask_supervision_loss is loss


def test_bench_compare_layouts_set_the_recipes_threads():
    """bench_model --compare: ``one-thread`` times every tree on 1 torch thread; ``shipped``
    on the threads its own recipe sets (here an override of the recipe: 2)."""
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    sys.path.insert(0, str(root / "scripts"))
    try:
        import bench_model
    finally:
        sys.path.pop(0)
    threads = torch.get_num_threads()
    try:
        for shipped, want in ((False, 1), (True, 2)):
            times = bench_model.recipe_step_times(
                str(root), "segmenter", 32, 2, 1,
                ["data.num_workers=0", "trainer.threads=2"] if shipped else
                ["data.num_workers=0"], shipped)
            assert len(times) == 1 and times[0][0] > 0
            assert torch.get_num_threads() == want
    finally:
        torch.set_num_threads(threads)


def test_bench_compare_ddp_layout_times_two_ranks_on_half_batches():
    """bench_model --compare --layout ddp: the old tree as shipped (one process), this tree
    under torchrun as 2 ranks of 1 thread on half the batch each (compare checks each
    child's world size)."""
    import argparse
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    sys.path.insert(0, str(root / "scripts"))
    try:
        import bench_model
    finally:
        sys.path.pop(0)
    args = argparse.Namespace(rounds=1, batch=2, round_steps=1, warmup=0, layout="ddp",
                              init=None, set=["data.num_workers=0"], set_new=[])
    r = bench_model.compare(str(root), "segmenter", 32, args)
    assert set(r) == {"old", "new"}
    assert all(wall > 0 and cpu > 0 for wall, cpu in r.values())


def test_bench_compare_starts_from_weights_after_warm_up_steps(monkeypatch):
    """bench_model --compare --init: the tree's own init_from loads the weights; --warmup
    steps run untimed."""
    import sys
    from pathlib import Path

    import train.loop
    import train.setup

    root = Path(__file__).resolve().parents[1]
    sys.path.insert(0, str(root / "scripts"))
    try:
        import bench_model
    finally:
        sys.path.pop(0)
    loaded, steps = [], []
    real_init, real_step = train.setup.init_from, train.loop.train_step
    monkeypatch.setattr(train.setup, "init_from",
                        lambda model, path, parts: loaded.append(path) or
                        real_init(model, path, parts))
    monkeypatch.setattr(train.loop, "train_step",
                        lambda *a, **k: steps.append(a[4]) or real_step(*a, **k))
    weights = str(root / "neuraltex" / "weights" / "default.safetensors")
    threads = torch.get_num_threads()
    try:
        times = bench_model.recipe_step_times(str(root), "segmenter", 32, 2, 1,
                                              ["data.num_workers=0"], init=weights, warmup=2)
    finally:
        torch.set_num_threads(threads)
    assert loaded == [weights] and steps == [1, 2, 3] and len(times) == 1


def test_amp_auto_is_bfloat16_only_where_the_device_runs_it():
    from train.setup import use_amp

    cpu = torch.device("cpu")
    assert use_amp(True, cpu) is True and use_amp(False, cpu) is False
    native = bool(torch.ops.mkldnn._is_mkldnn_bf16_supported())
    assert use_amp("auto", cpu) is native
    assert use_amp("auto", torch.device("cuda")) is True
