"""Short handles of a closed mesh: found by their shortest non-separating loop, and cut.

A handle of a closed surface is what a non-separating loop goes around: a bridge of the
solid (the loop rings the bridge) or a tunnel through it (the loop rings the tunnel's
wall). A handle whose loop is a few voxels long is narrower than the views can resolve
(a flap where two views' fringes meet, a slot carved by grazing rays): the samples do not
support it. Cutting the surface along such a loop and closing each side with a cap takes
the handle off and keeps one piece: a bridge is cut in two stumps, a tunnel is plugged.

The loops are found as in Erickson and Whittlesey's greedy homology generators, made local:
from roots covering the surface, each a shortest-path tree of limited reach; a loop closed
by one edge outside the tree is non-separating exactly when its homology class (mod 2) is
not zero, and that class is read off a cohomology basis (the tree-cotree decomposition's
dual cycles, one bit per handle) as the parity of the loop's crossings with each dual
cycle.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix, csr_matrix
from scipy.sparse.csgraph import (
    breadth_first_order,
    connected_components,
    dijkstra,
    minimum_spanning_tree,
)
from scipy.spatial import cKDTree

from scanmesh.shape import vertex_normals

#: Handles whose shortest non-separating loop is at most this many voxels long are cut by
#: :func:`scanmesh.merge`. Measured on the Stanford sets at a 1 mm voxel
#: (docs/benchmarks/merge-handles.md).
HANDLE_LOOP = 8.0

#: Handles whose shortest non-separating loop is at most this many voxels long and runs
#: mostly farther than a voxel from every sample (inferred surface no sample lines) are cut
#: too. Measured on the Stanford sets at a 1 mm voxel (docs/benchmarks/merge-handles.md).
UNLINED_LOOP = 32.0

#: How far each side of a cut is drawn towards its own side's faces (a share of the way to
#: the mean of its neighbours), so that the two caps do not touch.
CAP_GAP = 0.3

#: Normals of the two sides of a thin part (a bridge or a tunnel) are further apart than
#: this cosine (120°).
THIN_COSINE = -0.5

#: The roots' cells, in `longest` (a root per cell of the thin vertices).
COVER = 0.5

#: Most rounds of search and cut (each round cuts a set of disjoint, independent loops).
ROUNDS = 4


@dataclass(frozen=True)
class Loop:
    """A non-separating loop of a closed mesh."""

    #: vertex indices in order (the loop closes from the last to the first)
    vertices: tuple[int, ...]
    #: length (model units)
    length: float
    #: mean position (model units)
    centre: tuple[float, float, float]


class _Mesh:
    """A closed, oriented 2-manifold's edges, the faces beside them and its cohomology."""

    def __init__(self, vertices: np.ndarray, faces: np.ndarray):
        self.v = vertices
        self.f = faces
        n, m = len(vertices), len(faces)
        self.n = n
        half = faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
        self.half_keys = half[:, 0] * n + half[:, 1]
        self.half_order = np.argsort(self.half_keys, kind="stable")
        key = np.minimum(half[:, 0], half[:, 1]) * n + np.maximum(half[:, 0], half[:, 1])
        keys, inverse, counts = np.unique(key, return_inverse=True, return_counts=True)
        self.closed = bool(len(keys) and (counts == 2).all())
        if not self.closed:
            return
        self.keys = keys
        self.edges = np.stack([keys // n, keys % n], axis=1)
        self.length = np.linalg.norm(
            vertices[self.edges[:, 0]] - vertices[self.edges[:, 1]], axis=1
        )
        by_edge = np.argsort(inverse, kind="stable")
        self.beside = (by_edge // 3).reshape(-1, 2)  # the two faces of each edge
        ids = np.arange(len(keys))
        self.graph = csr_matrix(
            (np.concatenate([self.length, self.length]) + 1e-300,
             (np.concatenate([self.edges[:, 0], self.edges[:, 1]]),
              np.concatenate([self.edges[:, 1], self.edges[:, 0]]))),
            shape=(n, n),
        )  # fmt: skip
        self.bits = self._cohomology(ids, m)
        # the edge of each entry of `graph` (rows, then columns, in order)
        rows = np.repeat(np.arange(n), np.diff(self.graph.indptr))
        self.entry_edge = self.edge_ids(rows, self.graph.indices)
        self.live = self.bits.any(axis=1)  # edges a non-separating loop must cross one of
        self.local = np.full(n, -1, dtype=np.int64)  # scratch: a vertex's index in a ball

    def edge_ids(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """The edge index of each vertex pair (a, b) (which must be edges)."""
        key = np.minimum(a, b) * self.n + np.maximum(a, b)
        return np.searchsorted(self.keys, key)

    def class_of(self, loop: Loop) -> np.ndarray | None:
        """The homology class of `loop` (bits over the cohomology basis), None when it is
        not a loop of this mesh or separates."""
        ring = np.array(loop.vertices)
        if ring.max() >= self.n:
            return None
        nxt = np.roll(ring, -1)
        key = np.minimum(ring, nxt) * self.n + np.maximum(ring, nxt)
        at = np.searchsorted(self.keys, key)
        if (at >= len(self.keys)).any() or (
            self.keys[np.minimum(at, len(self.keys) - 1)] != key
        ).any():
            return None
        bits = np.bitwise_xor.reduce(self.bits[at], axis=0)
        return bits if bits.any() else None

    def face_of(self, a: int, b: int) -> int:
        """The face holding the directed edge a → b."""
        k = np.searchsorted(self.half_keys, a * self.n + b, sorter=self.half_order)
        return int(self.half_order[k] // 3)

    def _cohomology(self, ids: np.ndarray, m: int) -> np.ndarray:
        """(edges, words) uint64: bit i of an edge is set when its dual edge lies on the
        i-th dual cycle of the tree-cotree decomposition (2g of them)."""
        n, e = self.n, len(ids)
        tree = minimum_spanning_tree(
            coo_matrix((ids + 1.0, (self.edges[:, 0], self.edges[:, 1])), shape=(n, n))
        )
        in_tree = np.zeros(e, dtype=bool)
        in_tree[(tree.data - 1).astype(np.int64)] = True
        rest = np.flatnonzero(~in_tree)
        f0, f1 = self.beside[rest, 0], self.beside[rest, 1]
        cotree = minimum_spanning_tree(coo_matrix((rest + 1.0, (f0, f1)), shape=(m, m)))
        in_cotree = np.zeros(e, dtype=bool)
        in_cotree[(cotree.data - 1).astype(np.int64)] = True
        left = rest[~in_cotree[rest]]
        words = max(1, (len(left) + 63) // 64)
        bits = np.zeros((e, words), dtype=np.uint64)
        if len(left) == 0:
            return bits
        # the cotree as parent links (one root per piece), each face's link its edge
        sym = cotree + cotree.T
        parent = np.full(m, -1, dtype=np.int64)
        depth = np.zeros(m, dtype=np.int64)
        _, piece = connected_components(sym, directed=False)
        _, roots = np.unique(piece, return_index=True)
        for root in roots:
            order, pred = breadth_first_order(sym, root, directed=False, return_predecessors=True)
            parent[order[1:]] = pred[order[1:]]
            for f in order[1:]:
                depth[f] = depth[parent[f]] + 1
        fe = np.full(m, -1, dtype=np.int64)
        child = np.flatnonzero(parent >= 0)
        face_edges = self._face_edges()
        for k in range(3):
            cand = face_edges[child, k]
            other = np.where(
                self.beside[cand, 0] == child, self.beside[cand, 1], self.beside[cand, 0]
            )
            hit = (other == parent[child]) & in_cotree[cand]
            fe[child[hit]] = cand[hit]
        for i, h in enumerate(left):
            a, b = int(self.beside[h, 0]), int(self.beside[h, 1])
            cycle = [h]
            while a != b:
                if depth[a] >= depth[b]:
                    cycle.append(fe[a])
                    a = int(parent[a])
                else:
                    cycle.append(fe[b])
                    b = int(parent[b])
            bits[np.array(cycle), i // 64] |= np.uint64(1 << (i % 64))
        return bits

    def _face_edges(self) -> np.ndarray:
        half = self.f[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
        return self.edge_ids(half[:, 0], half[:, 1]).reshape(-1, 3)


def _loop_from(
    mesh: _Mesh, root: int, near: np.ndarray, reach: float
) -> tuple[Loop, np.ndarray] | None:
    """The shortest non-separating loop closed by one edge over the shortest-path tree
    from `root` (through the vertices `near`, within `reach` along the surface), with its
    homology class; None when there is none. O(edges among `near`)."""
    k = len(near)
    if k < 3:
        return None
    starts, ends = mesh.graph.indptr[near], mesh.graph.indptr[near + 1]
    counts = ends - starts
    pos = np.repeat(starts - np.cumsum(counts) + counts, counts) + np.arange(counts.sum())
    if not mesh.live[mesh.entry_edge[pos]].any():
        return None  # a loop crossing no dual cycle of the basis separates
    mesh.local[near] = np.arange(k)
    rows = np.repeat(np.arange(k), counts)
    cols = mesh.local[mesh.graph.indices[pos]]
    mesh.local[near] = -1
    keep = cols >= 0
    rows, cols, pos = rows[keep], cols[keep], pos[keep]
    indptr = np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=k))])
    sub = csr_matrix((mesh.graph.data[pos], cols, indptr), shape=(k, k))
    root_at = int(np.flatnonzero(near == root)[0])
    dist, pred = dijkstra(sub, indices=root_at, limit=reach, return_predecessors=True)
    par = np.where(pred >= 0, pred, k)
    tree_edge = np.full(k, -1, dtype=np.int64)
    has = pred >= 0
    tree_edge[has] = mesh.edge_ids(near[has], near[pred[has]])
    words = mesh.bits.shape[1]
    prefix = np.zeros((k + 1, words), dtype=np.uint64)
    prefix[:k][has] = mesh.bits[tree_edge[has]]
    anc = np.append(par, k)
    for _ in range(int(np.ceil(np.log2(k + 1))) + 1):
        prefix[:k] ^= prefix[anc[:k]]
        anc = anc[anc]
    reached = np.isfinite(dist)
    once = (rows < cols) & reached[rows] & reached[cols]
    r, c = rows[once], cols[once]
    ids = mesh.entry_edge[pos[once]]
    off_tree = (ids != tree_edge[r]) & (ids != tree_edge[c])
    r, c, ids = r[off_tree], c[off_tree], ids[off_tree]
    cls = prefix[r] ^ prefix[c] ^ mesh.bits[ids]
    live = cls.any(axis=1)
    if not live.any():
        return None
    r, c, ids, cls = r[live], c[live], ids[live], cls[live]
    total = dist[r] + dist[c] + mesh.length[ids]
    best = int(np.argmin(total))
    # the two tree paths up to where they meet
    ups_a, ups_b = [int(r[best])], [int(c[best])]
    seen = {ups_a[0]: 0}
    while pred[ups_a[-1]] >= 0:
        ups_a.append(int(pred[ups_a[-1]]))
        seen[ups_a[-1]] = len(ups_a) - 1
    while ups_b[-1] not in seen:
        ups_b.append(int(pred[ups_b[-1]]))
    meet = ups_b[-1]
    cycle = near[np.array(ups_a[: seen[meet] + 1][::-1] + ups_b[:-1])]
    length = float(total[best] - 2 * dist[meet])
    centre = mesh.v[cycle].mean(axis=0)
    loop = Loop(
        tuple(int(u) for u in cycle), length, (float(centre[0]), float(centre[1]), float(centre[2]))
    )
    return loop, cls[best]


def short_loops(
    vertices: np.ndarray, faces: np.ndarray, longest: float
) -> list[tuple[Loop, np.ndarray]]:
    """Non-separating loops at most `longest` long, shortest first, each with its homology
    class (bits over the mesh's cohomology basis); empty when the mesh is not closed. See
    :func:`_search`."""
    f = np.asarray(faces, dtype=np.int64)
    v = np.asarray(vertices, dtype=np.float64)
    mesh = _Mesh(v, f)
    if not mesh.closed or not mesh.bits.any():
        return []
    return _search(mesh, longest, 0.0)


def _search(
    mesh: _Mesh, longest: float, shift: float, among: np.ndarray | None = None
) -> list[tuple[Loop, np.ndarray]]:
    """A loop at most `longest` long from each root: one vertex per cell (`COVER · longest`
    across, the grid shifted by `shift` cells) among the vertices `among` (a mask) or, by
    default, where the surface is thin (a vertex within `longest / 3` whose normal is more
    than 120° from theirs: both sides of a bridge, or of a tunnel, that a loop this short
    rings), each loop then shortened from roots on it.
    O(pairs within `longest / 3` + roots · vertices within `longest`)."""
    used = np.zeros(mesh.n, dtype=bool)
    used[mesh.f.ravel()] = True
    tree = cKDTree(mesh.v)
    if among is None:
        normal = vertex_normals(mesh.v, mesh.f)
        pairs = tree.query_pairs(longest / 3, output_type="ndarray")
        facing = (normal[pairs[:, 0]] * normal[pairs[:, 1]]).sum(axis=1) < THIN_COSINE
        thin = np.zeros(mesh.n, dtype=bool)
        thin[pairs[facing].ravel()] = True
        thin &= used
    else:
        thin = used & among
    cover = longest * COVER
    reach = cover + longest / 2
    # a non-separating loop crosses a dual cycle of the basis: roots within reach of one
    crossing = np.unique(mesh.edges[mesh.live].ravel())
    thin[thin] = np.isfinite(
        cKDTree(mesh.v[crossing]).query(mesh.v[thin], distance_upper_bound=reach)[0]
    )
    candidates = np.flatnonzero(thin)
    cell = np.floor(mesh.v[candidates] / cover + shift).astype(np.int64)
    _, first = np.unique(cell, axis=0, return_index=True)
    found: dict[frozenset[int], tuple[Loop, np.ndarray]] = {}

    def search_from(root: int, reach: float) -> tuple[Loop, np.ndarray] | None:
        near = np.array(tree.query_ball_point(mesh.v[root], reach), dtype=np.int64)
        return _loop_from(mesh, root, np.sort(near), reach)

    for root in candidates[first]:
        got = search_from(int(root), reach)
        if got is None or got[0].length > 2 * longest:
            continue
        # shortened from a few vertices along it (a loop through them rings the same
        # handle, and the loop through the root may have come the long way round)
        ring = got[0].vertices
        for at in ring[:: max(1, len(ring) // 3)]:
            other = search_from(at, got[0].length / 2 + 1e-9)
            if other is not None and other[0].length < got[0].length:
                got = other
        if got[0].length <= longest:
            found.setdefault(frozenset(got[0].vertices), got)
    return sorted(found.values(), key=lambda lc: lc[0].length)


def _independent(chosen: list[int], bits: np.ndarray) -> list[int] | None:
    """`chosen` (a row-echelon basis as Python ints) with `bits` added, or None when it
    depends on them."""
    x = int.from_bytes(bits.astype("<u8").tobytes(), "little")
    for b in chosen:
        x = min(x, x ^ b)
    return None if x == 0 else sorted(chosen + [x], reverse=True)


def cut_short_handles(
    vertices: np.ndarray,
    faces: np.ndarray,
    labels: np.ndarray | None,
    longest: float,
    filled: int,
    samples: np.ndarray | None = None,
    unlined: float = 0.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, list[Loop]]:
    """The mesh with every handle the samples do not support cut along its shortest
    non-separating loop, each side closed by a fan (labelled `filled`), and the loops cut:
    a loop at most `longest` long (narrower than the samples resolve), or, given the
    `samples` ((K, 3) points), at most `unlined` long with most of its vertices farther
    than `longest / HANDLE_LOOP` (a voxel) from every sample (a handle no sample lines,
    made of inferred surface). A closed mesh keeps its pieces; its genus falls by one per
    loop. A mesh that is not closed is returned as given.
    O(rounds · roots · faces within the loops' lengths)."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    lab = None if labels is None else np.asarray(labels)
    lined = None if samples is None or unlined <= longest else cKDTree(samples)
    lining = longest / HANDLE_LOOP
    cut: list[Loop] = []
    left: list[Loop] = []  # found and not cut: checked again in the next round
    around: np.ndarray | None = None  # near the last round's cuts: where unlined loops are sought
    for round_ in range(ROUNDS):
        mesh = _Mesh(v, f)
        if not mesh.closed or not mesh.bits.any():
            break
        found = _search(mesh, longest, 0.5 * round_)
        if lined is not None:
            bare = lined.query(v, distance_upper_bound=lining)[0] > lining
            found += [
                (loop, bits)
                for loop, bits in _search(
                    mesh, unlined, 0.5 * round_, among=bare if around is None else bare & around
                )
                if loop.length > longest and bare[list(loop.vertices)].mean() > 0.5
            ]
        # a loop away from the cuts is still a loop of the mesh; its class is read again
        found += [(loop, bits) for loop in left if (bits := mesh.class_of(loop)) is not None]
        found.sort(key=lambda lc: lc[0].length)
        taken = np.zeros(len(v), dtype=bool)
        basis: list[int] = []
        now: list[Loop] = []
        left = []
        for loop, bits in found:
            ring = np.array(loop.vertices)
            grown = None if taken[ring].any() else _independent(basis, bits)
            if grown is None:
                left.append(loop)
                continue
            basis = grown
            taken[ring] = True
            now.append(loop)
        if not now:
            break
        for loop in now:
            v, f, lab = _cut(mesh, v, f, lab, loop, filled)
        cut.extend(now)
        rings = v[np.concatenate([list(loop.vertices) for loop in now])]
        reach = max(longest, unlined if lined is not None else 0.0)
        around = np.isfinite(cKDTree(rings).query(v, distance_upper_bound=reach)[0])
        left = [loop for loop in left if not taken[list(loop.vertices)].any()]
    out_faces = f.astype(np.asarray(faces).dtype)
    out_labels = None if lab is None else lab.astype(np.asarray(labels).dtype)
    return v, out_faces, out_labels, cut


def _cut(
    mesh: _Mesh, v: np.ndarray, f: np.ndarray, lab: np.ndarray | None, loop: Loop, filled: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """The mesh cut along `loop` (its left side given new vertices) and both sides capped."""
    ring = list(loop.vertices)
    k = len(ring)
    f = f.copy()
    fresh = np.arange(len(v), len(v) + k)
    loop_set = set(ring)
    left = np.empty((k, 3))
    right = np.empty((k, 3))
    for i in range(k):
        here, after, before = ring[i], ring[(i + 1) % k], ring[i - 1]
        mine = _wedge(mesh, here, after, before)
        rows = f[mine]
        rows[rows == here] = fresh[i]
        f[mine] = rows
        theirs = _wedge(mesh, here, before, after)
        # each side drawn towards its own faces, so that the caps keep apart
        for out, wedge in ((left, mine), (right, theirs)):
            own = [u for u in mesh.f[wedge].ravel().tolist() if u not in loop_set]
            p = v[here]
            out[i] = p + CAP_GAP * (v[own].mean(axis=0) - p) if own else p
    v = np.concatenate([v, left, left.mean(axis=0)[None], right.mean(axis=0)[None]])
    v[ring] = right
    c_left, c_right = len(v) - 2, len(v) - 1
    nxt = np.roll(np.arange(k), -1)
    caps = np.concatenate([
        np.stack([fresh[nxt], fresh, np.full(k, c_left)], axis=1),
        np.stack([np.array(ring), np.array(ring)[nxt], np.full(k, c_right)], axis=1),
    ])  # fmt: skip
    f = np.concatenate([f, caps])
    if lab is not None:
        lab = np.concatenate([lab, np.full(2 * k, filled, dtype=lab.dtype)])
    return v, f, lab


def _wedge(mesh: _Mesh, here: int, after: int, before: int) -> np.ndarray:
    """The faces around `here` from the one holding the edge here → after round to the one
    holding before → here (the faces left of a loop running before → here → after)."""
    face = mesh.face_of(here, after)
    wedge = []
    for _ in range(len(mesh.f)):
        wedge.append(face)
        row = mesh.f[face].tolist()
        into = row[(row.index(here) + 2) % 3]  # the edge into `here` in this face
        if into == before:
            break
        face = mesh.face_of(here, into)
    return np.array(wedge)
