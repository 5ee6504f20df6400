r"""Observer models: how a simulated participant turns a percept into an answer 1#..4#.

The simulated participant (:class:`experiments.participant_model.person.SimulatedPerson`) feels the
physics at its receptors and perceives a noisy feature vector :math:`x` (drops at a few times
and the peak rate of fall).  *Which answer* it gives is a separate, named choice: the paper does
not say how its participants decided, and the Figure 9 result depends on it.

Every observer sees, trial by trial, only the percepts of the current block so far and the
answers it already gave (it answers each trial before the next, as the paper's participants spoke
their answers), plus what it learned in familiarisation.  With probability ``lapse_rate`` it
guesses uniformly instead (applied by the caller, see :func:`answer_block`).

=====================  ========================================================================
name                   decision rule
=====================  ========================================================================
``absolute``           absolute identification: the maximum-likelihood class under Gaussian
                       templates learned on the real samples (one familiarisation touch each);
                       a simulated trial is judged against the real templates.  The model the
                       project used before the observer family.
``relative``           within-block relative: projects each percept on its own discrimination
                       axis (real templates 1# → 4#), ranks it among the block's percepts so
                       far, and, *knowing the 4 × 3 design* (each sample three times), names
                       the class whose share of the ranks it falls in, never naming a class
                       more often than the design allows.
``range_frequency``    Parducci's range–frequency judgement on the same axis, over the block so
                       far; learns nothing about the design.
``display_learned``    absolute identification with templates learned *on the display* (a
                       familiarisation block of replayed samples before the simulated block;
                       protocol variant
                       :func:`experiments.simulation.replay.with_display_familiarisation`).
=====================  ========================================================================

Parameters shared by the whole family live in
:class:`experiments.participant_model.person.PerceptionParameters`, with their sources there: the
perceptual noise the observer knows it has (0.3 K per drop feature, 0.3 K/s on the rate, Weber
fraction 0.1) and ``lapse_rate`` (0.02, the usual allowance for inattention); the familiarisation
(one touch per real sample) is the protocol's.  Observer-specific parameters are listed by
:meth:`Observer.parameters` with their source (``range_weight`` of ``range_frequency``); the
design-aware ``relative`` observer takes the design (``repetitions`` per sample) from the
protocol's block.  :func:`fit_observer` recovers them from percepts and answers (tests in
``tests/experiments/participant_model/test_observers.py``).

The same code answers in an emulated session (the simulated responder, one trial at a time) and
in the fast study simulation (:mod:`experiments.simulation.studies`, thousands of blocks at once):
:meth:`Observer.choose` takes a batch of blocks.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

__all__ = ["Observer", "AbsoluteObserver", "RelativeObserver", "RangeFrequencyObserver",
           "DisplayLearnedObserver", "OBSERVERS", "get_observer", "BlockContext", "answer_block",
           "fit_observer",
           "discrimination_axis"]


@dataclass
class BlockContext:
    """What an observer knows when a block starts (arrays carry a leading batch axis ``B``).

    Parameters
    ----------
    means : ndarray, shape (B, C, F)
        Template means of the ``C`` classes (the familiarisation percepts' mean).
    counts : ndarray, shape (B, C)
        Familiarisation percepts per class.
    noise_sd : callable
        ``noise_sd(features)`` -> standard deviation per feature (the person's own noise,
        :meth:`PerceptionParameters.noise_sd`): the observer knows its noise.
    repetitions : int
        Presentations of each class in the block (the design: the block has ``C x repetitions``
        trials); used only by observers that know the design.
    """

    means: np.ndarray
    counts: np.ndarray
    noise_sd: object
    repetitions: int = 3

    @property
    def n_classes(self) -> int:
        return int(self.means.shape[1])


def discrimination_axis(ctx: BlockContext) -> tuple[np.ndarray, np.ndarray]:
    """The observer's own 1-D axis: ``(w, origin)`` with projection ``z = (x - origin) · w``.

    ``w`` is the noise-weighted direction from the first class's template to the last's,
    ``(m_C - m_1) / s^2`` with ``s`` the noise at the templates' midpoint (Fisher's linear
    discriminant with a diagonal covariance); ``origin`` is the first template.  ``z`` grows
    from 1# towards 4# *as the observer learned them on the real samples*.
    """
    lo, hi = ctx.means[:, 0, :], ctx.means[:, -1, :]
    s = np.asarray(ctx.noise_sd(0.5 * (lo + hi)), dtype=float)
    return (hi - lo) / s ** 2, lo


class Observer:
    """Base class: a named decision rule with documented parameters.

    Subclasses set :attr:`name`, :attr:`parameters` (name -> (value, source or reason)) and
    implement :meth:`choose`.
    """

    name: str = ""
    #: Familiarisation on the display (the protocol needs such a block).
    familiarise_on_display: bool = False
    #: Which familiarisation's templates judge a simulated trial.
    template_mode_for_simulated: str = "real"

    def __init__(self, **params):
        unknown = sorted(set(params) - set(self.defaults()))
        if unknown:
            raise ValueError(f"observer {self.name!r}: unknown parameter(s) {unknown}; expected "
                             f"{sorted(self.defaults()) or 'none'}")
        self.params = {**self.defaults(), **params}

    @classmethod
    def defaults(cls) -> dict:
        """Parameter name -> default value."""
        return {k: v for k, (v, _) in cls.parameters().items()}

    @classmethod
    def parameters(cls) -> dict:
        """Parameter name -> (default, source of the value or reason for it)."""
        return {}

    def describe(self) -> dict:
        """JSON-ready name and parameters (logged by the simulated responder)."""
        return {"name": self.name, "parameters": dict(self.params)}

    def choose(self, percepts: np.ndarray, answers: np.ndarray, ctx: BlockContext) -> np.ndarray:
        """The answer (class index 0..C-1) to the *last* percept of each block in the batch.

        Parameters
        ----------
        percepts : ndarray, shape (B, k, F)
            The block's percepts so far, the current one last.
        answers : ndarray of int, shape (B, k - 1)
            The answers already given in the block (class indices; lapses included).
        ctx : BlockContext

        Returns
        -------
        ndarray of int, shape (B,)
        """
        raise NotImplementedError


class AbsoluteObserver(Observer):
    r"""Absolute identification: the maximum-likelihood class under the learned templates.

    .. math:: \hat c = \arg\max_c \sum_k \log N\big(x_k;\ m_{ck},\ \sigma_k(m_c)^2 (1 + 1/n_c)\big)

    Identical to :meth:`SimulatedPerson.decide` (without its lapse, applied by the caller).
    """

    name = "absolute"

    def choose(self, percepts, answers, ctx):
        x = np.asarray(percepts, dtype=float)[:, -1, :]                    # (B, F)
        var = np.asarray(ctx.noise_sd(ctx.means), dtype=float) ** 2 * \
            (1.0 + 1.0 / ctx.counts[..., None])                             # (B, C, F)
        diff = x[:, None, :] - ctx.means
        ll = -0.5 * np.sum(diff ** 2 / var + np.log(2 * np.pi * var), axis=-1)
        return np.argmax(ll, axis=-1)


class DisplayLearnedObserver(AbsoluteObserver):
    """Absolute identification with templates learned on the display for simulated trials.

    Needs a familiarisation block on the display (the protocol variant
    :func:`~experiments.simulation.replay.with_display_familiarisation`); real trials are still
    judged against the real samples' templates.
    """

    name = "display_learned"
    familiarise_on_display = True
    template_mode_for_simulated = "simulated"


class RelativeObserver(Observer):
    """Within-block relative judgement by rank, knowing the 4 × 3 design.

    Each percept is projected on the observer's own axis (:func:`discrimination_axis`).  At the
    ``k``-th trial of a block, with the current projection of rank ``r`` (1 = nearest 1#) among
    the ``k`` seen so far, its expected place in the whole block is the quantile
    ``q = (r - 1/2) / k``; the observer names class ``ceil(q C)``, unless that class was already
    named ``repetitions`` times in this block, in which case it names the nearest class still
    available (the lower one on a tie).
    """

    name = "relative"

    def choose(self, percepts, answers, ctx):
        w, origin = discrimination_axis(ctx)
        z = np.einsum("bkf,bf->bk", np.asarray(percepts, dtype=float) - origin[:, None, :], w)
        k = z.shape[1]
        rank = 1 + np.sum(z[:, :-1] < z[:, -1:], axis=1) + 0.5 * np.sum(z[:, :-1] == z[:, -1:], axis=1)
        q = (rank - 0.5) / k
        n_cls = ctx.n_classes
        wanted = np.clip(np.ceil(q * n_cls).astype(int) - 1, 0, n_cls - 1)
        used = np.zeros((z.shape[0], n_cls), dtype=int)
        if answers.shape[1]:
            for c in range(n_cls):
                used[:, c] = np.sum(answers == c, axis=1)
        free = used < int(ctx.repetitions)
        classes = np.arange(n_cls)
        distance = np.abs(classes[None, :] - wanted[:, None]) + 0.1 * (classes[None, :] > wanted[:, None])
        distance = np.where(free, distance, np.inf)
        choice = np.argmin(distance, axis=1)
        # a block longer than the design (cannot happen in the protocol): fall back to the rank
        return np.where(np.any(free, axis=1), choice, wanted)


class RangeFrequencyObserver(Observer):
    r"""Range–frequency judgement over the block so far (Parducci), ignorant of the design.

    On the observer's own axis, the current projection :math:`z` gets the judgement

    .. math:: J = w\,\frac{z - z_{\min}}{z_{\max} - z_{\min}} + (1 - w)\,\frac{r - 1}{k - 1}

    (range value and frequency value over the ``k`` percepts of the block so far, ``r`` its rank;
    ``J = 1/2`` on the first trial or when all are equal) and names class
    :math:`\min(C, 1 + \lfloor J C \rfloor)`.
    """

    name = "range_frequency"

    @classmethod
    def parameters(cls):
        return {"range_weight": (0.5, "Parducci's range-frequency theory: judgements weigh the "
                                      "range and frequency principles about equally (w close "
                                      "to 0.5 in category-rating data, Parducci 1965; Parducci "
                                      "& Wedell 1986)")}

    def __init__(self, **params):
        super().__init__(**params)
        w = self.params["range_weight"]
        if not (isinstance(w, (int, float)) and 0.0 <= w <= 1.0):
            raise ValueError(f"observer 'range_frequency': range_weight: expected a number in "
                             f"[0, 1], got {w!r}")

    def choose(self, percepts, answers, ctx):
        w, origin = discrimination_axis(ctx)
        z = np.einsum("bkf,bf->bk", np.asarray(percepts, dtype=float) - origin[:, None, :], w)
        k = z.shape[1]
        cur = z[:, -1]
        lo, hi = z.min(axis=1), z.max(axis=1)
        span = hi - lo
        range_value = np.where(span > 0, (cur - lo) / np.where(span > 0, span, 1.0), 0.5)
        if k > 1:
            rank = np.sum(z[:, :-1] < cur[:, None], axis=1) + 0.5 * np.sum(z[:, :-1] == cur[:, None], axis=1)
            freq_value = rank / (k - 1)
        else:
            freq_value = np.full_like(cur, 0.5)
        weight = float(self.params["range_weight"])
        judgement = weight * range_value + (1.0 - weight) * freq_value
        n_cls = ctx.n_classes
        return np.minimum(n_cls - 1, np.floor(judgement * n_cls).astype(int))


#: The observer family by name.
OBSERVERS = {cls.name: cls for cls in (AbsoluteObserver, RelativeObserver, RangeFrequencyObserver,
                                       DisplayLearnedObserver)}


def get_observer(name: str, **params) -> Observer:
    """An observer by name (:data:`OBSERVERS`) with its parameters.

    Raises
    ------
    ValueError
        Unknown name or parameter (the message lists the known ones).
    """
    try:
        cls = OBSERVERS[name]
    except KeyError:
        raise ValueError(f"observer: expected one of {', '.join(OBSERVERS)}, got {name!r}") from None
    return cls(**params)


def answer_block(observer: Observer, percepts: np.ndarray, ctx: BlockContext, lapse: np.ndarray,
                 guesses: np.ndarray) -> np.ndarray:
    """Answers to whole blocks, trial by trial, as the observer gives them in a session.

    Parameters
    ----------
    observer : Observer
    percepts : ndarray, shape (B, T, F)
        The blocks' percepts in presentation order.
    ctx : BlockContext
    lapse : ndarray of bool, shape (B, T)
        Which trials are lapses (the caller draws ``u < lapse_rate``).
    guesses : ndarray of int, shape (B, T)
        The class guessed on a lapse (0..C-1).

    Returns
    -------
    ndarray of int, shape (B, T)
        Class indices (0-based).
    """
    percepts = np.asarray(percepts, dtype=float)
    b, t = percepts.shape[:2]
    answers = np.zeros((b, t), dtype=int)
    for k in range(t):
        choice = observer.choose(percepts[:, :k + 1], answers[:, :k], ctx)
        answers[:, k] = np.where(lapse[:, k], guesses[:, k], choice)
    return answers


def fit_observer(name: str, percepts: np.ndarray, answers: np.ndarray, ctx: BlockContext,
                 grid: dict | None = None) -> dict:
    """Maximum-likelihood parameters of observer ``name`` from blocks of percepts and answers.

    The likelihood of an answer is ``(1 - lapse) 1[answer = rule's choice] + lapse / C``; for
    each point of ``grid`` (parameter -> values; default: none, only the lapse rate is fitted)
    the rule's choices are computed with the *given* earlier answers (as the observer saw
    them), the lapse rate has the closed-form maximum ``C/(C-1) x disagreement``, and the grid
    point with the highest log-likelihood wins.

    Returns
    -------
    dict
        The fitted parameters and ``lapse_rate``, plus ``log_likelihood``.
    """
    grid = dict(grid or {})
    answers = np.asarray(answers, dtype=int)
    percepts = np.asarray(percepts, dtype=float)
    n_cls = ctx.n_classes
    best = None
    for values in itertools.product(*grid.values()):
        params = dict(zip(grid, values))
        obs = get_observer(name, **params)
        choice = np.stack([obs.choose(percepts[:, :k + 1], answers[:, :k], ctx)
                           for k in range(percepts.shape[1])], axis=1)
        agree = float(np.mean(choice == answers))
        lapse = min(1.0, max(0.0, (1.0 - agree) * n_cls / (n_cls - 1)))
        p_agree = (1 - lapse) + lapse / n_cls
        p_other = lapse / n_cls
        ll = answers.size * (agree * np.log(max(p_agree, 1e-300))
                             + (1 - agree) * np.log(max(p_other, 1e-300)))
        if best is None or ll > best["log_likelihood"] + 1e-9:
            best = {**params, "lapse_rate": lapse, "log_likelihood": float(ll)}
    return best
