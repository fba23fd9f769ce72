"""Kalman fusion of node measurements into the surface map and the information gain (paper 002, eqs. 9-10, 13).

The map is the GP over the mesh nodes as a Gaussian: mean (n,) in K, covariance P (n, n) in K^2. A
measurement observes nodes ``idx`` (H selects them) with independent noise variances ``r``:

    S = H P H^T + R,   K = P H^T S^-1,   mu+ = mu + K (y - H mu),   P+ = P - K H P      (eqs. 9-10)

Eq. 10 as printed adds K H P; a posterior can only be less uncertain, so the sign is minus. Applied to all
measurements at once from the prior this equals the batch GP posterior of eqs. 4-5.

Information gain (eq. 13) is the drop in covariance trace, tr(P-) - tr(P+) = tr(P H^T S^-1 H P)
= tr(S^-1 (P P)_{idx, idx}). :class:`GainEvaluator` scores a candidate with one m x m Cholesky factor of S
(m = distinct nodes seen) and the m x m block of P P it needs, never an n x n update.
Repeated measurements of one node are first merged (precisions add), which is exact for independent noise.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike
from scipy.linalg import cho_factor, cho_solve, lapack


def fuse_repeats(idx: ArrayLike, noise_var: ArrayLike, y: ArrayLike | None = None
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Merge repeated measurements of the same node into one: (unique nodes, combined variance, combined value
    or None). With independent noise the merged measurement carries exactly the same information."""
    idx = np.asarray(idx, dtype=np.int64)
    prec = 1.0 / np.broadcast_to(np.asarray(noise_var, dtype=float), idx.shape)
    nodes, inv = np.unique(idx, return_inverse=True)
    total = np.bincount(inv, weights=prec, minlength=len(nodes))
    merged_y = None
    if y is not None:
        merged_y = np.bincount(inv, weights=prec * np.asarray(y, dtype=float), minlength=len(nodes)) / total
    return nodes, 1.0 / total, merged_y


class GaussianMap:
    """The surface map: mean (n,) K and covariance (n, n) K^2, updated in place by Kalman fusion."""

    def __init__(self, mean: ArrayLike, covariance: ArrayLike) -> None:
        self.mean = np.array(mean, dtype=float)
        self.cov = np.array(covariance, dtype=float)

    @property
    def trace(self) -> float:
        """tr(P) in K^2: the total uncertainty of the map."""
        return float(np.trace(self.cov))

    def rmse(self, truth: ArrayLike) -> float:
        """Root-mean-square error (K) of the mean against the true node values."""
        return float(np.sqrt(np.mean((self.mean - np.asarray(truth, dtype=float)) ** 2)))

    def update(self, idx: ArrayLike, y: ArrayLike | None, noise_var: ArrayLike) -> None:
        """Fuse measurements ``y`` (K) of nodes ``idx`` with variances ``noise_var`` (K^2), eqs. 9-10 with
        P+ = P- - K H P-. Repeats of a node are merged first (exact). With ``y`` None only the covariance is
        updated (planning needs no values)."""
        idx, r, y = fuse_repeats(idx, noise_var, y)
        if idx.size == 0:
            return
        PH = self.cov[:, idx]
        S = PH[idx] + np.diag(r)
        c = cho_factor(S, lower=True)
        G = cho_solve(c, PH.T)
        if y is not None:
            self.mean += G.T @ (np.asarray(y, dtype=float) - self.mean[idx])
        self.cov -= PH @ G
        self.cov = 0.5 * (self.cov + self.cov.T)


class GainEvaluator:
    """Scores candidate measurements against a fixed covariance P by the trace drop of eq. 13.

    ``weights`` (n,) >= 0 turns the trace into tr(W P) (None: every node counts once, eq. 13 as printed).
    A candidate seeing m distinct nodes costs one m x m Cholesky factor of S = H P H^T + R and its inverse
    (LAPACK potrf + potri, m^3) and the block (P W P)_{idx, idx}; gain = sum(S^-1 * (P W P)_{idx, idx}).
    With A = P W^(1/2) (P symmetric, W >= 0), P W P = A A^T: a block is A_{idx,:} A_{idx,:}^T (m^2 n; NumPy
    hands X X^T to BLAS syrk, half a general product). The block is computed alone until the blocks so far
    have cost as much as the whole product (n^3); from then on the product is formed once and its blocks
    are read. A greedy step scores ~100 candidates of tens of nodes (blocks only, a fraction of the product); a
    CMA-ES plan scores ~150 trajectories of a few hundred nodes (the product, after at most its own cost in
    blocks). Both ways are exact (see the tests), so the choice changes rounding only.
    """

    def __init__(self, cov: np.ndarray, weights: ArrayLike | None = None) -> None:
        self.cov = cov
        self._A = cov if weights is None else cov * np.sqrt(np.asarray(weights, dtype=float))
        self._PWP: np.ndarray | None = None
        self._block_work = 0.0

    def _block(self, nodes: np.ndarray) -> np.ndarray:
        """(P W P)_{nodes, nodes}: from the full product once the blocks have cost as much as it (class docs)."""
        if self._PWP is not None:
            return self._PWP[np.ix_(nodes, nodes)]
        n = self.cov.shape[0]
        self._block_work += float(nodes.size) ** 2 * n
        if self._block_work >= float(n) ** 3:
            self._PWP = self._A @ self._A.T
            return self._PWP[np.ix_(nodes, nodes)]
        rows = self._A[nodes]
        return rows @ rows.T

    def gain(self, idx: ArrayLike, noise_var: ArrayLike) -> float:
        """tr(W P-) - tr(W P+) (K^2) for measuring nodes ``idx`` with variances ``noise_var`` (repeats allowed)."""
        nodes, r, _ = fuse_repeats(idx, noise_var)
        if nodes.size == 0:
            return 0.0
        S = self.cov[np.ix_(nodes, nodes)] + np.diag(r)
        c, info = lapack.dpotrf(S, lower=1)
        if info != 0:
            raise np.linalg.LinAlgError(f"H P H^T + R is not positive definite (potrf info {info})")
        inv, _ = lapack.dpotri(c, lower=1)
        Q = self._block(nodes)
        return float(2.0 * np.sum(np.tril(inv, -1) * Q) + np.sum(np.diag(inv) * np.diag(Q)))
