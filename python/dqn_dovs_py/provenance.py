"""Where a model file came from: the provenance keys every trained network carries in its metadata text.

    python -m dqn_dovs_py.provenance show FILE [FILE ...]
    python -m dqn_dovs_py.provenance check FILE [FILE ...]
    python -m dqn_dovs_py.provenance set FILE --config C --seed S --source-commit HASH --init-from PATH|none [--note T]

The keys are `key: value` lines of the metadata text (docs/weight_format.md, "Provenance"):

    config: the training configuration (a path in the repository at the source commit, or the trainer's options)
    seed: the training seed
    source commit: `git rev-parse HEAD` of the tree that trained it, `+uncommitted` when tracked files had changes
    init from: the network it started from, `PATH sha256 HEX`, or `none`

A `.dqnw` holds them in its metadata field, its `.onnx` in `dqn_dovs.metadata` (a copy of that field), a people
predictor `.dqnp` (whose format has no metadata) in the `metadata` entry of its `.json` beside it. `set` rewrites
only the metadata of a `.dqnw` (every byte before it stays as it was; the checksum is recomputed) or the `.json` of a
`.dqnp`; an `.onnx` is made again from its `.dqnw` (`python -m dqn_dovs_py.export --onnx-from`).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import re
import struct
import subprocess
import sys
import zlib
from collections.abc import Mapping
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[2]
KEYS = ("config", "seed", "source commit", "init from")
NONE = "none"
UNKNOWN = "unknown"
UNCOMMITTED = "+uncommitted"
NOTE_KEY = "provenance note"
# A line of the old metadata layout that the source commit replaces.
OLD_KEYS = ("source revision",)
COMMIT_PATTERN = re.compile(r"[0-9a-f]{40}(\+uncommitted)?")
INIT_FROM_PATTERN = re.compile(r"(?P<path>\S+) sha256 (?P<sha>[0-9a-f]{64})")


class ProvenanceError(ValueError):
    """A model file whose provenance cannot be read or written; the message names the file and the reason."""


# ---- values -------------------------------------------------------------------------------------------------------


def sha256_of(path: str | os.PathLike) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def repo_path(path: str | os.PathLike) -> str:
    """`path` relative to the repository root when it lies inside it, else absolute."""
    full = Path(path).resolve()
    try:
        return full.relative_to(REPO_ROOT).as_posix()
    except ValueError:
        return str(full)


def source_commit(repo: str | os.PathLike = REPO_ROOT) -> str:
    """`git rev-parse HEAD` of `repo`, with `+uncommitted` when `git status --porcelain` lists a changed tracked file;
    UNKNOWN only where git or the repository is missing."""
    try:
        head = subprocess.run(["git", "-C", str(repo), "rev-parse", "HEAD"], capture_output=True, text=True,
                              timeout=30)
        if head.returncode != 0 or not COMMIT_PATTERN.fullmatch(head.stdout.strip()):
            return UNKNOWN
        status = subprocess.run(["git", "-C", str(repo), "status", "--porcelain", "--untracked-files=no"],
                                capture_output=True, text=True, timeout=60)
    except (OSError, subprocess.SubprocessError):
        return UNKNOWN
    dirty = status.returncode != 0 or bool(status.stdout.strip())
    return head.stdout.strip() + (UNCOMMITTED if dirty else "")


def init_from_value(path: str | os.PathLike | None) -> str:
    """`PATH sha256 HEX` of the weight file a run starts from, `none` without one."""
    if path is None:
        return NONE
    try:
        return f"{repo_path(path)} sha256 {sha256_of(path)}"
    except OSError as exc:
        raise ProvenanceError(f"init from '{path}': cannot read it ({exc.strerror})") from None


def make(config: str, seed: int | str, init_from: str | os.PathLike | None = None,
         commit: str | None = None) -> dict[str, str]:
    """The provenance of a run: `config` as given (a file is named by its repository path), the seed, the source
    commit (this tree's unless given) and the starting weight file (init_from_value)."""
    if config and os.path.isfile(config):
        config = repo_path(config)
    return {"config": str(config), "seed": str(seed), "source commit": commit or source_commit(),
            "init from": init_from_value(init_from)}


def lines(provenance: Mapping[str, str]) -> str:
    """The KEYS as `key: value` lines, in KEYS order (a missing or empty value reads UNKNOWN)."""
    return "\n".join(f"{key}: {str(provenance.get(key) or UNKNOWN).strip()}" for key in KEYS)


def parse(text: str) -> dict[str, str]:
    """Every `key: value` line of a metadata text (the first of a repeated key)."""
    out: dict[str, str] = {}
    for line in text.splitlines():
        key, sep, value = line.partition(": ")
        if sep and key.strip() and key == key.strip():
            out.setdefault(key, value.strip())
    return out


def of_text(text: str) -> dict[str, str]:
    """The KEYS present in a metadata text."""
    found = parse(text)
    return {key: found[key] for key in KEYS if key in found}


def with_provenance(text: str, provenance: Mapping[str, str], note: str | None = None) -> str:
    """`text` with its KEYS (and OLD_KEYS, and the note) replaced by `provenance`'s, written after the `exported:`
    line (or the first line), every other line kept in its place."""
    drop = set(KEYS) | set(OLD_KEYS) | {NOTE_KEY}
    kept = [line for line in text.splitlines() if line.partition(": ")[0] not in drop]
    new = lines(provenance).splitlines() + ([f"{NOTE_KEY}: {note}"] if note else [])
    after = next((i + 1 for i, line in enumerate(kept) if line.startswith("exported: ")), min(1, len(kept)))
    return "\n".join(kept[:after] + new + kept[after:])


def problems(provenance: Mapping[str, str]) -> list[str]:
    """What is missing or not established in a file's provenance (empty: every key holds a value)."""
    out = []
    for key in KEYS:
        value = provenance.get(key)
        if value is None:
            out.append(f"'{key}' missing")
        elif not value.strip() or value.strip().lower().startswith(UNKNOWN):
            out.append(f"'{key}' is {value.strip() or 'empty'!r}")
    commit = provenance.get("source commit")
    if commit and not commit.lower().startswith(UNKNOWN) and not COMMIT_PATTERN.match(commit):
        out.append(f"'source commit' {commit!r} is not a 40-digit commit hash")
    init = provenance.get("init from")
    if init and init != NONE and not init.lower().startswith(UNKNOWN) and not INIT_FROM_PATTERN.fullmatch(init):
        out.append(f"'init from' {init!r} is neither 'none' nor 'PATH sha256 HEX'")
    return out


def init_from_file(provenance: Mapping[str, str]) -> tuple[str, str] | None:
    """(path, sha256) named by `init from`; None for `none` or a value that names no file."""
    m = INIT_FROM_PATTERN.fullmatch(provenance.get("init from", ""))
    return (m.group("path"), m.group("sha")) if m else None


# ---- files --------------------------------------------------------------------------------------------------------


def predictor_summary(path: str | os.PathLike) -> Path:
    """The `.json` beside a people predictor `.dqnp`, which holds its metadata."""
    return Path(path).with_suffix(".json")


def metadata_of(path: str | os.PathLike) -> str:
    """The metadata text of a `.dqnw`, `.onnx` or `.dqnp` (its `.json`); ProvenanceError naming the file."""
    path = Path(path)
    from .export import OnnxExportError, WeightFileError, load_weights, read_onnx_metadata  # noqa: PLC0415

    try:
        if path.suffix == ".dqnw":
            return load_weights(path).metadata
        if path.suffix == ".onnx":
            return read_onnx_metadata(path).get("dqn_dovs.metadata", "")
        if path.suffix == ".dqnp":
            summary = predictor_summary(path)
            try:
                data = json.loads(summary.read_text())
            except OSError as exc:
                raise ProvenanceError(f"{path}: its metadata is kept in {summary}, which cannot be read "
                                      f"({exc.strerror})") from None
            except json.JSONDecodeError as exc:
                raise ProvenanceError(f"{summary}: not JSON ({exc})") from None
            if not isinstance(data, dict) or not isinstance(data.get("metadata", ""), str):
                raise ProvenanceError(f"{summary}: expected an object whose 'metadata' is text")
            return data.get("metadata", "")
    except (WeightFileError, OnnxExportError) as exc:
        raise ProvenanceError(str(exc)) from None
    raise ProvenanceError(f"{path}: no provenance in a '{path.suffix}' file (.dqnw, .onnx or .dqnp)")


def read(path: str | os.PathLike) -> dict[str, str]:
    """The KEYS present in a model file's metadata (metadata_of)."""
    return of_text(metadata_of(path))


def rewrite_weight_metadata(data: bytes, metadata: str, path: str = "<memory>") -> bytes:
    """The `.dqnw` image `data` with its metadata replaced: every byte before the metadata field is kept, the
    checksum is recomputed. The image is checked as load_weights checks it first (WeightFileError naming the field)."""
    from .export import MAX_METADATA_LENGTH, parse as parse_weights  # noqa: PLC0415

    old = parse_weights(data, path).metadata.encode("utf-8")
    start = len(data) - 4 - len(old) - 4  # the metadata's length field
    if start < 0 or struct.unpack_from("<I", data, start)[0] != len(old) or data[start + 4:len(data) - 4] != old:
        raise ProvenanceError(f"weight file '{path}': field 'metadata': not the last field before the checksum")
    new = metadata.encode("utf-8")
    if len(new) > MAX_METADATA_LENGTH:
        raise ProvenanceError(f"weight file '{path}': field 'metadata': longer than 1 MiB")
    body = data[:start] + struct.pack("<I", len(new)) + new
    out = body + struct.pack("<I", zlib.crc32(body) & 0xFFFFFFFF)
    parse_weights(out, path)
    return out


def set_provenance(path: str | os.PathLike, provenance: Mapping[str, str], note: str | None = None) -> str:
    """Writes `provenance` (and `note`) into the metadata of a `.dqnw` or of a `.dqnp`'s `.json`; returns the new
    metadata text. Refuses a provenance with problems() and an `.onnx` (made again from its `.dqnw`)."""
    path = Path(path)
    wrong = problems(provenance)
    if wrong:
        raise ProvenanceError(f"{path}: refusing to write an incomplete provenance: {'; '.join(wrong)}")
    from .export import atomic_write  # noqa: PLC0415

    if path.suffix == ".dqnw":
        data = path.read_bytes()
        from .export import parse as parse_weights  # noqa: PLC0415

        text = with_provenance(parse_weights(data, str(path)).metadata, provenance, note)
        atomic_write(path, rewrite_weight_metadata(data, text, str(path)))
        return text
    if path.suffix == ".dqnp":
        if not path.is_file():
            raise ProvenanceError(f"{path}: no such file")
        summary = predictor_summary(path)
        data = json.loads(summary.read_text()) if summary.is_file() else {}
        text = with_provenance(str(data.get("metadata", "")), provenance, note)
        data["metadata"] = text
        atomic_write(summary, (json.dumps(data, indent=2) + "\n").encode("utf-8"))
        return text
    if path.suffix == ".onnx":
        raise ProvenanceError(f"{path}: an .onnx copies its .dqnw's metadata; set it there and convert again "
                              "(python -m dqn_dovs_py.export --onnx-from MODEL.dqnw)")
    raise ProvenanceError(f"{path}: no provenance in a '{path.suffix}' file (.dqnw or .dqnp)")


def set_state_parameters(path: str | os.PathLike, text: str) -> str:
    """Writes a `state parameters:` line (NAME=VALUE words: the dovs/* and robot/* values the network's states were
    built with, which planner_node holds its own parameters against) into a `.dqnw`'s metadata, replacing one it has
    and keeping every other line; returns the new metadata text."""
    path = Path(path)
    if path.suffix != ".dqnw":
        raise ProvenanceError(f"{path}: state parameters belong to a .dqnw")
    from .export import STATE_PARAMETERS_KEY, atomic_write, parse as parse_weights  # noqa: PLC0415

    data = path.read_bytes()
    kept = [line for line in parse_weights(data, str(path)).metadata.splitlines()
            if not line.startswith(STATE_PARAMETERS_KEY + ":")]
    new = "\n".join(kept + [f"{STATE_PARAMETERS_KEY}: {' '.join(text.split())}"])
    atomic_write(path, rewrite_weight_metadata(data, new, str(path)))
    return new


# ---- command line -------------------------------------------------------------------------------------------------


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m dqn_dovs_py.provenance", description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="command", required=True)
    show = sub.add_parser("show", help="print each file's provenance keys")
    show.add_argument("files", nargs="+")
    check = sub.add_parser("check", help="exit 1 naming every file whose provenance is missing or unknown")
    check.add_argument("files", nargs="+")
    put = sub.add_parser("set", help="write the provenance into a .dqnw's metadata or a .dqnp's .json")
    put.add_argument("file")
    put.add_argument("--config", required=True, help="the training configuration (a file: its repository path)")
    put.add_argument("--seed", required=True, help="the training seed")
    put.add_argument("--source-commit", required=True, help="the commit the run trained with (40 hex digits)")
    put.add_argument("--init-from", required=True, metavar="PATH|none",
                     help="the weight file it started from (its sha256 is read now), or none")
    put.add_argument("--note", default=None, help=f"a '{NOTE_KEY}:' line, e.g. how a value was established")
    state = sub.add_parser("state", help="write a .dqnw's 'state parameters:' line (the dovs/* and robot/* values its "
                                         "states were built with)")
    state.add_argument("file")
    state.add_argument("--dovs", default="", metavar="NAME=VALUE,...",
                       help="DOVS parameters the training set over the defaults (the config's dovs section)")
    a = ap.parse_args(argv)
    try:
        if a.command == "state":
            from . import _core  # noqa: PLC0415 - the C++ core writes the line the planner reads

            dovs = dict(item.split("=", 1) for item in a.dovs.split(",") if item.strip())
            text = set_state_parameters(a.file, _core.state_parameters({k.strip(): v.strip() for k, v in dovs.items()}))
            print(f"{a.file}: {text.splitlines()[-1]}")
            return 0
        if a.command == "set":
            commit = subprocess.run(["git", "-C", str(REPO_ROOT), "rev-parse", "--verify", "--quiet",
                                     f"{a.source_commit}^{{commit}}"], capture_output=True, text=True, timeout=30)
            full = commit.stdout.strip() if commit.returncode == 0 else a.source_commit
            values = make(a.config, a.seed, None if a.init_from == NONE else a.init_from, commit=full)
            text = set_provenance(a.file, values, a.note)
            print(f"{a.file}:\n  " + "\n  ".join(lines(of_text(text)).splitlines()))
            return 0
        failed = 0
        for f in a.files:
            found = read(f)
            if a.command == "show":
                print(f"{f}:\n  " + "\n  ".join(lines(found).splitlines()))
            wrong = problems(found)
            if wrong:
                failed += 1
                if a.command == "check":
                    print(f"{f}: {'; '.join(wrong)}", file=sys.stderr)
        return 1 if failed and a.command == "check" else 0
    except (ValueError, OSError, RuntimeError) as exc:  # ProvenanceError, WeightFileError, OnnxExportError, JSON
        print(f"provenance: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
