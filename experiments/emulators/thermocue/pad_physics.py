"""Physics of the emulated display: Peltier pad, heat sink, sensors, finger and passive sample.

Everything here is plain floating point and deterministic given a seed; :mod:`device` owns the
state machine and calls :meth:`PadPlant.step` once per 10 ms tick.

Model (SI inside)
-----------------
Pad: a lumped thermal mass ``C`` (J/K) on the cold/hot face of a Peltier module, whose other face
sits on a heat sink (lumped, ``C_hs``, cooled to the room through ``G_hs``). With ``i`` the module
current (positive heats the pad), Seebeck coefficient ``a`` (V/K), electrical resistance ``R_e``
and thermal conductance ``K``::

    Q_pad = a i T_pad[K] + i² R_e / 2 + K (T_hs - T_pad) + q_finger
    Q_hs  = -a i T_hs[K] + i² R_e / 2 + K (T_pad - T_hs) + G_hs (T_room - T_hs)

Contact sensor: a thin-film thermometer on the pad, first-order lag ``tau_sensor`` plus white
noise, digitised to 0.001 °C. Controller (device firmware), every ``dt_control``:
feed-forward of the setpoint's derivative (the device knows the next profile sample) and of the
modelled leak to the heat sink, a proportional term, and a disturbance observer that estimates
the unmodelled heat flow (mostly the finger) from the measured temperature change; the desired
heat flow is turned into a current by inverting the Peltier equation with the firmware's
(deliberately imperfect, ±5 %) model, then clamped to ``±i_max``.

Finger (playback): the skin slab of :mod:`stimuli` (0 < x < L, inner boundary held at the skin
temperature, uniform initially) discretised in 32 finite volumes (the first 3 µm thick) refined towards the surface and
advanced exactly over each tick (matrix exponential, input held); its surface exchanges heat with
the pad through the finger–pad contact resistance (``stimuli.contact_resistance`` of a 0.4 µm
copper face) while touching, and with room air (10 W/m²K) otherwise, over the paper's 135 mm².

Passive sample (record): the interface temperatures by the scene planner's model
(:func:`stimuli.planner.planned_temperature`, within :data:`SAMPLE_MODEL_TOLERANCE_K`), material
side for the contact sensor glued on the sample, skin side for the finger, from the first touch;
the planner's decisions (:func:`compact_plan`) go back to the host in the ``sim_finger`` reply.

The finger on the pad (playback) is not a planned model: it is the plant's own state, advanced
with the pad it exchanges heat with (the pad's temperature depends on the finger's heat flow,
which the display planner's imposed-surface models do not describe); the ``sim_finger`` reply
names it (:data:`FINGER_ON_PAD_MODEL`).
"""
from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.linalg import expm

__all__ = ["normal_stream", "PadParams", "PadPlant", "FingerSkin", "FingerScript", "PassiveSample",
           "CONTACT_AREA_M2", "finger_pad_resistance", "compact_plan", "SAMPLE_MODEL_TOLERANCE_K",
           "FINGER_ON_PAD_MODEL"]

_dot = np.dot
#: Contact area of the fingertip, m² (paper: 2 N on 135 mm²).
CONTACT_AREA_M2 = 135e-6
#: Heat transfer coefficient of the finger to room air, W/(m² K).
H_AIR = 10.0
KELVIN = 273.15


def normal_stream(seed: int, n: int = 65536):
    """An endless iterator of standard normal numbers (a seeded block of ``n``, cycled).

    ``next()`` on it costs a few tens of nanoseconds, against a microsecond for
    ``random.gauss``: the emulator draws seven numbers per 10 ms tick.
    """
    return itertools.cycle(_normal_block(int(seed), int(n)))


@lru_cache(maxsize=8)
def _normal_block(seed: int, n: int) -> tuple:
    """The block of :func:`normal_stream` (made once per process: a study's emulated sessions
    share the study's seed, and drawing the block cost ~3 ms a device)."""
    return tuple(np.random.default_rng(seed).standard_normal(n).tolist())


@dataclass(frozen=True)
class PadParams:
    """Parameters of the emulated pad, module, heat sink and sensors (SI, °C)."""

    capacity: float = 0.8            # J/K, pad + half the module
    conductance: float = 0.4         # W/K, module, pad to heat sink
    seebeck: float = 0.025           # V/K, module
    resistance: float = 1.5          # ohm, module
    i_max: float = 3.0               # A
    hs_capacity: float = 60.0        # J/K
    hs_conductance: float = 2.0      # W/K, heat sink to room (fan)
    room: float = 20.0               # °C
    tau_sensor: float = 0.003        # s
    noise_sensor: float = 0.003      # °C rms
    noise_force: float = 0.005       # N rms per sensor
    noise_ambient: float = 0.01      # °C rms
    dt_control: float = 0.005        # s (200 Hz)
    model_error: float = 0.05        # relative error of the firmware's model
    kp: float = 40.0                 # W/K
    tau_observer: float = 0.02       # s


def finger_pad_resistance() -> float:
    """Contact resistance between the finger and the pad's polished copper face, m² K/W.

    ``stimuli.contact_resistance(0.4 µm, copper)`` (Eq. 5 of the paper at 2 N on 135 mm²).
    """
    from stimuli import Skin, contact_resistance, material
    from stimuli.paper import PAD_MATERIAL, PAD_ROUGHNESS_M
    return float(contact_resistance(PAD_ROUGHNESS_M, skin=Skin(1.0e-3), material=material(PAD_MATERIAL)))


@lru_cache(maxsize=64)
def _skin_matrices(thickness, conductivity, density, specific_heat, g_surface, dt, n=32):
    # geometric cells from the surface inwards, first cell 3 µm
    first = min(3e-6, thickness / n)
    lo, hi = 1.0, 2.0
    for _ in range(80):          # ratio r with first * (r^n - 1)/(r - 1) = thickness
        r = 0.5 * (lo + hi)
        s = first * (r ** n - 1) / (r - 1)
        lo, hi = (r, hi) if s < thickness else (lo, r)
    w_surf = first * r ** np.arange(n)            # index 0 at the surface
    w = w_surf[::-1] * thickness / w_surf.sum()   # index 0 at the inner boundary
    xc = np.cumsum(w) - w / 2
    cap = density * specific_heat * w
    A = np.zeros((n, n))
    B = np.zeros((n, 2))                          # inputs: surface reservoir, core
    g_core = conductivity / (w[0] / 2)
    g_surf = 1.0 / (1.0 / g_surface + w[-1] / (2 * conductivity))
    for i in range(n - 1):
        g = conductivity / (xc[i + 1] - xc[i])
        A[i, i] -= g; A[i, i + 1] += g; A[i + 1, i + 1] -= g; A[i + 1, i] += g
    A[0, 0] -= g_core; B[0, 1] = g_core
    A[-1, -1] -= g_surf; B[-1, 0] = g_surf
    A /= cap[:, None]; B /= cap[:, None]
    M = np.zeros((n + 2, n + 2))
    M[:n, :n] = A * dt; M[:n, n:] = B * dt
    E = expm(M)
    return E[:n, :n].copy(), E[:n, n:].copy(), xc, float(g_surf), float(w[-1])


class FingerSkin:
    """The finger's skin slab, advanced in fixed ticks (see module Notes).

    Parameters
    ----------
    thickness_m : float, m
    skin_temperature_C : float, °C
        Uniform initial temperature and inner-boundary temperature.
    dt : float, s
        Tick.
    resistance : float, m² K/W
        Finger–pad contact resistance while touching.
    """

    def __init__(self, thickness_m, skin_temperature_C, dt, resistance, skin=None):
        if skin is None:
            try:
                from stimuli import Skin
                skin = Skin(thickness_m)
            except ImportError:  # pragma: no cover - stimuli is part of the package
                skin = None
        k, rho, c = ((skin.conductivity, skin.density, skin.specific_heat) if skin is not None
                     else (0.34, 1200.0, 3340.0))
        self.conductivity = k
        self.dermis = skin.dermis if skin is not None else 0.6 * thickness_m
        self.core = float(skin_temperature_C)
        key = (float(thickness_m), k, rho, c)
        self._touch = _skin_matrices(*key, 1.0 / resistance, dt)
        self._air = _skin_matrices(*key, H_AIR, dt)
        n = self._touch[0].shape[0]
        # one matrix per contact state acting on [T..., outside, core]
        self._ab = {True: np.hstack(self._touch[:2]), False: np.hstack(self._air[:2])}
        self._g = {True: self._touch[3], False: self._air[3]}
        self._x = np.full(n + 2, self.core)
        self._x_next = np.full(n + 2, self.core)     # the next tick's state is written here
        # each state vector's first n cells (a view, made once): where the product goes
        self._heads = {id(self._x): self._x[:n], id(self._x_next): self._x_next[:n]}
        self.n = n
        self.surface_node = self.core
        self.flux = 0.0       # W/m², skin to pad (or air), over the last tick

    @property
    def T(self) -> np.ndarray:
        """Cell temperatures from the inner boundary to the surface, °C."""
        return self._x[:self.n]

    def step(self, touching: bool, outside_C: float) -> float:
        """Advance one tick with the pad (or air) at ``outside_C``; return the heat flux into it, W/m²."""
        x = self._x
        n = self.n
        x[n] = outside_C
        # the same product as ``A @ x`` (one BLAS gemv), written straight into the other state
        # vector: no temporary, no copy back (the inner boundary, x[n + 1], never changes)
        nxt = self._x_next
        _dot(self._ab[touching], x, out=self._heads[id(nxt)])
        self._x, self._x_next = nxt, x
        s_old = self.surface_node
        self.surface_node = s_new = nxt.item(n - 1)
        # average surface flux over the tick (trapezoid on the surface node)
        self.flux = self._g[touching] * (0.5 * (s_old + s_new) - outside_C)
        return self.flux

    def surface_C(self, touching: bool) -> float:
        """Temperature of the skin surface, °C."""
        _, _, _, g_surf, w = self._touch if touching else self._air
        return self.surface_node - self.flux * w / (2 * self.conductivity)

    def temperature_at(self, depth_from_inner_m: float) -> float:
        """Temperature at ``x`` from the inner boundary (linear between cell centres), °C."""
        xc = self._touch[2]
        return float(np.interp(depth_from_inner_m, xc, self.T))


class PassiveSample:
    """A sample at rest on the display (record mode): interface temperatures from :mod:`stimuli`.

    Parameters
    ----------
    material : str
        A name from ``stimuli.MATERIALS``.
    roughness_m, thickness_m : float, m
    temperature_C : float, °C
    """

    def __init__(self, material="stainless_steel", roughness_m=1.6e-6, thickness_m=3e-3,
                 temperature_C=20.0):
        self.material = str(material)
        self.roughness_m = float(roughness_m)
        self.thickness_m = None if thickness_m is None else float(thickness_m)
        self.temperature_C = float(temperature_C)

    def curves(self, skin_thickness_m, skin_temperature_C, dt, n, force_N=2.0):
        """``(material_side_C, skin_side_C)`` at ``t = k dt``, k = 0..n-1, from first touch;
        the contact resistance is Eq. 5 at the finger's ``force_N``."""
        return self.planned_curves(skin_thickness_m, skin_temperature_C, dt, n, force_N)[:2]

    def planned_curves(self, skin_thickness_m, skin_temperature_C, dt, n, force_N=2.0):
        """``(material_side_C, skin_side_C, plans)``: :meth:`curves` and the scene planner's
        decision for each side (``plans``: ``{"interface_material": ..., "interface_skin": ...}``,
        each :func:`compact_plan`); the same cached computation as :meth:`curves`."""
        return _interface_curves(self.material, self.roughness_m, self.thickness_m,
                                 self.temperature_C, round(float(skin_thickness_m), 9),
                                 round(float(skin_temperature_C), 3), dt, n,
                                 round(float(force_N), 3))


#: What the ``sim_finger`` reply says models the finger on the pad (playback): not the planner's.
FINGER_ON_PAD_MODEL = {"model": "finite volumes (32 cells, exact over each tick), coupled to the pad",
                       "method": "plant state", "tolerance_K": None, "bound_K": None,
                       "note": "two-way heat exchange with the pad: not an imposed-surface scene, "
                               "so not planned"}

#: K: the tolerance of the passive sample's interface temperatures, half the display's 0.01 K
#: resolution (a finer model would not change a reading).
SAMPLE_MODEL_TOLERANCE_K = 0.005


def compact_plan(plan) -> dict:
    """A scene planner's decision in a few fields, small enough for an emulator reply
    (:func:`stimuli.planner.plan_summary`)."""
    from stimuli.planner import plan_summary
    return plan_summary(plan)


@lru_cache(maxsize=256)
def _interface_curves(mat, roughness, thickness, t_mat, skin_th, t_skin, dt, n, force_N=2.0):
    from stimuli import Skin, contact_resistance, material
    skin = Skin(skin_th)
    m = material(mat, thickness=thickness)
    R = contact_resistance(roughness, skin=skin, material=m, force=force_N)
    t = np.arange(n) * dt
    # through the scene planner (stimuli.planner) to half the display's 0.01 K resolution
    from stimuli.planner import planned_temperature
    tol = SAMPLE_MODEL_TOLERANCE_K
    tm, pm = planned_temperature("interface_material", skin, m, R, t_skin, t_mat, t, tolerance=tol)
    ts, ps = planned_temperature("interface_skin", skin, m, R, t_skin, t_mat, t, tolerance=tol)
    tm, ts = np.asarray(tm, dtype=float), np.asarray(ts, dtype=float)
    tm.setflags(write=False); ts.setflags(write=False)
    return tm, ts, {"interface_material": compact_plan(pm), "interface_skin": compact_plan(ps)}


class PadPlant:
    """Pad, module, heat sink, contact sensor and the firmware's controller.

    ``step(setpoint, next_setpoint, load_W, enabled)`` advances one tick and returns the contact
    sensor reading; the fields ``pad``, ``hs``, ``sensor``, ``current`` hold the state.
    Fault hooks: ``stuck_current`` (A, a driver stuck on), ``sensor_override`` (°C or None),
    ``sensor_frozen`` (bool).
    """

    def __init__(self, params: PadParams, tick: float, start_C: float, seed: int = 0):
        self.p = params
        self.tick = tick
        self.n_sub = max(1, int(round(tick / params.dt_control)))
        self.dtc = tick / self.n_sub
        self.noise = normal_stream(seed)
        self.pad = float(start_C)
        self.hs = params.room + 0.5
        self.sensor_state = self.pad
        self.sensor = self.pad
        self.current = 0.0
        self.d_hat = 0.0
        self._y_prev = self.pad
        self._q_prev = 0.0
        self.stuck_current = None
        self.current_scale = 1.0         # fault slow_pad: the share of the current the module gives
        self.relay_dead = False          # fault dead_relay: disabled, the driver keeps its current
        self.sensor_override = None
        self.sensor_frozen = False
        self.trip_C = None               # over-temperature cut: a reading above it opens the relay
        self.tripped = False             # ... within the same control step, until reset
        self.same_count = 0
        e = params.model_error
        self._c_hat = params.capacity * (1 + e)
        self._k_hat = params.conductance * (1 - e)
        self._a_hat = params.seebeck * (1 - e)
        self._r_hat = params.resistance * (1 + e)
        # the per-step constants (the parameters are frozen): computed once, not every tick
        dtc = self.dtc
        self._consts = (dtc, self.n_sub, params.capacity, params.conductance, params.seebeck,
                        params.resistance, self._c_hat, self._k_hat, self._a_hat, self._r_hat,
                        params.kp, params.i_max, dtc / params.tau_observer,
                        1.0 - math.exp(-dtc / params.tau_sensor), params.noise_sensor,
                        params.hs_conductance, params.room, params.hs_capacity)

    def step(self, sp0: float, sp1: float, load_W: float, enabled: bool) -> float:
        """Advance one tick: setpoint moving linearly from ``sp0`` to ``sp1``; return the reading."""
        (dtc, n, C, K, a, Re, ch, kh, ah, rh, kp, imax, g_obs, lag, noise, g_hs, room,
         C_hs) = self._consts
        nz = self.noise
        pad, hs, s_state, y_prev, q_prev, d_hat = (self.pad, self.hs, self.sensor_state,
                                                   self._y_prev, self._q_prev, self.d_hat)
        override, frozen, stuck = self.sensor_override, self.sensor_frozen, self.stuck_current
        trip = self.trip_C if self.trip_C is not None else math.inf
        if self.tripped:
            enabled = False
        imax *= self.current_scale
        held = self.current if self.relay_dead else 0.0   # a relay that never opens
        dsp = (sp1 - sp0) / n
        # the same doubles as the formulas in the comments below, each product or quotient
        # that does not change within the tick taken once (IEEE: (-a) i = -(a i), x - y = x + -y)
        ff = ch * dsp / dtc                   # feed-forward of the setpoint's slope
        half_rh, two_rh, half_Re = 0.5 * rh, 2.0 * rh, 0.5 * Re
        y = self.sensor
        same = self.same_count
        i = 0.0
        for k in range(n):
            # sensor
            s_state += lag * (pad - s_state)
            if override is not None:
                y_new = override
            elif frozen:
                y_new = y
            else:
                # round(v, 3) -- Python's correctly rounded decimal rounding, 0.3 us -- done as
                # k / 1000 with k the nearest integer to v * 1000: the same double whenever
                # v * 1000 is not within 1e-4 of a half (its rounding error is ~1e-11 here);
                # the division of two exact doubles is correctly rounded, as is round()'s result
                v = s_state + noise * next(nz)
                w = v * 1000.0
                kk = round(w)
                y_new = kk / 1000.0 if (kk and -0.4999 < w - kk < 0.4999) else round(v, 3)
            same = same + 1 if y_new == y else 0
            y = y_new
            r = sp0 + dsp * k
            if enabled and y > trip:             # the firmware's over-temperature cut: now
                enabled = False
                self.tripped = True
            if enabled:
                # disturbance observer: measured minus modelled heat flow
                d_meas = ch * (y - y_prev) / dtc - q_prev - kh * (hs - y_prev)
                d_hat += g_obs * (d_meas - d_hat)
                q_des = ff + kh * (r - hs) + kp * (r - y) - d_hat   # ff: ch dsp / dtc
                # invert the Peltier term  rh/2 i^2 + ah T i = q_des  for the root nearest 0
                aT = ah * (y + KELVIN)
                disc = aT * aT + two_rh * q_des
                i = (-aT + math.sqrt(disc)) / rh if disc > 0 else -aT / rh
                i = imax if i > imax else -imax if i < -imax else i
                q_prev = aT * i + half_rh * i * i    # ah (y + KELVIN) i + rh/2 i^2
            else:
                i = held
                q_prev = 0.0
                d_hat = 0.0
            y_prev = y
            if stuck is not None and enabled:      # the relay cuts a stuck driver too
                i = stuck
            joule = half_Re * i * i
            ai = a * i
            kd = K * (hs - pad)
            # q_hs: -a i (hs + KELVIN) + joule + K (pad - hs) + g_hs (room - hs)
            q_pad = ai * (pad + KELVIN) + joule + kd + load_W
            q_hs = -ai * (hs + KELVIN) + joule - kd + g_hs * (room - hs)
            pad += dtc * q_pad / C
            hs += dtc * q_hs / C_hs
        self.pad, self.hs, self.sensor_state, self._y_prev, self._q_prev, self.d_hat = (
            pad, hs, s_state, y_prev, q_prev, d_hat)
        self.sensor = y
        self.same_count = same
        self.current = i
        return y


class FingerScript:
    """A scripted fingertip: approach, press, hold, release (times in s, forces in N).

    The press ramps to 1.15 × ``force_N`` in 0.15 s (people overshoot a little), settles to
    ``force_N`` with a 0.2 s time constant, holds for ``hold_s`` from the start of the press, and
    releases in 0.1 s. The four pressure sensors share the force 27/24/26/23 %.
    """

    SHARES = (0.27, 0.24, 0.26, 0.23)

    def __init__(self, press_after_s=0.3, force_N=2.0, hold_s=20.0, skin_thickness_m=650e-6,
                 skin_temperature_C=35.5):
        self.press_after_s = float(press_after_s)
        self.force_N = float(force_N)
        self.hold_s = float(hold_s)
        self.skin_thickness_m = float(skin_thickness_m)
        self.skin_temperature_C = float(skin_temperature_C)
        self.start_us = None     # set when the script starts

    def force(self, t_us: int) -> float:
        if self.start_us is None:
            return 0.0
        tau = (t_us - self.start_us) * 1e-6 - self.press_after_s
        F = self.force_N
        if tau <= 0.0:
            return 0.0
        if tau < 0.15:
            return 1.15 * F * tau / 0.15
        if tau < self.hold_s:
            return F * (1.0 + 0.15 * math.exp(-(tau - 0.15) / 0.2))
        if tau < self.hold_s + 0.1:
            return F * (1.0 - (tau - self.hold_s) / 0.1)
        return 0.0
