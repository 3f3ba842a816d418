"""Writes and reads the `.dqnw` weight file of the Q-network (docs/weight_format.md), and writes the same network
as an ONNX model beside it (`OUT.onnx`, for inspection and other runtimes; the robot runs only the `.dqnw`).

    python -m dqn_dovs_py.export CHECKPOINT OUT.dqnw [--normalization FILE] [--note TEXT] [--no-onnx]
    python -m dqn_dovs_py.export --onnx-from MODEL.dqnw [--onnx-out OUT.onnx]

CHECKPOINT is a `torch.save`d dict with the keys
  "model"          state_dict of a DuelingQNet (required; a bare state_dict is accepted too),
  "model_config"   DuelingQNet constructor arguments (optional; defaults otherwise),
  "normalization"  {name: float} of the state normaliser (optional if --normalization is given),
  "command"        the training command line (optional, copied into the metadata).
"""

from __future__ import annotations

import argparse
import datetime
import hashlib
import inspect
import io
import json
import math
import os
import struct
import sys
import warnings
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping

import numpy as np
import torch
from torch import nn

from .model import DuelingQNet, widened

MAGIC = b"DQNDOVSW"
FORMAT_VERSION = 1
# Version 2 adds `state layout: grid channels` (u32) after the grid's columns: a network on a grid of several
# channels (docs/dovs.md "Grid channels"). A one-channel network is always written as version 1.
FORMAT_VERSION_CHANNELS = 2
# Version 3 adds the wall rays, the person tokens and the quantile head (docs/weight_format.md).
FORMAT_VERSION_TOKENS = 3
# Version 4 adds the route points (u32) after the cvar count (docs/weight_format.md).
FORMAT_VERSION_ROUTE = 4
SUPPORTED_VERSIONS = (FORMAT_VERSION, FORMAT_VERSION_CHANNELS, FORMAT_VERSION_TOKENS, FORMAT_VERSION_ROUTE)
MAX_WALL_RAYS, MAX_PERSON_TOKENS, MAX_TOKEN_SIZE, MAX_QUANTILES = 32, 16, 256, 256
MAX_ROUTE_POINTS = 16
MAX_GRID_CHANNELS = 16
# Inputs after the grid: the 8 features, or 17 when the state carries the previous choice after them (the file's
# `state layout: feature count`; docs/dovs.md "The previous action").
FEATURE_COUNT = 8
# The metadata key of the parameters a network's state depends on beyond its normalisation (C++ kStateParametersKey).
STATE_PARAMETERS_KEY = "state parameters"
FEATURE_COUNT_WITH_PREVIOUS_CHOICE = 17


def format_version_for(grid_channels: int) -> int:
    """The version a writer puts in the file of a network reading `grid_channels` grid channels."""
    return FORMAT_VERSION if grid_channels == 1 else FORMAT_VERSION_CHANNELS

LAYER_CONV2D = 1
LAYER_LINEAR = 2
LAYER_RELU = 3
LAYER_TYPE_NAMES = {LAYER_CONV2D: "conv2d", LAYER_LINEAR: "linear", LAYER_RELU: "relu"}

STREAM_GRID = 0
STREAM_FEATURE = 1
STREAM_TRUNK = 2
STREAM_VALUE = 3
STREAM_ADVANTAGE = 4
STREAM_TOKEN = 5
STREAM_ATTENTION = 6
STREAM_NAMES = {STREAM_GRID: "grid", STREAM_FEATURE: "feature", STREAM_TRUNK: "trunk",
                STREAM_VALUE: "value", STREAM_ADVANTAGE: "advantage", STREAM_TOKEN: "token",
                STREAM_ATTENTION: "attention"}

MAX_NAME_LENGTH = 255
MAX_METADATA_LENGTH = 1 << 20

# The ONNX model beside a .dqnw (docs/weight_format.md, "The .onnx beside the weight file").
ONNX_OPSET = 17
ONNX_INPUT = "state"
ONNX_OUTPUT = "q_values"
# The second output of a quantile network: each action's CVaR, what its greedy choice maximises.
ONNX_ACTION_VALUES = "action_values"
ONNX_PROP_PREFIX = "dqn_dovs."


class WeightFileError(RuntimeError):
    """A weight file that cannot be written or read; the message names the file and the field."""

    def __init__(self, path: str | os.PathLike, field_name: str, reason: str) -> None:
        super().__init__(f"weight file '{path}': field '{field_name}': {reason}")
        self.path = str(path)
        self.field = field_name


@dataclass
class LayerRecord:
    stream: int
    type: int
    # conv2d: in_channels, out_channels, kernel_h, kernel_w, stride_h, stride_w, pad_h, pad_w
    # linear: in_features, out_features
    shape: dict = field(default_factory=dict)
    weight: np.ndarray | None = None  # float32, PyTorch layout
    bias: np.ndarray | None = None

    @property
    def name(self) -> str:
        return f"{STREAM_NAMES.get(self.stream, '?')} {LAYER_TYPE_NAMES.get(self.type, '?')}"


@dataclass
class WeightFile:
    format_version: int
    grid_rows: int
    grid_cols: int
    feature_count: int
    normalization: dict[str, float]
    action_count: int
    layers: list[LayerRecord]
    metadata: str
    grid_channels: int = 1  # versions 2 and 3; version 1 files have one
    # Version 3 only (older files: 0, 0, 0, 1, 1).
    wall_ray_count: int = 0
    person_token_count: int = 0
    token_size: int = 0
    quantile_count: int = 1
    cvar_count: int = 1
    # Version 4 only (older files: 0).
    route_point_count: int = 0


# --------------------------------------------------------------------------------------------- writing

def _layer_records(model: DuelingQNet) -> list[LayerRecord]:
    """Turns the model's modules into file records, refusing anything the C++ reader cannot run."""
    records: list[LayerRecord] = []

    def add(stream: int, module: nn.Module, where: str) -> None:
        if isinstance(module, nn.Sequential):
            for i, sub in enumerate(module):
                add(stream, sub, f"{where}.{i}")
        elif isinstance(module, nn.Conv2d):
            if stream != STREAM_GRID:
                raise ValueError(f"{where}: conv2d is only supported in the grid stream")
            if module.dilation != (1, 1) or module.groups != 1 or module.bias is None:
                raise ValueError(f"{where}: only conv2d with dilation 1, one group and a bias can be exported")
            if isinstance(module.padding, str) or module.padding_mode != "zeros":
                raise ValueError(f"{where}: only explicit zero padding can be exported")
            shape = dict(in_channels=module.in_channels, out_channels=module.out_channels,
                         kernel_h=module.kernel_size[0], kernel_w=module.kernel_size[1],
                         stride_h=module.stride[0], stride_w=module.stride[1],
                         pad_h=module.padding[0], pad_w=module.padding[1])
            records.append(LayerRecord(stream, LAYER_CONV2D, shape, _tensor(module.weight), _tensor(module.bias)))
        elif isinstance(module, nn.Linear):
            if module.bias is None:
                raise ValueError(f"{where}: linear layers without bias cannot be exported")
            shape = dict(in_features=module.in_features, out_features=module.out_features)
            records.append(LayerRecord(stream, LAYER_LINEAR, shape, _tensor(module.weight), _tensor(module.bias)))
        elif isinstance(module, nn.ReLU):
            records.append(LayerRecord(stream, LAYER_RELU))
        elif isinstance(module, (nn.Flatten, nn.Identity)):
            pass  # the grid stream's flatten is implicit in the format
        else:
            raise ValueError(f"{where}: module type {type(module).__name__} has no weight-file record")

    add(STREAM_GRID, model.grid, "grid")
    add(STREAM_FEATURE, model.features, "features")
    add(STREAM_TRUNK, model.trunk, "trunk")
    add(STREAM_VALUE, model.value, "value")
    add(STREAM_ADVANTAGE, model.advantage, "advantage")
    if model.person_tokens > 0:
        add(STREAM_TOKEN, model.token_encoder, "token_encoder")
        add(STREAM_ATTENTION, model.attention, "attention")
    return records


def _tensor(t: torch.Tensor) -> np.ndarray:
    return t.detach().to(device="cpu", dtype=torch.float32).contiguous().numpy().copy()


def _string(data: bytes) -> bytes:
    return struct.pack("<I", len(data)) + data


def serialize(weights: WeightFile, path_for_errors: str = "<memory>") -> bytes:
    """The complete file image of `weights`, checksum included."""
    out = bytearray(MAGIC)
    out += struct.pack("<III", weights.format_version, weights.grid_rows, weights.grid_cols)
    if weights.format_version >= FORMAT_VERSION_CHANNELS:
        out += struct.pack("<I", weights.grid_channels)
    out += struct.pack("<I", weights.feature_count)
    if weights.format_version >= FORMAT_VERSION_TOKENS:
        out += struct.pack("<5I", weights.wall_ray_count, weights.person_token_count, weights.token_size,
                           weights.quantile_count, weights.cvar_count)
    if weights.format_version >= FORMAT_VERSION_ROUTE:
        out += struct.pack("<I", weights.route_point_count)
    out += struct.pack("<I", len(weights.normalization))
    for name, value in weights.normalization.items():
        encoded = name.encode("utf-8")
        if not 1 <= len(encoded) <= MAX_NAME_LENGTH:
            raise WeightFileError(path_for_errors, "normalization name", f"'{name}' must have 1..255 bytes")
        out += _string(encoded) + struct.pack("<f", value)
    out += struct.pack("<II", weights.action_count, len(weights.layers))
    for i, layer in enumerate(weights.layers):
        out += struct.pack("<II", layer.stream, layer.type)
        if layer.type == LAYER_CONV2D:
            keys = ("in_channels", "out_channels", "kernel_h", "kernel_w", "stride_h", "stride_w", "pad_h", "pad_w")
            dims = [int(layer.shape[k]) for k in keys]
            out += struct.pack("<8I", *dims)
            weight_shape = (dims[1], dims[0], dims[2], dims[3])
            bias_len = dims[1]
        elif layer.type == LAYER_LINEAR:
            dims = [int(layer.shape["in_features"]), int(layer.shape["out_features"])]
            out += struct.pack("<2I", *dims)
            weight_shape = (dims[1], dims[0])
            bias_len = dims[1]
        else:
            continue
        weight = np.asarray(layer.weight, dtype="<f4")
        bias = np.asarray(layer.bias, dtype="<f4")
        if weight.shape != weight_shape or bias.shape != (bias_len,):
            raise WeightFileError(path_for_errors, f"layer {i} ({layer.name}) tensors",
                                  f"weight {weight.shape} / bias {bias.shape} do not match the declared shape "
                                  f"{weight_shape} / ({bias_len},)")
        out += weight.tobytes(order="C") + bias.tobytes(order="C")
    meta = weights.metadata.encode("utf-8")
    if len(meta) > MAX_METADATA_LENGTH:
        raise WeightFileError(path_for_errors, "metadata", "longer than 1 MiB")
    out += _string(meta)
    out += struct.pack("<I", zlib.crc32(bytes(out)) & 0xFFFFFFFF)
    return bytes(out)


def weights_from_model(model: DuelingQNet, normalization: Mapping[str, float], metadata: str) -> WeightFile:
    if not normalization:
        raise ValueError("normalization must name at least one constant of the state normaliser")
    norm: dict[str, float] = {}
    for name, value in normalization.items():
        value = float(value)
        if not math.isfinite(value):
            raise ValueError(f"normalization constant '{name}' is not finite ({value})")
        norm[str(name)] = value
    records = _layer_records(model)
    for i, layer in enumerate(records):
        for label, tensor in (("weight", layer.weight), ("bias", layer.bias)):
            if tensor is not None and not np.isfinite(tensor).all():
                raise ValueError(f"layer {i} ({layer.name}) {label} contains NaN or inf: refusing to export")
    from .model import TOKEN_SIZE, cvar_quantile_count  # noqa: PLC0415
    tokens = model.wall_rays != 0 or model.person_tokens != 0 or model.quantiles != 1
    version = (FORMAT_VERSION_ROUTE if model.route_points != 0 else FORMAT_VERSION_TOKENS if tokens
               else format_version_for(model.grid_channels))
    return WeightFile(version, model.grid_rows, model.grid_cols, model.feature_count,
                      norm, model.action_count, records, metadata, grid_channels=model.grid_channels,
                      wall_ray_count=model.wall_rays, person_token_count=model.person_tokens,
                      token_size=TOKEN_SIZE if model.person_tokens > 0 else 0, quantile_count=model.quantiles,
                      cvar_count=cvar_quantile_count(model.quantiles, model.cvar_alpha),
                      route_point_count=model.route_points)


def onnx_path_for(path: str | os.PathLike) -> Path:
    """Where export_model writes the ONNX model of the weight file `path`: same directory and stem, `.onnx`."""
    return Path(path).with_suffix(".onnx")


def export_model(model: DuelingQNet, path: str | os.PathLike, normalization: Mapping[str, float],
                 metadata: str, onnx: bool = True) -> Path:
    """Writes `model` to `path` (.dqnw) and, unless `onnx` is False, the same network to `onnx_path_for(path)`
    (write_onnx). Each file is written next to its target and renamed into place, so a reader never sees half a
    file. Returns the .dqnw path."""
    path = Path(path)
    if onnx and onnx_path_for(path) == path:
        raise ValueError(f"{path}: the weight file needs another suffix than .onnx (the ONNX model goes beside it)")
    data = serialize(weights_from_model(model, normalization, metadata), str(path))
    atomic_write(path, data)
    if onnx:
        write_onnx(data, onnx_path_for(path), str(path))
    return path


def atomic_write(path: Path, data: bytes) -> None:
    """Writes `data` beside `path` and renames it into place, so a reader never sees half a file."""
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_bytes(data)
    os.replace(tmp, path)


# --------------------------------------------------------------------------------------------- reading

class _Reader:
    def __init__(self, data: bytes, path: str) -> None:
        self.data = data
        self.end = len(data) - 4  # the checksum
        self.pos = 0
        self.path = path

    def take(self, n: int, field_name: str) -> bytes:
        if n > self.end - self.pos:
            raise WeightFileError(self.path, field_name,
                                  f"truncated: needs {n} bytes at offset {self.pos}, {max(self.end - self.pos, 0)} remain")
        out = self.data[self.pos:self.pos + n]
        self.pos += n
        return out

    def u32(self, field_name: str) -> int:
        return struct.unpack("<I", self.take(4, field_name))[0]

    def f32(self, count: int, field_name: str) -> np.ndarray:
        return np.frombuffer(self.take(4 * count, field_name), dtype="<f4").astype(np.float32)


def parse(data: bytes, path: str = "<memory>") -> WeightFile:
    """Parses a file image with the same checks, in the same order, as the C++ reader."""
    if len(data) < 8:
        raise WeightFileError(path, "magic", f"truncated: file has {len(data)} bytes")
    if data[:8] != MAGIC:
        raise WeightFileError(path, "magic", f"expected {MAGIC!r}, found {data[:8]!r}")
    if len(data) < 12:
        raise WeightFileError(path, "format version", "truncated: file ends right after the magic")
    version = struct.unpack("<I", data[8:12])[0]
    if version not in SUPPORTED_VERSIONS:
        raise WeightFileError(path, "format version",
                              f"file has version {version}, this reader supports versions {FORMAT_VERSION} to "
                              f"{FORMAT_VERSION_ROUTE}")
    r = _Reader(data, path)
    r.take(8, "magic")
    r.u32("format version")
    rows, cols = r.u32("state layout: grid rows"), r.u32("state layout: grid cols")
    channels = 1
    if version >= FORMAT_VERSION_CHANNELS:
        channels = r.u32("state layout: grid channels")
        if not 1 <= channels <= MAX_GRID_CHANNELS:
            raise WeightFileError(path, "state layout: grid channels",
                                  f"{channels} outside [1, {MAX_GRID_CHANNELS}]")
    features = r.u32("state layout: feature count")
    v3 = dict(wall_ray_count=0, person_token_count=0, token_size=0, quantile_count=1, cvar_count=1)
    if version >= FORMAT_VERSION_TOKENS:
        for key, field_name, low, high in (("wall_ray_count", "state layout: wall rays", 0, MAX_WALL_RAYS),
                                           ("person_token_count", "state layout: person tokens", 0, MAX_PERSON_TOKENS),
                                           ("token_size", "state layout: token size", 0, MAX_TOKEN_SIZE),
                                           ("quantile_count", "quantile count", 1, MAX_QUANTILES),
                                           ("cvar_count", "cvar count", 1, MAX_QUANTILES)):
            v3[key] = r.u32(field_name)
            if not low <= v3[key] <= (v3["quantile_count"] if key == "cvar_count" else high):
                raise WeightFileError(path, field_name, f"{v3[key]} outside [{low}, {high}]")
    if version >= FORMAT_VERSION_ROUTE:
        v3["route_point_count"] = r.u32("state layout: route points")
        if not 0 <= v3["route_point_count"] <= MAX_ROUTE_POINTS:
            raise WeightFileError(path, "state layout: route points",
                                  f"{v3['route_point_count']} outside [0, {MAX_ROUTE_POINTS}]")
    normalization: dict[str, float] = {}
    for i in range(r.u32("normalization count")):
        length = r.u32(f"normalization entry {i} name length")
        if not 1 <= length <= MAX_NAME_LENGTH:
            raise WeightFileError(path, f"normalization entry {i} name length", f"{length} outside [1, 255]")
        name = r.take(length, f"normalization entry {i} name").decode("utf-8", errors="replace")
        normalization[name] = float(r.f32(1, f"normalization entry {i} value")[0])
    action_count = r.u32("action count")
    layers: list[LayerRecord] = []
    for i in range(r.u32("layer count")):
        stream, kind = r.u32(f"layer {i} stream"), r.u32(f"layer {i} type")
        if stream not in STREAM_NAMES:
            raise WeightFileError(path, f"layer {i} stream", f"unknown stream id {stream}")
        if kind not in LAYER_TYPE_NAMES:
            raise WeightFileError(path, f"layer {i} type", f"unknown layer type id {kind}")
        layer = LayerRecord(stream, kind)
        if kind == LAYER_CONV2D:
            keys = ("in_channels", "out_channels", "kernel_h", "kernel_w", "stride_h", "stride_w", "pad_h", "pad_w")
            layer.shape = {k: r.u32(f"layer {i} {k}") for k in keys}
            s = layer.shape
            w_shape = (s["out_channels"], s["in_channels"], s["kernel_h"], s["kernel_w"])
            b_len = s["out_channels"]
        elif kind == LAYER_LINEAR:
            layer.shape = {k: r.u32(f"layer {i} {k}") for k in ("in_features", "out_features")}
            w_shape = (layer.shape["out_features"], layer.shape["in_features"])
            b_len = layer.shape["out_features"]
        if kind != LAYER_RELU:
            layer.weight = r.f32(int(np.prod(w_shape)), f"layer {i} ({layer.name}) weight").reshape(w_shape)
            layer.bias = r.f32(b_len, f"layer {i} ({layer.name}) bias")
        layers.append(layer)
    meta_len = r.u32("metadata length")
    metadata = r.take(meta_len, "metadata").decode("utf-8", errors="replace")
    if r.pos != r.end:
        raise WeightFileError(path, "trailing bytes", f"{r.end - r.pos} unexpected bytes before the checksum")
    stored = struct.unpack("<I", data[-4:])[0]
    computed = zlib.crc32(data[:-4]) & 0xFFFFFFFF
    if stored != computed:
        raise WeightFileError(path, "checksum", f"CRC-32 stored 0x{stored:08x} but the content gives 0x{computed:08x}")
    return WeightFile(version, rows, cols, features, normalization, action_count, layers, metadata,
                      grid_channels=channels, **v3)


def load_weights(path: str | os.PathLike) -> WeightFile:
    """Reads a `.dqnw` file (magic, version, truncation and checksum checked)."""
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise WeightFileError(path, "file", f"cannot open: {exc.strerror}") from exc
    return parse(data, str(path))


def model_from_weights(weights: WeightFile) -> DuelingQNet:
    """Rebuilds the DuelingQNet a file describes and loads its tensors (for round-trip checks)."""
    by_stream: dict[int, list[LayerRecord]] = {s: [] for s in STREAM_NAMES}
    for layer in weights.layers:
        by_stream[layer.stream].append(layer)
    convs = [l for l in by_stream[STREAM_GRID] if l.type == LAYER_CONV2D]
    feature_linears = [l for l in by_stream[STREAM_FEATURE] if l.type == LAYER_LINEAR]
    trunk_linears = [l for l in by_stream[STREAM_TRUNK] if l.type == LAYER_LINEAR]
    token_linears = [l for l in by_stream[STREAM_TOKEN] if l.type == LAYER_LINEAR]
    attention_linears = [l for l in by_stream[STREAM_ATTENTION] if l.type == LAYER_LINEAR]
    if not convs or len(feature_linears) != 1:
        raise ValueError("the file's layers do not follow the DuelingQNet structure")
    # The CVaR share that gives the file's count: m / Nq (cvar_quantile_count rounds it back up to m).
    alpha = weights.cvar_count / weights.quantile_count
    model = DuelingQNet(
        grid_rows=weights.grid_rows, grid_cols=weights.grid_cols, feature_count=weights.feature_count,
        grid_channels=weights.grid_channels,
        action_count=weights.action_count, conv_channels=[c.shape["out_channels"] for c in convs],
        conv_strides=[c.shape["stride_h"] for c in convs], conv_kernel=convs[0].shape["kernel_h"],
        feature_hidden=feature_linears[0].shape["out_features"],
        trunk_hidden=[l.shape["out_features"] for l in trunk_linears],
        quantiles=weights.quantile_count, cvar_alpha=alpha, wall_rays=weights.wall_ray_count,
        person_tokens=weights.person_token_count, route_points=weights.route_point_count,
        token_hidden=[l.shape["out_features"] for l in token_linears] or (64, 64),
        attention_hidden=[l.shape["out_features"] for l in attention_linears[:-1]])
    expected = _layer_records(model)
    if [(l.stream, l.type, l.shape) for l in expected] != [(l.stream, l.type, l.shape) for l in weights.layers]:
        raise ValueError("the file's layers do not follow the DuelingQNet structure")
    # In file order (stream by stream), which is not the modules' registration order once tokens exist.
    parts = [model.grid, model.features, model.trunk, model.value, model.advantage]
    if model.person_tokens > 0:
        parts += [model.token_encoder, model.attention]
    params = [m for part in parts for m in part.modules() if isinstance(m, (nn.Conv2d, nn.Linear))]
    weighted = [l for l in weights.layers if l.type != LAYER_RELU]
    with torch.no_grad():
        for module, layer in zip(params, weighted):
            module.weight.copy_(torch.from_numpy(layer.weight))
            module.bias.copy_(torch.from_numpy(layer.bias))
    return model


def widen_grid_channels(model: DuelingQNet, grid_channels: int) -> DuelingQNet:
    """The network `model` (one grid channel) reading `grid_channels` channels: the first convolution gets zero
    weights for the new channels, every other tensor is copied, so its Q-values are the same on any state whose
    first channel is the old grid (whatever the new channels hold)."""
    if model.grid_channels != 1 or grid_channels < 1:
        raise ValueError(f"widen_grid_channels: widens a network of 1 grid channel to more, not "
                         f"{model.grid_channels} to {grid_channels}")
    return _widened(model, grid_channels=int(grid_channels))


def widen_previous_action(model: DuelingQNet) -> DuelingQNet:
    """The network `model` (8 features) reading the previous choice too (17 feature inputs, docs/dovs.md "The
    previous action"): the feature stream's first layer gets zero weights for the 9 new inputs, every other tensor
    is copied, so its Q-values are the same on any state whatever the previous choice."""
    if model.feature_count != FEATURE_COUNT:
        raise ValueError(f"widen_previous_action: widens a network of {FEATURE_COUNT} features, not "
                         f"{model.feature_count}")
    return _widened(model, feature_count=FEATURE_COUNT_WITH_PREVIOUS_CHOICE)


def _widened(model: DuelingQNet, **inputs: int) -> DuelingQNet:
    """`model` with more inputs (grid channels and/or feature inputs): the tensors that read them (the first
    convolution, the feature stream's first layer) keep their weights for the old inputs and get zeros for the new
    ones; every other tensor is copied (model.widened)."""
    return widened(model, **inputs)


# --------------------------------------------------------------------------------------------- ONNX

class OnnxExportError(RuntimeError):
    """An ONNX model that cannot be written or read; the message names the file."""

    def __init__(self, path: str | os.PathLike, reason: str) -> None:
        super().__init__(f"onnx file '{path}': {reason}")
        self.path = str(path)


def state_layout_name(weights: WeightFile) -> str:
    """Name of the network input's layout, e.g. `grid20x20+features8` (grid row-major, then the features), or
    `grid3x20x20+features8` for a grid of 3 channels (channel-major)."""
    channels = "" if weights.grid_channels == 1 else f"{weights.grid_channels}x"
    name = f"grid{channels}{weights.grid_rows}x{weights.grid_cols}+features{weights.feature_count}"
    if weights.wall_ray_count:
        name += f"+wallrays{weights.wall_ray_count}"
    if weights.route_point_count:
        name += f"+route{weights.route_point_count}x2"
    if weights.person_token_count:
        name += f"+tokens{weights.person_token_count}x{weights.token_size}"
    return name


def onnx_metadata_props(weights: WeightFile, data: bytes, weights_path: str) -> dict[str, str]:
    """The metadata_props the ONNX model of the weight file image `data` (parsed: `weights`) carries, so that a
    reader can tell which .dqnw it came from and what its input means."""
    props = {
        "weight_format_version": str(weights.format_version),
        "weights_file": os.path.basename(weights_path),
        "weights_sha256": hashlib.sha256(data).hexdigest(),
        "weights_crc32": f"0x{struct.unpack('<I', data[-4:])[0]:08x}",
        "state_layout": state_layout_name(weights),
        "grid_rows": str(weights.grid_rows),
        "grid_cols": str(weights.grid_cols),
        "feature_count": str(weights.feature_count),
        "action_count": str(weights.action_count),
        # Values as the .dqnw stores them (float32), written as the exact double of that float32.
        "normalization": json.dumps(weights.normalization),
        "input_normalization": "by the caller: `state` is the state builder's output, already normalised with "
                               "the constants in dqn_dovs.normalization; the graph applies none, like the .dqnw "
                               "network",
        "metadata": weights.metadata,
    }
    if weights.grid_channels != 1:  # a one-channel model's metadata is what it was before channels existed
        props["grid_channels"] = str(weights.grid_channels)
    if weights.format_version >= FORMAT_VERSION_TOKENS:
        props.update(wall_rays=str(weights.wall_ray_count), person_tokens=str(weights.person_token_count),
                     token_size=str(weights.token_size), quantile_count=str(weights.quantile_count),
                     cvar_count=str(weights.cvar_count))
    if weights.format_version >= FORMAT_VERSION_ROUTE:
        props["route_points"] = str(weights.route_point_count)
    return {ONNX_PROP_PREFIX + k: v for k, v in props.items()}


def _import_onnx(path: str | os.PathLike):
    try:
        import onnx  # noqa: PLC0415 - only the ONNX functions need it
    except ImportError as exc:
        raise OnnxExportError(path, "the onnx package is not installed (pip install -r python/requirements.txt), "
                                    "or skip the .onnx (export_model(..., onnx=False), --no-onnx)") from exc
    return onnx


def write_onnx(data: bytes, out: str | os.PathLike, weights_path: str = "<memory>") -> Path:
    """Writes the network of the weight file image `data` (read from `weights_path`, which names it in errors and
    metadata) as an ONNX model to `out`: input `state` [N, state size] float32, output `q_values` [N, actions],
    N dynamic, opset ONNX_OPSET, the weight file's description in metadata_props (onnx_metadata_props). The graph
    is exported from the network rebuilt from `data`, so it holds exactly the file's float32 tensors."""
    out = Path(out)
    onnx = _import_onnx(out)
    weights = parse(data, weights_path)
    model = model_from_weights(weights).eval()
    example = torch.zeros(1, model.state_size, dtype=torch.float32)
    outputs = [ONNX_OUTPUT]
    if model.quantiles > 1:  # a quantile network also gives what its choice maximises, each action's CVaR
        outputs.append(ONNX_ACTION_VALUES)
        model = _QAndActionValues(model)
    options = dict(opset_version=ONNX_OPSET, input_names=[ONNX_INPUT], output_names=outputs,
                   dynamic_axes={name: {0: "batch"} for name in [ONNX_INPUT, *outputs]}, do_constant_folding=True)
    if "dynamo" in inspect.signature(torch.onnx.export).parameters:
        options["dynamo"] = False  # the TorchScript exporter: no extra packages
    buffer = io.BytesIO()
    with warnings.catch_warnings():
        # The tracer's note on the input-shape check in forward() and the exporter's deprecation notice.
        warnings.simplefilter("ignore")
        with torch.no_grad():
            torch.onnx.export(model, (example,), buffer, **options)
    proto = onnx.load_from_string(buffer.getvalue())
    proto.producer_name = "dqn_dovs_py.export"
    proto.doc_string = (f"DQN-DOVS dueling Q-network of {os.path.basename(weights_path)}: {ONNX_INPUT} "
                        f"[N, {example.shape[1]}] float32 (normalised state, {state_layout_name(weights)}) -> "
                        f"{ONNX_OUTPUT} [N, {weights.action_count}]")
    del proto.metadata_props[:]
    for key, value in onnx_metadata_props(weights, data, weights_path).items():
        entry = proto.metadata_props.add()
        entry.key, entry.value = key, value
    onnx.checker.check_model(proto)
    try:
        atomic_write(out, proto.SerializeToString())
    except OSError as exc:
        raise OnnxExportError(out, f"cannot write: {exc.strerror}") from exc
    return out


class _QAndActionValues(nn.Module):
    """A quantile network with two outputs for ONNX: Q (the quantiles' mean) and the action values (CVaR)."""

    def __init__(self, net: DuelingQNet) -> None:
        super().__init__()
        self.net = net

    def forward(self, state: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        z = self.net.quantile_values(state)
        from .model import cvar_of_quantiles  # noqa: PLC0415
        return z.mean(dim=2), cvar_of_quantiles(z, self.net.cvar_alpha)


def onnx_from_weights(weights_path: str | os.PathLike, out: str | os.PathLike | None = None) -> Path:
    """Converts an existing .dqnw to ONNX (write_onnx); `out` defaults to onnx_path_for(weights_path). The weight
    file is checked as load_weights checks it (WeightFileError naming the file and field)."""
    out = onnx_path_for(weights_path) if out is None else Path(out)
    if out.resolve() == Path(weights_path).resolve():
        raise OnnxExportError(out, "is the weight file itself; give an output path that ends in .onnx")
    try:
        data = Path(weights_path).read_bytes()
    except OSError as exc:
        raise WeightFileError(weights_path, "file", f"cannot open: {exc.strerror}") from exc
    return write_onnx(data, out, str(weights_path))


def read_onnx_metadata(path: str | os.PathLike) -> dict[str, str]:
    """The metadata_props of an ONNX model written by write_onnx (all of them, keys as stored). Raises
    OnnxExportError for a missing or unparsable file and for one without the dqn_dovs entries."""
    onnx = _import_onnx(path)
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise OnnxExportError(path, f"cannot open: {exc.strerror}") from exc
    try:
        proto = onnx.load_from_string(data)
        onnx.checker.check_model(proto)
    except Exception as exc:  # noqa: BLE001 - protobuf and checker errors have no common base
        raise OnnxExportError(path, f"not a valid ONNX model ({type(exc).__name__}: {exc})") from None
    props = {p.key: p.value for p in proto.metadata_props}
    if ONNX_PROP_PREFIX + "weights_sha256" not in props:
        raise OnnxExportError(path, "carries no dqn_dovs metadata (not written by dqn_dovs_py.export)")
    return props


# --------------------------------------------------------------------------------------------- CLI

def build_metadata(training_command: str | None, checkpoint: str | None, note: str | None = None,
                   provenance: Mapping[str, str] | None = None, state_parameters: str | None = None) -> str:
    """The metadata text: the training command, the export date, the provenance keys (provenance.KEYS: config,
    seed, source commit, init from; a key `provenance` lacks reads `unknown`), the state parameters the environments
    built their states with (`state parameters:`, which planner_node holds its own dovs/* and robot/* against), the
    checkpoint and the note."""
    from . import provenance as prov  # noqa: PLC0415 - provenance imports this module

    lines = [
        f"training command: {training_command or 'unknown'}",
        f"exported: {datetime.datetime.now(datetime.timezone.utc).isoformat(timespec='seconds')}",
        *prov.lines(provenance or {}).splitlines(),
    ]
    if state_parameters:
        lines.append(f"{STATE_PARAMETERS_KEY}: {state_parameters}")
    if checkpoint:
        lines.append(f"checkpoint: {checkpoint}")
    if note:
        lines.append(f"note: {note}")
    return "\n".join(lines)


def _load_mapping(path: str) -> dict[str, float]:
    text = Path(path).read_text()
    if path.endswith((".yaml", ".yml")):
        import yaml
        data = yaml.safe_load(text)
    else:
        data = json.loads(text)
    if not isinstance(data, dict):
        raise ValueError(f"{path}: expected a mapping of name -> number")
    return {str(k): float(v) for k, v in data.items()}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m dqn_dovs_py.export",
                                     description="Export a DQN-DOVS checkpoint to a .dqnw weight file and an .onnx "
                                                 "beside it, or convert an existing .dqnw to .onnx (--onnx-from).")
    parser.add_argument("checkpoint", nargs="?", help="torch.save'd checkpoint (see the module docstring for its keys)")
    parser.add_argument("out", nargs="?", help="output .dqnw path (the .onnx goes beside it, same stem)")
    parser.add_argument("--normalization", help="JSON or YAML mapping name -> value; overrides the checkpoint's")
    parser.add_argument("--note", help="extra text for the metadata")
    parser.add_argument("--no-onnx", action="store_true", help="write only the .dqnw")
    parser.add_argument("--onnx-from", metavar="MODEL.dqnw",
                        help="convert this existing weight file to ONNX instead of exporting a checkpoint")
    parser.add_argument("--onnx-out", metavar="OUT.onnx", help="with --onnx-from: output path (default: same stem)")
    args = parser.parse_args(argv)
    if args.onnx_from:
        if args.checkpoint or args.out or args.normalization or args.note or args.no_onnx:
            parser.error("--onnx-from takes only --onnx-out")
        try:
            path = onnx_from_weights(args.onnx_from, args.onnx_out)
        except (OSError, ValueError, RuntimeError) as exc:
            print(f"onnx conversion failed: {exc}", file=sys.stderr)
            return 1
        print(f"wrote {path} ({path.stat().st_size} bytes) from {args.onnx_from}")
        return 0
    if not (args.checkpoint and args.out):
        parser.error("give CHECKPOINT and OUT.dqnw, or --onnx-from MODEL.dqnw")
    if args.onnx_out:
        parser.error("--onnx-out goes with --onnx-from; a checkpoint export writes the .onnx beside OUT.dqnw")
    try:
        ckpt = torch.load(args.checkpoint, map_location="cpu", weights_only=True)
        if not isinstance(ckpt, dict):
            raise ValueError(f"{args.checkpoint}: expected a dict checkpoint, got {type(ckpt).__name__}")
        state_dict = ckpt.get("model", ckpt)
        model = DuelingQNet(**dict(ckpt.get("model_config") or {}))
        model.load_state_dict(state_dict)
        normalization = _load_mapping(args.normalization) if args.normalization else ckpt.get("normalization")
        if not normalization:
            raise ValueError(f"{args.checkpoint} has no 'normalization' entry: pass --normalization FILE")
        metadata = build_metadata(ckpt.get("command"), os.path.abspath(args.checkpoint), args.note,
                                  ckpt.get("provenance"), ckpt.get("state_parameters"))
        path = export_model(model.eval(), args.out, normalization, metadata, onnx=not args.no_onnx)
    except (OSError, ValueError, RuntimeError, KeyError, TypeError) as exc:
        print(f"export failed: {exc}", file=sys.stderr)
        return 1
    n_params = sum(p.numel() for p in model.parameters())
    print(f"wrote {path} ({path.stat().st_size} bytes, {n_params} parameters)")
    if not args.no_onnx:
        print(f"wrote {onnx_path_for(path)} ({onnx_path_for(path).stat().st_size} bytes)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
