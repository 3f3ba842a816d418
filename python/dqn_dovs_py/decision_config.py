"""The decision step's parameters as the robot reads them, for the trainer.

The nodes read the action shield from the parameter server, loaded from `config/dovs.yaml` (`action_shield/*`)
and `config/static_safety.yaml` (`static_safety/*`), and the velocity-space model from `config/dovs.yaml`
(`dovs/*`). The trainer reads the same files here and hands the values to the C++ environment by name
(`dqn_dovs_py._core.VecEnv(..., shield_parameters=..., dovs_parameters=...)`, the names of `setShieldParameter` in
include/dqn_dovs/policy/action_shield.h and of `setDovsParameter` in include/dqn_dovs/dovs/dovs.h), so training
never runs C++ defaults while the robot runs the YAML.

    from dqn_dovs_py.decision_config import load_shield_parameters
    params = load_shield_parameters()            # the repository's config/
    params = load_shield_parameters("my/config")  # another folder with the same two files
"""

from __future__ import annotations

import os

import yaml

DEFAULT_CONFIG_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "config")
# (file, section, name prefix): config/dovs.yaml action_shield/NAME -> NAME,
# config/static_safety.yaml static_safety/NAME -> static_safety/NAME.
SOURCES = (("dovs.yaml", "action_shield", ""), ("static_safety.yaml", "static_safety", "static_safety/"))


class DecisionConfigError(ValueError):
    """A configuration file that cannot be read as the robot reads it; the message names the file and key."""


def _text(value) -> str:
    """A YAML scalar as the C++ setter reads it: booleans as true/false, numbers in full precision."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return repr(value)
    raise TypeError(f"{value!r} is not a boolean or a number")


def _section(path: str, section: str) -> dict:
    """The mapping `section` of the YAML file `path`; DecisionConfigError naming the file when it cannot be read,
    is not YAML or has no such section."""
    try:
        with open(path) as f:
            document = yaml.safe_load(f) or {}
    except OSError as e:
        raise DecisionConfigError(f"{path}: cannot be read ({e.strerror})") from None
    except yaml.YAMLError as e:
        raise DecisionConfigError(f"{path}: not valid YAML ({e})") from None
    values = document.get(section) if isinstance(document, dict) else None
    if not isinstance(values, dict):
        raise DecisionConfigError(f"{path}: no '{section}' section")
    return values


def load_dovs_parameters(config_dir: str | None = None) -> dict[str, str]:
    """The velocity-space model's parameters of `config_dir`'s dovs.yaml (default: the repository's config/), its
    `dovs:` section, as name -> text (the names of setDovsParameter). Raises DecisionConfigError naming the file and
    key for a missing file or section, an unknown name, or a value that is not a scalar."""
    from . import env  # noqa: PLC0415 - the compiled module is needed only here

    known = set(env.import_core().dovs_parameter_names())
    path = os.path.join(config_dir or DEFAULT_CONFIG_DIR, "dovs.yaml")
    out: dict[str, str] = {}
    for key, value in _section(path, "dovs").items():
        if str(key) not in known:
            raise DecisionConfigError(f"{path}: 'dovs/{key}' is not a DOVS parameter")
        try:
            out[str(key)] = _text(value)
        except TypeError as e:
            raise DecisionConfigError(f"{path}: 'dovs/{key}': {e}") from None
    return out


def load_shield_parameters(config_dir: str | None = None) -> dict[str, str]:
    """The action shield's parameters of `config_dir` (default: the repository's config/) as name -> text.

    Raises DecisionConfigError naming the file and key for a missing file or section, a key that is not a
    shield parameter, or a value that is not a scalar."""
    from . import env  # noqa: PLC0415 - the compiled module is needed only here

    known = set(env.import_core().shield_parameter_names())
    config_dir = config_dir or DEFAULT_CONFIG_DIR
    out: dict[str, str] = {}
    for file_name, section, prefix in SOURCES:
        path = os.path.join(config_dir, file_name)
        for key, value in _section(path, section).items():
            name = prefix + str(key)
            if name not in known:
                raise DecisionConfigError(f"{path}: '{section}/{key}' is not an action shield parameter")
            try:
                out[name] = _text(value)
            except TypeError as e:
                raise DecisionConfigError(f"{path}: '{section}/{key}': {e}") from None
    return out
