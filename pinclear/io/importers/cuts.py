"""Which joints to cut: the spanning tree of a mechanism's joint graph.

The number of cut joints is fixed by the topology (joints - bodies, the world counted as a
body); which ones is a choice. Each cut joint becomes a closure whose rows pinclear solves for
(pinclear.model.closures: ball 3, universal 4, revolute and prismatic 5, fixed 6), so the tree kept
is a maximum spanning tree of the rows (Kruskal's algorithm on the rows, heaviest first: the
cut joints' rows are then the fewest possible), ties broken towards a shallow tree (joints nearer
the root are kept first, so the cut falls at the deepest joint of a loop). URDF has no ball or
universal joint: those are always cut. ``forced`` (``--cut JOINT``) are cut first, so the joints
that will get clearances can be cut joints.
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass

from pinclear.core.errors import ModelFileError
from pinclear.io.importers.graph import ROWS, TREE_TYPES, WORLD


@dataclass
class Tree:
    """The chosen tree: ``edges`` (joint, reversed) in breadth-first order from the root (reversed:
    the joint's child is the tree parent), ``cuts`` the cut joints, ``why`` one line per cut,
    ``depth`` of every body."""

    edges: list
    cuts: list
    why: dict
    depth: dict
    parent_of: dict


def spanning_tree(g, root=WORLD, forced=()) -> Tree:
    file = g.file
    names = {j.name for j in g.joints}
    for f in forced:
        if f not in names:
            raise ModelFileError(file, "--cut", f"no joint named {f!r}", choices=sorted(names))
    nodes = [root] + [b for b in g.bodies if b != root]
    level = _levels(g, root)
    idx = {j.name: k for k, j in enumerate(g.joints)}
    # heaviest first (the cut keeps the fewest rows), then nearer the root, then file order
    order = sorted((j for j in g.joints if j.type in TREE_TYPES and j.name not in forced),
                   key=lambda j: (-ROWS[j.type], max(level.get(j.parent, 0), level.get(j.child, 0)), idx[j.name]))
    uf = {n: n for n in nodes}

    def find(n):
        while uf[n] != n:
            uf[n] = uf[uf[n]]
            n = uf[n]
        return n

    kept = set()
    for j in order:
        a, b = find(j.parent), find(j.child)
        if a != b:
            uf[a] = b
            kept.add(j.name)
    loose = sorted(n for n in nodes if find(n) != find(root))
    if loose:
        raise ModelFileError(file, f"link {loose[0]!r}", "is not connected to the root "
                             f"{root!r} by joints a URDF tree can hold (revolute, prismatic, fixed; ball and "
                             "universal joints are always cut, and so are the --cut joints)", choices=loose[:10])
    edges, depth, parent_of = _orient(g, root, kept)
    cuts = [j for j in g.joints if j.name not in kept]
    why = {j.name: _reason(g, j, forced, parent_of, depth) for j in cuts}
    return Tree(edges, [j.name for j in cuts], why, depth, parent_of)


def _levels(g, root):
    """Breadth-first level of every body in the whole joint graph (ties of the cut choice)."""
    adj = {}
    for j in g.joints:
        adj.setdefault(j.parent, []).append(j.child)
        adj.setdefault(j.child, []).append(j.parent)
    level, todo = {root: 0}, deque([root])
    while todo:
        n = todo.popleft()
        for m in adj.get(n, []):
            if m not in level:
                level[m] = level[n] + 1
                todo.append(m)
    return level


def _orient(g, root, kept):
    adj = {}
    for j in g.joints:
        if j.name in kept:
            adj.setdefault(j.parent, []).append((j, False))
            adj.setdefault(j.child, []).append((j, True))
    edges, depth, parent_of, todo = [], {root: 0}, {}, deque([root])
    while todo:
        n = todo.popleft()
        for j, rev in adj.get(n, []):
            other = j.parent if rev else j.child
            if other in depth:
                continue
            depth[other] = depth[n] + 1
            parent_of[other] = (j, n)
            edges.append((j, rev))
            todo.append(other)
    return edges, depth, parent_of


def _path(a, b, parent_of, depth):
    """Joints on the tree path between bodies a and b."""
    left, right = [], []
    while a != b:
        if depth[a] >= depth[b]:
            j, a = parent_of[a]
            left.append(j)
        else:
            j, b = parent_of[b]
            right.append(j)
    return left + right[::-1]


def _reason(g, j, forced, parent_of, depth) -> str:
    loop = _path(j.parent, j.child, parent_of, depth)
    others = ", ".join(f"{o.name} ({o.type}, {ROWS[o.type]})" for o in loop)
    if j.name in forced:
        head = "cut as asked (--cut)"
    elif j.type not in TREE_TYPES:
        head = f"a {j.type} joint: URDF has no {j.type} joint, so it is always cut"
    else:
        head = (f"the fewest rows of its loop ({ROWS[j.type]}; every other joint of the loop has as many or more), "
                "and of those the deepest (a shallow tree)")
    return f"{head}; closes the loop through {others}"
