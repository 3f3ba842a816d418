"""python -m dqn_dovs_py.average_weights: the parameters of weight files of one layout, averaged into a file the C++
planner runs; mismatched files refused by name."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import torch

from built_tools import built_tool
from qnet_samples import random_net, random_states
from dqn_dovs_py.average_weights import average, main
from dqn_dovs_py.export import export_model, load_weights, model_from_weights
from dqn_dovs_py.model import DuelingQNet

NORMALIZATION = {"v_max": 0.7, "w_max": 3.14159265, "goal_distance_scale": 8.0}
ROOT = Path(__file__).resolve().parents[2]


def _export(net, path: Path, normalization=NORMALIZATION) -> str:
    export_model(net, path, normalization, "test network", onnx=False)
    return str(path)


def test_the_average_of_networks_is_the_mean_of_their_parameters_and_runs_in_cpp(tmp_path):
    a, b = random_net(0), random_net(1)
    fa, fb = _export(a, tmp_path / "a.dqnw"), _export(b, tmp_path / "b.dqnw")
    out = tmp_path / "mix.dqnw"
    assert main(["--out", str(out), "--weights", "3,1", fa, fb]) == 0
    mixed = load_weights(out)
    assert "average of 2 weight files" in mixed.metadata and "0.75 x" in mixed.metadata
    for la, lb, lm in zip(load_weights(fa).layers, load_weights(fb).layers, mixed.layers):
        if la.weight is None:
            continue
        np.testing.assert_allclose(lm.weight, 0.75 * la.weight + 0.25 * lb.weight, rtol=0, atol=1e-6)
        np.testing.assert_allclose(lm.bias, 0.75 * la.bias + 0.25 * lb.bias, rtol=0, atol=1e-6)
    # The C++ planner's inference of the averaged file is the PyTorch network with the averaged parameters.
    states = random_states(16, seed=3)
    expected = model_from_weights(mixed).eval()(torch.from_numpy(states)).detach().numpy()
    states.astype("<f4").tofile(tmp_path / "states.f32")
    run = subprocess.run([str(built_tool("dqn_dovs_qnet_eval")), str(out), str(tmp_path / "states.f32"),
                          str(tmp_path / "q.f32")], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    q = np.fromfile(tmp_path / "q.f32", dtype="<f4").reshape(-1, 8)
    assert np.abs(q - expected).max() < 1e-4
    # A network averaged with itself is itself.
    same = average([fa, fa])
    for la, ls in zip(load_weights(fa).layers, same.layers):
        if la.weight is not None:
            np.testing.assert_array_equal(ls.weight, la.weight)


def test_files_that_do_not_average_are_refused_by_name(tmp_path):
    fa = _export(random_net(0), tmp_path / "a.dqnw")
    other_norm = _export(random_net(1), tmp_path / "norm.dqnw", {**NORMALIZATION, "v_max": 0.5})
    wider = tmp_path / "wide.dqnw"
    export_model(DuelingQNet(trunk_hidden=(64,)).eval(), wider, NORMALIZATION, "other layout", onnx=False)
    for files, extra, words in (([fa, other_norm], [], "state normalisation"),
                                ([fa, str(wider)], [], "layout"),
                                ([fa, fa], ["--weights", "1"], "1 weights for 2 files"),
                                ([fa, fa], ["--weights", "1,-1"], "non-negative"),
                                ([fa, str(tmp_path / "missing.dqnw")], [], "missing.dqnw")):
        proc = subprocess.run([sys.executable, "-m", "dqn_dovs_py.average_weights", "--out", str(tmp_path / "x.dqnw"),
                               *extra, *files], capture_output=True, text=True, timeout=120,
                              env={"PYTHONPATH": str(ROOT / "python"), "PATH": "/usr/bin:/bin"})
        assert proc.returncode == 2, proc.stderr
        assert words in proc.stderr, proc.stderr
    assert not (tmp_path / "x.dqnw").exists()
