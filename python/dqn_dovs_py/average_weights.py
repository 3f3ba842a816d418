"""Averages the parameters of weight files of one network layout (a "model soup" of fine-tuned runs that start from
the same network, or an interpolation between a network and such an average), into a new weight file.

    PYTHONPATH=python .venv/bin/python -m dqn_dovs_py.average_weights --out soup.dqnw A.dqnw B.dqnw C.dqnw
    PYTHONPATH=python .venv/bin/python -m dqn_dovs_py.average_weights --out mix.dqnw --weights 0.7,0.3 A.dqnw soup.dqnw

Every file must have the same layout (format version, grid, features, actions, every layer's shape) and the same
state normalisation; otherwise the average would mean nothing and the tool refuses, naming the file and what
differs. The result's metadata names its sources and weights. Only networks fine-tuned from one common network
average into something useful: the parameters of independent trainings do not line up.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np

from dqn_dovs_py.export import WeightFile, WeightFileError, atomic_write, load_weights, serialize


def _layout(w: WeightFile) -> tuple:
    return (w.format_version, w.grid_rows, w.grid_cols, w.grid_channels, w.feature_count, w.action_count,
            [(layer.stream, layer.type, dict(layer.shape)) for layer in w.layers])


def average(files: list[str], weights: list[float] | None = None) -> WeightFile:
    """The weighted mean of the files' parameters (uniform without `weights`; weights need not sum to 1, they are
    normalised). Raises ValueError naming the file and what differs."""
    if not files:
        raise ValueError("no weight file to average")
    weights = [1.0] * len(files) if weights is None else list(weights)
    if len(weights) != len(files):
        raise ValueError(f"{len(weights)} weights for {len(files)} files")
    if any(not np.isfinite(x) or x < 0 for x in weights) or sum(weights) <= 0:
        raise ValueError(f"weights must be finite, non-negative and not all zero, got {weights}")
    loaded = [load_weights(f) for f in files]
    first = loaded[0]
    for path, w in zip(files[1:], loaded[1:]):
        if _layout(w) != _layout(first):
            raise ValueError(f"{path}: its layout (version, grid, features, actions, layers) differs from {files[0]}'s")
        if w.normalization != first.normalization:
            raise ValueError(f"{path}: its state normalisation {w.normalization} differs from {files[0]}'s "
                             f"{first.normalization}")
    share = np.asarray(weights, dtype=np.float64) / float(sum(weights))
    out = WeightFile(first.format_version, first.grid_rows, first.grid_cols, first.feature_count,
                     dict(first.normalization), first.action_count, [], "", grid_channels=first.grid_channels)
    for i, layer in enumerate(first.layers):
        merged = type(layer)(layer.stream, layer.type, dict(layer.shape))
        if layer.weight is not None:
            merged.weight = sum(s * w.layers[i].weight.astype(np.float64) for s, w in zip(share, loaded)).astype(
                np.float32)
            merged.bias = sum(s * w.layers[i].bias.astype(np.float64) for s, w in zip(share, loaded)).astype(
                np.float32)
        out.layers.append(merged)
    sources = "\n".join(f"  {s:.6g} x {os.path.abspath(f)}" for s, f in zip(share, files))
    out.metadata = f"average of {len(files)} weight files (python -m dqn_dovs_py.average_weights):\n{sources}"
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m dqn_dovs_py.average_weights",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("files", nargs="+", help="weight files (.dqnw) of one layout and normalisation")
    parser.add_argument("--out", required=True, help="the averaged weight file to write (.dqnw)")
    parser.add_argument("--weights", help="comma-separated weights, one per file (default: equal)")
    args = parser.parse_args(argv)
    try:
        weights = [float(x) for x in args.weights.split(",")] if args.weights else None
        result = average(args.files, weights)
        atomic_write(Path(args.out), serialize(result, args.out))
    except (ValueError, WeightFileError, OSError) as exc:
        print(f"average_weights: {exc}", file=sys.stderr)
        return 2
    print(f"wrote {args.out}: {result.metadata.splitlines()[0]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
