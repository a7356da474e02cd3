"""YAML files read with limits: size, UTF-8, nesting, duplicate keys, alias expansion; then a schema.

Every failure is one InputError line naming the file (and the line, where YAML gives one).
"""
from __future__ import annotations

import yaml
from pydantic import BaseModel, ValidationError

from cvtdesign.errors import InputError, shorten
from cvtdesign.io.schema import schema_error


MAX_FILE_BYTES = 10 * 1024 * 1024   # a variant, study or protocol file is a few kB
MAX_NESTING = 50                     # YAML collections inside collections (a variant file needs 4)
MAX_NODES = 1_000_000                # YAML nodes after expanding aliases ("billion laughs")


class StrictLoader(yaml.SafeLoader):
    """PyYAML's SafeLoader, refusing a key repeated in one mapping (SafeLoader keeps the last silently) and
    collections nested deeper than MAX_NESTING (the composer recurses: 20,000 '[' exhaust Python's stack)."""

    def __init__(self, stream):
        super().__init__(stream)
        self._depth = 0

    def compose_node(self, parent, index):
        if self._depth >= MAX_NESTING:
            raise yaml.composer.ComposerError(None, None, f"collections nested more than {MAX_NESTING} deep",
                                              self.peek_event().start_mark)
        self._depth += 1
        try:
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1

    def construct_mapping(self, node, deep=False):
        if isinstance(node, yaml.MappingNode):
            seen = {}
            for key_node, _ in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge":
                    continue
                key = self.construct_object(key_node, deep=True)
                try:
                    first = seen.get(key)
                except TypeError:       # an unhashable key: SafeLoader's own error follows
                    continue
                if first is not None:
                    raise yaml.constructor.ConstructorError(
                        None, None, f"duplicate key '{shorten(key)}' (first on line {first + 1}); every key may "
                        "appear once in a mapping", key_node.start_mark)
                seen[key] = key_node.start_mark.line
        return super().construct_mapping(node, deep)


def _expanded_nodes(root) -> int:
    """Number of nodes of the document with every alias expanded (shared nodes counted at each use), stopping
    past MAX_NODES; a node that contains itself (a recursive alias) counts as too many."""
    size, state, stack = {}, {}, [root]
    while stack:
        node = stack[-1]
        children = [] if isinstance(node, yaml.ScalarNode) else \
            node.value if isinstance(node, yaml.SequenceNode) else [n for kv in node.value for n in kv]
        if state.get(id(node)) is None:
            state[id(node)] = "open"
            stack.extend(c for c in children if id(c) not in size)
            if any(state.get(id(c)) == "open" for c in children):
                return MAX_NODES + 1
            continue
        stack.pop()
        if id(node) not in size:
            size[id(node)] = min(1 + sum(size[id(c)] for c in children), MAX_NODES + 1)
            state[id(node)] = "done"
    return size[id(root)]


def load_yaml(path):
    """The YAML document of a file, read with the limits above; every failure is one InputError line."""
    where = str(path)
    try:
        with open(path, "rb") as f:
            raw = f.read(MAX_FILE_BYTES + 1)
    except OSError as e:
        raise InputError(f"{where}: cannot read file ({e.strerror or type(e).__name__})") from None
    if len(raw) > MAX_FILE_BYTES:
        raise InputError(f"{where}: larger than {MAX_FILE_BYTES // 2**20} MB; expected a YAML file of a few kB")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as e:
        line = raw[:e.start].count(b"\n") + 1
        raise InputError(f"{where}: line {line}: not UTF-8 text (byte 0x{raw[e.start]:02x}); expected a YAML "
                         "file saved as UTF-8") from None
    loader = None
    try:
        loader = StrictLoader(text)      # its reader refuses control characters (a NUL byte) here already
        node = loader.get_single_node()
        if node is not None and _expanded_nodes(node) > MAX_NODES:
            raise InputError(f"{where}: its aliases expand to more than {MAX_NODES} YAML nodes (or refer to "
                             "themselves); expected a plain YAML file")
        return None if node is None else loader.construct_document(node)
    except InputError:          # already one line naming the file (an InputError is a ValueError too)
        raise
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        line = f" (line {mark.line + 1})" if mark else ""
        problem = getattr(e, "problem", None) or getattr(e, "reason", None) or str(e)
        raise InputError(f"{where}: not valid YAML{line}: {' '.join(str(problem).split())}") from None
    except (ValueError, OverflowError, RecursionError) as e:   # e.g. an integer beyond Python's 4300 digits
        raise InputError(f"{where}: not valid YAML: {' '.join(str(e).split()) or type(e).__name__}") from None
    finally:
        if loader is not None:
            loader.dispose()


def read_spec(path, model: type[BaseModel], fields: str):
    """Read a YAML file (`load_yaml`) and validate it against `model`; every failure is one InputError line."""
    where = str(path)
    data = load_yaml(path)
    if not isinstance(data, dict):
        raise InputError(f"{where}: expected a YAML mapping with fields {fields}")
    try:
        return model.model_validate(data)
    except ValidationError as err:
        raise schema_error(err, where, model) from None
