"""No circle of imports between fitlab's modules.

grimp reads the sources (it imports nothing) and records every import statement of a module: at module level,
inside functions and under ``if TYPE_CHECKING``.  So a function-local import does not hide a circle from this
test; a module that must import late for start-up time imports a module that does not import it back.  An edge
is an import statement as written: importing ``a.b.c`` is an edge to ``a.b.c``, not to the packages above it.
"""

from __future__ import annotations

import grimp
import pytest


def circles(graph: grimp.ImportGraph) -> list[list[str]]:
    """Every strongly connected component of more than one module (Tarjan's algorithm, iterative), each as one
    shortest circle through it (``a, b, ..., a``), sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[list[str]] = []
    for root in sorted(graph.modules):
        if root in index:
            continue
        work = [(root, iter(sorted(graph.find_modules_directly_imported_by(root))))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            v, children = work[-1]
            w = next(children, None)
            if w is not None:
                if w not in index:
                    index[w] = low[w] = len(index)
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(graph.find_modules_directly_imported_by(w)))))
                elif w in on_stack:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                component = []
                while True:
                    w = stack.pop()
                    on_stack.discard(w)
                    component.append(w)
                    if w == v:
                        break
                if len(component) > 1:
                    components.append(sorted(component))
    out = []
    for component in components:
        a = component[0]
        b = min(m for m in graph.find_modules_directly_imported_by(a) if m in component)
        back = graph.find_shortest_chain(importer=b, imported=a)
        assert back is not None
        out.append([a, *back])
    return sorted(out)


def test_the_cycle_finder_finds_circles_and_only_them():
    g = grimp.ImportGraph()
    for importer, imported in [("p.a", "p.b"), ("p.b", "p.c"), ("p.c", "p.a"), ("p.c", "p.d"), ("p.d", "p.e"),
                               ("p.e", "p.d"), ("p.f", "p.a")]:  # fmt: skip
        g.add_import(importer=importer, imported=imported)
    assert circles(g) == [["p.a", "p.b", "p.c", "p.a"], ["p.d", "p.e", "p.d"]]
    g.remove_import(importer="p.c", imported="p.a")
    g.remove_import(importer="p.e", imported="p.d")
    assert circles(g) == []


@pytest.fixture(scope="module")
def graph() -> grimp.ImportGraph:
    return grimp.build_graph("fitlab", cache_dir=None)  # cache_dir=None: nothing written into the checkout


def test_no_module_of_fitlab_imports_itself_back(graph):
    # the graph is fitlab's whole, the imports inside functions included (codegen re-measures a fit inside its
    # functions); the registry imports the families by name (importlib), which no reading of the source sees
    assert len(graph.modules) > 200 and graph.count_imports() > 600
    assert graph.direct_import_exists(importer="fitlab.codegen._files", imported="fitlab.fit.verify")
    found = circles(graph)
    assert not found, "import circles: " + "; ".join(" -> ".join(c) for c in found)
