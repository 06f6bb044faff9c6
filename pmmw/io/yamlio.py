"""Reading YAML the user wrote: duplicate keys refused, alias bombs refused, errors with lines.

Every YAML file pmmw reads (scenarios, ``--set`` values, the material database, layered-surface
stacks, atmosphere files) goes through `load_yaml`. PyYAML's safe loader already refuses
arbitrary objects; on top of it:

- A duplicate key in a mapping is an error (PyYAML keeps the last one silently).
- The document is composed into its node graph first and its size is measured *as expanded*
  (an alias counts as a full copy of what it names). A few hundred bytes of nested aliases
  ("billion laughs") expand to billions of nodes: validation, deep copies and error messages
  would then run for minutes and exhaust memory. More than `MAX_NODES` expanded nodes, or
  nesting deeper than `MAX_DEPTH`, is refused before anything is built. Legitimate anchors
  (one material reused by several entries) stay far below both.

The document is parsed by libyaml (PyYAML's C parser) where PyYAML has it: the material database's
files take about 0.1 s of every render's start with PyYAML's Python parser, a tenth of that with
libyaml. The values are the same (the tags are resolved and the values constructed by the same
Python code); a document that libyaml refuses, or that the checks above refuse, is read again by
the Python parser, so every message, its line and column are PyYAML's as before.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import yaml

from pmmw.errors import UserError

MAX_NODES = 200_000  # expanded scalar/sequence/mapping nodes in one document
MAX_DEPTH = 64  # nesting of sequences and mappings


class MalformedYAML(UserError):
    """The text is not YAML at all (as opposed to YAML that is refused)."""


class _Loader(yaml.SafeLoader):
    pass


def _construct_mapping(loader, node, deep=False):
    seen = set()
    for key_node, _ in node.value:  # the keys as written: a merge (<<) may be overridden
        if key_node.tag == "tag:yaml.org,2002:merge":
            continue
        key = loader.construct_object(key_node, deep=deep)
        try:
            dup = key in seen
            seen.add(key)
        except TypeError:  # unhashable key: let the stock constructor report it
            break
        if dup:
            raise yaml.constructor.ConstructorError(
                "while constructing a mapping", node.start_mark, f"found duplicate key {key!r}", key_node.start_mark
            )
    loader.flatten_mapping(node)
    return yaml.SafeLoader.construct_mapping(loader, node, deep=deep)


_Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)

_LIBYAML = hasattr(yaml, "CSafeLoader")  # PyYAML built with libyaml


class _FastLoader(getattr(yaml, "CSafeLoader", yaml.SafeLoader)):  # type: ignore[misc]
    """`_Loader` on libyaml's parser: the same constructors."""


_FastLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)


class _TooLarge(Exception):
    pass


def _expanded_size(root: yaml.Node) -> int:
    """Nodes of the document with every alias expanded, without expanding it (memoized on the
    shared nodes); raises `_TooLarge` past the limits."""
    sizes: dict[int, int] = {}

    def size(node: yaml.Node, depth: int) -> int:
        if depth > MAX_DEPTH:
            raise _TooLarge(f"nested deeper than {MAX_DEPTH} levels")
        got = sizes.get(id(node))
        if got is not None:
            return got
        sizes[id(node)] = 1  # a recursive alias counts once (PyYAML builds it as a cycle)
        total = 1
        if isinstance(node, yaml.SequenceNode):
            for child in node.value:
                total += size(child, depth + 1)
        elif isinstance(node, yaml.MappingNode):
            for k, v in node.value:
                total += size(k, depth + 1) + size(v, depth + 1)
        if total > MAX_NODES:
            raise _TooLarge(f"expands (through its aliases) to more than {MAX_NODES:,} values")
        sizes[id(node)] = total
        return total

    return size(root, 0)


def load_yaml(text: str, file: str | Path | None = None, key: str | None = None) -> Any:
    """Parse one YAML document.

    Parameters
    ----------
    text : str
    file, key : optional
        Where the text came from (a path, or ``--set`` and its key), for the error message.

    Raises
    ------
    UserError
        Malformed YAML (with line and column), a duplicate key, or a document too large or
        too deep once its aliases are expanded.
    """
    if _LIBYAML:
        fast = _FastLoader(text)
        try:
            node = fast.get_single_node()
            if node is None:
                return None
            _expanded_size(node)
            return fast.construct_document(node)
        except (_TooLarge, yaml.YAMLError, RecursionError):
            pass  # the Python parser below says why, in PyYAML's words
        finally:
            fast.dispose()
    loader = _Loader(text)
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        _expanded_size(node)
        return loader.construct_document(node)
    except _TooLarge as e:
        raise UserError(f"the YAML {e}; write the values out instead of nesting aliases", file, key) from None
    except yaml.MarkedYAMLError as e:
        mark = e.problem_mark or e.context_mark
        where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark is not None else ""
        what = ": ".join(p for p in (e.context, e.problem) if p)
        if "duplicate key" in (e.problem or ""):
            raise UserError(f"{where}{e.problem}", file, key) from None
        raise MalformedYAML(f"malformed YAML: {where}{what}", file, key) from None
    except yaml.YAMLError as e:
        raise MalformedYAML(f"malformed YAML: {e}", file, key) from None
    except RecursionError:
        raise UserError(f"the YAML is nested too deeply (more than {MAX_DEPTH} levels)", file, key) from None
    finally:
        loader.dispose()


def read_yaml(path: str | os.PathLike[str], what: str = "YAML file") -> Any:
    """`load_yaml` of a file; an unreadable file is a `UserError` naming it."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        reason = e.strerror if isinstance(e, OSError) and e.strerror else str(e)
        raise UserError(f"cannot read {what}: {reason}", path) from None
    return load_yaml(text, path)
