"""Speed against error of every thermal-model method on a 20 s profile sampled at 1 kHz.

One concept (~500 lines): ``thermocue bench model``, its problems and rows (the mpmath references
they are measured against: :mod:`.model_references`).

Two problems, both the paper's simulated trial (stainless steel half-space, R_a = 12.5 µm -> Eq. 5
resistance, skin 650 µm with receptors at 0.6 L, T_S0 = 35.5 °C, T_M0 = 20 °C):

* ``interface``: the target interface temperature on the material side (Eq. 7's quantity) with
  every :class:`stimuli.Contact` method and inversion setting, and the finite-volume solver at
  several grids. Reference: mpmath's Talbot inversion of the exact Laplace-domain solution at
  40 digits, at 41 times (the first sample, geometric to 20 s, and uniform ones).
* ``receptor``: :func:`stimuli.skin_response` at the receptors while the display imposes that
  target profile (20001 samples, linear in between), with every method and grid, plus a per-mode
  exact recursion (the eigen series advanced mode by mode; bench only) for comparison.
  Reference: the Duhamel sum evaluated in mpmath at 30 digits with its own image/eigen series,
  at 31 times including the first and the last sample.
* ``pad``: the same receptor response when the finger touches the display's pad through its own
  contact resistance R_pad (``skin_response(..., resistance=R_pad)``, the Robin case), exact and
  numerical. Reference: the same mpmath Duhamel sum with the Robin slab's eigenfunction series.

Cost is the best of several runs of the whole 20001-point profile, divided by 20001 (µs per point);
the machine is named in the output. The stable closed form of Eq. 7 (``Contact`` method
``"paper-as-printed"`` on the interface) is the yardstick of the issue's targets; the ratios to it
come from 40 interleaved rounds of Eq. 7, the exact interface and ``skin_response`` (best of each),
which is robust to other load on a shared machine.
"""
from __future__ import annotations

import json
import math
import os
import platform
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["run_model_benchmark", "machine_info"]

from .model_references import (DURATION_S, RATE_HZ, interface_reference,  # noqa: E402
                               layered_reference, receptor_reference,
                               receptor_robin_reference, reference_times)
SKIN_THICKNESS_M = 650e-6
ROUGHNESS_M = 12.5e-6
T_SKIN_C = 35.5
T_MATERIAL_C = 20.0
#: The display's pad face (stimuli.paper.PAD_ROUGHNESS_M / PAD_MATERIAL): Eq. 5
#: of polished copper, R_a 0.4 µm, gives the finger-pad resistance R_pad of the ``pad`` rows.
from stimuli.paper import PAD_MATERIAL, PAD_ROUGHNESS_M  # noqa: E402


# --------------------------------------------------------------------------- machine
def _cpu_model() -> str:
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            for line in fh:
                if line.lower().startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def machine_info() -> dict:
    """Platform, CPU model, core count, load and the numerical library versions."""
    import mpmath
    import scipy
    try:
        load = os.getloadavg()[0]
    except OSError:  # pragma: no cover
        load = float("nan")
    return {"platform": platform.platform(), "machine": platform.machine(), "cpu_model": _cpu_model(),
            "cpu_count": os.cpu_count(), "load_average_1min": load,
            "python": platform.python_version(), "numpy": np.__version__, "scipy": scipy.__version__,
            "mpmath": mpmath.__version__}


def _best_seconds(fn, repeat=7, budget_s=3.0):
    """Best wall time of ``fn()`` over ``repeat`` runs (fewer if one run exceeds the budget)."""
    best = math.inf
    start = time.perf_counter()
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
        if time.perf_counter() - start > budget_s:
            break
    return best


def modal_recursion(skin, t, surface_temperature, initial_temperature, depth, tol_K=1e-7):
    """Eigen series advanced mode by mode with an exact recursion per sample step (bench only).

    u = xi h(t) + sum_n c_n(t) sin(n pi xi), c_n' = -lambda_n c_n - a_n h'(t), a_n = 2(-1)^(n+1)/(n pi),
    c_n(0+) = -a_n h_0; over a step with slope s: c <- r c - a_n s (1 - r)/lambda_n, r = e^(-lambda_n dt),
    one ``scipy.signal.lfilter`` per mode. Modes: enough that the neglected ones are < tol_K at t_1;
    the neglected modes' quasi-static part, -h'(t) sum_{n>N} a_n sin(n pi xi)/lambda_n (closed form
    from sum (-1)^(n+1) sin(n pi xi)/n^3 = pi^3 (xi - xi^3)/12), is added back.
    """
    from scipy.signal import lfilter
    t = np.asarray(t, dtype=float)
    dt = t[1] - t[0]
    h = np.asarray(surface_temperature, dtype=float) - initial_temperature
    L = skin.thickness
    xi = depth / L
    lam1 = skin.diffusivity * (math.pi / L) ** 2
    tail, n = math.inf, 0
    h0 = abs(h[0]) + 1e-300
    while tail > tol_K:
        n += 1
        tail = (2 * h0 / math.pi) * sum(math.exp(-k * k * lam1 * dt) / k for k in range(n + 1, n + 200))
    slopes = np.diff(h) / dt
    u = xi * h.copy()
    static = (L * L / skin.diffusivity) * (xi - xi ** 3) / 6.0     # sum over all n of a_n sin / lambda_n
    for k in range(1, n + 1):
        static -= (2.0 * (-1) ** (k + 1) / (k * math.pi)) * math.sin(k * math.pi * xi) / (lam1 * k * k)
    u[1:] -= slopes * static
    for k in range(1, n + 1):
        lam = lam1 * k * k
        r = math.exp(-lam * dt)
        a = 2.0 * (-1) ** (k + 1) / (k * math.pi)
        c0 = -a * h[0]
        b = -a * (-math.expm1(-lam * dt)) / lam
        c = lfilter([b], [1.0, -r], slopes, zi=[r * c0])[0]
        sn = math.sin(k * math.pi * xi)
        u[1:] += sn * c
    u[0] = 0.0 if xi < 1 else h[0]
    return initial_temperature + u, n


# --------------------------------------------------------------------------- run
def _row(problem, method, setting, seconds, err_K, err_theta, n_ref, note=""):
    pts = int(DURATION_S * RATE_HZ) + 1
    return {"problem": problem, "method": method, "setting": setting,
            "cost_per_point_us": seconds / pts * 1e6, "total_ms": seconds * 1e3,
            "max_error_K": err_K, "max_error_theta": err_theta, "reference_points": n_ref,
            "note": note}


@dataclass
class _Problem:
    """The benchmark's trial: the profile's times, the skin, the steel and their contact."""

    quick: bool
    repeat: int                  # timing runs per row (best of)
    n: int                       # points of the 20 s profile
    t: np.ndarray                # its times, s
    idx: np.ndarray              # indices of the reference times
    skin: object
    steel: object
    R: float                     # Eq. 5 resistance of the steel, m² K/W
    dT: float                    # skin minus material temperature, K
    contact: object              # stimuli.Contact of skin and steel


def _problem(quick: bool) -> _Problem:
    from stimuli import Contact, Skin, contact_resistance, material
    n = int(DURATION_S * RATE_HZ) + 1
    skin = Skin(SKIN_THICKNESS_M)
    steel = material("stainless_steel")
    R = float(contact_resistance(ROUGHNESS_M, skin=skin, material=steel))
    contact = Contact(skin, steel, resistance=R, skin_temperature=T_SKIN_C,
                      material_temperature=T_MATERIAL_C)
    idx = reference_times()
    if quick:
        idx = idx[::4]
    return _Problem(quick=quick, repeat=3 if quick else 7, n=n, t=np.arange(n) / RATE_HZ, idx=idx,
                    skin=skin, steel=steel, R=R, dT=T_SKIN_C - T_MATERIAL_C, contact=contact)


def _bencher(rows, problem: str, ref, pb: _Problem):
    """``bench(method, setting, fn, note="")``: time ``fn`` (best of ``pb.repeat``), compare its
    values at the reference times with ``ref`` and append the row of ``problem``."""
    def bench(method, setting, fn, note=""):
        vals = fn()
        secs = _best_seconds(fn, pb.repeat)
        err = float(np.max(np.abs(np.asarray(vals)[pb.idx] - ref)))
        rows.append(_row(problem, method, setting, secs, err, err / abs(pb.dT), int(pb.idx.size), note))
    return bench


def _interface_rows(rows, pb: _Problem, echo) -> None:
    """Rows "interface": the target interface temperature (Eq. 7's quantity), every method."""
    from stimuli.exact import invert_laplace
    from stimuli.finite_volume import solve_contact
    from stimuli.laplace import ContactTransform
    t, skin, steel, R, dT = pb.t, pb.skin, pb.steel, pb.R, pb.dT
    echo(f"thermocue bench model: {machine_info()['cpu_model']}, {pb.n} points ({DURATION_S:g} s at "
         f"{RATE_HZ:g} Hz); computing mpmath references at {pb.idx.size} times ...")
    bench = _bencher(rows, "interface", T_MATERIAL_C + dT * interface_reference(skin, steel, R, pb.idx), pb)
    contact = pb.contact
    bench("paper-as-printed", "Eq. 7 stable (erfcx)",
          lambda: contact.interface_temperature(t, side="material", method="paper-as-printed"),
          "the yardstick")
    bench("paper", "corrected closed form",
          lambda: contact.interface_temperature(t, side="material", method="paper"))
    bench("exact", "default",
          lambda: contact.interface_temperature(t, side="material", method="exact"))
    tr = ContactTransform.from_contact(skin, steel, R)
    for nodes in ((12, 16) if pb.quick else (8, 12, 16, 20, 24, 32)):
        bench("exact", f"nodes={nodes}",
              lambda nodes=nodes: np.concatenate(   # R > 0: theta(L+, 0) = 0
                  [[T_MATERIAL_C], T_MATERIAL_C + dT * invert_laplace(
                      lambda s: tr.material_rise(s, tr.L), t[1:], nodes=nodes)]))
    for cells in ((16, 32) if pb.quick else (16, 32, 64, 128)):
        bench("numerical", f"cells={cells}",
              lambda cells=cells: solve_contact(skin, steel, R, T_SKIN_C, T_MATERIAL_C, t,
                                                depth=skin.thickness, side="material", cells=cells))


def _receptor_rows(rows, pb: _Problem, g, echo) -> None:
    """Rows "receptor": the receptors while the display replays the interface profile ``g``."""
    from stimuli import skin_response
    from stimuli.finite_volume import solve_surface
    t, skin, quick = pb.t, pb.skin, pb.quick
    echo("  receptor reference (mpmath Duhamel sum) ...")
    bench = _bencher(rows, "receptor", T_SKIN_C + receptor_reference(skin, g - T_SKIN_C, pb.idx), pb)
    bench("exact", "Duhamel + FFT", lambda: skin_response(skin, t, g, T_SKIN_C))
    bench("paper", "n = 0 image term", lambda: skin_response(skin, t, g, T_SKIN_C, method="paper"))
    bench("paper-as-printed", "Eq. 8 prefactor",
          lambda: skin_response(skin, t, g, T_SKIN_C, method="paper-as-printed"))
    for cells in ((16,) if quick else (8, 16, 32, 64)):
        bench("numerical", f"cells={cells} x1,2,4, Richardson",
              lambda cells=cells: skin_response(skin, t, g, T_SKIN_C, method="numerical", cells=cells))
    for cells in ((32,) if quick else (32, 64, 128, 256)):
        bench("numerical", f"cells={cells}, single grid",
              lambda cells=cells: solve_surface(skin, t, g, T_SKIN_C, cells=cells))
    for tol in ((1e-7,) if quick else (1e-5, 1e-7, 1e-9)):
        modes = modal_recursion(skin, t, g, T_SKIN_C, skin.dermis, tol_K=tol)[1]
        bench("modal-recursion", f"{modes} modes (bench only)",
              lambda tol=tol: modal_recursion(skin, t, g, T_SKIN_C, skin.dermis, tol_K=tol)[0],
              "exact per-mode recursion, one lfilter per mode, static tail correction")


def _pad_rows(rows, pb: _Problem, g, echo) -> float:
    """Rows "pad": the same display profile felt through the finger-pad resistance (Robin
    boundary); returns that resistance R_pad, m² K/W."""
    from stimuli import contact_resistance, material, skin_response
    t, skin = pb.t, pb.skin
    R_pad = float(contact_resistance(PAD_ROUGHNESS_M, skin=skin, material=material(PAD_MATERIAL)))
    echo(f"  finger-pad reference (R_pad = {R_pad:.4g} m² K/W, mpmath Robin eigen series) ...")
    bench = _bencher(rows, "pad", T_SKIN_C + receptor_robin_reference(skin, R_pad, g - T_SKIN_C, pb.idx), pb)
    bench("exact", "R_pad, Duhamel + Bromwich",
          lambda: skin_response(skin, t, g, T_SKIN_C, resistance=R_pad))
    for cells in ((16,) if pb.quick else (16, 32, 64)):
        bench("numerical", f"R_pad, cells={cells} x1,2,4",
              lambda cells=cells: skin_response(skin, t, g, T_SKIN_C, method="numerical",
                                                cells=cells, resistance=R_pad))
    return R_pad


def _interleaved_best(timed: dict, rounds: int) -> dict:
    """Best wall time of each function over ``rounds`` interleaved rounds (robust to a shared
    machine: a busy moment slows every function of its round, not one)."""
    best = {k: math.inf for k in timed}
    for _ in range(rounds):
        for k, fn in timed.items():
            t0 = time.perf_counter()
            fn()
            best[k] = min(best[k], time.perf_counter() - t0)
    return best


def _pick(rows, problem, method, setting=None):
    """The rows of ``problem`` and ``method`` (and ``setting`` when given)."""
    return [r for r in rows if r["problem"] == problem and r["method"] == method
            and (setting is None or r["setting"] == setting)]


def _ratios(rows, best: dict, n: int, R_pad: float, layered: dict) -> dict:
    """The targets' figures: costs relative to Eq. 7 (or to the exact model a planner replaces)
    from the interleaved ``best`` times, errors from the rows."""
    eq7 = best["eq7"] / n * 1e6
    exact_if = _pick(rows, "interface", "exact", "default")[0]
    sr_exact = _pick(rows, "receptor", "exact")[0]
    # the cheapest numerical setting within 1e-6 K (else the most accurate one)
    sr_num_best = _cheapest_within([r for r in _pick(rows, "receptor", "numerical")
                                    if "Richardson" in r["setting"]], 1e-6)
    pad_exact = _pick(rows, "pad", "exact")[0]
    pad_num_best = _cheapest_within(_pick(rows, "pad", "numerical"), 1e-6)
    return {
        "eq7_cost_per_point_us": eq7,
        "exact_cost_per_point_us": best["exact"] / n * 1e6,
        "skin_response_exact_cost_per_point_us": best["skin_response"] / n * 1e6,
        "exact_over_eq7_cost_ratio": best["exact"] / best["eq7"],
        "exact_max_error_theta": exact_if["max_error_theta"],
        "skin_response_exact_over_eq7_cost_ratio": best["skin_response"] / best["eq7"],
        "skin_response_exact_max_error_K": sr_exact["max_error_K"],
        "skin_response_numerical_over_eq7_cost_ratio": sr_num_best["cost_per_point_us"] / eq7,
        "skin_response_numerical_setting": sr_num_best["setting"],
        "skin_response_numerical_max_error_K": sr_num_best["max_error_K"],
        "pad_resistance_m2K_per_W": R_pad,
        "skin_response_pad_exact_cost_per_point_us": best["skin_response_pad"] / n * 1e6,
        "skin_response_pad_exact_over_eq7_cost_ratio": best["skin_response_pad"] / best["eq7"],
        "skin_response_pad_exact_max_error_K": pad_exact["max_error_K"],
        "skin_response_pad_numerical_over_eq7_cost_ratio": pad_num_best["cost_per_point_us"] / eq7,
        "skin_response_pad_numerical_setting": pad_num_best["setting"],
        "skin_response_pad_numerical_max_error_K": pad_num_best["max_error_K"],
        "layered_exact_over_eq7_cost_ratio": best["layered"] / best["eq7"],
        "layered_exact_max_error_K": layered["errors"]["layered"],
        "perfusion_exact_over_eq7_cost_ratio": best["perfusion"] / best["eq7"],
        "perfusion_exact_max_error_K": layered["errors"]["perfusion"],
        "planner_cold_over_exact_cost_ratio": best["planner_cold"] / best["perfusion"],
        "planner_repeated_over_exact_cost_ratio": best["planner_repeated"] / best["perfusion"],
        "planner_profile_scene_cold_over_exact_cost_ratio":
            best["planner_profile_cold"] / best["exact_slab_interface"],
        "planner_evaluated_scene_cold_over_exact_cost_ratio":
            best["planner_evaluated_cold"] / best["exact_hypodermis"],
        "planner_near_tolerance_scene_cold_over_exact_cost_ratio":
            best["planner_near_tolerance_cold"] / best["exact_hypodermis"],
        "display_planner_decay_over_exact_cost_ratio":
            best["display_planner_decay"] / best["display_full_decay"],
        "display_planner_step_over_exact_cost_ratio":
            best["display_planner_step"] / best["display_full_step"],
        "planned_model": layered["planned_model"],
        "planned_over_full_cost_ratio": best["planned"] / best["perfusion"],
        "planned_max_error_K": layered["errors"]["planned"],
        "planner_tolerance_K": layered["tolerance_K"],
    }


def _targets(ratios: dict) -> dict:
    """Whether each of the issue's targets is met by the figures ``ratios``."""
    r = ratios
    return {
        "exact_within_1e-12_theta_at_3x_eq7": bool(r["exact_max_error_theta"] <= 1e-12
                                                    and r["exact_over_eq7_cost_ratio"] <= 3.0),
        "skin_response_within_1e-6_K_at_3x_eq7": bool(
            r["skin_response_exact_max_error_K"] <= 1e-6
            and r["skin_response_exact_over_eq7_cost_ratio"] <= 3.0),
        "layered_within_1e-9_K_at_3x_eq7": bool(r["layered_exact_max_error_K"] <= 1e-9
                                                and r["layered_exact_over_eq7_cost_ratio"] <= 3.0),
        "perfusion_within_1e-9_K_at_3x_eq7": bool(r["perfusion_exact_max_error_K"] <= 1e-9
                                                  and r["perfusion_exact_over_eq7_cost_ratio"] <= 3.0),
        "planned_within_tolerance": bool(r["planned_max_error_K"] <= r["planner_tolerance_K"]),
        "planner_overhead_within_10pct_cold": bool(r["planner_cold_over_exact_cost_ratio"] <= 0.10),
        "planner_overhead_within_10pct_repeated": bool(
            r["planner_repeated_over_exact_cost_ratio"] <= 0.10),
        "planner_overhead_within_10pct_profile_scene": bool(
            r["planner_profile_scene_cold_over_exact_cost_ratio"] <= 0.10),
        "planner_overhead_within_10pct_hypodermis_scene": bool(
            r["planner_evaluated_scene_cold_over_exact_cost_ratio"] <= 0.10),
        "planner_overhead_within_10pct_near_tolerance_scene": bool(
            r["planner_near_tolerance_scene_cold_over_exact_cost_ratio"] <= 0.10),
        "display_planner_overhead_within_10pct_decay": bool(
            r["display_planner_decay_over_exact_cost_ratio"] <= 0.10),
        "display_planner_overhead_within_10pct_step": bool(
            r["display_planner_step_over_exact_cost_ratio"] <= 0.10),
    }


def _profile_info(pb: _Problem, R_pad: float) -> dict:
    """The trial the rows are measured on (the ``profile`` of ``bench.json``)."""
    return {"duration_s": DURATION_S, "rate_Hz": RATE_HZ, "points": pb.n,
            "skin_thickness_m": SKIN_THICKNESS_M, "receptor_depth_m": pb.skin.dermis,
            "material": "stainless_steel (half-space)", "roughness_m": ROUGHNESS_M,
            "resistance_m2K_per_W": pb.R, "pad_resistance_m2K_per_W": R_pad,
            "pad": f"{PAD_MATERIAL}, R_a {PAD_ROUGHNESS_M * 1e6:g} µm (Eq. 5)",
            "skin_temperature_C": T_SKIN_C,
            "material_temperature_C": T_MATERIAL_C,
            "reference": "mpmath: Talbot inversion at 40 digits (interface), Duhamel sum of "
                         "image/eigen series at 30 digits (receptor), of the Robin "
                         "eigen series at 30 digits (pad)",
            "reference_times_s": (pb.idx / RATE_HZ).tolist()}


def run_model_benchmark(out_dir, *, quick: bool = False, echo=print) -> dict:
    """Measure every method, write ``bench.json``, ``bench.csv``, ``bench.png`` and return the dict.

    Parameters
    ----------
    out_dir : path
        Created if missing.
    quick : bool
        Fewer timing repeats and grids (for tests); the same tables.
    echo : callable
        Receives each printed line.
    """
    from stimuli import skin_response
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    pb = _problem(quick)
    t, skin, contact = pb.t, pb.skin, pb.contact
    rows = []
    _interface_rows(rows, pb, echo)
    g = contact.interface_temperature(t, side="material", method="exact")
    _receptor_rows(rows, pb, g, echo)
    R_pad = _pad_rows(rows, pb, g, echo)
    layered = _bench_layered(rows, pb, echo)
    # the targets' ratios: interleaved runs of the three, best of each (robust to a shared machine)
    best = _interleaved_best(
        {"eq7": lambda: contact.interface_temperature(t, side="material", method="paper-as-printed"),
         "exact": lambda: contact.interface_temperature(t, side="material", method="exact"),
         "skin_response": lambda: skin_response(skin, t, g, T_SKIN_C),
         "skin_response_pad": lambda: skin_response(skin, t, g, T_SKIN_C, resistance=R_pad),
         **layered["timed"]}, 8 if quick else 40)
    ratios = _ratios(rows, best, pb.n, R_pad, layered)
    result = {"machine": machine_info(), "profile": _profile_info(pb, R_pad),
              "rows": rows, "ratios": ratios, "targets": _targets(ratios)}
    _write(out, result, echo)
    return result


def _layered_exact_rows(rows, pb: _Problem, ridx, echo):
    """Rows "layered" of the exact layered and perfused contact (receptor); returns their
    errors, their timed functions and the perfused model's reference at ``ridx``, °C."""
    from stimuli.layered import LayeredContact, skin_layers
    skin, dT = pb.skin, pb.dT
    errors, timed = {}, {}
    for key, w, setting in (("layered", None, "epidermis + dermis"),
                            ("perfusion", 1.25e-3, "epidermis + dermis, Pennes 1.25e-3 /s")):
        layers = skin_layers(skin, perfusion=w)
        c = LayeredContact(layers, pb.steel, pb.R, T_SKIN_C, T_MATERIAL_C)
        echo(f"  layered reference ({setting}, mpmath transfer matrices, {ridx.size} times) ...")
        ref = T_MATERIAL_C + dT * layered_reference(layers, pb.steel, pb.R, ridx)   # theta -> °C

        def fn(c=c):
            return c.temperature("receptor", pb.t, skin.dermis)
        vals = fn()
        err = float(np.max(np.abs(vals[ridx] - ref)))
        rows.append(_row("layered", "exact", setting, _best_seconds(fn, pb.repeat), err, err / abs(dT),
                         int(ridx.size), "receptor in contact with a steel half-space"))
        errors[key], timed[key] = err, fn
    return errors, timed, ref


def _cold(scene):
    """A function that plans ``scene`` from cold (the planner's cache emptied first)."""
    from stimuli.planner import plan, plan_scene

    def cold():
        plan_scene.cache_clear()
        return plan(scene)
    return cold


def _harder_scenes_timed(pb: _Problem, scene) -> dict:
    """The scene planner from cold on the scenes harder to decide, and the exact models it
    replaces there, to be timed.

    A scene the closed forms and the quasi-steady screen cannot decide (a 2 mm hypodermis: the
    skin is not quasi-steady within 20 s, perfusion's closed form 0.53 K exceeds the 0.3 K): the
    Laplace-domain bounds decide it (perfusion <= 0.14 K, the layers >= 0.8 K); and the same at
    0.1 K, where perfusion's Laplace bound does not fit and it is evaluated at the probes.
    """
    from stimuli.layered import LayeredContact, skin_layers
    hard = scene.replace(hypodermis_m=2e-3)
    near = hard.replace(tolerance_K=0.1)
    hard_contact = LayeredContact(skin_layers(pb.skin, perfusion=1.25e-3, hypodermis=2e-3), pb.steel,
                                  pb.R, T_SKIN_C, T_MATERIAL_C)
    hard_x = hard_contact.thickness - pb.skin.epidermis
    return {"planner_evaluated_cold": _cold(hard),
            "planner_near_tolerance_cold": _cold(near),
            "exact_hypodermis": lambda: hard_contact.temperature("receptor", pb.t, hard_x)}


def _production_scene_timed(pb: _Problem) -> dict:
    """The production scene (a target profile: the material-side interface of the 3 mm slab, to
    half the display's 0.01 K resolution) planned from cold, and the exact slab interface."""
    from stimuli import Contact
    from stimuli.scene import Scene
    prod = Scene(quantity="interface_material", geometry="slab", sample_thickness_m=3e-3,
                 resistance=pb.R, tolerance_K=0.005, duration_s=DURATION_S, rate_Hz=RATE_HZ,
                 skin_temperature_C=T_SKIN_C, material_temperature_C=T_MATERIAL_C)
    slab_contact = Contact(pb.skin, pb.steel.with_thickness(3e-3), pb.R, T_SKIN_C, T_MATERIAL_C)
    return {"planner_profile_cold": _cold(prod),
            "exact_slab_interface": lambda: slab_contact.interface_temperature(pb.t)}


def _display_planner_timed(pb: _Problem) -> dict:
    """The display-driven planner (the simulated participant's trials) and the full model.

    20 s at 1 kHz, layers and perfusion stated, pad 1e-4 m^2 K/W, 0.3 K; a decay drive (the
    quasi-steady screen cannot decide the layers) and a step; against the full layered,
    perfused exact response.
    """
    from stimuli.display_planner import plan_display
    from stimuli.layered import layered_skin_response, skin_layers
    skin, t = pb.skin, pb.t
    R_pad_display = 1e-4
    drives = {"decay": 27.75 + (T_SKIN_C - 27.75) * np.exp(-t / 2.0), "step": np.full(t.size, 25.0)}
    full_layers = skin_layers(skin, perfusion=1.25e-3)
    display = {}
    for name, g in drives.items():
        h = g - T_SKIN_C
        display[f"display_full_{name}"] = (
            lambda g=g: layered_skin_response(full_layers, t, g, T_SKIN_C, skin.dermis, R_pad_display))
        display[f"display_planner_{name}"] = (
            lambda h=h: plan_display(skin, skin.dermis, R_pad_display, DURATION_S, RATE_HZ, h,
                                     tolerance=0.3, layered=True, perfusion_per_s=1.25e-3))
    return display


def _bench_layered(rows, pb: _Problem, echo):
    """Rows "layered": the exact layered and perfused contact (receptor) and the scene planner."""
    from stimuli.planner import PROBE_INVERSION_ERROR, PROBE_NODES, plan
    from stimuli.scene import Scene
    skin, dT = pb.skin, pb.dT
    ridx = pb.idx[:: (3 if pb.quick else 2)]
    ridx = ridx[ridx > 0]
    errors, timed, ref = _layered_exact_rows(rows, pb, ridx, echo)
    # the planner on the perfused scene: it neglects perfusion, keeps the layers
    scene = Scene(quantity="receptor", geometry="half-space", layered=True, perfusion_per_s=1.25e-3,
                  resistance=pb.R, receptor_depth_m=skin.epidermis, duration_s=DURATION_S,
                  rate_Hz=RATE_HZ, skin_temperature_C=T_SKIN_C, material_temperature_C=T_MATERIAL_C)
    p = plan(scene)
    planned = p.evaluate()
    errors["planned"] = float(np.max(np.abs(planned[ridx] - ref)))   # ref: the perfused model
    timed.update(_harder_scenes_timed(pb, scene))
    timed.update({"planner_cold": _cold(scene), "planner_repeated": lambda: plan(scene),
                  "planned": lambda: p.evaluate(), **_production_scene_timed(pb)})
    timed.update(_display_planner_timed(pb))  # last: the scene planner's rows time as before this was added
    rows.append(_row("layered", "planner", f"plan -> {p.model.describe()}",
                     _best_seconds(timed["planner_cold"], pb.repeat),
                     errors["planned"], errors["planned"] / abs(dT), int(ridx.size),
                     f"cost: the planner alone (cold; perfusion bounded in closed form, the layers "
                     f"screened: no probe evaluated here; where probes are, {PROBE_NODES} nodes per "
                     f"window, their bound {PROBE_INVERSION_ERROR:g} dT added); error: the planned "
                     f"model against the "
                     f"perfused reference, tolerance {scene.tolerance_K:g} K"))
    return {"errors": errors, "timed": timed, "planned_model": p.model.describe(),
            "tolerance_K": scene.tolerance_K}


def _cheapest_within(rows, tol_K):
    """The cheapest row within ``tol_K`` (else the most accurate one)."""
    within = [r for r in rows if r["max_error_K"] <= tol_K]
    return (min(within, key=lambda r: r["cost_per_point_us"]) if within
            else min(rows, key=lambda r: r["max_error_K"]))


def _format_table(rows) -> list[str]:
    head = f"{'problem':<10} {'method':<17} {'setting':<32} {'cost_per_point_us':>17} {'max_error_K':>12} {'max_error_theta':>15}"
    lines = [head, "-" * len(head)]
    for r in rows:
        lines.append(f"{r['problem']:<10} {r['method']:<17} {r['setting']:<32} "
                     f"{r['cost_per_point_us']:>17.4f} {r['max_error_K']:>12.3e} {r['max_error_theta']:>15.3e}")
    return lines


def _write(out: Path, result: dict, echo) -> None:
    m = result["machine"]
    echo(f"machine: {m['cpu_model']} x{m['cpu_count']}, {m['platform']}, python {m['python']}, "
         f"numpy {m['numpy']}, scipy {m['scipy']}, load {m['load_average_1min']:.2f}")
    for line in _format_table(result["rows"]):
        echo(line)
    for k, v in result["ratios"].items():
        echo(f"{k}: {v:.4g}" if isinstance(v, float) else f"{k}: {v}")
    for k, v in result["targets"].items():
        echo(f"target {k}: {'met' if v else 'NOT met'}")
    (out / "bench.json").write_text(json.dumps(result, indent=2), encoding="utf-8")
    keys = ["problem", "method", "setting", "cost_per_point_us", "total_ms", "max_error_K",
            "max_error_theta", "reference_points"]
    with open(out / "bench.csv", "w", encoding="utf-8") as fh:
        fh.write(",".join(keys) + "\n")
        for r in result["rows"]:
            fh.write(",".join(f'"{r[k]}"' if isinstance(r[k], str) else repr(r[k]) for k in keys) + "\n")
    _plot(out / "bench.png", result)
    echo(f"wrote {out / 'bench.json'}, {out / 'bench.csv'}, {out / 'bench.png'}")


def _plot(path: Path, result: dict) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter
    eq7 = result["ratios"]["eq7_cost_per_point_us"]
    fig, axes = plt.subplots(1, 2, figsize=(12, 5))
    for ax, problem, title in zip(axes, ("interface", "receptor"),
                                  ("interface temperature (Eq. 7 quantity)",
                                   "receptor, display-driven (squares: through R_pad)")):
        for r in result["rows"]:
            if r["problem"] != problem and not (problem == "receptor" and r["problem"] == "pad"):
                continue
            y = max(r["max_error_K"], 1e-16)
            ax.loglog(r["cost_per_point_us"], y, "s" if r["problem"] == "pad" else "o")
            ax.annotate(f"{r['method']} {r['setting']}", (r["cost_per_point_us"], y), fontsize=6,
                        xytext=(3, 3), textcoords="offset points")
        ax.axvline(3 * eq7, color="k", lw=0.8, ls="--")
        ax.text(3 * eq7, ax.get_ylim()[1], " 3 x Eq. 7", fontsize=7, va="top")
        ax.axhline(1e-12 * abs(T_SKIN_C - T_MATERIAL_C) if problem == "interface" else 1e-6,
                   color="k", lw=0.8, ls=":")
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel("cost per point (µs)")
        ax.set_ylabel("max error vs mpmath (K)")
        ax.set_title(title, fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
    m = result["machine"]
    fig.suptitle(f"20 s at 1 kHz; {m['cpu_model']} x{m['cpu_count']}, numpy {m['numpy']}, "
                 f"scipy {m['scipy']}", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
