"""Box evaluations in forked workers (roa.proof._parallel_boxes): the same verdict, boxes and
proved counts as in one process, and bad worker counts refused."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import roa
from roa.errors import RoaInputError
from roa.model._linearisation import lyapunov_matrix
from roa.proof._validate import validate_level

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "examples" / "systems"))
import pendulum_nn  # noqa: E402

sys.path.pop(0)


@pytest.mark.parametrize("system", [pendulum_nn.SYSTEM, pendulum_nn.SYSTEM_RELU],
                         ids=["tanh", "relu"])  # fmt: skip
def test_workers_give_the_same_verdict_and_boxes(system):
    P = lyapunov_matrix(system)
    V = roa.QuadraticLyapunov(P, np.zeros(system.n))
    # a level inside the basin (certified) and one far past it (refuted by a witness)
    for level in (0.5 * float(np.min(np.diag(P))), 1e3):
        one = validate_level(system, V, level, batch=64)
        two = validate_level(system, V, level, batch=64, workers=2)
        assert one.status == two.status
        assert one.boxes == two.boxes
        assert one.meta.get("proved_boxes") == two.meta.get("proved_boxes")
        assert one.witness == two.witness


@pytest.mark.parametrize("workers", [0, -1, 1.5, "2"])
def test_bad_worker_counts_are_refused(workers):
    s = pendulum_nn.SYSTEM
    V = roa.QuadraticLyapunov(lyapunov_matrix(s), np.zeros(s.n))
    with pytest.raises(RoaInputError, match="workers"):
        validate_level(s, V, 0.1, workers=workers)
