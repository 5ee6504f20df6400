"""The calibration's contact as a scene of the planner: the planner's model reduced
to the calibration's setup, and the plan of a fitted calibration's contact.
"""
from __future__ import annotations

import warnings as _warnings
from dataclasses import replace as _replace
from experiments.calibration.errors import CalibrationError
from experiments.calibration.model import ContactSetup

__all__ = ["planned_setup", "plan_calibration"]


GEOMETRY_RANK = {"half-space": 0, "slab": 1, "slab-on-support": 2}


def planned_setup(setup: ContactSetup, model) -> ContactSetup:
    """``setup`` reduced to the scene planner's ``model`` (:class:`stimuli.scene.Model`).

    A calibration scene states homogeneous skin, no perfusion, no sensor lag and the sample as a
    half-space or an insulated slab, so the planner's only simplifications are the slab (to a
    half-space) and the exact half-space (to the printed Eq. 7). The half-space is evaluated by
    :class:`ResponseGrid`'s exact transform in both cases: the fit needs dθ/dR and dθ/dL, which
    Eq. 7's printed form does not give, and the exact form is the one Eq. 7 was checked against.
    """
    if model.layered or model.perfusion or model.sensor or model.geometry == "slab-on-support":
        raise CalibrationError(f"calibration: model: the calibration's forward model has homogeneous "
                               f"skin on a half-space or an insulated slab, got {model.describe()!r}")
    d = setup.material.thickness
    if model.geometry == "half-space" and d is not None:
        return _replace(setup, material=setup.material.with_thickness(None))
    if model.geometry == "slab" and d is None:
        raise CalibrationError("calibration: model: a slab model for a half-space sample")
    return setup


def plan_calibration(traces, setup: ContactSetup, resistance: float, skin_thickness: float,
                     tolerance_K: float):
    """Plan the calibration's contact scene: the longest trace's times, its temperatures,
    ``resistance`` and ``skin_thickness``, the sensor's side as the quantity, ``tolerance_K``.

    Returns
    -------
    plan : stimuli.planner.Plan or None
        None for a lumped sensor (not a scene quantity) or a scene the planner refuses.
    record : dict
        :meth:`Plan.to_dict`, or ``{"note": why not planned}``.
    """
    from stimuli import ModelInputError
    from stimuli.planner import plan
    from stimuli.scene import Scene
    side = setup.sensor.side
    if side == "lumped":
        return None, {"note": "lumped sensor: not a scene quantity; the fit's exact model"}
    tr = max(traces, key=lambda x: x.duration_s)
    mat = setup.material
    try:
        with _warnings.catch_warnings():
            _warnings.simplefilter("ignore")            # range warnings belong to the traces' loader
            scene = Scene(quantity=f"interface_{side}", duration_s=round(tr.duration_s, 6),
                          rate_Hz=round(tr.n / tr.duration_s, 6), tolerance_K=max(tolerance_K, 1e-6),
                          material=mat.with_thickness(None), resistance=float(resistance),
                          skin_thickness_m=float(skin_thickness),
                          skin_temperature_C=tr.skin_temperature_C,
                          material_temperature_C=tr.material_temperature_C,
                          geometry="half-space" if mat.thickness is None else "slab",
                          sample_thickness_m=mat.thickness or 3e-3)
            p = plan(scene)
            return p, p.to_dict()
    except ModelInputError as exc:
        return None, {"note": f"not planned: {exc}"}


def plan_calibration_scene(fit):
    """The scene planner's view of the calibration's contact at the fitted values, at the traces' own
    noise level (tolerance = the residual SD), for a massless sensor."""
    prob = fit.problem
    return plan_calibration(prob.traces, prob.setup, fit.resistances()[0].value,
                            fit.skin_thickness.value, fit.sigma_C)[1]
