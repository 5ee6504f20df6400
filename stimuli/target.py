r"""Target interface profiles for simulated trials: what the display must reproduce.

A simulated trial replays, on the thermal display, the interface temperature the fingertip would
have felt on a real sample (by default the paper's Eq. 7 quantity, ``Contact.interface_temperature(
side="material")``), for that sample's roughness (via Eq. 5), the participant's skin thickness and
the initial temperatures. :func:`target_profile` samples it at the display's rate, quantises it to
the display's resolution, records the method, an error bound and a content hash, and caches it on
disk by that hash (:mod:`stimuli._cache`).

``side=`` chooses what is replayed: the paper's material-side T_M(L+), the skin-side T_S(L-), or
the "compensated" pad temperature that makes a finger touching the pad through its own contact
resistance R_pad feel exactly the real contact (see :func:`target_profile`, Notes).
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field

import numpy as np

from . import _cache
from .errors import ModelInputError
from .paper import TARGET_SIDES
from .properties import Material, Skin

__all__ = ["TargetProfile", "target_profile", "MODEL_REVISION", "SIDES"]

#: What :func:`target_profile` can return (``side=``).
SIDES = TARGET_SIDES

#: Bumped when a change in the model would change a cached profile (part of the hash).
MODEL_REVISION = 3   # 2: profiles planned by the scene planner, the plan stored with them;
#                      3: a profile computed by another method records that method as its plan
_KIND = "target"


def _package_version() -> str:
    try:
        from importlib.metadata import version   # lazy on purpose: ~18 ms, only when a target is cached
        return version("thermocue")
    except Exception:  # pragma: no cover - running from a source tree without metadata
        return "0+unknown"


@dataclass(frozen=True, eq=False)
class TargetProfile:
    """A simulated trial's target interface profile, ready to hand to a display.

    Attributes
    ----------
    times : ndarray, s
        Uniform from 0, ``1 / rate`` apart, ``duration * rate + 1`` points.
    temperature : ndarray, °C
        Target temperature of the ``side`` asked for (default: the material side, Eq. 7),
        quantised to ``resolution``.
    method : str
        Model method used (``Contact`` method name; for ``side="compensated"`` with
        ``tolerance``, "<material side>+<skin side>" when the two sides used different ones).
    error_bound : float, K
        Bound on |temperature - exact interface temperature| at the sample times:
        the model's error (measured against the exact method unless it *is* the exact method)
        plus half the quantisation step.
    content_hash : str
        sha256 hex of the inputs, the method, the package version and :data:`MODEL_REVISION`.
    parameters : dict
        Every input in SI (JSON-ready), including the contact resistance used.
    cached : bool
        True if this profile was read from the cache (not part of equality, which compares the
        hash, the method and the arrays).
    """

    times: np.ndarray
    temperature: np.ndarray
    method: str
    error_bound: float
    content_hash: str
    parameters: dict
    cached: bool = field(default=False, compare=False)

    def __eq__(self, other):
        if not isinstance(other, TargetProfile):
            return NotImplemented
        return (self.content_hash == other.content_hash and self.method == other.method
                and np.array_equal(self.times, other.times)
                and np.array_equal(self.temperature, other.temperature))

    def __hash__(self):
        return hash(self.content_hash)

    def to_dict(self) -> dict:
        """JSON-ready form: parameters, method, error bound (K), hash, time_s and target_C lists."""
        return {"content_hash": self.content_hash, "method": self.method,
                "error_bound_K": self.error_bound, "parameters": self.parameters,
                "time_s": self.times.tolist(), "target_C": self.temperature.tolist()}


def _positive(name, value):
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = float("nan")
    if not (math.isfinite(v) and v > 0):
        raise ModelInputError(f"target_profile: {name}: expected a finite number > 0, got {value!r}")
    return v


def _finite(name, value):
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = float("nan")
    if not math.isfinite(v):
        raise ModelInputError(f"target_profile: {name}: expected a finite number, got {value!r}")
    return v


def _resolve_material(mat, sample_thickness) -> Material:
    from .materials import material as lookup
    if isinstance(mat, Material):
        m = mat
    elif isinstance(mat, str):
        m = lookup(mat)
    else:
        raise ModelInputError(f"target_profile: material: expected a name or a stimuli.Material, got {mat!r}")
    if sample_thickness is not None:
        m = m.with_thickness(_positive("sample_thickness", sample_thickness))
    return m


def _parameters(mat, skin, roughness, resistance, Ts, Tm, duration, rate, resolution, method,
                tolerance, side, pad_resistance):
    return {
        "material": {"name": mat.name, "conductivity_W_per_mK": mat.conductivity,
                     "density_kg_per_m3": mat.density, "specific_heat_J_per_kgK": mat.specific_heat,
                     "thickness_m": mat.thickness},
        "roughness_m": roughness,
        "resistance_m2K_per_W": resistance,
        "skin": {"thickness_m": skin.thickness, "dermis_m": skin.dermis,
                 "conductivity_W_per_mK": skin.conductivity, "density_kg_per_m3": skin.density,
                 "specific_heat_J_per_kgK": skin.specific_heat},
        "skin_temperature_C": Ts, "material_temperature_C": Tm,
        "duration_s": duration, "rate_Hz": rate, "resolution_K": resolution,
        "method": method, "tolerance_K": tolerance,
        "side": side, "pad_resistance_m2K_per_W": pad_resistance,
    }


def _interface(contact, times, side, method, tol):
    """One interface side by ``method`` (or ``tolerance``): (T °C, method used, model error K)."""
    T, info = contact.interface_temperature(times, side=side, method=method, tolerance=tol,
                                            full_output=True)
    T = np.asarray(T, dtype=float)
    used = info.method
    if used == "exact" and math.isfinite(info.error_bound):
        return T, used, float(info.error_bound)
    exact, exact_info = contact.interface_temperature(times, side=side, method="exact",
                                                      full_output=True)
    return T, used, float(np.max(np.abs(T - exact))) + float(exact_info.error_bound)


def _side_temperature(contact, times, side, pad_resistance, method, tol):
    """The profile of ``side`` (see :func:`target_profile`): (T °C, method used, model error K)."""
    if side in ("material", "skin"):
        return _interface(contact, times, side, method, tol)
    R = contact.resistance
    # T_pad = T_S(L-) - R_pad q, q = (T_S(L-) - T_M(L+)) / R  =>  T_M + (1 - R_pad / R)(T_S - T_M);
    # for R = 0 (hence R_pad = 0) both sides are equal and T_pad = T_M(L+).
    w = 0.0 if R == 0.0 else 1.0 - pad_resistance / R
    Tm, m_used, m_err = _interface(contact, times, "material", method, tol)
    if w == 0.0:
        return Tm, m_used, m_err
    Ts, s_used, s_err = _interface(contact, times, "skin", method, tol)
    used = m_used if m_used == s_used else f"{m_used}+{s_used}"
    # |T - T_exact| <= (1 - w) err_M + w err_S
    return Tm + w * (Ts - Tm), used, (1.0 - w) * m_err + w * s_err


def target_profile(material="stainless_steel", roughness=1.6e-6, skin=None, skin_temperature=35.5,
                   material_temperature=20.0, duration=20.0, rate=100.0, resolution=0.01,
                   sample_thickness=None, method="exact", *, tolerance=None, resistance=None,
                   cache=True, cache_dir=None, side="material", pad_resistance=None,
                   force=None, physics=None):
    """The target interface temperature profile of a simulated trial.

    Parameters
    ----------
    material : str or Material
        The simulated sample's material (a :data:`stimuli.MATERIALS` name or a Material).
    roughness : float, m
        Its surface roughness R_a; gives the contact resistance by Eq. 5
        (:func:`stimuli.contact_resistance` with the paper's defaults) unless ``resistance``.
    skin : Skin or None
        The participant's skin (``None``: ``Skin(650e-6)``, group A's mean).
    skin_temperature, material_temperature : float, °C
        Initial T_S0 and T_M0.
    duration : float, s
    rate : float, Hz
        The display's sample rate; ``duration * rate`` must be a whole number.
    resolution : float, K
        The display's setpoint resolution; the profile is rounded to multiples of it.
    sample_thickness : float or None, m
        ``None``: half-space; e.g. 3e-3 for the paper's samples (slab, insulated back).
    method : str
        A :class:`stimuli.Contact` method ("exact", "paper", "paper-as-printed", "numerical").
    tolerance : float or None, K, keyword-only
        Let :class:`Contact` pick the cheapest method within it (``method`` is then ignored).
    resistance : float or None, m^2 K/W, keyword-only
        Use this contact resistance instead of Eq. 5.
    cache : bool, keyword-only
        Read and write the on-disk cache.
    cache_dir : path or None, keyword-only
        Cache folder (default ``$THERMOCUE_CACHE`` or ``~/.cache/thermocue``).
    side : {"material", "skin", "compensated"}, keyword-only
        Which temperature the profile is (see Notes): ``"material"`` (default, the paper's
        Eq. 7) T_M(L+, t); ``"skin"`` T_S(L-, t); ``"compensated"`` the pad temperature that,
        through ``pad_resistance``, gives the skin exactly the real contact's temperatures.
    pad_resistance : float or None, m^2 K/W, keyword-only
        The finger-pad contact resistance R_pad of the display (``None``: 0); used by
        ``side="compensated"`` (must be <= R), recorded for every side.
    force : float or None, N, keyword-only
        Contact force for Eq. 5 (``None``: the paper's 2 N); recorded as ``force_N``.
    physics : dict or None, keyword-only
        More :class:`stimuli.scene.Scene` options for the effects this function has no argument
        for (``geometry``, ``support``, ``effective_thickness_m``, ``layered``,
        ``hypodermis_m``, ``perfusion_per_s``); recorded.

    Returns
    -------
    TargetProfile
        ``parameters["plan"]`` holds the scene planner's decisions (:func:`stimuli.planner.plan`):
        with ``method="exact"`` (the default) the profile's scene -- the side asked for, the
        sample's geometry, ``physics`` -- is planned to ``tolerance`` or, without one, to half
        the display's ``resolution`` (a coarser model would waste the display's precision), and
        the planned model computes the profile; any other ``method`` (or a ``tolerance``) is used
        as asked and the record names it (``model``, ``method``: what was played, ``bound_K``: its
        distance from the exact model), with the planner's answer under ``planner`` for
        information.

    Raises
    ------
    ModelInputError
        A non-positive duration, rate or resolution, ``duration * rate`` not whole, an unknown
        material, method or side, a negative ``pad_resistance`` or, for ``"compensated"``, one
        larger than the sample's contact resistance R.

    Notes
    -----
    On a real sample the skin surface T_S(L-) and the sample surface T_M(L+) differ by R q, the
    contact resistance R (Eq. 5) times the heat flux q = (T_S(L-) - T_M(L+)) / R out of the skin.
    A finger on the display's pad is in contact too, through its own resistance R_pad
    (:func:`stimuli.contact_resistance` of the pad's roughness and material, e.g.
    ``contact_resistance(0.4e-6, skin, material("copper"))``), so the skin obeys
    -lambda_S dT/dx = (T_S(L-) - T_pad) / R_pad (:func:`stimuli.skin_response` ``resistance=``).

    * ``"material"`` (the paper's method, the default): T_pad = T_M(L+). In reality the skin is
      coupled to T_M(L+) through R; on the display it is coupled to the same history through
      R_pad. For a rough sample (R > R_pad) the display's path is less resistive, more heat
      leaves the skin, and the sample feels colder than in reality (about 0.3 K at the receptors
      for R_a 12.5 um and 3.5 K for 100 um, steel against a 0.4 um copper pad, 5 s, tests):
      the order of rough samples can reverse.
    * ``"skin"``: T_pad = T_S(L-), exact only for an ideal pad (R_pad = 0).
    * ``"compensated"``: T_pad = T_S(L-) - R_pad q = T_M(L+) + (1 - R_pad / R)(T_S(L-) - T_M(L+)).
      The real skin's temperature field then satisfies the display's Robin condition with the
      same flux q, so by uniqueness the finger on the pad feels the real contact's temperatures
      and flux exactly (the only errors: the model's and the display's quantisation and
      sampling). Needs R_pad <= R (a pad cannot remove resistance). R_pad = 0 gives "skin",
      R_pad = R gives "material".

    Examples
    --------
    >>> import tempfile
    >>> from stimuli.properties import Skin
    >>> d = tempfile.mkdtemp()
    >>> p = target_profile(roughness=12.5e-6, skin=Skin(650e-6), skin_temperature=35.5,
    ...                    material_temperature=20.0, duration=2.0, rate=10.0, cache_dir=d)
    >>> p.times.size, float(p.times[1]), p.cached
    (21, 0.1, False)
    >>> target_profile(roughness=12.5e-6, skin=Skin(650e-6), skin_temperature=35.5,
    ...                material_temperature=20.0, duration=2.0, rate=10.0, cache_dir=d).cached
    True
    """
    a = _checked(material, roughness, skin, skin_temperature, material_temperature, duration, rate,
                 resolution, sample_thickness, tolerance, resistance, side, pad_resistance, force)
    params = _parameters(a.mat, a.skin, a.rough, a.R, a.Ts, a.Tm, a.duration, a.rate, a.res,
                         None if a.tol is not None else str(method), a.tol, side, a.R_pad)
    physics = _checked_physics(physics, method, a.tol, tolerance, a.mat)
    params["force_N"] = a.F
    if physics:
        params["physics"] = dict(physics)
    key = _cache.content_hash({"parameters": params, "version": _package_version(),
                               "revision": MODEL_REVISION, "kind": _KIND})
    times = np.arange(a.n + 1) / a.rate
    times.setflags(write=False)
    hit = _cached_profile(key, a, times, params, cache_dir) if cache else None
    if hit is not None:
        return hit
    T, used, model_err, planned_dict = _computed(a, times, side, method, physics)
    # in the form a cache hit gives back (keys sorted, as stored): a profile's parameters, and the
    # session log that records them, must not depend on whether the cache held the profile
    params["plan"] = json.loads(json.dumps(planned_dict, sort_keys=True))
    if not np.all(np.isfinite(T)):
        raise ModelInputError(f"target_profile: method: {used!r} gave non-finite temperatures")  # pragma: no cover
    counts = np.round(T / a.res)
    temp = counts * a.res
    temp.setflags(write=False)
    bound = model_err + 0.5 * a.res
    if cache:
        _cache.store(_KIND, key, {"content_hash": key, "method": used, "error_bound_K": bound,
                                  "parameters": params, "plan": params["plan"],
                                  "counts": [int(c) for c in counts]},
                     cache_dir)
    return TargetProfile(times, temp, used, bound, key, params, cached=False)


@dataclass(frozen=True)
class _Asked:
    """:func:`target_profile`'s physical arguments, checked, in SI units."""

    skin: Skin
    mat: Material
    rough: float             # roughness, m
    Ts: float                # skin temperature, °C
    Tm: float                # material temperature, °C
    duration: float          # s
    rate: float              # Hz
    res: float               # resolution, K
    n: int                   # samples after the first
    tol: float | None        # tolerance, K
    F: float                 # force, N
    R: float                 # the sample's contact resistance, m^2 K/W
    R_pad: float             # the pad's contact resistance, m^2 K/W


def _checked(material, roughness, skin, skin_temperature, material_temperature, duration, rate,
             resolution, sample_thickness, tolerance, resistance, side, pad_resistance,
             force) -> _Asked:
    """The arguments checked (ModelInputError names the first bad one) and Eq. 5 applied."""
    from .roughness import contact_resistance
    skin = Skin(650e-6) if skin is None else skin
    if not isinstance(skin, Skin):
        raise ModelInputError(f"target_profile: skin: expected a stimuli.Skin, got {skin!r}")
    mat = _resolve_material(material, sample_thickness)
    rough = _finite("roughness", roughness)
    if rough < 0:
        raise ModelInputError(f"target_profile: roughness: expected a value >= 0 in m, got {roughness!r}")
    Ts, Tm = _finite("skin_temperature", skin_temperature), _finite("material_temperature", material_temperature)
    duration, rate, res = _positive("duration", duration), _positive("rate", rate), _positive("resolution", resolution)
    n = duration * rate
    if abs(n - round(n)) > 1e-9 * max(1.0, n):
        raise ModelInputError(f"target_profile: duration: expected a whole number of samples at "
                              f"{rate!r} Hz, got duration {duration!r} s")
    tol = None if tolerance is None else _positive("tolerance", tolerance)
    F = 2.0 if force is None else _positive("force", force)
    R = (float(contact_resistance(rough, skin=skin, material=mat, force=F)) if resistance is None
         else _finite("resistance", resistance))
    if side not in SIDES:
        raise ModelInputError(f"target_profile: side: expected one of {', '.join(SIDES)}, got {side!r}")
    R_pad = 0.0 if pad_resistance is None else _finite("pad_resistance", pad_resistance)
    if R_pad < 0:
        raise ModelInputError(f"target_profile: pad_resistance: expected a value >= 0 in m^2 K/W, "
                              f"got {pad_resistance!r}")
    if side == "compensated" and R_pad > R:
        raise ModelInputError(
            f"target_profile: pad_resistance: expected <= the sample's contact resistance "
            f"R = {R!r} m^2 K/W for side='compensated' (a pad cannot remove resistance: the "
            f"compensated pad temperature T_M(L+) + (R - R_pad) q needs R_pad <= R), got {pad_resistance!r}")
    return _Asked(skin=skin, mat=mat, rough=rough, Ts=Ts, Tm=Tm, duration=duration, rate=rate,
                  res=res, n=int(round(n)), tol=tol, F=F, R=R, R_pad=R_pad)


def _checked_physics(physics, method, tol, tolerance, mat) -> dict:
    """``physics`` checked (:func:`_check_physics`), and against the method and the sample."""
    physics = _check_physics(physics)
    if physics and (method != "exact" or tol is not None):
        raise ModelInputError(f"target_profile: physics: expected method='exact' without a tolerance "
                              f"(the planner computes these effects), got method={method!r}, "
                              f"tolerance={tolerance!r}")
    if physics.get("geometry", "slab") != "half-space" and mat.thickness is None and physics.get("geometry"):
        raise ModelInputError(f"target_profile: sample_thickness: expected the slab's thickness for "
                              f"physics geometry {physics['geometry']!r}, got None")
    return physics


def _cached_profile(key, a: _Asked, times, params, cache_dir):
    """The profile of ``key`` from the disk cache (its plan into ``params``), or None."""
    hit = _cache.load(_KIND, key, cache_dir)
    if hit is None or len(hit.get("counts", ())) != a.n + 1:
        return None
    temp = np.asarray(hit["counts"], dtype=float) * a.res
    temp.setflags(write=False)
    if "plan" in hit:
        params["plan"] = hit["plan"]
    return TargetProfile(times, temp, hit["method"], float(hit["error_bound_K"]), key,
                         params, cached=True)


def _computed(a: _Asked, times, side, method, physics):
    """The profile's temperatures by the planned model (or the method asked for): (T °C, method
    used, model error K, the plan's record)."""
    from .contact import Contact
    mat = a.mat
    planned = _plan_profile(mat, a.skin, a.R, a.Ts, a.Tm, a.duration, a.rate, a.res, a.tol, side,
                            physics)
    planned_dict = planned if isinstance(planned, dict) else planned.to_dict()
    model = None if isinstance(planned, dict) or method != "exact" or a.tol is not None else planned.model
    if model is not None and _needs_scene(model):
        T, used, model_err = _scene_side_temperature(planned, times, side, a.R_pad)
    else:
        if model is not None:            # the planned model, through Contact (bit-identical)
            if model.geometry == "half-space":
                mat = mat.with_thickness(None)
            if model.method == "eq7":
                method = "paper-as-printed"
        contact = Contact(a.skin, mat, resistance=a.R, skin_temperature=a.Ts, material_temperature=a.Tm)
        T, used, model_err = _side_temperature(contact, times, side, a.R_pad, method, a.tol)
        if model is not None and model != planned.full_model:
            model_err += planned.bound_K     # what the neglected effects may cost
    if model is None and not isinstance(planned, dict):
        # the method asked for (or Contact's choice within ``tolerance``) was played, not the
        # planner's model: the record names what was played, the planner's answer beside it
        planned_dict = _as_asked(used, side, mat, model_err, a.tol, planned_dict)
    return T, used, model_err, planned_dict


def _as_asked(used, side, mat, model_err, tol, planned_dict) -> dict:
    """The plan record of a profile computed by the method asked for, not the planner's model.

    ``model`` and ``method`` name what was played (``used``), ``bound_K`` its error against the
    exact model of the same side and geometry, ``tolerance_K`` the tolerance it was chosen
    within (None: the method was asked for by name); ``planner`` the scene planner's answer for
    the same scene, for information.
    """
    geometry = "half-space" if mat.thickness is None else f"slab {mat.thickness * 1e3:g} mm"
    return {"model": f"{used}, {side} side, {geometry} (as asked, not planned)",
            "method": used, "bound_K": float(model_err), "tolerance_K": tol,
            "note": ("method chosen within the tolerance by stimuli.Contact" if tol is not None
                     else "method asked for by name; bound_K: its distance from the exact model"),
            "planner": planned_dict}


_PHYSICS = ("geometry", "support", "effective_thickness_m", "layered", "hypodermis_m",
            "perfusion_per_s", "receptor_depth_m")


def _check_physics(physics):
    if physics is None:
        return {}
    if not isinstance(physics, dict) or any(k not in _PHYSICS for k in physics):
        raise ModelInputError(f"target_profile: physics: expected a dict with keys among "
                              f"{', '.join(_PHYSICS)}, got {physics!r}")
    return dict(physics)


def _profile_scenes(mat, skin, R, Ts, Tm, duration, rate, res, tol, side, physics):
    from .scene import Scene
    quantities = {"material": ("interface_material",), "skin": ("interface_skin",),
                  "compensated": ("interface_material", "interface_skin")}[side]
    opts = dict(physics)
    geometry = opts.pop("geometry", "half-space" if mat.thickness is None else "slab")
    base = dict(duration_s=duration, rate_Hz=rate, tolerance_K=tol if tol is not None else 0.5 * res,
                material=mat.with_thickness(None), resistance=R, skin_thickness_m=skin.thickness,
                receptor_depth_m=opts.pop("receptor_depth_m", skin.epidermis),
                skin_temperature_C=Ts, material_temperature_C=Tm, geometry=geometry,
                sample_thickness_m=mat.thickness if mat.thickness is not None else 3e-3, **opts)
    return [Scene(quantity=q, **base) for q in quantities]


def _plan_profile(mat, skin, R, Ts, Tm, duration, rate, res, tol, side, physics):
    """The planner's decisions for the profile's scene(s); one model for both sides when two."""
    from .planner import plan
    if Ts == Tm:
        return {"model": "none", "note": "no temperature difference: nothing to model"}
    plans = [plan(s) for s in _profile_scenes(mat, skin, R, Ts, Tm, duration, rate, res, tol, side,
                                              physics)]
    if len(plans) == 1 or plans[0].model == plans[1].model:
        return plans[0]
    return _Both(plans)


class _Both:
    """Two sides planned to different models: the union of what they keep (the full model)."""

    def __init__(self, plans):
        self.plans = plans
        self.model = plans[0].full_model
        self.bound_K = 0.0

    def to_dict(self):
        return {"model": self.model.describe(), "bound_K": 0.0,
                "sides": [p.to_dict() for p in self.plans]}


def _needs_scene(model) -> bool:
    """Whether the planned model needs stimuli.scene (layers, perfusion, a support)."""
    return model.layered or model.perfusion or model.geometry == "slab-on-support" or model.sensor


def _scene_side_temperature(planned, times, side, pad_resistance):
    """Like :func:`_side_temperature` with the planned (layered, perfused, supported) model."""
    from .scene import evaluate
    plans = planned.plans if isinstance(planned, _Both) else [planned]
    scenes = {p.scene.quantity: p.scene for p in plans}
    if side == "compensated" and len(scenes) == 1:
        raise ModelInputError("target_profile: side: internal: compensated needs both sides")  # pragma: no cover
    err = planned.bound_K

    def one(q):
        sc = scenes[q]
        return evaluate(sc, planned.model, times), sc

    if side in ("material", "skin"):
        T, sc = one("interface_material" if side == "material" else "interface_skin")
        return T, "exact", err + 1e-12 * abs(sc.skin_temperature_C - sc.material_temperature_C)
    (Tm, sc), (Ts, _) = one("interface_material"), one("interface_skin")
    R = sc.resistance
    w = 0.0 if R == 0.0 else 1.0 - pad_resistance / R
    return Tm + w * (Ts - Tm), "exact", err + 1e-12 * abs(sc.skin_temperature_C - sc.material_temperature_C)
