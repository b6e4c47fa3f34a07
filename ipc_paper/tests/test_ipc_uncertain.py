"""The IPC with the plant's mass ratio uncertain (the controller designed for delta = 1)."""

from __future__ import annotations

import numpy as np
import pytest

from ipc_paper.system import (
    closed_loop,
    closed_loop_uncertain,
    to_flat,
    transformed,
    transformed_uncertain,
)


def test_nominal_plant_is_the_designed_loop():
    X = np.random.default_rng(0).uniform(-0.5, 0.5, (20, 4))
    assert np.allclose(transformed_uncertain().nominal().f(X), transformed().f(X), atol=1e-13)
    assert np.allclose(closed_loop_uncertain().nominal().f(X), closed_loop().f(X), atol=1e-13)


@pytest.mark.parametrize("delta_plant", [0.5, 0.8, 2.0])
def test_flat_loop_is_the_physical_loop_pushed_through_the_coordinate_map(delta_plant):
    """xi' = D(to_flat)(x) f(x): the flat loop with a mismatched plant equals the physical loop
    (the model's accelerations at delta_plant, the law at delta = 1) pushed through (2.2),
    by central differences (step 1e-6, tolerance 1e-6)."""
    phys = closed_loop_uncertain().at(delta_plant=delta_plant)
    flat = transformed_uncertain().at(delta_plant=delta_plant)
    rng = np.random.default_rng(1)
    for x in rng.uniform([-1, -1, -1.0, -1], [1, 1, 1.0, 1], (10, 4)):
        h = 1e-6
        J = np.stack([(to_flat(x + h * e) - to_flat(x - h * e)) / (2 * h) for e in np.eye(4)],
                     axis=1)  # fmt: skip
        pushed = J @ phys.f(x[None])[0]
        assert np.allclose(flat.f(to_flat(x)[None])[0], pushed, atol=1e-6, rtol=1e-6)
