r"""The scene planner: the cheapest model whose every neglected effect stays within the tolerance.

:func:`plan` starts from the scene's full model (every effect it states, :meth:`Scene.full_model`)
and drops effects one at a time, most expensive first (the pad's sensor lag, perfusion, the
slab's support, the slab itself, the skin's layers), then tries the paper's closed form (Eq. 7,
when the question is the material-side interface of homogeneous skin on a half-space). A drop is
kept when the model without it still agrees with the full model within the tolerance.

How the error is bounded (cheaply, and checked)
-----------------------------------------------
* The full model and each candidate are evaluated at ~20 probe times (the first three samples,
  geometric and uniform times to the end) with one shared, cheap :class:`stimuli.exact.InversionPlan`
  (``PROBE_NODES`` = 12 nodes per window instead of 24, each probe value within
  ``PROBE_INVERSION_ERROR`` x |Delta T| of the exact one); the candidate's error is ``SAFETY`` (1.5)
  x (its largest difference from the full model there + both probe inversions' bounds), plus both
  production inversions' bounds. Between probes the temperatures are smooth, monotone or
  single-humped; the factor covers the probes missing the worst time. The test
  ``tests/stimuli/test_planner.py`` evaluates planned and full models at every sample of a grid of
  scenes and asserts the error is within the tolerance -- a bound that is wrong fails there.
* The sensor lag is not evaluated: a first-order lag of tau changes a signal by at most
  tau sup |dT/dt|, with the sup over the profile's sampled slopes (a jump at contact counts as
  its slope over the first sample); it applies to the interface quantities (what a sensor reads)
  and is "not applicable" to the receptor.
* Perfusion is first bounded in closed form (:func:`perfusion_bound`, the maximum principle),
  then, if that is too loose, in the Laplace domain (:func:`perfusion_laplace_bound`: a majorant
  that grows in time, bounded by its transform at a real s); when either fits the tolerance it
  is neglected without evaluating anything, and the model without it becomes the reference of
  the later drops, its bound added to their errors.
* Screens (``screen=True``, production) keep an effect without evaluating it when it certainly
  matters: a warmed-through slab (:func:`warmed_through`) and, at the receptor, layered skin
  whose quasi-steady effect is ``LAYER_SCREEN`` tolerances (:func:`layers_matter`) or whose
  effect is at least ``LAYER_LOWER_SCREEN`` tolerances by a Laplace-domain lower bound
  (:func:`_effect_lower_bound`, exact transforms at a real s). Keeping
  is always safe; the tests check that every screened keep is an evaluated keep. With these,
  a cold layered, perfused scene is planned in ~0.07 of one exact evaluation
  (benchmarks/README.md). ``screen=False`` (``thermocue explain``) evaluates every effect.

The decisions (each effect: kept or neglected, the error its neglect causes, why) travel with
every profile (``TargetProfile.parameters["plan"]``, hence the session's events) and are
printed by ``thermocue explain``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .exact import INVERSION_ERROR, WINDOW_RATIO, InversionPlan
from .scene import Model, Scene, evaluate
from .planner_bounds import (PERFUSION_LAPLACE_NOTE, PERFUSION_NOTE, as_half_space, layers_matter,
                             lower_screen, scene_skin, warmed_through, perfusion_bound,
                             perfusion_laplace_bound)
from .planner_bounds import perfusion_factor  # noqa: F401 (public as stimuli.planner.perfusion_factor)

__all__ = ["plan", "planned_temperature", "plan_line", "plan_summary", "Plan", "Decision", "SAFETY", "EFFECTS",
           "perfusion_bound", "perfusion_laplace_bound"]

#: Factor on the probe error for the times between probes (checked by the planner's grid test).
SAFETY = 1.5

#: Contour nodes per window of the probes' own inversion (production: 24). About a third of the
#: transform evaluations (52 instead of 150 for a 20 s scene at 1 kHz): the probes' cost is the
#: complex arithmetic at the nodes.
PROBE_NODES = 12

#: Bound on the absolute error of the probes' inversion (``PROBE_NODES``) of a function bounded
#: by 1 (theta). Measured against the production inversion (itself within ``INVERSION_ERROR`` of
#: mpmath) on every model the planner compares, over a grid of scenes: at most 1.7e-7
#: (``tests/stimuli/test_planner.py::test_probe_inversion_error_bound``); stated with a margin.
PROBE_INVERSION_ERROR = 1e-6

#: Why perfusion is kept without evaluation when its bounds cannot settle it and the layers stay.
_PERFUSION_KEPT_NOTE = ("kept without evaluation: its upper bound exceeds the tolerance and the "
                        "layers stay, so dropping it would save nothing (same transfer matrix)")

#: Effects, in the order they are tried for dropping.
EFFECTS = ("sensor", "perfusion", "support", "slab", "layered", "closed_form")


@dataclass(frozen=True)
class Decision:
    """One effect: ``included`` or neglected, ``bound_K`` = the error neglecting it causes (or
    would cause) at this scene, ``note`` = why, in words."""

    effect: str
    included: bool
    bound_K: float
    note: str

    def to_dict(self) -> dict:
        # JSON has no NaN (caches and session events are strict): an unevaluated bound is None
        return {"effect": self.effect, "included": self.included,
                "bound_K": None if math.isnan(self.bound_K) else self.bound_K, "note": self.note}


@dataclass(frozen=True)
class Plan:
    """The planner's answer: the model, each decision, and the planned model's error bound (K)."""

    scene: Scene
    model: Model
    full_model: Model
    decisions: tuple
    bound_K: float
    probe_times: np.ndarray

    def evaluate(self, t=None):
        """The scene's quantity with the planned model, °C."""
        return evaluate(self.scene, self.model, t)

    def to_dict(self) -> dict:
        """JSON-ready: the model, every decision, the bound and the tolerance."""
        return {"model": self.model.describe(), "method": self.model.method,
                "geometry": self.model.geometry, "layered": self.model.layered,
                "perfusion": self.model.perfusion, "sensor": self.model.sensor,
                "bound_K": self.bound_K, "tolerance_K": self.scene.tolerance_K,
                "quantity": self.scene.quantity,
                "decisions": [d.to_dict() for d in self.decisions]}

    def lines(self) -> list:
        """Human-readable explanation, one line each."""
        s = self.scene
        out = [f"scene: {s.quantity} over {s.duration_s:g} s at {s.rate_Hz:g} Hz, tolerance "
               f"{s.tolerance_K:g} K",
               f"model: {self.model.describe()} (bound {self.bound_K:.3g} K against the full "
               f"model: {self.full_model.describe()})"]
        for d in self.decisions:
            state = "kept     " if d.included else "neglected"
            out.append(f"  {state} {d.effect:<11s} {d.bound_K:10.3g} K  {d.note}")
        return out


def _probe_times(scene: Scene) -> np.ndarray:
    T, dt = scene.duration_s, 1.0 / scene.rate_Hz
    first = dt * np.arange(1, 4)
    geo = np.geomspace(min(4 * dt, T), T, 10)
    uni = np.linspace(T / 8, T, 8)
    t = np.unique(np.concatenate([first, geo, uni]))
    return t[(t > 0) & (t <= T)]


@lru_cache(maxsize=32)
def probe_plan(duration_s: float, rate_Hz: float, cheap: bool = False):
    """Probe times and their inversion plan, shared by every scene of that duration and rate.

    ``cheap``: ``PROBE_NODES`` per window, error within ``PROBE_INVERSION_ERROR`` (the scene
    planner's); else the production inversion, within ``INVERSION_ERROR`` (the display planner's).
    """
    t = _probe_times(Scene(duration_s=duration_s, rate_Hz=rate_Hz))
    t.setflags(write=False)
    if cheap:
        return t, _DensePlan(InversionPlan(t, nodes=PROBE_NODES, window_ratio=WINDOW_RATIO))
    return t, InversionPlan(t)


class _DensePlan:
    """An :class:`InversionPlan` of a few times applied as one complex matrix product.

    The same sums as ``plan.apply`` (``Im sum_k c_k exp(s_k t_j) f_k`` over each time's window),
    with the windows laid side by side in one (times x nodes) matrix that is zero outside each
    time's window: one call instead of one per window (the probes' times are few).
    """

    def __init__(self, plan: InversionPlan):
        self.s = plan.s
        self.shape = plan.shape
        W = np.zeros((plan._n, plan.s.size), dtype=complex)
        k = plan._k
        for i, j, a, c, basis in plan._windows:
            if basis[0] != "full":
                raise ValueError("_DensePlan: expected a few times per window")
            W[plan._order[i:j], a:a + k] = (basis[1] + 1j * basis[2]) * c
        self._W = W

    def apply(self, fs):
        return (self._W @ np.asarray(fs)).imag.reshape(self.shape)


def _with(model: Model, **changes) -> Model:
    """``dataclasses.replace`` for a :class:`Model` (a few times cheaper: the planner's hot path)."""
    d = {"method": model.method, "geometry": model.geometry, "layered": model.layered,
         "perfusion": model.perfusion, "sensor": model.sensor}
    d.update(changes)
    return Model(**d)


def _drop(model: Model, effect: str, scene: Scene) -> Model | None:
    """The model without ``effect``, or None when it does not hold it."""
    if effect == "perfusion" and model.perfusion:
        return _with(model, perfusion=False)
    if effect == "support" and model.geometry == "slab-on-support":
        return _with(model, geometry="slab")
    if effect == "slab" and model.geometry == "slab":
        return _with(model, geometry="half-space")
    if effect == "layered" and model.layered:
        return _with(model, layered=False)
    if effect == "closed_form" and model.method == "exact" and model.geometry == "half-space" \
            and not model.layered and not model.perfusion and scene.quantity == "interface_material":
        return _with(model, method="eq7")
    return None


_NOTES = {
    "perfusion": "Pennes perfusion of the dermis",
    "support": "the half-space the slab rests on",
    "slab": "the sample's finite thickness (else a half-space)",
    "layered": "epidermis and dermis properties (else Table 1's homogeneous skin)",
    "closed_form": "exact inversion (else the paper's printed Eq. 7)",
}


def plan(scene: Scene, *, screen: bool = True) -> Plan:
    """The cheapest model of ``scene`` within its tolerance (see the module docstring).

    Parameters
    ----------
    scene : Scene
    screen : bool
        Keep, without evaluating it, a slab that is certainly warmed through over the scene
        (D < sqrt(alpha_M t_end) / 2: its back is felt within the scene, by kelvins on metals);
        keeping an effect is always safe, so this only saves the planner's time. Its decision then
        has ``bound_K = nan``. Likewise layered skin at the receptor (:func:`layers_matter`), and
        perfusion neglected by its closed form (:func:`perfusion_bound`) when that fits.
        ``False`` evaluates every effect (``thermocue explain``).

    Returns
    -------
    Plan

    Examples
    --------
    >>> from stimuli.scene import Scene
    >>> p = plan(Scene(quantity="receptor", perfusion_per_s=1.25e-3, tolerance_K=0.3))
    >>> p.model.describe()                  # the 3 mm slab matters, perfusion does not
    'exact, slab, homogeneous skin'
    >>> [(d.effect, d.included) for d in p.decisions]
    [('sensor', False), ('perfusion', False), ('slab', True)]
    """
    return plan_scene(_resolved(scene), bool(screen))


def _resolved(scene: Scene) -> Scene:
    """The scene with Eq. 5 and the material names resolved once (evaluations repeat them)."""
    # the scene was validated when it was made; these are values derived from it, so the copy is
    # not validated again (Scene.replace would: ~10 us of the planner's ~60 us on a cold scene)
    out = object.__new__(Scene)
    out.__dict__.update(scene.__dict__)
    for k, v in (("resistance", scene.contact_resistance),
                 ("material", as_half_space(scene)),
                 ("support", None if scene.support is None else scene.support_object())):
        object.__setattr__(out, k, v)
    return out


def _at_probes(scene: Scene, model: Model, probes: np.ndarray, ip: InversionPlan) -> np.ndarray:
    """:func:`stimuli.scene.evaluate` at the probe times (all > 0), without its per-call checks.

    The same transform and inversion as ``evaluate(scene, model, probes, plan=ip)`` (equal to
    the last bit; ``tests/stimuli/test_planner.py`` checks it), minus the validation of times
    the planner made itself: ~30 % of the planner's cost on a cold multi-effect scene.
    """
    if model.method != "exact":
        return evaluate(scene, model, probes)
    from .scene import scene_contact
    c = scene_contact(scene, model)
    tr = c.transform
    if scene.quantity == "interface_material":
        theta = ip.apply(tr.material_rise(ip.s, tr.L))
    else:
        x = c.thickness - scene.receptor_depth if scene.quantity == "receptor" else tr.L
        theta = 1.0 - ip.apply(tr.skin_deficit(ip.s, float(x)))
    T = c.material_initial + (c.skin_initial - c.material_initial) * theta
    if model.sensor and scene.sensor_time_constant_s > 0:      # never for the planner's candidates
        return evaluate(scene, model, probes, plan=ip)
    return T


class _Planning:
    """One run of :func:`plan_scene`: the scene's probes and reference, the model so far and the
    decisions made, one method per step (the sensor, then each effect of :data:`EFFECTS`)."""

    def __init__(self, scene: Scene):
        self.scene = scene
        self.full = scene.full_model()
        self.probes, self.ip = probe_plan(scene.duration_s, scene.rate_Hz, cheap=True)
        dT = abs(scene.skin_temperature_C - scene.material_temperature_C)
        self.inv = INVERSION_ERROR * dT             # a production evaluation's inversion error
        self.pinv = PROBE_INVERSION_ERROR * dT      # a probe value's inversion error
        self.base = _with(self.full, sensor=False)
        self.tol = scene.tolerance_K
        self.decisions = []
        self.cache = {}
        self.ref_model, self.ref_offset = self.base, 0.0
        self.sensor_bound = 0.0
        self.current, self.current_err, self.prev = self.base, 0.0, None

    def skin(self):
        """The scene's skin (as ``scene.skin``), made once."""
        if "skin" not in self.cache:
            L = self.scene.skin_thickness_m
            self.cache["skin"] = scene_skin(L, L - self.scene.receptor_depth)
        return self.cache["skin"]

    def layers_screen(self, cand):
        """Why the layers are kept without evaluation (their screens), or None; asked by the
        perfusion step and again by the layers' own step: computed once per (reference,
        candidate)."""
        key = ("layers", self.ref_model, cand, self.ref_offset)
        if key not in self.cache:
            why = layers_matter(self.scene, self.skin())
            if why is None:
                why = lower_screen(self.scene, self.ref_model, cand, self.skin(), self.tol,
                                   self.ref_offset)
            self.cache[key] = why
        return self.cache[key]

    def reference(self):
        """The model every candidate is compared with, at the probes: the full model, or the
        full model without perfusion when its closed-form bound (``ref_offset``, added to every
        error) neglected it (never after an evaluation: the sensor's bound evaluates the full
        model first)."""
        if "ref" not in self.cache:
            self.cache["ref"] = _at_probes(self.scene, self.ref_model, self.probes, self.ip)
        return self.cache["ref"]

    def sensor(self) -> None:
        """The sensor: tau sup|dT/dt|, analytic."""
        scene = self.scene
        if not scene.sensor_time_constant_s > 0:
            self.decisions.append(Decision("sensor", False, 0.0, "no sensor lag stated"))
        elif scene.quantity == "receptor":
            self.decisions.append(Decision("sensor", False, 0.0, "not applicable: the receptor is "
                                           "not read by the pad's sensor"))
        else:
            tt = np.concatenate([[0.0], self.probes])
            T0 = evaluate(scene, self.base, np.array([0.0]))
            vals = np.concatenate([T0, self.reference()])
            # each probe value is within pinv of the exact one (the value at 0 is exact)
            rate = float(np.max((np.abs(np.diff(vals)) + 2.0 * self.pinv) / np.diff(tt)))
            b = scene.sensor_time_constant_s * rate
            keep = b + self.inv > self.tol
            if not keep:
                self.sensor_bound = b
            self.decisions.append(Decision("sensor", keep, b, f"tau {scene.sensor_time_constant_s:g} s"
                                           f" x max |dT/dt| {rate:.3g} K/s"))

    def screened(self, effect: str, cand, screen: bool) -> bool:
        """Whether a screen keeps ``effect`` without evaluating it (its decision made)."""
        why = warmed_through(self.scene) if (screen and effect == "slab") else None
        if why is None:
            why = self.layers_screen(cand) if (screen and effect == "layered") else None
        if why is not None:
            self.decisions.append(Decision(effect, True, math.nan, why))
        return why is not None

    def perfusion_by_bound(self, cand) -> bool:
        """Whether perfusion is decided without evaluating anything: neglected by its closed
        form or Laplace-domain bound, or kept unevaluated beside kept layers."""
        scene, inv, sensor_bound = self.scene, self.inv, self.sensor_bound
        b = perfusion_bound(scene, self.skin())
        err = b + inv + inv + sensor_bound
        if err <= self.tol:          # neglected by the closed form, without evaluating anything
            self.decisions.append(Decision("perfusion", False, b,
                                           _NOTES["perfusion"] + "; " + PERFUSION_NOTE))
            self.current, self.current_err, self.ref_model, self.ref_offset = cand, err, cand, b
            return True
        # where heat leaks out of the skin within the scene: the Laplace-domain bound
        b = perfusion_laplace_bound(scene, self.current, self.skin(), self.tol - inv - inv - sensor_bound)
        err = b + inv + inv + sensor_bound
        if err <= self.tol:
            self.decisions.append(Decision("perfusion", False, b,
                                           _NOTES["perfusion"] + "; " + PERFUSION_LAPLACE_NOTE))
            self.current, self.current_err, self.ref_model, self.ref_offset = cand, err, cand, b
            return True
        # neither bound settles it. Where the layers are kept anyway (their screen says so) the
        # model stays exact and layered with or without perfusion, and perfusion sits in the
        # same transfer matrix: dropping it would save nothing (benchmarks/README.md), so
        # deciding it at the probes would be pure overhead. Kept, unevaluated, bound stated.
        layers_out = _drop(self.current, "layered", scene) if self.full.layered else None
        if layers_out is not None and self.layers_screen(layers_out) is not None:
            self.decisions.append(Decision("perfusion", True, b,
                                           _NOTES["perfusion"] + "; " + _PERFUSION_KEPT_NOTE))
            return True
        return False

    def at_probes(self, effect: str, cand) -> None:
        """Decide ``effect`` by evaluating the model without it at the probes."""
        pinv, inv = self.pinv, self.inv
        ref = self.reference()
        self.prev = ref if self.prev is None else self.prev
        val = _at_probes(self.scene, cand, self.probes, self.ip)
        # probe differences are within 2 pinv of the exact ones (pinv each side; Eq. 7 is exact)
        cand_p = pinv if cand.method == "exact" else 0.0
        step = SAFETY * (float(np.max(np.abs(val - self.prev))) + pinv + cand_p)
        cand_inv = inv if cand.method == "exact" else 0.0
        err = (SAFETY * (float(np.max(np.abs(val - ref))) + pinv + cand_p) + inv + cand_inv
               + self.sensor_bound)
        if self.ref_offset:
            err += self.ref_offset
        if err <= self.tol:
            self.decisions.append(Decision(effect, False, step, _NOTES[effect]))
            self.current, self.current_err, self.prev = cand, err, val
        else:
            self.decisions.append(Decision(effect, True, step, _NOTES[effect]))

    def run(self, screen: bool) -> Plan:
        """The plan: the sensor, then each effect dropped if its neglect fits the tolerance."""
        self.sensor()
        for effect in EFFECTS[1:]:
            cand = _drop(self.current, effect, self.scene)
            if cand is None:
                if effect == "slab" and self.current.geometry == "slab-on-support":
                    self.decisions.append(Decision("slab", True, math.nan, "kept with its support"))
                continue
            if self.screened(effect, cand, screen):
                continue
            if (screen and effect == "perfusion" and "ref" not in self.cache
                    and self.perfusion_by_bound(cand)):
                continue
            self.at_probes(effect, cand)
        full, scene = self.full, self.scene
        model = _with(self.current, sensor=full.sensor and self.sensor_bound == 0.0
                      and scene.quantity != "receptor")
        bound = max(self.current_err, self.sensor_bound + self.inv)
        return Plan(scene, model, full, tuple(self.decisions), float(bound), self.probes)


@lru_cache(maxsize=256)
def plan_scene(scene: Scene, screen: bool = True) -> Plan:
    """:func:`plan` of a resolved scene (cached: the same scene is planned once)."""
    return _Planning(scene).run(screen)


def planned_temperature(quantity: str, skin, material, resistance: float, skin_temperature: float,
                        material_temperature: float, t, *, tolerance: float | None = None,
                        **physics):
    """One production call: the scene of a contact, planned, then evaluated at times ``t``.

    The chokepoint the simulated participant and the emulator's finger use instead of building a
    :class:`stimuli.Contact` themselves, so that every production temperature is computed by the
    planned model (:func:`plan`).

    Parameters
    ----------
    quantity : {"receptor", "interface_material", "interface_skin"}
    skin : Skin
        Thickness L and receptor depth (``L - skin.dermis`` below the surface).
    material : Material
        A half-space or a slab (insulated back; ``physics`` may say ``geometry="slab-on-support"``).
    resistance : float, m^2 K/W
    skin_temperature, material_temperature : float, °C
    t : array_like, s
        Times >= 0 (any grid: the plan is made for the scene ``0..max(t)`` at the grid's rate).
    tolerance : float or None, K
        Default :data:`stimuli.scene.PERCEPTUAL_FLOOR_K`.
    **physics
        More :class:`stimuli.scene.Scene` options (``layered``, ``perfusion_per_s``, ...).

    Returns
    -------
    T : ndarray, °C
    plan : Plan or None
        None when the two temperatures are equal (the temperature then stays put).
    """
    from .scene import PERCEPTUAL_FLOOR_K
    t = np.asarray(t, dtype=float)
    if float(skin_temperature) == float(material_temperature):   # nothing flows: nothing to plan
        return np.full(t.shape, float(skin_temperature)), None
    tmax = float(np.max(t)) if t.size else 1.0
    pos = np.unique(t[t > 0])
    dt = float(np.min(np.diff(np.concatenate([[0.0], pos])))) if pos.size else tmax
    rate = 1.0 / dt
    duration = round(tmax * rate) / rate if tmax > 0 else dt
    geometry = physics.pop("geometry", "half-space" if material.thickness is None else "slab")
    scene = Scene(quantity=quantity, duration_s=max(duration, dt), rate_Hz=rate,
                  tolerance_K=PERCEPTUAL_FLOOR_K if tolerance is None else tolerance,
                  material=material.with_thickness(None), resistance=float(resistance),
                  skin_thickness_m=skin.thickness, receptor_depth_m=skin.epidermis,
                  skin_temperature_C=skin_temperature, material_temperature_C=material_temperature,
                  geometry=geometry,
                  sample_thickness_m=3e-3 if material.thickness is None else material.thickness,
                  **physics)
    p = plan(scene)
    if p.model.sensor:
        return evaluate(p.scene, p.model, scene.times)[np.round(t * rate).astype(int)], p
    return evaluate(p.scene, p.model, t), p


def plan_summary(plan) -> dict:
    """A planner's decision in a few JSON-ready fields (for a log event or an emulator reply).

    Parameters
    ----------
    plan : Plan or stimuli.display_planner.DisplayPlan or None
        None: nothing was planned (equal temperatures: nothing flows).

    Returns
    -------
    dict
        ``model`` (what was evaluated), ``method``, ``tolerance_K``, ``bound_K`` (the planned
        model's error bound against the full model) and the effects ``kept`` / ``neglected``.
    """
    if plan is None:
        return {"model": "none", "method": "none", "tolerance_K": None, "bound_K": 0.0,
                "kept": [], "neglected": [], "note": "equal temperatures: nothing flows"}
    d = plan.to_dict()
    return {"model": d["model"], "method": d["method"], "tolerance_K": d["tolerance_K"],
            "bound_K": d["bound_K"],
            "kept": [x["effect"] for x in d["decisions"] if x["included"]],
            "neglected": [x["effect"] for x in d["decisions"] if not x["included"]]}


def plan_line(plan: dict) -> str:
    """One line saying what a plan (:meth:`Plan.to_dict`, as logged) kept and neglected.

    Examples
    --------
    >>> plan_line({"model": "exact, slab, homogeneous skin", "bound_K": 0.004, "tolerance_K": 0.3,
    ...            "decisions": [{"effect": "sensor", "included": False, "bound_K": 0.0},
    ...                          {"effect": "slab", "included": True, "bound_K": None}]})
    'model exact, slab, homogeneous skin (error <= 0.004 K of 0.3 K); neglected: sensor <= 0 K; kept: slab'
    """
    if not isinstance(plan, dict):
        return "model: not recorded"
    if "sides" in plan:
        return "; ".join(f"side {i + 1}: {plan_line(p)}" for i, p in enumerate(plan["sides"]))
    if not plan.get("decisions"):
        return f"model {plan.get('model', 'not recorded')}" + (
            f" ({plan['note']})" if plan.get("note") else "")
    head = f"model {plan.get('model')}"
    if plan.get("bound_K") is not None and plan.get("tolerance_K") is not None:
        head += f" (error <= {plan['bound_K']:.2g} K of {plan['tolerance_K']:g} K)"
    dropped = [f"{d['effect']} <= {d['bound_K']:.2g} K" if d.get("bound_K") is not None
               else d["effect"] for d in plan["decisions"] if not d.get("included")]
    kept = [d["effect"] for d in plan["decisions"] if d.get("included")]
    return (head + "; neglected: " + (", ".join(dropped) or "nothing")
            + "; kept: " + (", ".join(kept) or "nothing"))
