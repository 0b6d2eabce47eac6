"""Lazy reshuffle and equivariance terms (``loss.reshuffle_every``, ``loss.equivariance_every``):
computed on every k-th step only, weighted by k."""

from dataclasses import replace

import pytest
import torch

from neuraltex.data.generator import generate
from neuraltex.model import build_model
from neuraltex.model_config import ModelConfig
from train.loss_config import LossConfig
from train.objective import CriticObjective, GeneratorObjective


def test_lazy_terms_fall_on_every_kth_step_with_weight_k():
    loss = LossConfig(equivariance_every=4, reshuffle_every=2)
    eq = [loss.at(s).equivariance for s in range(8)]
    rs = [loss.at(s).reshuffle for s in range(8)]
    assert eq == [0, 0, 0, 4, 0, 0, 0, 4]  # steps 4 and 8 done: a run's logged steps
    assert rs == [0, 2, 0, 2, 0, 2, 0, 2]
    assert sum(eq) == sum(rs) == 8  # the expected weight is 1 a step
    assert LossConfig().at(5).equivariance == LossConfig().at(5).reshuffle == 1.0
    for bad in ({"equivariance_every": 0}, {"reshuffle_every": -1}, {"r1_every": -2}):
        with pytest.raises(ValueError, match="positive whole number"):
            LossConfig(**bad)


@pytest.fixture(scope="module")
def objective():
    torch.manual_seed(0)
    model, d, dp = build_model(ModelConfig(), with_critics=True)
    loss = LossConfig(lpips_backbone="random", equivariance_every=2, reshuffle_every=2)
    critics = CriticObjective(d, dp, loss, image_size=32)
    images = torch.stack([torch.from_numpy(generate(i, 0, 32).image).permute(2, 0, 1)
                          for i in range(4)]).float()
    # eval: spectral norm's power iteration and batch-norm statistics would move between calls
    return GeneratorObjective(model, critics, loss).eval(), critics.eval(), images


def test_a_due_step_adds_the_terms_times_k_and_a_skipped_step_computes_none(objective):
    gen, _, images = objective
    due = gen.loss.at(1)
    assert (due.reshuffle, due.equivariance) == (2.0, 2.0)
    once = replace(due, reshuffle=1.0, equivariance=1.0)
    skipped = gen.loss.at(2)
    with torch.no_grad():
        a = gen(images, None, once, torch.Generator().manual_seed(3))
        b = gen(images, None, due, torch.Generator().manual_seed(3))
        c = gen(images, None, skipped, torch.Generator().manual_seed(3))
    lazy = (due.texture * a.logs["texture"] + due.pgan * a.logs["pgan"]
            + due.csis * a.logs["csis"] + a.logs["recon_t"])
    assert a.logs["texture"] == b.logs["texture"] and a.logs["csis"] == b.logs["csis"]
    assert float(b.loss) == pytest.approx(float(a.loss) + lazy, rel=1e-5)
    assert c.reshuffled is None and not {"texture", "pgan", "csis", "recon_t"} & set(c.logs)
    assert float(c.loss) == pytest.approx(float(a.loss) - lazy, rel=1e-5)


def test_the_critics_weight_d_p_by_k_and_keep_the_lazy_r1_of_d_p_without_a_reshuffle(
        objective):
    gen, critics, images = objective
    with torch.no_grad():
        out = gen(images, None, gen.loss.at(1), torch.Generator().manual_seed(0))
    recon, fake = out.recon, out.reshuffled
    one, l1 = critics(images, recon, fake, 1, torch.Generator().manual_seed(5))
    two, l2 = critics(images, recon, fake, 1, torch.Generator().manual_seed(5), dp_weight=2.0)
    assert float(two.detach()) == pytest.approx(float(one.detach()) + l1["dp"], rel=1e-5)
    # step 0 is an R1 step (r1_every 16): without fakes D_p still gets its R1 on real crops
    _, logs = critics(images, recon, None, 0, torch.Generator().manual_seed(5))
    assert "dp" not in logs and logs["r1_p"] >= 0 and "r1" in logs
    _, logs = critics(images, recon, None, 1, torch.Generator().manual_seed(5))
    assert set(logs) == {"d"}


def test_a_run_with_lazy_terms_logs_them_on_the_steps_that_carry_them(tmp_path):
    """The trainer end to end (generator and critic steps, GANs on): the lazy terms and D_p
    appear in the logs of the steps that end a period only."""
    from hydra import compose, initialize_config_dir

    from tests.test_train import FAST, ROOT
    from train.loop import run

    def logs(steps: int) -> dict:
        with initialize_config_dir(config_dir=str(ROOT / "configs"), version_base="1.3"):
            cfg = compose(config_name="train", overrides=[
                f"run_dir={tmp_path / str(steps)}", *FAST, f"trainer.max_steps={steps}",
                "trainer.export=null", "loss.equivariance_every=2", "loss.reshuffle_every=4",
                # random LPIPS trunk: the fallback's one warning is test_losses.py's to see
                "loss.lpips_backbone=random"])
        return run(cfg)

    four, three = logs(4), logs(3)
    assert {"texture", "pgan", "dp", "csis", "recon_t"} <= set(four)
    assert not {"texture", "pgan", "dp", "csis", "recon_t"} & set(three)
    assert all(torch.isfinite(torch.tensor(v)) for v in four.values())
