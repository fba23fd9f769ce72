"""Kalman fusion of node measurements into the surface map and the information gain (paper 002, eqs. 9-10, 13).

The map is the GP over the mesh nodes as a Gaussian: mean (n,) in K, covariance P (n, n) in K^2. A
measurement observes nodes ``idx`` (H selects them) with independent noise variances ``r``:

    S = H P H^T + R,   K = P H^T S^-1,   mu+ = mu + K (y - H mu),   P+ = P - K H P      (eqs. 9-10)

Eq. 10 as printed adds K H P; a posterior can only be less uncertain, so the sign is minus. Applied to all
measurements at once from the prior this equals the batch GP posterior of eqs. 4-5.

Information gain (eq. 13) is the drop in covariance trace, tr(P-) - tr(P+) = tr(P H^T S^-1 H P)
= tr(S^-1 (P P)_{idx, idx}). :class:`GainEvaluator` scores a candidate with one m x m Cholesky factor of S
(m = distinct nodes seen) and one triangular solve, never an n x n update.
Repeated measurements of one node are first merged (precisions add), which is exact for independent noise.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike
from scipy.linalg import lapack

from snakeplan.jit import kernel


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


def _cholesky(S: np.ndarray) -> np.ndarray:
    """Lower Cholesky factor of S (LAPACK potrf); LinAlgError when S is not positive definite."""
    c, info = lapack.dpotrf(S, lower=1)
    if info != 0:
        raise np.linalg.LinAlgError(f"H P H^T + R is not positive definite (potrf info {info})")
    return c


class GaussianMap:
    """The surface map: mean (n,) K and covariance (n, n) K^2, updated in place by Kalman fusion."""

    def __init__(self, mean: ArrayLike, covariance: ArrayLike) -> None:
        self.mean = np.array(mean, dtype=float)
        cov = np.asarray(covariance, dtype=float)
        self.cov = 0.5 * (cov + cov.T)

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
        updated (planning needs no values). With S = L L^T and X = L^-1 H P: K H P = X^T X and K (y - H mu) =
        X^T L^-1 (y - H mu); X^T X is formed by BLAS syrk, so P stays exactly symmetric at half a general
        product's cost."""
        idx, r, y = fuse_repeats(idx, noise_var, y)
        if idx.size == 0:
            return
        L = _cholesky(_innovation(self.cov, idx, r))
        X, _ = lapack.dtrtrs(L, self.cov[idx], lower=1)
        if y is not None:
            z, _ = lapack.dtrtrs(L, np.asarray(y, dtype=float) - self.mean[idx], lower=1)
            self.mean += X.T @ z
        self.cov -= X.T @ X


#: A gain evaluator forms the full product P W P once its per-candidate solves have cost this share of it (n^3):
#: a CMA-ES plan's ~150 trajectories of a few hundred nodes then read blocks after a handful of solves, while a
#: greedy step's ~100 candidates of tens of nodes stay well below it. Chosen between 1 and 1/4 by the compute
#: time of one mission (station seed 3: 10 % less CPU); both ways are exact, so plans do not depend on it.
PRODUCT_SHARE = 0.25


class GainEvaluator:
    """Scores candidate measurements against a fixed covariance P by the trace drop of eq. 13.

    ``weights`` (n,) >= 0 turns the trace into tr(W P) (None: every node counts once, eq. 13 as printed).
    A candidate seeing m distinct nodes costs one m x m Cholesky factor S = H P H^T + R = L L^T (LAPACK potrf,
    m^3 / 3); the gain is tr(S^-1 (P W P)_{idx, idx}). With A = P W^(1/2) (P symmetric, W >= 0), P W P = A A^T,
    so the gain is ||L^-1 A_{idx,:}||_F^2: one triangular solve (trtrs, m^2 n), no n x n product. Once these
    solves have cost ``PRODUCT_SHARE`` of the whole product (n^3), the product is formed once and each candidate
    reads its block instead: gain = sum(S^-1 * (P W P)_{idx, idx}) with S^-1 from potri (m^3). Both ways are
    exact (see the tests), so the choice changes rounding only.
    """

    def __init__(self, cov: np.ndarray, weights: ArrayLike | None = None) -> None:
        self.cov = cov
        self._A = cov if weights is None else cov * np.sqrt(np.asarray(weights, dtype=float))
        self._PWP: np.ndarray | None = None
        self._block_work = 0.0

    def _use_product(self, m: int) -> bool:
        """Whether to read the block from the full product P W P (formed here once the per-candidate work so far
        has cost as much as it; class docs)."""
        if self._PWP is None:
            n = self.cov.shape[0]
            self._block_work += float(m) ** 2 * n
            if self._block_work < PRODUCT_SHARE * float(n) ** 3:
                return False
            self._PWP = self._A @ self._A.T
        return True

    def gain(self, idx: ArrayLike, noise_var: ArrayLike) -> float:
        """tr(W P-) - tr(W P+) (K^2) for measuring nodes ``idx`` with variances ``noise_var`` (repeats allowed)."""
        nodes, r, _ = fuse_repeats(idx, noise_var)
        if nodes.size == 0:
            return 0.0
        S = _innovation(self.cov, nodes, r)
        if not self._use_product(nodes.size):
            X, _ = lapack.dtrtrs(_cholesky(S), self._A[nodes], lower=1)
            return float(np.vdot(X, X))
        inv, _ = lapack.dpotri(_cholesky(S), lower=1)
        return _lower_dot(inv, self._PWP, nodes)


def warm_up() -> None:
    """Load the gain's kernels (numba's cache, or a compile when cold) on a three-node map, so that a mission's
    timed planning never pays for them: the first gain of so small a map reads the full product, and both
    kernels run with the array layouts of a real one (LAPACK's inverse is in column order for two nodes or more;
    for one node numba sees it as a row-ordered 1 x 1)."""
    ev = GainEvaluator(np.eye(3))
    ev.gain(np.array([0, 1]), np.array([1.0, 1.0]))
    ev.gain(np.array([0]), np.array([1.0]))


@kernel
def _innovation(cov, nodes, r):
    """S = P[nodes, nodes] + diag(r), gathered in one pass (m x m)."""
    m = nodes.shape[0]
    S = np.empty((m, m))
    for i in range(m):
        for j in range(m):
            S[i, j] = cov[nodes[i], nodes[j]]
        S[i, i] += r[i]
    return S


@kernel
def _lower_dot(inv, Q, nodes):
    """sum(S^-1 * Q[nodes, nodes]) for symmetric S^-1 given by its lower triangle ``inv`` (potri) and symmetric
    Q: the diagonal once, each entry below it twice, without gathering the block."""
    total = 0.0
    for j in range(nodes.shape[0]):
        total += inv[j, j] * Q[nodes[j], nodes[j]]
        for i in range(j + 1, nodes.shape[0]):
            total += 2.0 * inv[i, j] * Q[nodes[i], nodes[j]]
    return total
