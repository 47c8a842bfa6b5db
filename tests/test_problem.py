"""The identification problem's pieces: priors, losses, the box (active set) and pooling."""

from __future__ import annotations

import ast
import importlib
import pkgutil
from pathlib import Path

import numpy as np
import pytest

import mocap_mj
from mocap_mj.errors import MocapError
from mocap_mj.solve.lm import bounded_step
from mocap_mj.solve.losses import LOSS_NAMES, loss_named
from mocap_mj.solve.priors import LinearGaussianPrior, Prior, total_prior, weak_prior
from mocap_mj.solve.problem import TrialData, check_bounds, pool, unpool


def test_linear_gaussian_prior_gradient_and_hessian() -> None:
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=(4, 6)), rng.normal(0, 0.01, 4)
    prior = LinearGaussianPrior(a, b, rng.uniform(0.005, 0.05, 4), noise=0.002)
    assert isinstance(prior, Prior)
    theta, h = rng.normal(0, 0.01, 6), 1e-6
    fd = [(prior.cost(theta + h * e) - prior.cost(theta - h * e)) / (2 * h) for e in np.eye(6)]
    np.testing.assert_allclose(prior.gradient(theta), fd, rtol=1e-6, atol=1e-12)
    step = rng.normal(0, 0.01, 6)  # quadratic: the Hessian predicts the change exactly
    change = prior.cost(theta + step) - prior.cost(theta)
    predicted = prior.gradient(theta) @ step + 0.5 * step @ prior.hessian() @ step
    assert change == pytest.approx(predicted, rel=1e-9)


def test_weak_prior_is_the_isotropic_penalty() -> None:
    theta0 = np.linspace(0.1, 0.2, 5)
    theta = theta0 + np.array([0.01, -0.02, 0.0, 0.03, 0.005])
    prior = weak_prior(theta0, sigma=0.05, noise=0.001)
    lam = (0.001 / 0.05) ** 2
    assert prior.cost(theta) == pytest.approx(0.5 * lam * np.sum((theta - theta0) ** 2), rel=1e-12)
    np.testing.assert_array_equal(prior.hessian(), lam * np.eye(5))
    free = np.array([0, 3])
    cost, g, hess = total_prior([prior, prior], theta, free)
    assert cost == pytest.approx(2 * prior.cost(theta))
    np.testing.assert_allclose(g, 2 * lam * (theta - theta0)[free])
    np.testing.assert_allclose(hess, 2 * lam * np.eye(2))
    with pytest.raises(MocapError):
        LinearGaussianPrior(np.eye(2), np.zeros(2), np.array([0.01, 0.0]))


@pytest.mark.parametrize("name", LOSS_NAMES)
def test_loss_weights_are_the_derivative_over_distance(name: str) -> None:
    loss = loss_named(name)
    d = np.array([[0.0005, 0.002, 0.01, 0.05]])
    present = np.array([[True, True, True, False]])
    c, h = 0.003, 1e-9
    w = loss.weights(d, present, c)
    assert w[0, 3] == 0.0
    for j in range(3):
        one = np.zeros_like(present)
        one[0, j] = True
        dp, dm = d.copy(), d.copy()
        dp[0, j] += h
        dm[0, j] -= h
        rho_prime = (loss.value(dp, one, c) - loss.value(dm, one, c)) / (2 * h)
        assert w[0, j] == pytest.approx(rho_prime / d[0, j], rel=1e-5)
    with pytest.raises(MocapError, match="l2, huber, cauchy"):
        loss_named("l1")


def test_bounded_step_stays_in_the_box() -> None:
    # Random systems, starts and boxes: the step never leaves the box, and a parameter held
    # at a bound is one whose unconstrained step pointed outward.
    rng = np.random.default_rng(3)
    for _ in range(200):
        p = int(rng.integers(1, 8))
        j = rng.normal(size=(p + 3, p))
        s = j.T @ j
        rhs = rng.normal(size=p)
        lower = -rng.uniform(0, 1, p)
        upper = rng.uniform(0, 1, p)
        theta = rng.uniform(lower, upper)
        snap = rng.integers(0, 3, p)  # some starts exactly on a bound
        theta = np.where(snap == 1, lower, np.where(snap == 2, upper, theta))
        dth, held = bounded_step(s, rhs, s + 1e-3 * np.eye(p), theta, lower, upper, 1e-12)
        new = theta + dth
        assert np.all(new >= lower) and np.all(new <= upper)
        assert np.all(dth[held] == 0.0)
        assert np.all((theta[held] == lower[held]) | (theta[held] == upper[held]))


def test_bounds_are_checked_and_pooling_round_trips() -> None:
    lo, hi = check_bounds(3, None, np.array([1.0, 2.0, 3.0]))
    assert np.all(np.isneginf(lo)) and hi[2] == 3.0
    with pytest.raises(MocapError, match=r"lower\[1\]"):
        check_bounds(2, np.array([0.0, 2.0]), np.array([1.0, 1.0]))
    trials = [
        TrialData(f"t{i}", np.full((n, 2, 3), float(i)), np.arange(n) * 0.01)
        for i, n in enumerate((4, 3))
    ]
    used = [np.array([True, False, True, True]), np.array([False, True, True])]
    q = [np.arange(4.0)[:, None], np.arange(3.0)[:, None] + 10]
    markers, pooled = pool(trials, q, used)
    assert markers.shape == (5, 2, 3) and pooled[:, 0].tolist() == [0, 2, 3, 11, 12]
    back = unpool(pooled, used)
    np.testing.assert_array_equal(back[0][used[0]], q[0][used[0]])
    assert np.isnan(back[0][1, 0]) and np.isnan(back[1][0, 0])


def _packages() -> list[str]:
    """mocap_mj and every module of it (``__main__`` aside), the add-on packages and their
    subpackages."""
    names = []
    for top in ("mocap_mj", "mocap_synth", "mocap_viewer"):
        pkg = importlib.import_module(top)
        names.append(top)
        for info in pkgutil.walk_packages(pkg.__path__, f"{top}."):
            if info.ispkg or (top == "mocap_mj" and not info.name.endswith("__main__")):
                names.append(info.name)
    return names


@pytest.mark.parametrize("module", _packages())
def test_every_all_name_resolves(module: str) -> None:
    mod = importlib.import_module(module)
    missing = [n for n in getattr(mod, "__all__", []) if not hasattr(mod, n)]
    assert not missing, f"{module}.__all__ names missing: {missing}"


def test_library_does_not_import_the_command_line_layer() -> None:
    # Only cli.py, __main__.py and commands/ may import the CLI layer (docs/architecture.md).
    root = Path(mocap_mj.__file__).parent
    offenders = []
    for path in root.rglob("*.py"):
        rel = path.relative_to(root).as_posix()
        if rel.startswith("commands/") or rel in ("cli.py", "__main__.py"):
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module is not None:
                if {"cli", "commands"} & set(node.module.split(".")):
                    offenders.append(f"{rel}: from {'.' * node.level}{node.module}")
    assert not offenders, offenders
