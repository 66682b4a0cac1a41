"""Butcher tableaux as frozen data that check their own order conditions when built.

An explicit Runge-Kutta method with ``s`` stages is ``(c, a, b)``: stage
``k_i = f(t + c_i h, y + h sum_j a_ij k_j)`` and ``y1 = y0 + h sum_i b_i k_i``.
An embedded pair adds ``b_hat`` (the lower-order solution; the error estimate is
``h sum_i (b_i - b_hat_i) k_i``), and a continuous extension adds ``dense``:
``y(t0 + theta h) = y0 + h sum_i k_i sum_j dense[i, j] theta**(j + 1)``.

The order conditions checked are the rooted-tree conditions up to order 5
(Hairer, Norsett & Wanner, *Solving ODEs I*, Sec. II.2, Table 2.2), written with
``C = diag(c)``; e.g. order 3 needs ``b.c**2 = 1/3`` and ``b.A c = 1/6``.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


def _conditions(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> list[tuple[int, float, float]]:
    """(order, value, exact) of every rooted-tree condition up to order 5."""
    ac = a @ c
    ac2, aac = a @ c**2, a @ ac
    rows = [
        (1, b.sum(), 1.0),
        (2, b @ c, 1 / 2),
        (3, b @ c**2, 1 / 3), (3, b @ ac, 1 / 6),
        (4, b @ c**3, 1 / 4), (4, b @ (c * ac), 1 / 8), (4, b @ ac2, 1 / 12), (4, b @ aac, 1 / 24),
        (5, b @ c**4, 1 / 5), (5, b @ (c**2 * ac), 1 / 10), (5, b @ (c * ac2), 1 / 15),
        (5, b @ (c * aac), 1 / 30), (5, b @ ac**2, 1 / 20), (5, b @ (a @ c**3), 1 / 20),
        (5, b @ (a @ (c * ac)), 1 / 40), (5, b @ (a @ ac2), 1 / 60), (5, b @ (a @ aac), 1 / 120),
    ]
    return rows


def freeze_arrays(obj, keys) -> None:
    """Replace the fields ``keys`` of a frozen dataclass by read-only float arrays (None stays)."""
    for key in keys:
        val = getattr(obj, key)
        if val is not None:
            arr = np.array(val, dtype=float)
            arr.setflags(write=False)
            object.__setattr__(obj, key, arr)


def highest_order(rows, max_order: int, tol: float) -> int:
    """Highest p <= max_order such that every condition ``(order, value, exact)`` of
    ``rows`` with order <= p holds to ``tol`` (shared by the Butcher and Rosenbrock checks)."""
    p = 0
    for order in range(1, max_order + 1):
        if not all(abs(v - x) <= tol for o, v, x in rows if o == order):
            break
        p = order
    return p


def order_of(a, b, c, tol: float = 1e-12) -> int:
    """Highest p <= 5 such that all conditions of order <= p hold to ``tol``."""
    return highest_order(_conditions(a, b, c), 5, tol)


@dataclass(frozen=True)
class ButcherTableau:
    """Explicit RK coefficients; raises ValueError at construction if the sum rules fail.

    Parameters
    ----------
    name : literature name of the method.
    c, a, b : nodes ``(s,)``, strictly lower-triangular matrix ``(s, s)``, weights ``(s,)``.
    order : claimed order of ``b``.
    b_hat, error_order : embedded weights and their order (adaptive pairs), optional.
    dense : ``(s, m)`` continuous-extension coefficients, optional (must give ``b`` at theta=1).
    """

    name: str
    c: np.ndarray
    a: np.ndarray
    b: np.ndarray
    order: int
    b_hat: np.ndarray | None = None
    error_order: int | None = None
    dense: np.ndarray | None = field(default=None, repr=False)

    def __post_init__(self):
        freeze_arrays(self, ("c", "a", "b", "b_hat", "dense"))
        self._check()

    def _check(self):
        a, b, c = self.a, self.b, self.c
        s = len(b)
        if a.shape != (s, s) or c.shape != (s,):
            raise ValueError(f"{self.name}: a must be ({s}, {s}) and c ({s},), got {a.shape}, {c.shape}")
        if np.any(np.triu(a) != 0.0):
            raise ValueError(f"{self.name}: a must be strictly lower triangular (explicit method)")
        if not np.allclose(a.sum(axis=1), c, rtol=0, atol=1e-14):
            raise ValueError(f"{self.name}: row sums of a must equal c, got {a.sum(axis=1)} vs {c}")
        got = order_of(a, b, c)
        if got < min(self.order, 5):
            raise ValueError(f"{self.name}: b is of order {got}, claimed {self.order}")
        if self.b_hat is not None:
            got_hat = order_of(a, self.b_hat, c)
            if got_hat < self.error_order:
                raise ValueError(f"{self.name}: b_hat is of order {got_hat}, claimed {self.error_order}")
        if self.dense is not None and not np.allclose(self.dense.sum(axis=1), b, atol=1e-14):
            raise ValueError(f"{self.name}: dense output at theta = 1 must reproduce b")

    @property
    def stages(self) -> int:
        return len(self.b)

    @property
    def b_err(self) -> np.ndarray:
        """Error weights ``b - b_hat`` (the local error estimate is ``h sum b_err_i k_i``)."""
        if self.b_hat is None:
            raise ValueError(f"{self.name} has no embedded pair")
        return self.b - self.b_hat
