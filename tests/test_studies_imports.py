"""The modules of polywear.studies import each other without a circle (function-level imports included)."""

import ast
from pathlib import Path

import polywear.studies

STUDIES = Path(polywear.studies.__file__).parent


def sibling_imports(path: Path) -> set[str]:
    """Names of the studies modules that ``path`` imports anywhere in its body."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            if node.level == 1 and node.module:
                names.add(node.module.split(".")[0])
            elif node.level == 1:
                names.update(alias.name for alias in node.names)
            elif node.level == 0 and (node.module or "").startswith("polywear.studies."):
                names.add(node.module.split(".")[2])
    return names


def cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One import circle of ``graph`` (module -> modules it imports), or None."""
    state: dict[str, int] = {}

    def visit(node, path):
        state[node] = 1
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                return path[path.index(nxt):] + [nxt] if nxt in path else [node, nxt]
            if nxt not in state and (found := visit(nxt, path + [nxt])):
                return found
        state[node] = 2
        return None

    for start in sorted(graph):
        if start not in state and (found := visit(start, [start])):
            return found
    return None


def test_the_cycle_finder_finds_a_circle_and_accepts_a_chain():
    assert cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert cycle({"a": {"b"}, "b": {"c"}, "c": set()}) is None


def test_studies_modules_form_no_import_circle():
    modules = {p.stem for p in STUDIES.glob("*.py")} - {"__init__"}
    graph = {m: sibling_imports(STUDIES / f"{m}.py") & modules for m in modules}
    assert graph["fast_band"] and graph["global_sensitivity"]  # the parser sees the imports that exist
    assert cycle(graph) is None, f"import circle in polywear.studies: {' -> '.join(cycle(graph))}"
