"""The import graph of the cgbound package, checked against its layers and drawn for docs/architecture.md.

    python tools/import_graph.py            print the findings and the Mermaid picture
    python tools/import_graph.py --write    regenerate the block between the markers in docs/architecture.md
    python tools/import_graph.py --check    exit 1 if that block is stale or any rule is broken

Every ``cgbound/**/*.py`` file is parsed with ``ast`` (nothing is imported); relative imports are resolved;
imports inside functions (lazy imports) count like the others and are drawn dotted. The rules
(tests/test_architecture.py asserts the same ones):

1. no import cycle among cgbound modules;
2. no import from a module to a module of a higher layer (``LAYERS`` below is the one layer table);
3. ``_core`` (the C extension) is imported only by ``cgbound/_engine.py``;
4. no private name (``_x``) imported from another cgbound module, nor read as ``module._x``.

A module that ``LAYERS`` does not place is an error that names it: add it to the table.
"""
import argparse
import ast
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = "cgbound"
DOC = ROOT / "docs" / "architecture.md"
START, END = "<!-- import-graph:start -->", "<!-- import-graph:end -->"

#: layer number -> (name, what it holds); lowest first. A module may import from its own layer or below.
LAYER_NAMES = {
    0: ("core", "the C extension and its one seam, validation, threads, memory, atomic files, progress bars"),
    1: ("physics/data", "box geometry, snapshots and contacts"),
    2: ("kernels", "coarse-graining kernels and the Gaussian's truncation"),
    3: ("targets", "where fields are evaluated: grids and point sets"),
    4: ("fields", "the primary sums, the derived fields, the momentum-balance check"),
    5: ("pipeline", "the per-snapshot pipeline, entry points, tiles, executors, the Result they return, its writers and plots"),
    6: ("I/O", "readers, MercuryCG files"),
    7: ("front ends", "the package root, the command line, the paper-reproduction wing"),
}

#: module (dotted, relative to cgbound; a package name covers all its submodules) -> layer.
#: "__init__" is the package root. Names of today's layout that issue 12 retires are kept so that the
#: tool reports on any checkout (marked "today").
LAYERS = {
    "_core": 0, "_engine": 0, "_version": 0, "_validate": 0, "_threads": 0, "_memory": 0, "_atomic": 0, "progress": 0,
    "readahead": 0,                                               # frames read in a thread one ahead
    "box": 1, "snapshot": 1,
    "units": 1,                                                   # units of particle data and of every field
    "kernels": 2, "truncation": 2,
    "grid": 3,
    "primaries": 4, "fields": 4, "residual": 4,
    # result.py is the object the pipeline returns (coarse_grain builds one), so it sits with the pipeline, and
    # writers.py with it: Result.to_hdf5 & co. call the writers, which import nothing above layer 0
    "pipeline": 5, "coarse": 5, "tiled": 5, "executors": 5, "result": 5, "writers": 5,
    "averaging": 5,                                               # time averages over blocks of frames
    "block_errors": 5, "scale_separation": 5,                     # error bars from block means; choosing w
    "_partial": 5, "_dask": 5,                                    # today
    "plot": 5,                                                    # Result.plot and _repr_png_ draw through it
    "readers": 6, "mercurycg": 6,
    "rheology": 6,                                                # ratios of a Result's stress components
    "__init__": 7, "__main__": 7, "cli": 7, "paper": 7,
    "scenes": 7, "profiles": 7, "datasets": 7, "blobs": 7,        # today (the paper wing, before cgbound/paper/)
    "rotation": 5, "angular_balance": 5,                          # spin, couple stress (through the pipeline); their balance
    "cylindrical": 3, "cylindrical_fields": 5,                    # cylindrical grids; their fields from ring quadrature
    "cylindrical_balance": 5,                                     # the momentum balance on ring averages (hoop terms)
    "cylindrical_ring": 4,                                        # exact ring averages of point sources
    "cylindrical_axial": 4,                                       # exact z-averages of line integrals on θ-resolved grids
    "cylindrical_axial_segments": 4,                              # z-averaged line integrals on rings; the rays
}

#: packages drawn as one node
COLLAPSED = ("readers", "paper", "scenes")

#: the only module allowed to import the C extension
CORE, ENGINE = "_core", "_engine"


class UnknownModules(Exception):
    pass


def discover(package_dir):
    """{module name: path} for every .py file of the package (``__init__`` for the root)."""
    modules = {}
    for path in sorted(package_dir.rglob("*.py")):
        parts = list(path.relative_to(package_dir).with_suffix("").parts)
        if parts[-1] == "__init__" and len(parts) > 1:
            parts = parts[:-1]
        modules[".".join(parts)] = path
    return modules


def package_of(module, path):
    """The dotted package (relative to cgbound, "" for the root) that relative imports in ``module`` start from."""
    if path.name == "__init__.py":
        return "" if module == "__init__" else module
    return module.rpartition(".")[0]


def resolve(modules, dotted):
    """The module a dotted name (relative to cgbound, "" for the root) refers to: itself, or the root."""
    if dotted == "":
        return "__init__"
    if dotted in modules or dotted == CORE:
        return dotted
    return None


def is_lazy(node, parents):
    """Whether an import statement sits inside a function (runs only when the function is called)."""
    p = parents.get(node)
    while p is not None:
        if isinstance(p, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
            return True
        p = parents.get(p)
    return False


def imports_of(module, path, modules):
    """[(imported module, names imported from it, lazy, line)], and {local alias: module} for module aliases."""
    tree = ast.parse(path.read_text(), filename=str(path))
    parents = {child: node for node in ast.walk(tree) for child in ast.iter_child_nodes(node)}
    here = package_of(module, path)
    found, aliases = [], {}

    def add(target, names, node):
        found.append((target, tuple(names), is_lazy(node, parents), node.lineno))

    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name == PACKAGE or alias.name.startswith(PACKAGE + "."):
                    dotted = alias.name[len(PACKAGE) + 1:]
                    target = resolve(modules, dotted) or "__init__"
                    add(target, (), node)
                    if alias.asname:
                        aliases[alias.asname] = target
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = here.split(".") if here else []
                if node.level > 1:
                    base = base[:len(base) - (node.level - 1)]
                dotted = ".".join(base + ([node.module] if node.module else []))
            elif node.module == PACKAGE or (node.module or "").startswith(PACKAGE + "."):
                dotted = node.module[len(PACKAGE) + 1:]
            else:
                continue
            target = resolve(modules, dotted) or "__init__"
            plain = []
            for alias in node.names:
                sub = resolve(modules, f"{dotted}.{alias.name}" if dotted else alias.name)
                if sub is not None and sub != "__init__":
                    add(sub, (), node)               # a submodule, e.g. `from . import plot`
                    aliases[alias.asname or alias.name] = sub
                else:
                    plain.append(alias.name)
            if plain or not node.names:
                add(target, plain, node)
    return found, aliases


def private_reads(path, aliases):
    """[(module, name, line)] for ``alias._name`` where alias is an imported cgbound module."""
    tree = ast.parse(path.read_text(), filename=str(path))
    out = []
    for node in ast.walk(tree):
        if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in aliases
                and is_private(node.attr)):
            out.append((aliases[node.value.id], node.attr, node.lineno))
    return out


def is_private(name):
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def layer_of(module):
    if module in LAYERS:
        return LAYERS[module]
    head = module.split(".")[0]
    return LAYERS.get(head)


def node_of(module):
    head = module.split(".")[0]
    return head if head in COLLAPSED else module


class Graph:
    """Modules, import edges and the rule findings of one checkout."""

    def __init__(self, root=ROOT):
        self.root = Path(root)
        self.modules = discover(self.root / PACKAGE)
        unknown = sorted(m for m in self.modules if layer_of(m) is None)
        if unknown:
            raise UnknownModules(
                "no layer for " + ", ".join(f"cgbound/{self.modules[m].relative_to(self.root / PACKAGE)} "
                                            f"(module {m!r})" for m in unknown)
                + ": add each to LAYERS in tools/import_graph.py ("
                + "; ".join(f"{n} {name}" for n, (name, _) in LAYER_NAMES.items()) + ")")
        self.edges = []          # (importer, imported, names, lazy, line)
        self.private = []        # (importer, module, name, line)
        for module, path in self.modules.items():
            found, aliases = imports_of(module, path, self.modules)
            for target, names, lazy, line in found:
                if target == module:
                    continue
                self.edges.append((module, target, names, lazy, line))
                for name in names:
                    if is_private(name):
                        self.private.append((module, target, name, line))
            for target, name, line in private_reads(path, aliases):
                if target != module:
                    self.private.append((module, target, name, line))

    def where(self, module, line):
        return f"{self.modules[module].relative_to(self.root)}:{line}" if module in self.modules else module

    def cycles(self):
        """Strongly connected components with more than one module (Tarjan), each sorted."""
        succ = {}
        for a, b, *_ in self.edges:
            succ.setdefault(a, set()).add(b)
        index, low, stack, on, out = {}, {}, [], set(), []

        def visit(v):
            index[v] = low[v] = len(index)
            stack.append(v)
            on.add(v)
            for w in sorted(succ.get(v, ())):
                if w not in index:
                    visit(w)
                    low[v] = min(low[v], low[w])
                elif w in on:
                    low[v] = min(low[v], index[w])
            if low[v] == index[v]:
                comp = []
                while True:
                    w = stack.pop()
                    on.discard(w)
                    comp.append(w)
                    if w == v:
                        break
                if len(comp) > 1:
                    out.append(sorted(comp))

        sys.setrecursionlimit(max(1000, 10 * len(self.modules)))
        for v in sorted(set(succ) | {b for _, b, *_ in self.edges}):
            if v not in index:
                visit(v)
        return sorted(out)

    def short_cycles(self):
        """For every module on a cycle, one shortest cycle through it (as a list starting at its least
        module), without repeats: a readable account of what the components of ``cycles`` are made of."""
        succ = {}
        for a, b, *_ in self.edges:
            succ.setdefault(a, set()).add(b)
        found = set()
        for comp in self.cycles():
            for start in comp:
                prev, frontier, path = {start: None}, [start], None
                while frontier and path is None:
                    nxt = []
                    for v in frontier:
                        for w in sorted(succ.get(v, ())):
                            if w == start:
                                path = [v]
                                while prev[path[-1]] is not None:
                                    path.append(prev[path[-1]])
                                path.reverse()
                                break
                            if w not in prev:
                                prev[w] = v
                                nxt.append(w)
                        if path is not None:
                            break
                    frontier = nxt
                k = path.index(min(path))
                found.add(tuple(path[k:] + path[:k]))
        return sorted(found, key=lambda c: (len(c), c))

    def upward(self):
        return [(a, b, lazy, line) for a, b, _, lazy, line in self.edges if layer_of(b) > layer_of(a)]

    def core_importers(self):
        return sorted({(a, line) for a, b, _, _, line in self.edges if b == CORE and a != ENGINE})

    def findings(self):
        """Human-readable rule violations, one per line (empty when the layout is clean)."""
        out = []
        for cycle in self.short_cycles():
            out.append("import cycle: " + " -> ".join(cycle + (cycle[0],)))
        for a, b, lazy, line in self.upward():
            out.append(f"upward import: {a} (layer {layer_of(a)}) imports {b} (layer {layer_of(b)})"
                       f"{' lazily' if lazy else ''} at {self.where(a, line)}")
        for a, line in self.core_importers():
            out.append(f"_core imported outside {ENGINE}: {self.where(a, line)}")
        for a, b, name, line in sorted(set(self.private)):
            out.append(f"private name: {a} uses {b}.{name} at {self.where(a, line)}")
        return out

    # ---------------------------------------------------------------- picture
    def collapsed_edges(self):
        """{(node, node): lazy} with packages in COLLAPSED as one node; lazy if every underlying import is."""
        out = {}
        for a, b, _, lazy, _ in self.edges:
            key = (node_of(a), node_of(b))
            if key[0] != key[1]:
                out[key] = out.get(key, True) and lazy
        return dict(sorted(out.items()))

    def mermaid(self):
        nodes = sorted({node_of(m) for m in self.modules} | {node_of(b) for _, b, *_ in self.edges})
        bad = {(node_of(a), node_of(b)) for a, b, *_ in self.upward()}
        in_cycle = set()
        for comp in self.cycles():
            members = set(comp)
            in_cycle |= {(node_of(a), node_of(b)) for a, b, *_ in self.edges if a in members and b in members}
        lines = ["```mermaid", "flowchart TB"]
        for layer in sorted(LAYER_NAMES, reverse=True):
            members = [n for n in nodes if layer_of(n) == layer]
            if not members:
                continue
            lines.append(f'  subgraph L{layer}["{layer} {LAYER_NAMES[layer][0]}"]')
            for n in members:
                label = f"{n}/" if n in COLLAPSED else ("cgbound/__init__" if n == "__init__" else n)
                lines.append(f'    {node_id(n)}["{label}"]')
            lines.append("  end")
        red = []
        for k, ((a, b), lazy) in enumerate(self.collapsed_edges().items()):
            lines.append(f"  {node_id(a)} {'-.->' if lazy else '-->'} {node_id(b)}")
            if (a, b) in bad or (a, b) in in_cycle:
                red.append(str(k))
        if red:
            lines.append(f"  linkStyle {','.join(red)} stroke:#d00,stroke-width:2px")
        lines.append("```")
        return "\n".join(lines)

    def block(self):
        """The generated part of docs/architecture.md, markers included."""
        rows = ["| layer | name | holds | modules |", "|---|---|---|---|"]
        for layer, (name, holds) in LAYER_NAMES.items():
            mods = sorted({node_of(m) for m in self.modules if layer_of(m) == layer}
                          | ({CORE} if layer == layer_of(CORE) else set()))
            shown = ", ".join(f"`{m}/`" if m in COLLAPSED else f"`{m}`" for m in mods)
            rows.append(f"| {layer} | {name} | {holds} | {shown} |")
        findings = self.findings()
        text = [START,
                "<!-- generated by `python tools/import_graph.py --write` from the code; do not edit by hand -->",
                "",
                *rows,
                "",
                "Arrows point from the importing module to the imported one; dotted arrows are imports inside a "
                "function (lazy); red arrows break a rule (an import up a layer, or part of a cycle). Packages "
                f"{', '.join(f'`{p}/`' for p in COLLAPSED)} are drawn as one node each.",
                "",
                self.mermaid(),
                "",
                "Rule check (`python tools/import_graph.py --check`): "
                + ("no import cycle, no import up a layer, `_core` only in `_engine`, no private name across "
                   "modules." if not findings else f"{len(findings)} finding(s):"),
                ""]
        text += [f"- {f}" for f in findings]
        if findings:
            text.append("")
        text.append(END)
        return "\n".join(text)


def node_id(name):
    return "m_" + name.replace(".", "_")


def embedded(doc_text):
    """The block between the markers (markers included), or None."""
    i, j = doc_text.find(START), doc_text.find(END)
    if i < 0 or j < i:
        return None
    return doc_text[i:j + len(END)]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--write", action="store_true", help="regenerate the block in docs/architecture.md")
    group.add_argument("--check", action="store_true",
                       help="exit 1 if the block is stale or a rule is broken (cycle, upward import, ...)")
    parser.add_argument("--root", default=str(ROOT), help="checkout to read (default: this one)")
    args = parser.parse_args(argv)
    root = Path(args.root)
    doc = root / "docs" / "architecture.md"
    try:
        graph = Graph(root)
    except UnknownModules as exc:
        print(f"import_graph: {exc}", file=sys.stderr)
        return 2
    block = graph.block()
    if args.write:
        text = doc.read_text()
        old = embedded(text)
        if old is None:
            print(f"import_graph: {doc}: expected the markers {START} ... {END}, found none", file=sys.stderr)
            return 2
        doc.write_text(text.replace(old, block))
        print(f"wrote the import graph into {doc.relative_to(root)}")
        for line in graph.findings():
            print(line)
        return 0
    if args.check:
        status = 0
        text = doc.read_text() if doc.exists() else ""
        if embedded(text) != block:
            print(f"stale: {doc.relative_to(root)} does not hold the current import graph "
                  "(run python tools/import_graph.py --write)")
            status = 1
        for line in graph.findings():
            print(line)
            status = 1
        return status
    print(block)
    return 0


if __name__ == "__main__":
    sys.exit(main())
