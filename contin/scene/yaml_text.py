"""YAML of scenes: the safe loader, read once into data and the line of each key, bounded in size.

:class:`SceneLoader` is PyYAML's safe loader with YAML 1.2's float syntax
(``1e-6`` is a number) that refuses a key given twice in one mapping.
:func:`load_nodes` parses a text once and gives both the data and its node
tree (the line of each key, :func:`line_map`); what aliases would build
beyond :data:`MAX_VALUES` values or :data:`MAX_DEPTH` levels is refused.
"""

from __future__ import annotations

import re

import yaml

from contin.scene.schema import SceneError

__all__ = ["SceneLoader", "MAX_VALUES", "MAX_DEPTH", "load_text", "load_nodes", "line_map"]


class SceneLoader(yaml.SafeLoader):
    """Safe YAML loader that reads ``1e-6`` as a number, as YAML 1.2 does, and refuses a key given twice
    in one mapping (PyYAML keeps the last silently; a merge ``<<`` may still be overridden)."""

    def construct_mapping(self, node, deep=False):
        if isinstance(node, yaml.MappingNode):
            seen: dict = {}
            for key_node, _ in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge":
                    continue
                key = self.construct_object(key_node, deep=deep)
                try:
                    if key in seen:
                        raise yaml.constructor.ConstructorError(
                            "while constructing a mapping", node.start_mark,
                            f"the key {key!r} is given twice (first on line {seen[key]})", key_node.start_mark)
                except TypeError:  # an unhashable key: the base class reports it
                    continue
                seen[key] = key_node.start_mark.line + 1
        return super().construct_mapping(node, deep)


SceneLoader.yaml_implicit_resolvers = {k: list(v) for k, v in yaml.SafeLoader.yaml_implicit_resolvers.items()}
SceneLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"""^(?:[-+]?(?:[0-9][0-9_]*)\.[0-9_]*(?:[eE][-+]?[0-9]+)?
    |[-+]?(?:[0-9][0-9_]*)(?:[eE][-+]?[0-9]+)
    |\.[0-9_]+(?:[eE][-+][0-9]+)?
    |[-+]?\.(?:inf|Inf|INF)
    |\.(?:nan|NaN|NAN))$""", re.X),
    list("-+0123456789."),
)


#: values a scene may hold once its YAML aliases are expanded (a scene has a few hundred)
MAX_VALUES = 100_000
#: nesting depth a scene may have (a scene has about five levels)
MAX_DEPTH = 64


def load_text(text: str, source: str = "<string>"):
    """The data of YAML ``text`` (see :func:`load_nodes`)."""
    return load_nodes(text, source)[0]


def load_nodes(text: str, source: str = "<string>"):
    """``(data, root node)`` of YAML ``text``, parsed once: the node tree gives the line numbers too."""
    loader = SceneLoader(text)
    try:
        root = loader.get_single_node()
        data = None if root is None else loader.construct_document(root)
    except RecursionError:
        raise SceneError(source, f"YAML nested at most {MAX_DEPTH} levels deep", "deeper nesting") from None
    except ValueError as exc:  # Python refuses to convert integers of more than 4300 digits
        raise SceneError(source, "numbers a scene can hold", "a number too long to read",
                         hint=f" ({exc})") from None
    finally:
        loader.dispose()
    _check_expansion(data, source)
    return data, root


def _check_expansion(data, source: str) -> None:
    """Refuse what YAML aliases can build: a structure that contains itself, or one that expands
    to more values than any scene holds (the "billion laughs" of nested aliases)."""
    count = 0
    stack = [(data, 0, ())]
    while stack:
        node, depth, path = stack.pop()
        count += 1
        if count > MAX_VALUES:
            raise SceneError(source, f"a scene of at most {MAX_VALUES} values with its YAML aliases expanded",
                             "more (aliases nested within aliases)")
        if isinstance(node, (dict, list)):
            if id(node) in path:
                raise SceneError(source, "YAML whose aliases do not refer to themselves", "a recursive alias")
            if depth >= MAX_DEPTH:
                raise SceneError(source, f"YAML nested at most {MAX_DEPTH} levels deep", "deeper nesting")
            inner = (*path, id(node))
            items = list(node.keys()) + list(node.values()) if isinstance(node, dict) else node
            stack.extend((v, depth + 1, inner) for v in items)


def line_map(root) -> dict:
    """Dotted key -> line number, from the YAML node tree (of a document :func:`_check_expansion` accepted)."""
    lines: dict = {}

    def walk(node, prefix):
        if isinstance(node, yaml.MappingNode):
            for k, v in node.value:
                key = f"{prefix}.{k.value}" if prefix else str(k.value)
                lines[key] = k.start_mark.line + 1
                walk(v, key)
        elif isinstance(node, yaml.SequenceNode):
            for i, v in enumerate(node.value):
                key = f"{prefix}[{i}]"
                lines[key] = v.start_mark.line + 1
                walk(v, key)

    if root is not None:
        walk(root, "")
    return lines
