"""Reading config input: YAML within bounds (config, grid and training files, ``--set`` values, a run folder's
files): a bounded alias expansion, nesting depth, number length and file size, so an alias bomb
or a 20,000-deep document is one line, fast, naming the input; and merging a file's keys and
``--set KEY=VALUE`` overrides over the defaults."""

from __future__ import annotations

import copy
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml

from petswarm_env.config_base import ConfigError, describe_value

# -- reading YAML within bounds: a config, a grid or a training file is a few kB of a few hundred values
# (configs/default.yaml: about 600 nodes), so a file far beyond these is a mistake or an attack (an
# alias bomb, "billion laughs", expands 300 bytes into 10^9 values; a 20,000-deep nesting overflows
# the parser's recursion); both are refused before anything is built from them
MAX_YAML_BYTES = 128_000  # a file: the largest shipped, configs/default.yaml, is 29 kB (PyYAML reads some 100 kB a second)
MAX_YAML_DEPTH = 50  # nested mappings and lists (the deepest shipped key, robot_types.NAME.sensors[i].id, is 5)
MAX_YAML_VALUES = 200_000  # values after the aliases are expanded (each use of an alias counts its whole value)
MAX_NUMBER_CHARS = 100  # characters of one number (1e308 needs 5; Python refuses ints of more than 4300 digits)


class _BoundedLoader(yaml.SafeLoader):
    """PyYAML's safe loader with a bounded nesting depth (checked while composing, before
    Python's recursion limit is reached)."""

    def compose_node(self, parent, index):  # noqa: ANN001 (PyYAML's signature)
        self._depth = getattr(self, "_depth", 0) + 1
        try:
            if self._depth > MAX_YAML_DEPTH:
                mark = self.peek_event().start_mark
                raise _YamlLimit(f"is nested more than {MAX_YAML_DEPTH} levels deep (line {mark.line + 1}); "
                                 "a config nests a few levels")
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1


class _YamlLimit(Exception):
    """A YAML document beyond the bounds above (the text says which)."""


_NUMBER_TAGS = ("tag:yaml.org,2002:int", "tag:yaml.org,2002:float")


def _check_expansion(root: yaml.Node) -> None:
    """Count the values of the document with every alias expanded, without expanding it (each
    node's count once, iteratively); refuse a recursive alias, more than :data:`MAX_YAML_VALUES`
    values, and a number longer than :data:`MAX_NUMBER_CHARS`."""
    size: dict[int, int] = {}
    on_path: set[int] = set()
    stack: list[tuple[yaml.Node, bool]] = [(root, False)]
    while stack:
        node, done = stack.pop()
        key = id(node)
        if done:
            on_path.discard(key)
            if isinstance(node, yaml.MappingNode):
                children = [c for pair in node.value for c in pair]
            elif isinstance(node, yaml.SequenceNode):
                children = node.value
            else:
                children = []
            size[key] = 1 + sum(size[id(c)] for c in children)
            if size[key] > MAX_YAML_VALUES:
                raise _YamlLimit(f"expands to more than {MAX_YAML_VALUES} values through its aliases (*name; line "
                                 f"{node.start_mark.line + 1}); write the values out or use fewer aliases")
            continue
        if key in size:
            continue
        if key in on_path:
            raise _YamlLimit(f"has an alias inside its own anchor (line {node.start_mark.line + 1}); a config value cannot contain itself")
        if isinstance(node, yaml.ScalarNode):
            if node.tag in _NUMBER_TAGS and len(node.value) > MAX_NUMBER_CHARS:
                raise _YamlLimit(f"has a number of {len(node.value)} characters (line {node.start_mark.line + 1}); "
                                 "give a number within the key's range")
            size[key] = 1
            continue
        on_path.add(key)
        stack.append((node, True))
        children = [c for pair in node.value for c in pair] if isinstance(node, yaml.MappingNode) else node.value
        stack.extend((c, False) for c in children if id(c) not in size)


def parse_yaml(text: str, where: str) -> Any:
    """The YAML document in ``text``, within the bounds above. ``where`` names the input for the
    message ("config file 'x.yaml'", "--set KEY"); raises :class:`ConfigError` in one line, and
    ``yaml.YAMLError`` for text that is not YAML (the caller words it)."""
    if len(text) > MAX_YAML_BYTES:
        raise ConfigError(f"{where} holds {len(text)} characters, more than the {MAX_YAML_BYTES} a config may have")
    loader = _BoundedLoader(text)
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        _check_expansion(node)
        return loader.construct_document(node)
    except _YamlLimit as exc:
        raise ConfigError(f"{where} {exc}") from None
    except RecursionError:
        raise ConfigError(f"{where} is nested too deeply to read; a config nests a few levels") from None
    except ValueError as exc:  # a constructor's number conversion (e.g. an int beyond Python's digit limit)
        raise ConfigError(f"{where} holds a value that cannot be read ({' '.join(str(exc).split())[:120]}); "
                          "give a number within the key's range") from None
    finally:
        loader.dispose()


def read_yaml(path: str | Path, what: str = "config file") -> dict[str, Any]:
    """The mapping of the YAML file at ``path`` (:func:`parse_yaml`'s bounds); ``what`` names the
    file's role in the messages ("config file", "grid file", ...)."""
    path = Path(path)
    if not path.is_file():
        what_is = "is a folder" if path.is_dir() else "does not exist" if not path.exists() else "is not a regular file"
        raise ConfigError(f"{what} '{path}' {what_is}; pass an existing YAML file")
    try:
        if path.stat().st_size > MAX_YAML_BYTES:
            raise ConfigError(f"{what} '{path}' is {path.stat().st_size} bytes, more than the {MAX_YAML_BYTES} a config may have")
        data = parse_yaml(path.read_text(encoding="utf-8"), f"{what} '{path}'")
    except yaml.YAMLError as exc:
        raise ConfigError(" ".join(f"{what} '{path}' is not valid YAML: {exc}".split())) from None
    except UnicodeDecodeError:
        raise ConfigError(f"{what} '{path}' is not UTF-8 text; pass a YAML file") from None
    except OSError as exc:
        raise ConfigError(f"{what} '{path}' cannot be read ({exc.strerror or exc})") from None
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise ConfigError(f"{what} '{path}' must hold a mapping of keys, got {type(data).__name__}")
    bad = next((k for k in data if not isinstance(k, str)), None)
    if bad is not None:
        raise ConfigError(f"{what} '{path}' has a key {describe_value(bad)}; keys are names (text)")
    return data


def merge_mappings(base: dict[str, Any], over: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    out = copy.deepcopy(base)
    for key, value in over.items():
        dotted = f"{prefix}{key}"
        if key not in out and prefix.startswith("robot_types."):  # a user may add a type, or a key to one (pydantic checks it)
            out[key] = copy.deepcopy(value)
            continue
        if key not in out:
            allowed = ", ".join(sorted(out)) if out else "(none)"
            raise ConfigError(f"unknown config key '{dotted}'; allowed keys here: {allowed}")
        if isinstance(out[key], dict) and isinstance(value, Mapping):
            out[key] = merge_mappings(out[key], value, prefix=f"{dotted}.")
        else:
            out[key] = copy.deepcopy(value)
    return out


def flatten_dotted(d: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """``{"swarm": {"num_slaves": 4}}`` -> ``{"swarm.num_slaves": 4}`` (lists stay values)."""
    out: dict[str, Any] = {}
    for key, value in d.items():
        if isinstance(value, Mapping):
            out.update(flatten_dotted(value, f"{prefix}{key}."))
        else:
            out[f"{prefix}{key}"] = value
    return out


def dotted_keywords(overrides: Mapping[str, Any]) -> dict[str, Any]:
    """Keyword overrides: ``swarm__num_slaves=3`` means ``swarm.num_slaves = 3``. One key given in
    both forms is refused (which value was meant?)."""
    out: dict[str, Any] = {}
    for key, value in overrides.items():
        dotted = key.replace("__", ".") if isinstance(key, str) else key
        if dotted in out:
            forms = [k for k in overrides if isinstance(k, str) and k.replace("__", ".") == dotted]
            raise ConfigError(f"config key '{dotted}' is given twice ({' and '.join(forms)}); give it once")
        out[dotted] = value
    return out


def parse_override(item: str) -> tuple[str, Any]:
    """Parse ``KEY=VALUE`` (VALUE read as YAML, so ``3``, ``0.1``, ``true``, ``[1, 2]`` work)."""
    if "=" not in item:
        raise ConfigError(f"override '{item}' must look like KEY=VALUE, e.g. swarm.num_slaves=3")
    key, raw = item.split("=", 1)
    try:
        value = parse_yaml(raw, f"--set {key.strip()}")
    except yaml.YAMLError:
        value = raw
    return key.strip(), value


def nest_dotted(overrides: Mapping[str, Any]) -> dict[str, Any]:
    nested: dict[str, Any] = {}
    for key, value in overrides.items():
        parts = key.split(".")
        if not all(parts):
            raise ConfigError(f"config key '{key}' has an empty part (a leading, trailing or doubled '.'); write it as "
                              "section.key, e.g. swarm.num_slaves")
        node = nested
        for part in parts[:-1]:
            node = node.setdefault(part, {})
            if not isinstance(node, dict):
                raise ConfigError(f"override '{key}' conflicts with another override of '{part}'")
        node[parts[-1]] = value
    return nested
