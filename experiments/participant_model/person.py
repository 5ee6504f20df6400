r"""A simulated participant: skin physics at the thermoreceptors plus a Thurstonian decision rule.

Pure model, no I/O. A :class:`SimulatedPerson` has a fingertip skin (total thickness ``L``,
dermis ``d``; receptors at depth ``d`` from the inner boundary, i.e. under an epidermis of
``L - d``), an initial skin temperature, and perceptual noise. On each trial it *feels* the
receptor temperature the physics predicts:

* real trial: its own skin in contact with the steel sample through the contact resistance of
  the sample's roughness against its own skin (:func:`stimuli.planner.planned_temperature`,
  Eq. 5 resistance);
* simulated trial: the pad temperature the display actually produced, touched through its own
  finger–pad contact resistance (:func:`stimuli.display_planner.planned_skin_response`).

Both go through the scene planner at ``params.model_tolerance_C`` (a quarter of the smallest
difference between the samples at the receptors, not the perceptual floor); the decision of the
last one is :attr:`SimulatedPerson.last_plan`.

The decision rule. From the receptor trace :math:`T(t)` the person extracts the features
:math:`f` (:func:`receptor_features`): the drop :math:`T_0 - T(t_k)` at ``drop_times_s`` and
the peak rate of fall in the first ``rate_window_s``. It perceives
:math:`x = f + \varepsilon`, :math:`\varepsilon_k \sim N(0, \sigma_k(f)^2)` independent,
:math:`\sigma_k(f) = a_k + w |f_k|` (additive noise ``drop_noise_C`` / ``rate_noise_C_per_s``
plus a Weber fraction ``w``). Familiarisation trials (the sample is named) add :math:`x` to the
template of that sample, one template set per kind of stimulus (real or displayed); a test
trial is answered with

.. math:: \hat c = \arg\max_c \sum_k \log N\big(x_k;\ m_{ck},\ \sigma_k(m_c)^2 (1 + 1/n_c)\big)

(:math:`m_c` the mean of the :math:`n_c` familiarisation percepts of sample :math:`c`), using
the templates of the trial's kind if it has them, else the real samples'; with probability
``lapse_rate`` it guesses uniformly. A Thurstonian (Case V-like, unequal variance) observer.
Nothing about the paper's Figure 9 is built in: the pattern of correct answers follows from the
physics and the noise parameters, all in :class:`PerceptionParameters`.  This decision rule is the
``absolute`` member of a named family of observer models (:mod:`experiments.participant_model.observers`:
``absolute``, ``relative``, ``range_frequency``, ``display_learned``), which the simulated
responder selects with its ``observer`` option.

The sample is a 3 mm steel slab with an insulated back (the paper's samples are 3 mm thick,
§3.1), not a half-space; :class:`PerceptionParameters` has ``sample_thickness_m=None`` for a
half-space.

Notes
-----
The paper's display target (``stimuli.target_profile(side="material")``) is the *material* side
of the interface (Eq. 7's quantity). A simulated trial is felt as the pad's temperature through
the person's own finger–pad contact resistance (Eq. 5 for the pad's polished face, as the
emulated pad assumes), so a material-side target leaves out the temperature step across the
sample's (larger) contact resistance: it feels colder than the real sample, and the more so the
rougher the sample (the steel's surface stays nearer its own temperature when R is large). An
observer familiarised on the real samples then names 1# or 2# for almost every displayed sample.
``target_side="compensated"`` replays the pad temperature that, through the pad resistance,
reproduces the real contact (``predicted_cell_probabilities(target_side=...)`` compares them).
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

from stimuli.paper import (DERMIS_FRACTION_RANGE, GROUP_THICKNESS_UM, PAD_MATERIAL, PAD_ROUGHNESS_M,
                          SAMPLE_MATERIAL, SKIN_TEMPERATURE_RANGE_C)

__all__ = [
    "feature_names",
    "PerceptionParameters",
    "SimulatedPerson",
    "draw_person",
    "receptor_features",
    "MODEL_TOLERANCE_C",
]

_SD_FLOOR = 1e-6

#: K: the model error the simulated participant's physics may carry: a quarter of the smallest
#: difference between the stimuli it must tell apart, rounded down, so that the model's error
#: cannot confuse them (the perceptual floor, 0.3 K, would: it exceeds every difference).  The
#: stimuli are the paper's four samples, real and as each replay hypothesis plays them, felt by
#: the group profile skins (650 and 1000 µm, d = 0.6 L, 35.5 °C on 20 °C steel, the display
#: through the 0.4 µm copper pad): the real 1# and 2# differ least by 0.115 K (8 s drop, group
#: B), the replayed ones by 0.0122 K (printed Eq. 7, group A, a drop feature).
#: ``test_person.py`` recomputes both with the exact models, not the planner.
MODEL_TOLERANCE_C = 0.003


@dataclass(frozen=True)
class PerceptionParameters:
    """Every parameter of the simulated observer (SI except where the name says otherwise).

    Parameters
    ----------
    drop_times_s : tuple of float, s
        Times after contact at which the receptor temperature drop ``T0 - T_rec(t)`` is a
        feature ("a few seconds" and "the end" of the judged contact).
    rate_window_s : float, s
        The peak rate of fall of the receptor temperature, ``max(-dT_rec/dt)`` over
        ``(0, rate_window_s]``, is a feature (the initial rate of cooling).
    drop_noise_C : float, K
        Additive sensory noise (standard deviation) on each drop feature.
    rate_noise_C_per_s : float, K/s
        Additive sensory noise on the rate feature.
    weber_fraction : float
        Multiplicative noise: each feature's noise standard deviation grows by
        ``weber_fraction * |feature|`` (Weber-like).
    lapse_rate : float
        Probability of answering at random (uniform over the four classes) on a test trial.
    skin_temperature_sd_C : float, K
        Trial-to-trial variation of the skin temperature after rewarming (around the person's
        initial skin temperature).
    sample_thickness_m : float or None, m
        Steel sample thickness (insulated back); None for a half-space.
    material_temperature_C : float, °C
        Sample temperature when none is given by the trial (the paper's room: 20 °C).
    rt_median_s, rt_log_sd : float
        Response time after withdrawal: log-normal with this median (s) and log-sd.
    sample_rate_Hz : float, Hz
        Time step of the receptor trace the features are computed on.
    model_tolerance_C : float, K
        Largest error the scene planner may leave in a receptor temperature the person feels
        (:func:`stimuli.planner.planned_temperature`): :data:`MODEL_TOLERANCE_C`, a quarter of
        the smallest difference between the paper's stimuli (real and replayed) that the person
        must tell apart, not the perceptual floor (a model error as large as the noise would
        blur 1# and 2#).

    Notes
    -----
    The defaults are stated, not fitted to the paper's Figure 9: drop noise 0.3 K is of the
    order of fingertip cold-detection thresholds for fast changes (a few tenths of a kelvin),
    Weber fraction 0.1 is a typical discrimination fraction for intensive continua, and a
    2 % lapse rate is the usual allowance for inattention.
    """

    drop_times_s: tuple[float, ...] = (1.0, 3.0, 8.0)
    rate_window_s: float = 3.0
    drop_noise_C: float = 0.3
    rate_noise_C_per_s: float = 0.3
    weber_fraction: float = 0.10
    lapse_rate: float = 0.02
    skin_temperature_sd_C: float = 0.1
    sample_thickness_m: float | None = 3e-3
    material_temperature_C: float = 20.0
    rt_median_s: float = 1.5
    rt_log_sd: float = 0.35
    sample_rate_Hz: float = 100.0
    model_tolerance_C: float = MODEL_TOLERANCE_C

    def __post_init__(self):
        times = tuple(float(t) for t in self.drop_times_s)
        if not times or any(not math.isfinite(t) or t <= 0 for t in times):
            raise ValueError(f"PerceptionParameters: drop_times_s: expected positive times in s, "
                             f"got {self.drop_times_s!r}")
        object.__setattr__(self, "drop_times_s", times)
        positive = ("rate_window_s", "rt_median_s", "sample_rate_Hz", "model_tolerance_C")
        nonneg = ("drop_noise_C", "rate_noise_C_per_s", "weber_fraction", "skin_temperature_sd_C",
                  "rt_log_sd")
        for name in positive + nonneg:
            value = getattr(self, name)
            ok = isinstance(value, (int, float)) and math.isfinite(value) and \
                (value > 0 if name in positive else value >= 0)
            if not ok:
                what = "a number > 0" if name in positive else "a number >= 0"
                raise ValueError(f"PerceptionParameters: {name}: expected {what}, got {value!r}")
        if not (0.0 <= self.lapse_rate <= 1.0):
            raise ValueError(f"PerceptionParameters: lapse_rate: expected a probability in "
                             f"[0, 1], got {self.lapse_rate!r}")
        if self.sample_thickness_m is not None and not self.sample_thickness_m > 0:
            raise ValueError(f"PerceptionParameters: sample_thickness_m: expected > 0 m or None, "
                             f"got {self.sample_thickness_m!r}")

    @property
    def duration_s(self) -> float:
        """Contact time the features need, s."""
        return max(max(self.drop_times_s), self.rate_window_s)

    def noise_sd(self, features: np.ndarray) -> np.ndarray:
        """Noise standard deviation of each feature (last axis), K or K/s."""
        features = np.asarray(features, dtype=float)
        absolute = np.array([self.drop_noise_C] * len(self.drop_times_s) + [self.rate_noise_C_per_s])
        # A floor keeps a noise-free observer's likelihoods finite (nearest template wins).
        return np.maximum(absolute + self.weber_fraction * np.abs(features), _SD_FLOOR)

    def to_dict(self) -> dict:
        """JSON-ready parameters."""
        d = asdict(self)
        d["drop_times_s"] = list(self.drop_times_s)
        return d


def feature_names(params: PerceptionParameters) -> tuple[str, ...]:
    """Names of the features for ``params`` (drop at each time, then the peak rate)."""
    return tuple(f"drop_{t:g}s_C" for t in params.drop_times_s) + ("peak_rate_C_per_s",)


def receptor_features(t, receptor_C, initial_C, params: PerceptionParameters) -> np.ndarray:
    """Features of one receptor-temperature trace.

    Parameters
    ----------
    t : array_like, s
        Increasing times after contact (the trace at ``t = 0`` is taken as ``initial_C`` if
        ``t`` does not start at 0).
    receptor_C : array_like, °C
        Receptor temperature at ``t``.
    initial_C : float, °C
        Skin temperature before contact.
    params : PerceptionParameters

    Returns
    -------
    ndarray
        ``[drop at each of params.drop_times_s (K), peak rate of fall over the rate window
        (K/s)]``; a trace shorter than a drop time holds its last value.
    """
    t = np.asarray(t, dtype=float)
    y = np.asarray(receptor_C, dtype=float)
    if t.ndim != 1 or t.shape != y.shape or t.size < 2:
        raise ValueError(f"receptor_features: expected matching 1-D t and receptor_C with >= 2 "
                         f"points, got shapes {t.shape} and {y.shape}")
    if t[0] > 0:
        t = np.concatenate(([0.0], t))
        y = np.concatenate(([initial_C], y))
    rise = float(np.max(y)) - float(initial_C)
    if rise > 0.2:   # the features are drops and a rate of fall: a cooling observer
        raise ValueError(f"receptor_features: receptor_C: expected a cooling trace (a material "
                         f"colder than the skin), got a rise of {rise:.3g} K above {initial_C!r} °C; "
                         f"this observer's features assume cooling and do not describe warm materials")
    drops = initial_C - np.interp(params.drop_times_s, t, y)
    window = (t > 0) & (t <= params.rate_window_s)
    rate = -np.diff(y) / np.diff(t)
    in_window = window[1:]
    peak = float(np.max(rate[in_window])) if np.any(in_window) else 0.0
    return np.concatenate((drops, [peak]))


@dataclass
class SimulatedPerson:
    """One simulated participant.

    Parameters
    ----------
    skin_thickness_m : float, m
        Total fingertip skin thickness ``L``.
    dermis_fraction : float
        ``d / L``; the receptors lie at depth ``d`` (under an epidermis ``L - d``).
    skin_temperature_C : float, °C
        Skin temperature when touching (after rewarming).
    params : PerceptionParameters
    templates : dict
        Learned class templates: mode -> {roughness_id -> (sum of percepts, count)}. Filled
        by :meth:`learn`.
    """

    skin_thickness_m: float
    dermis_fraction: float = 0.6
    skin_temperature_C: float = 35.75
    params: PerceptionParameters = field(default_factory=PerceptionParameters)
    templates: dict = field(default_factory=dict)

    def __post_init__(self):
        if not (isinstance(self.skin_thickness_m, (int, float)) and 0 < self.skin_thickness_m < 5e-3):
            raise ValueError(f"SimulatedPerson: skin_thickness_m: expected a thickness in "
                             f"(0, 5e-3) m, got {self.skin_thickness_m!r}")
        if not 0 < self.dermis_fraction < 1:
            raise ValueError(f"SimulatedPerson: dermis_fraction: expected a share in (0, 1), "
                             f"got {self.dermis_fraction!r}")
        self._real_cache: dict = {}
        self.last_display_plan = None   # the planner's decisions of the last feel_imposed
        self.real_plans: dict = {}      # the planner's decisions of each real contact felt
        #: the planner's decision for the last receptor temperature felt (real or imposed), as
        #: :func:`stimuli.planner.plan_summary` plus ``felt_as``; the simulated responder logs it
        self.last_plan: dict | None = None

    # -- physics ---------------------------------------------------------------------------
    @property
    def skin(self):
        """The person's :class:`stimuli.Skin`."""
        from stimuli import Skin
        return Skin(self.skin_thickness_m, dermis=self.dermis_fraction * self.skin_thickness_m)

    def time_grid(self, duration_s: float | None = None) -> np.ndarray:
        """Uniform times 0, dt, ..., duration (s) at ``params.sample_rate_Hz``."""
        duration = self.params.duration_s if duration_s is None else float(duration_s)
        n = int(round(duration * self.params.sample_rate_Hz))
        return np.arange(n + 1) / self.params.sample_rate_Hz

    def feel_real(self, roughness_m: float, *, material: str = SAMPLE_MATERIAL,
                  sample_thickness_m: float | None | str = "default",
                  material_temperature_C: float | None = None,
                  skin_temperature_C: float | None = None, force_N: float = 2.0):
        """Receptor temperature on touching a real sample.

        Parameters
        ----------
        roughness_m : float, m
            The sample's Ra.
        material : str
            A :func:`stimuli.material` name.
        sample_thickness_m : float or None, m
            Default ``params.sample_thickness_m``; None is a half-space.
        material_temperature_C, skin_temperature_C : float, °C
            Default ``params.material_temperature_C`` and the person's skin temperature.
        force_N : float, N
            Contact force: R is Eq. 5 at this force (the paper's 2 N by default; pass the force
            the display measured in the trial).

        Returns
        -------
        t : ndarray, s
        receptor_C : ndarray, °C
        """
        from stimuli import contact_resistance
        from stimuli import material as make_material
        thickness = self.params.sample_thickness_m if sample_thickness_m == "default" \
            else sample_thickness_m
        t_m = self.params.material_temperature_C if material_temperature_C is None \
            else float(material_temperature_C)
        t_s = self.skin_temperature_C if skin_temperature_C is None else float(skin_temperature_C)
        key = (float(roughness_m), material, thickness, float(force_N))
        t = self.time_grid()
        if key not in self._real_cache:
            # The solution is linear in (T_S0 - T_M0): compute theta once per sample, scale after.
            skin = self.skin
            steel = make_material(material, thickness=thickness)
            resistance = contact_resistance(roughness=float(roughness_m), skin=skin, material=steel,
                                            force=float(force_N))
            # through the scene planner (stimuli.planner), at the target profiles' temperatures
            from stimuli.planner import planned_temperature
            T, plan = planned_temperature("receptor", skin, steel, resistance, 35.5, 20.0, t[1:],
                                          tolerance=self.params.model_tolerance_C)
            self.real_plans[key] = plan      # the planner's decisions, kept for the record
            theta = (np.asarray(T, dtype=float) - 20.0) / 15.5
            self._real_cache[key] = np.concatenate(([1.0], theta))
        from stimuli.planner import plan_summary
        self.last_plan = {"felt_as": "real", **plan_summary(self.real_plans[key])}
        theta = self._real_cache[key]
        return t, t_m + theta * (t_s - t_m)

    def pad_resistance(self, pad_roughness_m: float = PAD_ROUGHNESS_M,
                       pad_material: str = PAD_MATERIAL) -> float:
        """This person's finger–pad contact resistance, m² K/W.

        Eq. 5 (:func:`stimuli.contact_resistance`) for the pad's face (R_a ``pad_roughness_m``,
        m, of ``pad_material``) against this person's skin, at the paper's 2 N on 135 mm²: the
        same formula the emulated pad uses
        (:func:`experiments.emulators.thermocue.pad_physics.finger_pad_resistance`, 0.4 µm copper).
        """
        from stimuli import contact_resistance, material
        return float(contact_resistance(float(pad_roughness_m), skin=self.skin,
                                        material=material(pad_material)))

    def feel_imposed(self, t, surface_C, skin_temperature_C: float | None = None, *,
                     pad_resistance: float | None = None, layered: bool = False,
                     perfusion_per_s: float = 0.0):
        """Receptor temperature when a display's pad at ``surface_C`` is touched.

        Parameters
        ----------
        t : array_like, s
            Times after contact of the surface samples (need not be uniform; resampled).
        surface_C : array_like, °C
            The pad temperature the display produced (its contact sensor).
        skin_temperature_C : float, °C
            Skin temperature before contact (default: the person's).
        pad_resistance : float or None, m² K/W, keyword-only
            Finger–pad contact resistance (e.g. :meth:`pad_resistance`): the pad is touched
            through it (a Robin boundary, ``skin_response(..., resistance=...)``). ``None``:
            the pad temperature is imposed on the skin surface itself (an ideal contact).
        layered, perfusion_per_s : bool, float, keyword-only
            The skin's physics as known (:class:`stimuli.scene.Scene`'s options): the receptor
            is computed by the scene planner's model for it
            (:func:`stimuli.display_planner.planned_skin_response`, within
            ``params.model_tolerance_C``, the same tolerance as a real contact's); its decisions
            are kept in :attr:`last_display_plan` and :attr:`last_plan`.

        Returns
        -------
        t : ndarray, s
            Uniform times from 0 up to ``min(params.duration_s, t[-1])``.
        receptor_C : ndarray, °C
        """
        from stimuli.display_planner import planned_skin_response
        t_in = np.asarray(t, dtype=float)
        g_in = np.asarray(surface_C, dtype=float)
        ok = np.isfinite(t_in) & np.isfinite(g_in)
        t_in, g_in = t_in[ok], g_in[ok]
        if t_in.size < 2:
            raise ValueError(f"feel_imposed: expected a surface trace of >= 2 finite samples, "
                             f"got {t_in.size}")
        t_in = t_in - t_in[0]
        t_s = self.skin_temperature_C if skin_temperature_C is None else float(skin_temperature_C)
        grid = self.time_grid(min(self.params.duration_s, float(t_in[-1])))
        surface = np.interp(grid, t_in, g_in)
        skin = self.skin
        # through the scene planner (one chokepoint for every production temperature)
        receptor, self.last_display_plan = planned_skin_response(
            skin, grid, surface, t_s, depth=skin.dermis,
            resistance=None if pad_resistance is None else float(pad_resistance),
            tolerance=self.params.model_tolerance_C, layered=layered,
            perfusion_per_s=perfusion_per_s)
        from stimuli.planner import plan_summary
        self.last_plan = {"felt_as": "simulated", **plan_summary(self.last_display_plan)}
        return grid, np.asarray(receptor, dtype=float)

    def features(self, t, receptor_C, skin_temperature_C: float | None = None) -> np.ndarray:
        """Noise-free features of a receptor trace (see :func:`receptor_features`)."""
        t_s = self.skin_temperature_C if skin_temperature_C is None else float(skin_temperature_C)
        return receptor_features(t, receptor_C, t_s, self.params)

    # -- perception and decision -------------------------------------------------------------
    def perceive(self, features, rng: np.random.Generator) -> np.ndarray:
        """Noisy percept: ``features + N(0, noise_sd(features)^2)``, independent per feature."""
        features = np.asarray(features, dtype=float)
        return features + rng.standard_normal(features.shape) * self.params.noise_sd(features)

    def learn(self, roughness_id: int, percept, mode: str = "real") -> None:
        """Add a familiarisation percept to the template of ``roughness_id`` for ``mode``.

        ``mode`` is the kind of stimulus ("real" sample or "simulated" on the display): the
        observer keeps one template set per kind it was familiarised with.
        """
        bank = self.templates.setdefault(str(mode), {})
        total, count = bank.get(int(roughness_id), (0.0, 0))
        bank[int(roughness_id)] = (total + np.asarray(percept, dtype=float), count + 1)

    def template_set(self, mode: str | None = None) -> dict:
        """The templates used to judge a ``mode`` trial: that mode's if learned, else the real
        samples' (the paper's familiarisation), else any; ``{}`` if none."""
        for key in (mode, "real", *sorted(self.templates)):
            if key is not None and self.templates.get(key):
                return self.templates[key]
        return {}

    def template_means(self, mode: str | None = None) -> dict[int, np.ndarray]:
        """roughness_id -> mean learned percept (of :meth:`template_set`)."""
        return {k: total / count for k, (total, count) in sorted(self.template_set(mode).items())}

    def log_likelihoods(self, percept, mode: str | None = None) -> dict[int, float]:
        """Gaussian log-likelihood of ``percept`` under each learned template.

        The observer knows its own noise: class ``c`` predicts ``N(m_c, s_c^2 (1 + 1/n_c))``
        per feature, with ``m_c`` the template mean of ``n_c`` percepts and
        ``s_c = params.noise_sd(m_c)`` (the ``1/n_c`` term is the template's own uncertainty).
        """
        percept = np.asarray(percept, dtype=float)
        out = {}
        for rid, (total, count) in sorted(self.template_set(mode).items()):
            mean = total / count
            var = self.params.noise_sd(mean) ** 2 * (1.0 + 1.0 / count)
            out[rid] = float(-0.5 * np.sum((percept - mean) ** 2 / var + np.log(2 * np.pi * var)))
        return out

    def decide(self, percept, rng: np.random.Generator, choices=(1, 2, 3, 4),
               mode: str | None = None) -> int:
        """The answer to a test trial: maximum likelihood class, or a lapse (uniform guess).

        With no templates at all, every answer is a guess.
        """
        if rng.random() < self.params.lapse_rate or not self.template_set(mode):
            return int(rng.choice(choices))
        ll = self.log_likelihoods(percept, mode)
        return int(max(ll, key=ll.get))

    def response_time(self, rng: np.random.Generator) -> float:
        """A response time, s (log-normal)."""
        return float(self.params.rt_median_s * math.exp(self.params.rt_log_sd * rng.standard_normal()))

    def trial_skin_temperature(self, rng: np.random.Generator) -> float:
        """The skin temperature on one trial after rewarming, °C."""
        return float(self.skin_temperature_C + self.params.skin_temperature_sd_C * rng.standard_normal())

    def describe(self) -> dict:
        """JSON-ready description (SI plus the unit-suffixed user fields)."""
        return {"skin_thickness_um": self.skin_thickness_m * 1e6,
                "dermis_um": self.dermis_fraction * self.skin_thickness_m * 1e6,
                "dermis_fraction": self.dermis_fraction,
                "skin_temperature_C": self.skin_temperature_C,
                "parameters": self.params.to_dict()}


def draw_person(group: str | None = None, rng: np.random.Generator | int | None = None, *,
                thickness_um: tuple[float, float] | None = None,
                dermis_fraction: tuple[float, float] = DERMIS_FRACTION_RANGE,
                skin_temperature_C: tuple[float, float] = SKIN_TEMPERATURE_RANGE_C,
                params: PerceptionParameters | None = None) -> SimulatedPerson:
    """Draw a person uniformly within the ranges (the group's thickness range by default).

    Parameters
    ----------
    group : {"A", "B"}, optional
        Use :data:`stimuli.paper.GROUP_THICKNESS_UM` for the thickness range.
    rng : Generator or int
    thickness_um : (low, high), µm
        Overrides the group's range.
    dermis_fraction : (low, high)
    skin_temperature_C : (low, high), °C
        The paper's 35.5–36 °C.
    params : PerceptionParameters
    """
    rng = np.random.default_rng(rng)
    if thickness_um is None:
        if group not in GROUP_THICKNESS_UM:
            raise ValueError(f"draw_person: group: expected one of {sorted(GROUP_THICKNESS_UM)}, "
                             f"got {group!r}")
        thickness_um = GROUP_THICKNESS_UM[group]
    return SimulatedPerson(skin_thickness_m=float(rng.uniform(*thickness_um)) * 1e-6,
                           dermis_fraction=float(rng.uniform(*dermis_fraction)),
                           skin_temperature_C=float(rng.uniform(*skin_temperature_C)),
                           params=params or PerceptionParameters())
