"""Named params profiles: sets of ``dvc exp run -S key=value`` overrides kept in ``profiles/<name>.yaml``.

A profile file maps dotted params keys to values. :func:`load_profile` checks that every override
lands on an existing key and that the overridden params still validate (the same schema every stage
uses), so a typo fails before any stage runs.
"""

from __future__ import annotations

import copy
from pathlib import Path

import yaml

from hevlib.io import read_yaml_mapping
from hevlib.params import ParamsError, parse_params

PROFILES_DIR = Path("profiles")


def apply_overrides(params: dict, overrides: dict) -> dict:
    """A copy of the raw ``params`` mapping with each dotted-key override set. A key must exist, except with
    a leading ``+`` (DVC's and Hydra's "append"): then it is new, in a mapping that exists (a cycle of
    ``cycles.cycles``, a start state of ``sim.start``)."""
    out = copy.deepcopy(params)
    for dotted, value in overrides.items():
        append = str(dotted).startswith("+")
        node, parts = out, str(dotted).removeprefix("+").split(".")
        for i, part in enumerate(parts[:-1]):
            if not isinstance(node, dict) or part not in node:
                raise ParamsError(f"profile: {'.'.join(parts[: i + 1])}: no such params key")
            node = node[part]
        if not isinstance(node, dict):
            raise ParamsError(f"profile: {dotted}: {'.'.join(parts[:-1])} is not a mapping")
        if append == (parts[-1] in node):
            what = "already exists (drop the +)" if append else "no such params key (+ adds one)"
            raise ParamsError(f"profile: {dotted}: {what}")
        node[parts[-1]] = value
    return out


def load_profile(name: str, params_path: str | Path = "params.yaml", profiles_dir: str | Path = PROFILES_DIR) -> dict:
    """The overrides of ``profiles/<name>.yaml``, checked against ``params_path``."""
    path = Path(profiles_dir) / f"{name}.yaml"
    if not path.exists():
        known = sorted(p.stem for p in Path(profiles_dir).glob("*.yaml"))
        raise FileNotFoundError(f"{path}: no such profile (known: {', '.join(known) or 'none'})")
    overrides = read_yaml_mapping(path, what="profile (dotted params keys to values)", error=ParamsError, empty_ok=True)
    base = read_yaml_mapping(params_path, what="params file", error=ParamsError, missing_error=ParamsError)
    parse_params(apply_overrides(base, overrides))
    return overrides


def set_args(overrides: dict) -> list[str]:
    """``-S key=value`` arguments for ``dvc exp run`` (values in compact YAML flow style, no spaces, so
    ``$(hev profile NAME)`` splits into the right words)."""
    args = []
    for key, value in overrides.items():
        text = yaml.safe_dump(value, default_flow_style=True, width=float("inf"), sort_keys=False)
        text = text.strip().removesuffix("...").strip()
        text = text.replace(", ", ",").replace(": ", ":")
        if any(ch.isspace() for ch in text):
            raise ParamsError(f"profile: {key}: value {text!r} must not contain spaces")
        args += ["-S", f"{key}={text}"]
    return args
