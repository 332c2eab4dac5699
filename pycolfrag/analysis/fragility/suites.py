"""Record suites (docs/records.md): stripe curves on every IM of a suite table, cloud analysis, and
multiple-stripe fragility (Baker 2015).

A record-suite table is a dict of arrays in the layout of ``/samples`` (one row per run; keys of
:mod:`pycolfrag.core.names`), optionally with 2-D ``sa_g`` / ``sv_cm_s`` (rows x periods) and
``periods_s``. Fits use scipy only (no new dependency): ``scipy.stats.linregress`` for the cloud
regression, ``scipy.optimize.minimize`` for the logistic collapse model and the MSA likelihood.
statsmodels would give the same numbers (ordinary least squares and a binomial GLM) but would be a
new dependency for two two-parameter fits whose likelihoods and standard errors are a few lines.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pycolfrag.analysis.fragility import degenerate as _degenerate
from pycolfrag.analysis.fragility.bootstrap import as_rng
from pycolfrag.analysis.fragility.mle import LognormalFragility, _fit_reasons, _mle_bounds
from pycolfrag.analysis.fragility.stripes import stripe_curve
from pycolfrag.core import names as _names
from pycolfrag.core.errors import ParameterError
from pycolfrag.core.scipy_on_first_use import optimize, special, stats
from pycolfrag.core.validate import float_array
from pycolfrag.damage import PERFORMANCE_LEVELS, PerformanceLevel, _as_flags, exceeded


def ok_rows(table) -> np.ndarray:
    """Mask of a table's successful rows (``status == 0``; every row when it has no ``status``)."""
    status = table.get("status")
    n = len(np.asarray(table["collapsed"]))
    return np.ones(n, dtype=bool) if status is None else (np.asarray(status) == 0)


def table_im(table, im: str, period_s: float | None = None) -> tuple[np.ndarray, str]:
    """One IM column of a suite table and its label: a scalar IM, or a spectral IM (``sa_g``,
    ``sv_cm_s``) at ``period_s`` (the nearest stored period must match to 1e-9 s)."""
    q = _names.im(im)
    if not q.spectral:
        return np.asarray(table[im], dtype=float), q.label
    if period_s is None:
        raise ParameterError(f"{im} is spectral: give period_s")
    values = np.asarray(table[im], dtype=float)
    periods = np.asarray(table["periods_s"], dtype=float)
    j = int(np.argmin(np.abs(periods - float(period_s))))
    if abs(periods[j] - float(period_s)) > 1e-9:
        raise ParameterError(f"period {period_s} s is not stored (periods: {periods.tolist()})")
    return values[:, j], _names.label(im, float(period_s))


def stripe_analysis(table, levels=PERFORMANCE_LEVELS, ims=("pga_g", "pgv_cm_s", "sa_g", "sv_cm_s"), *,
                    period_s=1.0, n_stripes=12, stripes="equal-width", min_count=5, n_boot=200,
                    confidence=0.90, rng=None) -> dict:
    """Stripe-method fragility curves (paper Fig. 3 / Fig. 16) of a suite table, every IM x level.

    Successful rows (``status == 0``) only; spectral IMs at ``period_s``. Returns
    ``{(im, level.label): StripeCurve}`` (:func:`stripe_curve`).
    """
    ok = ok_rows(table)
    g = as_rng(rng)
    out = {}
    for im in ims:
        x, _ = table_im(table, im, period_s)
        for lev in levels:
            e = np.asarray(table[lev.edp], dtype=float)[ok]
            c = np.asarray(table["collapsed"])[ok].astype(bool)
            out[(im, lev.label)] = stripe_curve(x[ok], e, c, lev.threshold, n_stripes=n_stripes, stripes=stripes,
                                                min_count=min_count, n_boot=n_boot, confidence=confidence, rng=g)
    return out


@dataclass
class LogisticCollapse:
    """P(collapse | IM) = 1 / (1 + exp(-(c0 + c1 ln IM))), fitted by maximum likelihood.

    ``cov``: inverse of the observed information (the Hessian of -loglik) at the optimum.
    """

    c0: float
    c1: float
    cov: np.ndarray
    n: int
    n_collapsed: int
    loglik: float

    def __call__(self, im):
        im = np.asarray(im, dtype=float)
        return special.expit(self.c0 + self.c1 * np.log(im))

    @property
    def se(self) -> tuple[float, float]:
        return float(np.sqrt(self.cov[0, 0])), float(np.sqrt(self.cov[1, 1]))


def fit_logistic_collapse(im, collapsed) -> LogisticCollapse:
    """Logistic regression of the collapse flags on ln IM (``scipy.optimize.minimize``, BFGS with the
    analytic gradient; standard errors from the analytic Hessian). Both outcomes must occur; a
    separable sample (every collapse above every survivor) has no finite maximum and is refused."""
    x = np.log(_positive_im(im))
    y = _as_flags(collapsed).astype(float)
    if y.shape != x.shape:
        raise ParameterError(f"im has length {x.size}, collapsed has {y.size}")
    if y.all() or not y.any():
        raise ParameterError("logistic collapse fit needs both collapsed and standing runs")
    if x[y == 1].min() > x[y == 0].max() or x[y == 1].max() < x[y == 0].min():
        raise ParameterError("collapses and survivors are separated by the IM: the logistic fit has no finite "
                             "maximum (more runs near the threshold are needed)")
    X = np.column_stack([np.ones_like(x), x])

    def nll(b):
        eta = X @ b
        ll = np.sum(y * eta - np.logaddexp(0.0, eta))
        return -ll, -(X.T @ (y - special.expit(eta)))

    res = optimize.minimize(nll, np.zeros(2), jac=True, method="BFGS", options={"gtol": 1e-10})
    p = special.expit(X @ res.x)
    hess = (X * (p * (1 - p))[:, None]).T @ X
    return LogisticCollapse(float(res.x[0]), float(res.x[1]), np.linalg.inv(hess), int(y.size), int(y.sum()),
                            float(-res.fun))


def _positive_im(im) -> np.ndarray:
    im = float_array(im, "IM", ndim=None, allow_empty=True, finite=False)
    if im.ndim != 1 or im.size == 0:
        raise ParameterError("IM must be a non-empty 1-D array")
    if not np.all(np.isfinite(im)) or np.any(im <= 0):
        raise ParameterError("IM values must be finite and positive (they enter as ln IM)")
    return im


@dataclass
class CloudFit:
    """Cloud analysis: ln EDP = a + b ln IM + beta eps over the non-collapsed runs, plus collapse.

    Attributes
    ----------
    a, b : float
        Intercept and slope (ordinary least squares, ``scipy.stats.linregress``).
    se_a, se_b : float
        Their standard errors.
    beta : float
        Dispersion: standard deviation of the residuals with n - 2 degrees of freedom.
    n : int
        Runs in the regression (non-collapsed, EDP > 0); ``n_collapsed`` collapsed runs.
    collapse : LogisticCollapse or None
        P(C | IM), when collapses and survivors both occur and overlap in IM (else None:
        ``p_collapse`` is then the constant fraction).
    """

    a: float
    b: float
    se_a: float
    se_b: float
    beta: float
    n: int
    n_collapsed: int
    r2: float
    collapse: LogisticCollapse | None = None
    p_collapse: float = 0.0

    def median_edp(self, im):
        """exp(a + b ln IM): the median EDP of a standing column at ``im``."""
        return np.exp(self.a + self.b * np.log(np.asarray(im, dtype=float)))

    def collapse_probability(self, im):
        im = np.asarray(im, dtype=float)
        return self.collapse(im) if self.collapse is not None else np.full(im.shape, self.p_collapse)

    def exceedance(self, im, threshold):
        """P(EDP >= threshold | IM) = P(C|IM) + (1 - P(C|IM)) (1 - Phi((ln t - a - b ln IM) / beta))."""
        im = np.asarray(im, dtype=float)
        pc = self.collapse_probability(im)
        tail = stats.norm.sf((np.log(float(threshold)) - self.a - self.b * np.log(im)) / self.beta)
        return pc + (1.0 - pc) * tail


def cloud_analysis(im, edp, collapsed=None) -> CloudFit:
    """Cloud analysis of a record suite (each run one point in the ln IM - ln EDP plane).

    Parameters
    ----------
    im : array_like, > 0 (IM units)
    edp : array_like (dimensionless); collapsed and non-positive values stay out of the regression
    collapsed : array_like of bool, optional (default: nothing collapsed)
    """
    x = _positive_im(im)
    e = float_array(edp, "edp", ndim=None, finite=False)
    c = np.zeros(x.size, dtype=bool) if collapsed is None else _as_flags(collapsed)
    if e.shape != x.shape or c.shape != x.shape:
        raise ParameterError(f"im, edp and collapsed must have one value per run ({x.size}, {e.size}, {c.size})")
    with np.errstate(invalid="ignore"):
        use = (~c) & np.isfinite(e) & (e > 0)
    if use.sum() < 3:
        raise ParameterError(f"cloud regression needs at least 3 standing runs with EDP > 0, got {int(use.sum())}")
    lx, ly = np.log(x[use]), np.log(e[use])
    if np.ptp(lx) == 0:
        raise ParameterError("cloud regression needs runs at different IM values")
    r = stats.linregress(lx, ly)
    resid = ly - (r.intercept + r.slope * lx)
    n = int(use.sum())
    beta = float(np.sqrt(np.sum(resid ** 2) / (n - 2)))
    fit = CloudFit(float(r.intercept), float(r.slope), float(r.intercept_stderr), float(r.stderr), beta, n,
                   int(c.sum()), float(r.rvalue ** 2), p_collapse=float(c.mean()))
    if c.any() and not c.all():
        try:
            fit.collapse = fit_logistic_collapse(x, c)
        except ParameterError:
            fit.collapse = None
    return fit


@dataclass
class MSAFragility(LognormalFragility):
    """Multiple-stripe fragility (Baker 2015): :class:`LognormalFragility` plus the stripes it was
    fitted to and the standard errors of ln(median) and ln(beta) from the Fisher information."""

    im_levels: np.ndarray | None = None
    n_trials: np.ndarray | None = None
    n_exceed_stripe: np.ndarray | None = None
    cov_ln: np.ndarray | None = None


def msa_fragility(im_levels, n_trials, n_exceed) -> MSAFragility:
    """Lognormal fragility from multiple stripes by maximum likelihood (Baker 2015, Eq. 11).

    At stripe j (IM level x_j) z_j of n_j runs exceed; with p_j = Phi(ln(x_j / theta) / beta) the
    log-likelihood sum_j [ln C(n_j, z_j) + z_j ln p_j + (n_j - z_j) ln(1 - p_j)]
    (``scipy.stats.binom.logpmf``) is maximised over (ln theta, ln beta) with
    ``scipy.optimize.minimize`` (Nelder-Mead, then polished by L-BFGS-B). ``cov_ln`` is the inverse of
    the expected Fisher information sum_j n_j phi(z_j)^2 / (p_j (1 - p_j)) g_j g_j^T,
    g_j = (-1/beta, -z_j), of (ln theta, ln beta).
    """
    x = _positive_im(im_levels)
    n = np.asarray(n_trials)
    z = np.asarray(n_exceed)
    if n.shape != x.shape or z.shape != x.shape:
        raise ParameterError("im_levels, n_trials and n_exceed need one value per stripe")
    if np.any(n < 1) or np.any(z < 0) or np.any(z > n) or np.any(n != np.round(n)) or np.any(z != np.round(z)):
        raise ParameterError("n_trials must be integers >= 1 and n_exceed integers in [0, n_trials]")
    if z.sum() == 0 or z.sum() == n.sum():
        raise ParameterError("every run exceeds or none does: the MSA likelihood has no interior maximum")
    lx = np.log(x)

    def nll(p):
        pr = np.clip(stats.norm.cdf((lx - p[0]) / np.exp(p[1])), 1e-300, 1 - 1e-16)
        return -np.sum(stats.binom.logpmf(z, n, pr))

    frac = z / n
    x0 = np.array([lx[np.argmin(np.abs(frac - 0.5))], np.log(0.4)])
    res = optimize.minimize(nll, x0, method="Nelder-Mead", options={"xatol": 1e-10, "fatol": 1e-12, "maxiter": 4000})
    bounds = _mle_bounds(lx)
    res = optimize.minimize(nll, res.x, method="L-BFGS-B", bounds=bounds)
    ln_theta, ln_beta = res.x
    beta = float(np.exp(ln_beta))
    zz = (lx - ln_theta) / beta
    pr = stats.norm.cdf(zz)
    w = n * stats.norm.pdf(zz) ** 2 / np.clip(pr * (1 - pr), 1e-300, None)
    gvec = np.stack([-np.ones_like(zz) / beta, -zz])
    info = (gvec * w) @ gvec.T
    try:
        # one stripe: the information has rank 1 (a singular matrix that round-off makes invertible)
        cov = np.linalg.inv(info) if np.ptp(lx) > 0 else np.full((2, 2), np.nan)
    except np.linalg.LinAlgError:
        cov = np.full((2, 2), np.nan)
    runs_y = np.concatenate([np.arange(int(nj)) < int(zj) for nj, zj in zip(n, z)])
    reasons, causes = _fit_reasons(np.repeat(lx, n.astype(int)), runs_y, res.x, bounds)
    why = "; ".join(reasons)
    if why:
        _degenerate.warn(f"msa_fragility: {why}", causes)
    return MSAFragility(float(np.exp(ln_theta)), beta, int(n.sum()), int(z.sum()), float(-res.fun),
                        im_levels=x, n_trials=n.astype(int), n_exceed_stripe=z.astype(int), cov_ln=cov,
                        degenerate=why)


def msa_from_table(table, im: str, level: PerformanceLevel, *, stripe_key="scale", period_s=None) -> MSAFragility:
    """MSA fragility of a suite run at several amplitude factors (``--scale``): one stripe per value of
    ``stripe_key``; the stripe's IM level is the geometric mean of its runs' IM (the common IM level
    when the records were scaled to one; with plain amplitude factors the runs of a stripe have
    different IMs and :func:`fit_lognormal_fragility` on the individual IMs is the sharper fit)."""
    ok = ok_rows(table)
    x, _ = table_im(table, im, period_s)
    key = np.asarray(table[stripe_key])[ok]
    y = exceeded(np.asarray(table[level.edp], dtype=float)[ok], np.asarray(table["collapsed"])[ok].astype(bool),
                 level.threshold)
    x = x[ok]
    levels, n, z = [], [], []
    for k in np.unique(key):
        sel = key == k
        levels.append(float(np.exp(np.mean(np.log(_positive_im(x[sel]))))))
        n.append(int(sel.sum()))
        z.append(int(y[sel].sum()))
    return msa_fragility(np.array(levels), np.array(n), np.array(z))
