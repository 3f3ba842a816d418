"""The .onnx the exporter writes beside a .dqnw against the planner's Eigen inference: max |dQ| < 1e-4, the same
greedy actions, metadata that names the weight file, and clear errors from the converter.

onnxruntime runs the .onnx; the C++ tool dqn_dovs_qnet_eval (in $DQN_DOVS_BIN_DIR, as for test_qnet_parity.py) runs
the .dqnw. States from the training environment need the compiled dqn_dovs_py._core (skipped without it).
"""

from __future__ import annotations

import hashlib
import json
import struct
import subprocess
from pathlib import Path

import numpy as np
import onnx
import onnxruntime as ort
import pytest
import torch

from built_tools import built_tool
from qnet_samples import random_net, random_states
from dqn_dovs_py.export import (FORMAT_VERSION, ONNX_OPSET, OnnxExportError, export_model, load_weights, main,
                                onnx_from_weights, read_onnx_metadata)
from dqn_dovs_py.model import DuelingQNet, masked_argmax

ROOT = Path(__file__).resolve().parents[2]
MODELS = ROOT / "models"
NORMALIZATION = {"v_max": 0.7, "w_max": 3.14159265, "goal_distance_scale": 8.0}
TOLERANCE = 1e-4


def _eigen_q(weights: Path, states: np.ndarray, tmp_path: Path) -> np.ndarray:
    states_file, out_file = tmp_path / "states.f32", tmp_path / "q.f32"
    states.astype("<f4").tofile(states_file)
    result = subprocess.run([str(built_tool("dqn_dovs_qnet_eval")), str(weights), str(states_file), str(out_file)],
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, f"dqn_dovs_qnet_eval failed: {result.stderr}"
    return np.fromfile(out_file, dtype="<f4").reshape(len(states), 8)


def _onnx_q(model: Path, states: np.ndarray) -> np.ndarray:
    options = ort.SessionOptions()
    options.intra_op_num_threads = 1
    options.inter_op_num_threads = 1
    session = ort.InferenceSession(str(model), options, providers=["CPUExecutionProvider"])
    (q,) = session.run(["q_values"], {"state": states.astype(np.float32)})
    return q


def _assert_same_function(onnx_path: Path, weights: Path, states: np.ndarray, tmp_path: Path) -> float:
    q_onnx = _onnx_q(onnx_path, states)
    q_eigen = _eigen_q(weights, states, tmp_path)
    assert q_onnx.shape == q_eigen.shape == (len(states), 8)
    # A degenerate network (constant Q) would make equality prove little.
    assert q_eigen.std(axis=0).min() > 1e-3
    max_diff = float(np.abs(q_onnx - q_eigen).max())
    assert max_diff < TOLERANCE, f"max |dQ| onnx vs eigen = {max_diff}"
    # Greedy actions, unmasked and under random masks: identical wherever the best two are not within the
    # tolerance of each other (then the difference above cannot reorder them), which must be nearly every state.
    rng = np.random.default_rng(7)
    for mask in (np.ones_like(q_eigen, dtype=bool), rng.random(q_eigen.shape) < 0.6):
        top2 = np.sort(np.where(mask, q_eigen, -np.inf), axis=1)[:, -2:]
        clear = mask.sum(axis=1) < 2  # no choice to get wrong but the -1 or the single valid action
        clear[~clear] = (top2[~clear, 1] - top2[~clear, 0]) > 2 * TOLERANCE
        assert clear.mean() > 0.95
        a_onnx = masked_argmax(torch.from_numpy(q_onnx), torch.from_numpy(mask)).numpy()
        a_eigen = masked_argmax(torch.from_numpy(q_eigen), torch.from_numpy(mask)).numpy()
        assert np.array_equal(a_onnx[clear], a_eigen[clear])
    print(f"{onnx_path.name}: {len(states)} states, max |dQ| onnx vs eigen = {max_diff:.3g}")
    return max_diff


def _assert_metadata_matches(onnx_path: Path, weights_path: Path) -> None:
    props = read_onnx_metadata(onnx_path)
    weights = load_weights(weights_path)
    data = weights_path.read_bytes()
    assert props["dqn_dovs.weights_sha256"] == hashlib.sha256(data).hexdigest()
    assert props["dqn_dovs.weights_crc32"] == f"0x{struct.unpack('<I', data[-4:])[0]:08x}"
    assert props["dqn_dovs.weights_file"] == weights_path.name
    assert props["dqn_dovs.weight_format_version"] == str(FORMAT_VERSION) == str(weights.format_version)
    assert props["dqn_dovs.state_layout"] == "grid20x20+features8"
    assert [int(props[f"dqn_dovs.{k}"]) for k in ("grid_rows", "grid_cols", "feature_count", "action_count")] == \
        [weights.grid_rows, weights.grid_cols, weights.feature_count, weights.action_count]
    # Exactly the float32 values of the file, in the file's order.
    normalization = json.loads(props["dqn_dovs.normalization"])
    assert list(normalization.items()) == list(weights.normalization.items())
    assert props["dqn_dovs.metadata"] == weights.metadata
    assert props["dqn_dovs.input_normalization"].startswith("by the caller")
    # The graph's interface: state [batch, 408] float32 -> q_values [batch, 8] float32, a supported opset.
    proto = onnx.load(str(onnx_path))
    assert max(o.version for o in proto.opset_import if o.domain in ("", "ai.onnx")) == ONNX_OPSET
    (inp,), (out,) = proto.graph.input, proto.graph.output
    for value, name, width in ((inp, "state", 408), (out, "q_values", 8)):
        assert value.name == name
        assert value.type.tensor_type.elem_type == onnx.TensorProto.FLOAT
        batch, columns = value.type.tensor_type.shape.dim
        assert batch.dim_param and not batch.HasField("dim_value"), "the batch axis must be dynamic"
        assert columns.dim_value == width


@pytest.mark.parametrize("seed", [0, 1])
def test_fresh_network_onnx_matches_eigen(tmp_path: Path, seed: int) -> None:
    net = random_net(seed)
    weights = export_model(net, tmp_path / "net.dqnw", NORMALIZATION, f"onnx parity seed {seed}")
    onnx_path = tmp_path / "net.onnx"
    assert onnx_path.is_file(), "export_model writes the .onnx beside the .dqnw by default"
    _assert_metadata_matches(onnx_path, weights)
    states = random_states(500, seed + 200, edge_rows=True)
    _assert_same_function(onnx_path, weights, states, tmp_path)
    # The same function as the PyTorch network it came from, and the batch axis is dynamic (one state alone).
    with torch.no_grad():
        q_torch = net(torch.from_numpy(states)).numpy()
    assert float(np.abs(_onnx_q(onnx_path, states) - q_torch).max()) < TOLERANCE
    np.testing.assert_allclose(_onnx_q(onnx_path, states[5:6]), _onnx_q(onnx_path, states)[5:6], atol=1e-6)


def test_export_without_onnx_writes_only_the_weight_file(tmp_path: Path) -> None:
    export_model(random_net(2), tmp_path / "net.dqnw", NORMALIZATION, "no onnx", onnx=False)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["net.dqnw"]
    with pytest.raises(ValueError, match="suffix"):
        export_model(random_net(2), tmp_path / "net.onnx", NORMALIZATION, "")
    ckpt = tmp_path / "ckpt.pt"
    torch.save({"model": random_net(2).state_dict(), "normalization": NORMALIZATION}, ckpt)
    assert main([str(ckpt), str(tmp_path / "cli.dqnw"), "--no-onnx"]) == 0
    assert not (tmp_path / "cli.onnx").exists()
    assert main([str(ckpt), str(tmp_path / "cli.dqnw")]) == 0
    _assert_metadata_matches(tmp_path / "cli.onnx", tmp_path / "cli.dqnw")


@pytest.mark.parametrize("name", ["dqn_dovs", "curriculum"])
def test_shipped_onnx_is_current_and_matches_eigen(tmp_path: Path, name: str) -> None:
    weights, shipped = MODELS / f"{name}.dqnw", MODELS / f"{name}.onnx"
    # The committed .onnx was converted from the committed .dqnw (regenerate: --onnx-from models/NAME.dqnw).
    _assert_metadata_matches(shipped, weights)
    converted = onnx_from_weights(weights, tmp_path / f"{name}.onnx")
    assert read_onnx_metadata(converted) == read_onnx_metadata(shipped)
    states = random_states(400, 300, edge_rows=True)
    _assert_same_function(shipped, weights, states, tmp_path)
    np.testing.assert_array_equal(_onnx_q(converted, states), _onnx_q(shipped, states))


def test_shipped_onnx_matches_eigen_on_environment_states(core, tmp_path: Path) -> None:
    env = core.VecEnv(2, 4242, perfect_info=False, threads=1)
    env.set_stage(4.0, 8.0, 4, 10, "both")
    state, mask = env.reset()
    rng = np.random.default_rng(5)
    collected = []
    for _ in range(150):
        collected.append(np.asarray(state, dtype=np.float32))
        valid = [np.flatnonzero(m) for m in np.asarray(mask, dtype=bool)]
        actions = np.array([rng.choice(v) if len(v) else -1 for v in valid], dtype=np.int64)
        out = env.step(actions)
        state, mask = out["state"], out["mask"]
    states = np.concatenate(collected)
    assert states.shape == (300, 408) and np.isfinite(states).all()
    # Real states vary in the grid and the features (a stuck environment would test one input many times).
    assert len(np.unique(states, axis=0)) > 100
    _assert_same_function(MODELS / "dqn_dovs.onnx", MODELS / "dqn_dovs.dqnw", states, tmp_path)


def _convert(args: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    rc = main(args)
    return rc, capsys.readouterr().err


def test_converter_reports_bad_inputs(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    good = export_model(random_net(3), tmp_path / "good.dqnw", NORMALIZATION, "converter errors", onnx=False)
    out = tmp_path / "out.onnx"

    missing = tmp_path / "missing.dqnw"
    rc, err = _convert(["--onnx-from", str(missing), "--onnx-out", str(out)], capsys)
    assert rc == 1 and str(missing) in err and "cannot open" in err

    corrupt = tmp_path / "corrupt.dqnw"
    data = bytearray(good.read_bytes())
    data[len(data) // 2] ^= 0x10
    corrupt.write_bytes(bytes(data))
    rc, err = _convert(["--onnx-from", str(corrupt), "--onnx-out", str(out)], capsys)
    assert rc == 1 and str(corrupt) in err and "checksum" in err

    # An .onnx given where the weight file belongs is refused at the magic.
    assert main(["--onnx-from", str(good), "--onnx-out", str(out)]) == 0
    capsys.readouterr()
    rc, err = _convert(["--onnx-from", str(out), "--onnx-out", str(tmp_path / "again.onnx")], capsys)
    assert rc == 1 and "magic" in err and str(out) in err

    unwritable = tmp_path / "no_such_dir" / "x.onnx"
    rc, err = _convert(["--onnx-from", str(good), "--onnx-out", str(unwritable)], capsys)
    assert rc == 1 and str(unwritable) in err and "cannot write" in err

    with pytest.raises(SystemExit):
        main(["--onnx-from", str(good), "ckpt.pt"])  # a conversion takes no checkpoint
    capsys.readouterr()
    assert not (tmp_path / "again.onnx").exists() and not unwritable.parent.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["corrupt.dqnw", "good.dqnw", "out.onnx"]


def test_reading_a_corrupt_onnx_names_the_file(tmp_path: Path) -> None:
    onnx_path = export_model(random_net(4), tmp_path / "net.dqnw", NORMALIZATION, "corrupt onnx").with_suffix(".onnx")
    assert read_onnx_metadata(onnx_path)["dqn_dovs.metadata"] == "corrupt onnx"
    truncated = tmp_path / "truncated.onnx"
    truncated.write_bytes(onnx_path.read_bytes()[: onnx_path.stat().st_size // 2])
    with pytest.raises(OnnxExportError, match=r"onnx file '.*truncated\.onnx': not a valid ONNX model"):
        read_onnx_metadata(truncated)
    with pytest.raises(OnnxExportError, match=r"onnx file '.*missing\.onnx': cannot open"):
        read_onnx_metadata(tmp_path / "missing.onnx")
    # A valid ONNX model that did not come from the exporter.
    foreign = onnx.load(str(onnx_path))
    del foreign.metadata_props[:]
    onnx.save(foreign, str(tmp_path / "foreign.onnx"))
    with pytest.raises(OnnxExportError, match="no dqn_dovs metadata"):
        read_onnx_metadata(tmp_path / "foreign.onnx")


def _fresh_network(seed: int, **shape: int) -> DuelingQNet:
    """A new network of `shape` (DuelingQNet's arguments) with its biases moved off PyTorch's small defaults, so
    every layer's bias matters in a comparison."""
    torch.manual_seed(seed)
    net = DuelingQNet(**shape).eval()
    with torch.no_grad():
        for module in net.modules():
            if isinstance(module, (torch.nn.Conv2d, torch.nn.Linear)):
                module.bias.add_(0.3 * torch.randn_like(module.bias))
    return net


def _assert_onnx_eigen_and_torch_agree(net: DuelingQNet, stem: Path, states: np.ndarray, tmp_path: Path) -> None:
    """The exported `stem`.onnx and `stem`.dqnw compute `net`'s function on `states`."""
    onnx_path, weights_path = stem.with_suffix(".onnx"), stem.with_suffix(".dqnw")
    _assert_same_function(onnx_path, weights_path, states, tmp_path)
    with torch.no_grad():
        q_torch = net(torch.from_numpy(states)).numpy()
    assert float(np.abs(_onnx_q(onnx_path, states) - q_torch).max()) < TOLERANCE


def test_a_network_of_three_grid_channels_exports_and_matches_eigen(tmp_path: Path) -> None:
    """A version 2 file (docs/dovs.md "Grid channels"): its ONNX model reads [N, 1208] and is the same function as
    the Eigen network of the .dqnw, which reads the channels the way PyTorch does (channel-major)."""
    net = _fresh_network(5, grid_channels=3)
    export_model(net, tmp_path / "wide.dqnw", NORMALIZATION, "three channels")
    weights = load_weights(tmp_path / "wide.dqnw")
    assert (weights.format_version, weights.grid_channels) == (2, 3)
    props = read_onnx_metadata(tmp_path / "wide.onnx")
    assert props["dqn_dovs.state_layout"] == "grid3x20x20+features8"
    assert props["dqn_dovs.grid_channels"] == "3" and props["dqn_dovs.weight_format_version"] == "2"
    rng = np.random.default_rng(11)
    states = np.concatenate([np.where(rng.random((300, 1200)) < 0.7, 1.0, -1.0),
                             rng.uniform(-1.0, 1.0, size=(300, 8))], axis=1).astype(np.float32)
    _assert_onnx_eigen_and_torch_agree(net, tmp_path / "wide", states, tmp_path)


def test_a_network_that_reads_the_previous_choice_exports_and_matches_eigen(tmp_path: Path) -> None:
    """17 feature inputs (docs/dovs.md "The previous action"): its ONNX model reads [N, 417] and is the same function
    as the Eigen network of the .dqnw, whose feature stream reads the one-hot after the 8 features."""
    net = _fresh_network(6, feature_count=17)
    export_model(net, tmp_path / "prev.dqnw", NORMALIZATION, "previous choice")
    weights = load_weights(tmp_path / "prev.dqnw")
    assert (weights.format_version, weights.feature_count) == (1, 17)
    props = read_onnx_metadata(tmp_path / "prev.onnx")
    assert props["dqn_dovs.state_layout"] == "grid20x20+features17"
    rng = np.random.default_rng(12)
    states = np.concatenate([np.where(rng.random((300, 400)) < 0.7, 1.0, -1.0), rng.uniform(-1.0, 1.0, size=(300, 8)),
                             np.eye(9)[rng.integers(0, 9, size=300)]], axis=1).astype(np.float32)
    _assert_onnx_eigen_and_torch_agree(net, tmp_path / "prev", states, tmp_path)
