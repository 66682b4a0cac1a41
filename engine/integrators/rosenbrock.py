"""Rosenbrock (linearly implicit) tableaux as frozen data that check their own order conditions.

A Rosenbrock method (Hairer & Wanner, *Solving ODEs II*, Sec. IV.7) with ``s`` stages,
for ``y' = f(t, y)`` with Jacobian ``J = df/dy`` and ``f_t = df/dt``, is stored in the
*transformed* form of Eq. (7.25) that codes use (no matrix-vector product with ``J``)::

    (I / (h gamma) - J) U_i = f(t + c_i h, y0 + sum_j a_ij U_j) + sum_j (C_ij / h) U_j
                              + d_i h f_t,                        i = 1..s
    y1 = y0 + sum_i m_i U_i,      y1_hat = y0 + sum_i m_hat_i U_i

and a continuous extension
``y(t0 + theta h) = y0 + theta (y1 - y0) + theta (1 - theta) (sum_i dense[0, i] U_i
+ theta sum_i dense[1, i] U_i)`` (the form of Hairer's RODAS code).

The *original* coefficients follow as ``Gamma = (I / gamma - C)^-1`` (lower triangular,
diagonal ``gamma``), ``alpha = a Gamma``, ``b = m Gamma``, ``b_hat = m_hat Gamma``; on
construction the tableau checks ``c_i = sum_j alpha_ij``, ``d_i = sum_j Gamma_ij`` and the
order conditions of ``b`` and ``b_hat`` (Hairer & Wanner II, Table IV.7.1, up to order 4),
written with ``beta = alpha + Gamma`` strictly below the diagonal and ``B1 = beta 1``:

    order 1  sum b = 1
    order 2  b.B1 = 1/2 - gamma
    order 3  b.c^2 = 1/3;  b.beta B1 = 1/6 - gamma + gamma^2
    order 4  b.c^3 = 1/4;  b.(c * alpha B1) = 1/8 - gamma/3;  b.beta c^2 = 1/12 - gamma/3;
             b.beta beta B1 = 1/24 - gamma/2 + 3 gamma^2/2 - gamma^3
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .tableau import freeze_arrays, highest_order

TOL = 1e-12


def original_form(gamma: float, a, C, m):
    """``(alpha, Gamma, b)`` of the original form from the transformed ``(a, C, m)``."""
    s = len(m)
    Gamma = np.linalg.inv(np.eye(s) / gamma - np.asarray(C))
    return np.asarray(a) @ Gamma, Gamma, np.asarray(m) @ Gamma


def conditions(alpha, Gamma, b, gamma) -> list[tuple[int, float, float]]:
    """(order, value, exact) of every Rosenbrock order condition up to order 4."""
    beta = np.tril(alpha + Gamma, -1)
    c = alpha.sum(axis=1)
    B1 = beta.sum(axis=1)
    g = gamma
    return [
        (1, b.sum(), 1.0),
        (2, b @ B1, 0.5 - g),
        (3, b @ c**2, 1 / 3), (3, b @ beta @ B1, 1 / 6 - g + g * g),
        (4, b @ c**3, 0.25), (4, b @ (c * (alpha @ B1)), 1 / 8 - g / 3),
        (4, b @ beta @ c**2, 1 / 12 - g / 3),
        (4, b @ beta @ beta @ B1, 1 / 24 - g / 2 + 1.5 * g * g - g**3),
    ]


def order_of(alpha, Gamma, b, gamma, tol: float = TOL) -> int:
    """Highest p <= 4 such that all conditions of order <= p hold to ``tol``."""
    return highest_order(conditions(alpha, Gamma, b, gamma), 4, tol)


@dataclass(frozen=True)
class RosenbrockTableau:
    """Transformed Rosenbrock coefficients; raises ValueError if a sum rule fails.

    Parameters
    ----------
    name : literature name.
    gamma : diagonal coefficient (one LU decomposition per step).
    a, C : ``(s, s)`` strictly lower-triangular stage matrices (transformed form).
    c, d : ``(s,)`` stage times and time-derivative weights ``d_i = sum_j Gamma_ij``.
    m, m_hat : ``(s,)`` weights of the solution and of the embedded solution.
    order, error_order : claimed orders of ``m`` and ``m_hat``.
    dense : ``(2, s)`` continuous-extension weights (module docstring), optional.
    """

    name: str
    gamma: float
    a: np.ndarray
    C: np.ndarray
    c: np.ndarray
    d: np.ndarray
    m: np.ndarray
    m_hat: np.ndarray
    order: int
    error_order: int
    dense: np.ndarray | None = None

    def __post_init__(self):
        freeze_arrays(self, ("a", "C", "c", "d", "m", "m_hat", "dense"))
        self._check()

    def _check(self):
        s = self.stages
        if self.a.shape != (s, s) or self.C.shape != (s, s):
            raise ValueError(f"{self.name}: a and C must be ({s}, {s}), got {self.a.shape}, "
                             f"{self.C.shape}")
        if np.any(np.triu(self.a) != 0) or np.any(np.triu(self.C) != 0):
            raise ValueError(f"{self.name}: a and C must be strictly lower triangular")
        alpha, Gamma, b = original_form(self.gamma, self.a, self.C, self.m)
        if not np.allclose(alpha.sum(axis=1), self.c, rtol=0, atol=1e-13):
            raise ValueError(f"{self.name}: c must be the row sums of alpha, got {self.c} vs "
                             f"{alpha.sum(axis=1)}")
        if not np.allclose(Gamma.sum(axis=1), self.d, rtol=0, atol=1e-13):
            raise ValueError(f"{self.name}: d must be the row sums of Gamma, got {self.d} vs "
                             f"{Gamma.sum(axis=1)}")
        got = order_of(alpha, Gamma, b, self.gamma)
        if got < self.order:
            raise ValueError(f"{self.name}: m is of order {got}, claimed {self.order}")
        b_hat = self.m_hat @ Gamma
        got_hat = order_of(alpha, Gamma, b_hat, self.gamma)
        if got_hat < self.error_order:
            raise ValueError(f"{self.name}: m_hat is of order {got_hat}, claimed "
                             f"{self.error_order}")

    @property
    def stages(self) -> int:
        return len(self.m)

    @property
    def m_err(self) -> np.ndarray:
        """Error weights ``m - m_hat`` (local error estimate ``sum_i m_err_i U_i``)."""
        return self.m - self.m_hat

    def stability(self, z: complex) -> complex:
        """Stability function ``R(z) = 1 + z b (I - z (alpha + Gamma))^-1 1`` on y' = lambda y."""
        alpha, Gamma, b = original_form(self.gamma, self.a, self.C, self.m)
        s = self.stages
        return complex(1 + z * b @ np.linalg.solve(np.eye(s) - z * (alpha + Gamma), np.ones(s)))
