"""Surface Gaussian-process prior over the nodes of a triangle mesh (paper 002, eqs. 3-8).

The field lives on the mesh nodes. Its prior covariance is the Matérn 3/2 kernel of eq. 3 on the geodesic
(over-the-surface) distance between nodes, so heat on one side of the station does not correlate with the
other side through the module.

Geodesic distance: Dijkstra (scipy.sparse.csgraph) over a graph holding (1) the mesh edges, (2) for each edge
shared by two triangles, the straight path between the two opposite nodes across the edge when the unfolded
quad is convex (one-ring unfolding), and (3) every pair of nodes of a flat, convex patch of faces, joined
straight. It is exact on flat convex patches (a planar grid, the station's end caps) and elsewhere the length
of a real path over the mesh (an upper bound of the mesh's geodesic); against the exact geodesic of the
station's cylinder it is +1.7 % on average, -1.4 % to +6 % (the facets' chords are shorter than the arcs;
checked in tests/test_mapping.py).

Positive-definiteness: a Matérn kernel on geodesic distance is not a valid covariance on a closed surface (the
distance matrix is not Euclidean); on the station with a 3-4 m length scale the geodesic kernel matrix has
negative eigenvalues. The fix is the nearest positive-semidefinite matrix in the Frobenius norm (Higham 1988):
eigenvalue clipping, K = V max(L, floor) V^T, with floor = PD_FLOOR_REL * sigma_f^2 so a Cholesky factor
exists. It changes the kernel as little as any PSD matrix can, keeps its eigenvectors (the surface's own
modes) and leaves the positive part of the spectrum untouched. :class:`PDFix` records the smallest eigenvalues
before and after. On the station (1097 nodes, sigma_f 23.5 K, l 3.5 m) 354 eigenvalues are negative, the
smallest -58.8 K^2 (-0.11 sigma_f^2); after the fix all are >= 5.5e-4 K^2 and no entry moved by more than
12.7 K^2 (2.3 % of sigma_f^2). With the exact cylinder geodesic only 4 are negative (>= -1.42 K^2): most of
the indefiniteness comes from the graph approximation, the rest from the closed surface itself.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components, dijkstra
from scipy.spatial import ConvexHull

from snakeplan.mapping.models import DEFAULT_LENGTH_SCALE_MM, DEFAULT_SIGMA_F

#: Eigenvalue floor of the positive-definite fix, relative to sigma_f^2.
PD_FLOOR_REL = 1e-6
#: Two faces count as coplanar when their unit normals differ by less than this (rad).
FLAT_ANGLE_TOL_RAD = 1e-6
#: A flat patch counts as convex when its area is this close (relative) to its convex hull's.
CONVEX_AREA_TOL = 1e-9


def face_normals(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit normals (F, 3) and areas (F,) (mm^2) of the faces, oriented by their vertex order."""
    tri = vertices[faces]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    norm = np.linalg.norm(cross, axis=1)
    return cross / np.maximum(norm, 1e-300)[:, None], 0.5 * norm


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Unit node normals (n, 3): area-weighted mean of the incident face normals."""
    normals, area = face_normals(vertices, faces)
    acc = np.zeros_like(vertices, dtype=float)
    for k in range(3):
        np.add.at(acc, faces[:, k], normals * area[:, None])
    return acc / np.maximum(np.linalg.norm(acc, axis=1), 1e-300)[:, None]


def _unfolded_diagonals(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(i, j, unfolded length) of straight paths between the opposite nodes of every convex pair of adjacent
    faces."""
    edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    opposite = np.concatenate([faces[:, 2], faces[:, 0], faces[:, 1]])
    key = np.sort(edges, axis=1)
    order = np.lexsort((key[:, 1], key[:, 0]))
    k_sorted = key[order]
    same = np.all(k_sorted[1:] == k_sorted[:-1], axis=1)
    first, second = order[:-1][same], order[1:][same]
    a, b = vertices[key[first, 0]], vertices[key[first, 1]]
    c, d = vertices[opposite[first]], vertices[opposite[second]]
    e = b - a
    length = np.linalg.norm(e, axis=1)
    x = e / length[:, None]
    cx = np.einsum("ij,ij->i", c - a, x)
    dx = np.einsum("ij,ij->i", d - a, x)
    cy = np.linalg.norm(c - a - cx[:, None] * x, axis=1)
    dy = -np.linalg.norm(d - a - dx[:, None] * x, axis=1)
    cross_x = cx + (dx - cx) * cy / np.maximum(cy - dy, 1e-300)
    ok = (cross_x > 0) & (cross_x < length) & (cy > 0) & (dy < 0)
    return opposite[first][ok], opposite[second][ok], np.hypot(cx - dx, cy - dy)[ok]


def _flat_convex_patches(vertices: np.ndarray, faces: np.ndarray) -> list[np.ndarray]:
    """Node sets of the maximal edge-connected coplanar face patches whose shape is convex (>= 2 faces)."""
    normals, area = face_normals(vertices, faces)
    edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    owner = np.tile(np.arange(len(faces)), 3)
    key = np.sort(edges, axis=1)
    order = np.lexsort((key[:, 1], key[:, 0]))
    k_sorted = key[order]
    same = np.all(k_sorted[1:] == k_sorted[:-1], axis=1)
    f1, f2 = owner[order[:-1][same]], owner[order[1:][same]]
    planes = np.einsum("ij,ij->i", normals, vertices[faces[:, 0]])
    scale = 1.0 + np.abs(vertices).max()
    coplanar = (np.einsum("ij,ij->i", normals[f1], normals[f2]) > math.cos(FLAT_ANGLE_TOL_RAD)) & (
        np.abs(planes[f1] - planes[f2]) < FLAT_ANGLE_TOL_RAD * scale)
    adj = coo_matrix((np.ones(coplanar.sum()), (f1[coplanar], f2[coplanar])), shape=(len(faces),) * 2)
    _, label = connected_components(adj, directed=False)
    patches = []
    for lab in np.unique(label):
        fs = np.flatnonzero(label == lab)
        if len(fs) < 2:
            continue
        nodes = np.unique(faces[fs])
        n = normals[fs[0]]
        u = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
        u /= np.linalg.norm(u)
        w = np.cross(n, u)
        p2 = np.stack([vertices[nodes] @ u, vertices[nodes] @ w], axis=1)
        if abs(ConvexHull(p2).volume - area[fs].sum()) <= CONVEX_AREA_TOL * area[fs].sum():
            patches.append(nodes)
    return patches


def geodesic_distances(vertices: ArrayLike, faces: ArrayLike) -> np.ndarray:
    """All-pairs geodesic distances (n, n) in mm between mesh nodes (see the module docstring for the method)."""
    V = np.asarray(vertices, dtype=float)
    F = np.asarray(faces, dtype=np.int64)
    e = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    straight = [e]
    for nodes in _flat_convex_patches(V, F):
        a, b = np.triu_indices(len(nodes), 1)
        straight.append(np.stack([nodes[a], nodes[b]], axis=1))
    s = np.concatenate(straight)
    di, dj, dl = _unfolded_diagonals(V, F)
    i, j = np.concatenate([s[:, 0], di]), np.concatenate([s[:, 1], dj])
    w = np.concatenate([np.linalg.norm(V[s[:, 0]] - V[s[:, 1]], axis=1), dl])
    return dijkstra(_min_duplicates(i, j, w, len(V)), directed=False)


def _min_duplicates(i: np.ndarray, j: np.ndarray, w: np.ndarray, n: int):
    """Sparse symmetric graph keeping the shortest of duplicate edges."""
    a, b = np.minimum(i, j), np.maximum(i, j)
    order = np.lexsort((w, b, a))
    a, b, w = a[order], b[order], w[order]
    keep = np.ones(len(a), dtype=bool)
    keep[1:] = (a[1:] != a[:-1]) | (b[1:] != b[:-1])
    return coo_matrix((w[keep], (a[keep], b[keep])), shape=(n, n)).tocsr()


def matern32(distance: ArrayLike, sigma_f: float, length_scale: float) -> np.ndarray:
    """Eq. 3: sigma_f^2 (1 + sqrt(3) d / l) exp(-sqrt(3) d / l), d and l in mm; 0 at an infinite distance."""
    r = math.sqrt(3.0) * np.asarray(distance, dtype=float) / length_scale
    far = np.isinf(r)
    r = np.where(far, 0.0, r)
    return np.where(far, 0.0, sigma_f**2 * (1.0 + r) * np.exp(-r))


@dataclass(frozen=True)
class PDFix:
    """What the positive-definite fix did: smallest eigenvalues (K^2) before and after, how many were below
    the floor, and the largest entry change (K^2)."""

    smallest_before: tuple[float, ...]
    smallest_after: tuple[float, ...]
    n_clipped: int
    max_change: float


def nearest_psd(K: np.ndarray, floor: float, report: int = 5) -> tuple[np.ndarray, PDFix]:
    """Nearest symmetric matrix to ``K`` (Frobenius) with every eigenvalue >= ``floor``: eigenvalue clipping.
    The eigenvalues after are the clipped ones (same eigenvectors)."""
    S = 0.5 * (K + K.T)
    lam, V = np.linalg.eigh(S)
    clipped = np.maximum(lam, floor)
    out = (V * clipped) @ V.T
    out = 0.5 * (out + out.T)
    after = np.sort(clipped)
    return out, PDFix(tuple(float(v) for v in lam[:report]), tuple(float(v) for v in after[:report]),
                      int(np.sum(lam < floor)), float(np.max(np.abs(out - S))))


@dataclass(frozen=True)
class SurfacePrior:
    """The GP prior on a mesh's nodes: constant mean (K), covariance (n, n) in K^2, and the PD-fix report."""

    mean: np.ndarray
    covariance: np.ndarray
    sigma_f: float
    length_scale: float
    pd_fix: PDFix


_PRIOR_CACHE: dict[tuple, tuple[np.ndarray, PDFix]] = {}


def surface_prior(vertices: ArrayLike, faces: ArrayLike, mean: float = 0.0, sigma_f: float = DEFAULT_SIGMA_F,
                  length_scale: float = DEFAULT_LENGTH_SCALE_MM, distances: ArrayLike | None = None
                  ) -> SurfacePrior:
    """GP prior over the mesh nodes: Matérn 3/2 on geodesic distance (or on ``distances`` (n, n) mm if given),
    made positive-definite by eigenvalue clipping. The covariance of a mesh is cached within the process."""
    V = np.ascontiguousarray(vertices, dtype=float)
    F = np.ascontiguousarray(faces, dtype=np.int64)
    h = hashlib.sha1(V.tobytes() + F.tobytes())
    if distances is not None:
        h.update(np.ascontiguousarray(distances, dtype=float).tobytes())
    key = (h.hexdigest(), float(sigma_f), float(length_scale))
    if key not in _PRIOR_CACHE:
        D = geodesic_distances(V, F) if distances is None else np.asarray(distances, dtype=float)
        _PRIOR_CACHE[key] = nearest_psd(matern32(D, sigma_f, length_scale), PD_FLOOR_REL * sigma_f**2)
    cov, fix = _PRIOR_CACHE[key]
    return SurfacePrior(np.full(len(V), float(mean)), cov.copy(), float(sigma_f), float(length_scale), fix)


#: Neighbours each point of interest joins in the graph whose shortest paths stand for distances over a surface.
POINT_NEIGHBOURS = 8


def point_distances(points: ArrayLike, normals: ArrayLike, groups: ArrayLike, neighbours: int = POINT_NEIGHBOURS
                    ) -> np.ndarray:
    """Distances (n, n) mm over the surfaces between points sampled on them: shortest paths through the graph that
    joins each point to its ``neighbours`` nearest on the same surface (``groups``: the surface each lies on) by
    straight chords, and the straight distance between two points of one surface in one plane (their normal lines
    parallel and through each other's plane to 1e-6 mm: on a convex face, such as a box's, the straight segment is
    the geodesic; through a plate's hole it is shorter); inf between points of different surfaces or parts of one
    that the graph does not join (their fields are independent)."""
    from scipy.spatial import cKDTree

    P = np.asarray(points, dtype=float)
    N = np.asarray(normals, dtype=float)
    g = np.asarray(groups)
    n = len(P)
    rows, cols, w = [], [], []
    for k in np.unique(g):
        idx = np.flatnonzero(g == k)
        if idx.size < 2:
            continue
        d, j = cKDTree(P[idx]).query(P[idx], k=min(neighbours, idx.size - 1) + 1)
        rows.append(np.repeat(idx, d.shape[1] - 1))
        cols.append(idx[j[:, 1:]].ravel())
        w.append(d[:, 1:].ravel())
    D = np.full((n, n), np.inf)
    if rows:
        graph = coo_matrix((np.concatenate(w), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n)).tocsr()
        D = dijkstra(graph, directed=False)
    np.fill_diagonal(D, 0.0)
    chord = np.linalg.norm(P[:, None] - P[None], axis=-1)
    level = np.abs(np.einsum("ik,ijk->ij", N, P[None] - P[:, None]))
    coplanar = (g[:, None] == g[None]) & (np.abs(N @ N.T) >= 1.0 - 1e-12) & (level <= 1e-6) & (level.T <= 1e-6)
    return np.where(coplanar, chord, D)


def point_prior(points: ArrayLike, normals: ArrayLike, groups: ArrayLike, mean: float = 0.0,
                sigma_f: float = DEFAULT_SIGMA_F, length_scale: float = DEFAULT_LENGTH_SCALE_MM) -> SurfacePrior:
    """GP prior over points of interest (the field's values there): Matérn 3/2 on the distance over their
    surfaces (:func:`point_distances`), made positive-definite by eigenvalue clipping as on a mesh; cached within
    the process."""
    P = np.ascontiguousarray(points, dtype=float)
    N = np.ascontiguousarray(normals, dtype=float)
    g = np.ascontiguousarray(groups, dtype=np.int64)
    key = (hashlib.sha1(P.tobytes() + N.tobytes() + g.tobytes()).hexdigest(), float(sigma_f), float(length_scale))
    if key not in _PRIOR_CACHE:
        _PRIOR_CACHE[key] = nearest_psd(matern32(point_distances(P, N, g), sigma_f, length_scale),
                                        PD_FLOOR_REL * sigma_f**2)
    cov, fix = _PRIOR_CACHE[key]
    return SurfacePrior(np.full(len(P), float(mean)), cov.copy(), float(sigma_f), float(length_scale), fix)


def batch_posterior(mean: np.ndarray, cov: np.ndarray, idx: ArrayLike, y: ArrayLike, noise_var: ArrayLike
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Eqs. 4-5: GP posterior mean and covariance of all nodes given measurements ``y`` of nodes ``idx`` with
    noise variances ``noise_var`` (all at once, by a Cholesky factor of K_psi + R)."""
    idx = np.asarray(idx, dtype=np.int64)
    r = np.broadcast_to(np.asarray(noise_var, dtype=float), idx.shape)
    Kxs = cov[:, idx]
    S = cov[np.ix_(idx, idx)] + np.diag(r)
    L = np.linalg.cholesky(S)
    A = np.linalg.solve(L, Kxs.T)
    alpha = np.linalg.solve(L, np.asarray(y, dtype=float) - mean[idx])
    return mean + A.T @ alpha, cov - A.T @ A
