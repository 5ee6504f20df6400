"""The random-slope mixed logit's deviance (:mod:`analysis.glmm_slope`): each participant's
2-D integral over ``b_i ~ N(0, I_2)`` by adaptive Gauss-Hermite quadrature on a tensor grid,
centred on the conditional mode (Newton's method, warm-started from the last evaluation's modes
on the same data) and scaled by the Cholesky factor of the curvature there.
"""
from __future__ import annotations

import functools

import numpy as np
from scipy import special

from .glmm import GLMMData, logsumexp_rows

__all__ = ["slope_deviance"]

#: Upper bound of an SD (logit scale) in the optimisations and profiles.
SD_BOUND = 20.0


def lambda_matrix(t):
    """lme4's theta ``(l11, l21, l22)`` as the lower-triangular ``Lambda`` (2 x 2)."""
    return np.array([[t[0], 0.0], [t[1], t[2]]])


def _curvature(person, w, zt, m):
    """Per participant the 2 x 2 curvature I + sum_rows w z' z of the log integrand (m x 2 x 2)."""
    h = np.empty((m, 2, 2))
    for a in range(2):
        for c in range(a, 2):
            h[:, a, c] = h[:, c, a] = np.bincount(person, w * zt[:, a] * zt[:, c], m)
    h[:, 0, 0] += 1
    h[:, 1, 1] += 1
    return h


@functools.lru_cache(maxsize=8)
def _tensor_grid(n_agq: int):
    """Gauss-Hermite tensor grid: nodes (Q, 2), log weights + |t|^2 (Q,) (read-only)."""
    t1, w1 = np.polynomial.hermite.hermgauss(n_agq)
    tt = np.array([(a, c) for a in t1 for c in t1])       # Q x 2
    ww = np.array([a * c for a in w1 for c in w1])
    extra = np.sum(tt ** 2, axis=1) + np.log(ww)
    tt.flags.writeable = extra.flags.writeable = False
    return tt, extra


def _inner(x_eta, z, person, m, k, n, lam, n_agq, b0=None, onehot=None):
    """Per participant: log integral, nodes (m, Q, 2), eta at the nodes (rows, Q), posterior,
    and the conditional modes (m, 2).

    ``b0``: starting values of the modes (Newton's method converges to the same unique mode
    of the log-concave integrand from anywhere; a warm start from the previous evaluation
    saves iterations). ``onehot``: the (m, rows) participant indicator, if already built.
    """
    zt = z @ lam                                          # rows x 2: z' Lambda
    b = np.zeros((m, 2)) if b0 is None else np.array(b0, float)
    for _ in range(50):
        eta = x_eta + np.einsum("rk,rk->r", zt, b[person])
        p = special.expit(eta)
        r = k - n * p
        w = n * p * (1 - p)
        g = np.stack([np.bincount(person, zt[:, a] * r, m) for a in range(2)], axis=1) - b
        h = _curvature(person, w, zt, m)
        step = np.linalg.solve(h, g[..., None])[..., 0]
        b += step
        if np.max(np.abs(step)) < 1e-10:
            break
    else:
        if b0 is not None:            # a warm start that did not settle: from 0, as cold
            return _inner(x_eta, z, person, m, k, n, lam, n_agq, None, onehot)
    eta = x_eta + np.einsum("rk,rk->r", zt, b[person])
    p = special.expit(eta)
    w = n * p * (1 - p)
    h = _curvature(person, w, zt, m)
    chol = np.linalg.cholesky(h)                          # h = L L^T
    tt, extra = _tensor_grid(n_agq)
    # nodes: b = b_hat + sqrt(2) L^{-T} t
    linv_t = np.linalg.inv(np.transpose(chol, (0, 2, 1)))  # m x 2 x 2
    nodes = b[:, None, :] + np.sqrt(2.0) * np.einsum("mab,qb->mqa", linv_t, tt)
    eta_q = x_eta[:, None] + np.einsum("rk,rqk->rq", zt, nodes[person])
    ll_rows = k[:, None] * eta_q - n[:, None] * np.logaddexp(0.0, eta_q)
    if onehot is None:
        onehot = np.zeros((m, len(person)))
        onehot[person, np.arange(len(person))] = 1.0
    ll = onehot @ ll_rows
    log_terms = ll - 0.5 * np.sum(nodes ** 2, axis=2) + extra[None, :]
    log_det_l = np.log(chol[:, 0, 0]) + np.log(chol[:, 1, 1])
    norm = logsumexp_rows(log_terms)
    log_int = norm[:, 0] + np.log(2.0) - log_det_l - np.log(2 * np.pi)
    post = np.exp(log_terms - norm)
    return log_int, nodes, eta_q, post, b


def last_modes(data: GLMMData):
    """The last evaluation's conditional modes on ``data`` (a warm start), or None."""
    return data.__dict__.get("_slope_modes")


def inner_on(data: GLMMData, x_eta, z, lam, n_agq):
    """:func:`_inner` on ``data``, warm-started from (and remembering) its last modes."""
    b0 = last_modes(data)
    if b0 is not None and (b0.shape != (data.m, 2) or not np.all(np.isfinite(b0))):
        b0 = None
    out = _inner(x_eta, z, data.person, data.m, data.k, data.n, lam, n_agq, b0, data.onehot)
    data.__dict__["_slope_modes"] = out[4]
    return out[:4]


def slope_deviance(theta, data: GLMMData, z, n_agq: int = 5, grad: bool = False):
    """-2 log-likelihood at ``theta = (beta..., l11, l21, l22)`` (and its gradient).

    The gradient is the quadrature's posterior expectation of the complete-data score
    (accurate for ``n_agq >= 5``; :func:`fit_glmm_slope` uses central differences below).
    """
    theta = np.asarray(theta, float)
    beta, t = theta[:-3], theta[-3:]
    lam = lambda_matrix(t)
    x_eta = data.x @ beta
    log_int, nodes, eta_q, post = inner_on(data, x_eta, z, lam, n_agq)
    dev = -2.0 * float(log_int.sum())
    if not grad:
        return dev
    resid = data.k[:, None] - data.n[:, None] * special.expit(eta_q)
    wr = post[data.person] * resid                       # rows x Q
    g_beta = data.x.T @ wr.sum(axis=1)
    bn = nodes[data.person]                              # rows x Q x 2
    # d eta / d l11 = z0 b0, d l21 = z1 b0, d l22 = z1 b1
    g_t = np.array([np.sum(wr * z[:, 0:1] * bn[..., 0]), np.sum(wr * z[:, 1:2] * bn[..., 0]),
                    np.sum(wr * z[:, 1:2] * bn[..., 1])])
    return dev, -2.0 * np.append(g_beta, g_t)

