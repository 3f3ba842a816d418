"""DuelingQNet shapes, masked_argmax, and the .dqnw exporter/reader round trip (Python only)."""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np
import pytest
import torch

from dqn_dovs_py.export import (FORMAT_VERSION, MAGIC, WeightFileError, export_model, load_weights, main,
                             model_from_weights)
from dqn_dovs_py.model import DuelingQNet, masked_argmax

NORMALIZATION = {"v_max": 0.7, "w_max": 3.14159265, "distance_scale": 8.0}


def test_architecture_shapes_and_dueling_identity() -> None:
    torch.manual_seed(0)
    net = DuelingQNet()
    assert net.state_size == 408
    assert net.grid_out == 400  # 16 channels x 5 x 5
    assert net.trunk[0].in_features == 464
    q = net(torch.randn(4, 408))
    assert q.shape == (4, 8)
    # Dueling aggregation: the mean over actions of Q equals V.
    h = net.trunk(torch.cat([net.grid(torch.zeros(1, 1, 20, 20)).flatten(1), net.features(torch.zeros(1, 8))], 1))
    q0 = net(torch.zeros(1, 408))
    assert torch.allclose(q0.mean(dim=1), net.value(h).squeeze(1), atol=1e-6)
    with pytest.raises(ValueError, match=r"\[B, 408\]"):
        net(torch.zeros(4, 407))


def test_masked_argmax_never_picks_invalid() -> None:
    gen = torch.Generator().manual_seed(1)
    q = torch.randn(1000, 8, generator=gen)
    mask = torch.rand(1000, 8, generator=gen) < 0.4
    best = masked_argmax(q, mask)
    none_valid = ~mask.any(dim=1)
    assert (best[none_valid] == -1).all()
    chosen = best[~none_valid]
    assert mask[~none_valid].gather(1, chosen.unsqueeze(1)).all()
    expected = q.masked_fill(~mask, float("-inf")).max(dim=1).values[~none_valid]
    assert torch.equal(q[~none_valid].gather(1, chosen.unsqueeze(1)).squeeze(1), expected)
    # Ties go to the lowest index; -inf and NaN Q-values of valid actions are handled.
    assert masked_argmax(torch.tensor([1.0, 3.0, 3.0, 0.0]), torch.tensor([True, True, True, True])).item() == 1
    assert masked_argmax(torch.tensor([9.0, float("-inf"), float("-inf")]), torch.tensor([False, True, True])).item() == 1
    assert masked_argmax(torch.tensor([float("nan"), 2.0]), torch.tensor([True, True])).item() == 1


def test_export_round_trip_is_exact(tmp_path: Path) -> None:
    torch.manual_seed(2)
    net = DuelingQNet().eval()
    path = export_model(net, tmp_path / "net.dqnw", NORMALIZATION, "round trip")
    weights = load_weights(path)
    assert weights.format_version == FORMAT_VERSION
    assert (weights.grid_rows, weights.grid_cols, weights.feature_count, weights.action_count) == (20, 20, 8, 8)
    assert weights.normalization == pytest.approx(NORMALIZATION)
    assert list(weights.normalization) == list(NORMALIZATION)  # order kept
    assert weights.metadata == "round trip"
    rebuilt = model_from_weights(weights).eval()
    x = torch.randn(16, 408)
    with torch.no_grad():
        assert torch.equal(rebuilt(x), net(x))


def _exported(tmp_path: Path) -> bytes:
    torch.manual_seed(3)
    return export_model(DuelingQNet(), tmp_path / "net.dqnw", NORMALIZATION, "x").read_bytes()


def test_reader_names_the_field(tmp_path: Path) -> None:
    data = _exported(tmp_path)
    bad = tmp_path / "bad.dqnw"

    def error_field(blob: bytes) -> str:
        bad.write_bytes(blob)
        with pytest.raises(WeightFileError) as info:
            load_weights(bad)
        assert str(bad) in str(info.value)
        return info.value.field

    assert error_field(b"NOTAQNET" + data[8:]) == "magic"
    assert error_field(data[:8] + struct.pack("<I", 5) + data[12:]) == "format version"
    flipped = bytearray(data)
    flipped[len(data) // 2] ^= 0x01
    assert error_field(bytes(flipped)) == "checksum"
    for cut in (20, 100, len(data) // 2, len(data) - 5):
        bad.write_bytes(data[:cut])
        with pytest.raises(WeightFileError, match="truncated"):
            load_weights(bad)
    body = data[:-4] + b"\0\0"
    assert error_field(body + struct.pack("<I", zlib.crc32(body))) == "trailing bytes"
    with pytest.raises(WeightFileError, match="cannot open"):
        load_weights(tmp_path / "missing.dqnw")
    assert data.startswith(MAGIC)


def test_exporter_refuses_nan_and_empty_normalization(tmp_path: Path) -> None:
    net = DuelingQNet()
    with pytest.raises(ValueError, match="normalization"):
        export_model(net, tmp_path / "a.dqnw", {}, "")
    with pytest.raises(ValueError, match="not finite"):
        export_model(net, tmp_path / "a.dqnw", {"v_max": float("nan")}, "")
    with torch.no_grad():
        net.trunk[0].weight[0, 0] = float("nan")
    with pytest.raises(ValueError, match="NaN"):
        export_model(net, tmp_path / "a.dqnw", NORMALIZATION, "")
    assert not (tmp_path / "a.dqnw").exists()


def test_cli_exports_a_checkpoint(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    torch.manual_seed(4)
    net = DuelingQNet()
    ckpt = tmp_path / "ckpt.pt"
    torch.save({"model": net.state_dict(), "model_config": net.config(), "normalization": NORMALIZATION,
                "command": "python -m dqn_dovs_py.train --seed 4"}, ckpt)
    out = tmp_path / "net.dqnw"
    assert main([str(ckpt), str(out)]) == 0
    weights = load_weights(out)
    assert "python -m dqn_dovs_py.train --seed 4" in weights.metadata
    # A checkpoint without the trainer's provenance says so, key by key.
    assert "exported:" in weights.metadata and "source commit: unknown" in weights.metadata
    assert "config: unknown" in weights.metadata and "source revision" not in weights.metadata
    x = torch.randn(3, 408)
    with torch.no_grad():
        assert torch.equal(model_from_weights(weights)(x), net(x))
    # Without any normalisation the export fails and says how to fix it.
    torch.save({"model": net.state_dict()}, ckpt)
    assert main([str(ckpt), str(tmp_path / "other.dqnw")]) == 1
    assert "--normalization" in capsys.readouterr().err
    norm_file = tmp_path / "norm.json"
    norm_file.write_text('{"v_max": 0.7}')
    assert main([str(ckpt), str(tmp_path / "other.dqnw"), "--normalization", str(norm_file)]) == 0
    assert load_weights(tmp_path / "other.dqnw").normalization == pytest.approx({"v_max": 0.7})
    assert np.isfinite(list(load_weights(out).normalization.values())).all()
