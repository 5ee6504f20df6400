"""The simulated participant as a responder: ``--responder simulated``.

It wraps :class:`experiments.participant_model.person.SimulatedPerson`: before each trial it scripts the
emulator's finger (its own skin thickness and temperature, a ~2 N press) and, on real trials,
places the trial's sample on the emulator; after the trial it feels what the physics says at its
receptors (real trials: its skin on the sample through the contact resistance; simulated trials:
the display's recorded pad temperature touched through its own finger–pad contact resistance), learns templates on
familiarisation trials and answers test trials by the model's decision rule.
"""
from __future__ import annotations

import dataclasses
import hashlib
import math

import numpy as np

from experiments.errors import UserInputError
from experiments.participant_model.person import PerceptionParameters, SimulatedPerson, feature_names
from stimuli.paper import PAD_MATERIAL, PAD_ROUGHNESS_M
from experiments.responders.base import RESPONSE_IDS, Responder, Response
from experiments.responders.hand import press

__all__ = ["SimulatedResponder", "HOLD_MARGIN_S"]

#: s: how much longer than the recording a finger that is not asked to answer stays on. The
#: emulated press rises with a 0.2 s time constant, so 2.5 N crosses a 2 N threshold ~0.32 s
#: after it starts; contact (and the recording) begins only then.
HOLD_MARGIN_S = 1.0

_PARAM_FIELDS = {f.name: f for f in dataclasses.fields(PerceptionParameters)}


def _number(name: str, value, kind=float):
    """Coerce an option given as text (from the command line) to a number, or fail clearly."""
    try:
        out = kind(value)
    except (TypeError, ValueError):
        raise UserInputError(f"responder 'simulated': {name}: expected a number, got {value!r}") \
            from None
    if isinstance(out, float) and not math.isfinite(out):
        raise UserInputError(f"responder 'simulated': {name}: expected a finite number, got {value!r}")
    return out


def _stable_seed(text: str) -> int:
    return int.from_bytes(hashlib.sha256(text.encode()).digest()[:8], "little")


class SimulatedResponder(Responder, name="simulated", aliases=("model",)):
    """A simulated participant answering from the skin physics plus a Thurstonian observer.

    Parameters
    ----------
    seed : int, optional
        Seed of the person's randomness; default derived from the participant id. Each trial's
        randomness is drawn from ``(seed, trial_index)``, so answers do not depend on the order
        of calls or on resuming.
    skin_thickness_um : float, µm, optional
        Default: the participant record's ``skin_thickness.total_um``.
    dermis_fraction : float, optional
        Default: the record's ``dermis_um / total_um`` if given, else 0.6.
    skin_temperature_C : float, °C, optional
        Default: the record's ``initial_skin_temperature_C``, else 35.75 °C.
    press_after_s, force_N : float, s / N
        The scripted finger: when it presses after being armed, and how hard.  Without
        ``force_N`` each trial's press is drawn from the lab the Monte Carlo simulates
        (:data:`experiments.participant_model.lab.DEFAULT_LAB`: 2.5 ± 0.25 N, clipped to
        2.05-3 N, past the 2 N trigger), from ``(seed, trial_index)``; ``force_N`` presses every
        trial at that force.
    force_sd_N : float, N, optional
        The lab's per-touch force spread instead of the default's 0.25 N (``reproduce figure9
        --force-sd-N`` passes its own, so that the emulated study and the Monte Carlo share it).
    hold_s : float, s, optional
        How long the finger stays on, from the start of the press. Default: on trials that ask
        for an answer, the model's feature window + 0.5 s (the paper's participants withdrew
        after answering, within 20 s); on trials of a block with ``response = false`` (nothing
        to answer: Exp. 1's recordings, familiarisation) at least the protocol's recording,
        ``contact.record_s`` (``max_contact_s`` for played profiles), plus
        :data:`HOLD_MARGIN_S` for the press to reach the force threshold. Given, it is used
        on every trial.
    pad_roughness_um : float, µm, optional
        R_a of the display's face the finger touches (default: the protocol's ``[simulation]
        pad_roughness_um``, else 0.4 µm).
    pad_material : str, optional
        Its material (default: the protocol's ``pad_material``, else ``"copper"``).
    pad_contact : bool
        Feel the display's pad through the finger–pad contact resistance (default); false
        imposes the pad temperature on the skin directly.
    observer : str
        The decision rule, by name (:data:`experiments.participant_model.observers.OBSERVERS`):
        ``absolute`` (default: maximum likelihood against the real samples' templates),
        ``relative`` (within-block rank, knowing the 4 x 3 design), ``range_frequency``
        (range–frequency judgement over the block so far) or ``display_learned`` (absolute,
        with templates learned on a familiarisation block on the display). Logged in the
        ``simulated_participant`` event with its parameters (e.g. ``range_weight``, given as
        an option like the perception parameters). The block-relative observers remember the
        block's percepts in this process only: a resumed session's first answers in a block
        see only the trials after the resume.
    log_percepts : bool
        Log a ``simulated_percept`` event per answered trial (features felt, noisy percept,
        log-likelihood of each sample, answer), so every answer can be traced to the physics.
        Whatever it says, every receptor temperature felt logs a ``simulated_receptor_model``
        event (trial_index, felt_as, the scene planner's model, method, tolerance_K, bound_K,
        kept and neglected effects: :attr:`SimulatedPerson.last_plan`).
    **perception
        Any field of :class:`~experiments.participant_model.person.PerceptionParameters`
        (``drop_noise_C``, ``weber_fraction``, ``lapse_rate``, ...).
    """

    human = False

    def __init__(self, seed=None, skin_thickness_um=None, dermis_fraction=None,
                 skin_temperature_C=None, press_after_s=0.3, force_N=None, force_sd_N=None,
                 hold_s=None,
                 log_percepts=True, pad_roughness_um=None, pad_material=None, pad_contact=True,
                 observer="absolute", **perception):
        super().__init__()
        from experiments.participant_model.observers import OBSERVERS, get_observer
        if observer not in OBSERVERS:
            raise UserInputError(f"responder 'simulated': observer: expected one of "
                                 f"{', '.join(OBSERVERS)}, got {observer!r}")
        observer_params = {k: _number(k, perception.pop(k))
                           for k in list(perception) if k in OBSERVERS[observer].defaults()}
        try:
            self.observer = get_observer(observer, **observer_params)
        except ValueError as exc:
            raise UserInputError(f"responder 'simulated': {exc}") from None
        self._blocks: dict = {}
        unknown = sorted(set(perception) - set(_PARAM_FIELDS))
        if unknown:
            raise UserInputError(f"responder 'simulated': unknown option(s) {unknown}; expected "
                                 f"seed, skin_thickness_um, dermis_fraction, skin_temperature_C, "
                                 f"press_after_s, force_N, force_sd_N, hold_s, log_percepts, pad_roughness_um, "
                                 f"pad_material, pad_contact, observer (and its parameters) or one of "
                                 f"{sorted(_PARAM_FIELDS)}")
        values = {}
        for key, value in perception.items():
            if key == "drop_times_s" and isinstance(value, str):
                value = tuple(_number(key, v) for v in value.split(","))
            elif key == "sample_thickness_m" and value in (None, "none", "None", "half-space"):
                value = None
            elif key != "drop_times_s":
                value = _number(key, value)
            values[key] = value
        try:
            self.params = PerceptionParameters(**values)
        except ValueError as exc:
            raise UserInputError(f"responder 'simulated': {exc}") from None
        self.seed = None if seed is None else _number("seed", seed, int)
        self._overrides = {
            "skin_thickness_um": None if skin_thickness_um is None else _number("skin_thickness_um", skin_thickness_um),
            "dermis_fraction": None if dermis_fraction is None else _number("dermis_fraction", dermis_fraction),
            "skin_temperature_C": None if skin_temperature_C is None else _number("skin_temperature_C", skin_temperature_C),
        }
        self.press_after_s = _number("press_after_s", press_after_s)
        self.force_N = None if force_N is None else _number("force_N", force_N)
        from experiments.participant_model.lab import DEFAULT_LAB
        try:
            self.lab = DEFAULT_LAB if force_sd_N is None else dataclasses.replace(
                DEFAULT_LAB, force_sd_N=_number("force_sd_N", force_sd_N))
        except ValueError as exc:
            raise UserInputError(f"responder 'simulated': {exc}") from None
        self.hold_given = hold_s is not None
        self.hold_s = self.params.duration_s + 0.5 if hold_s is None else _number("hold_s", hold_s)
        self.log_percepts = log_percepts not in (False, "false", "False", "0", 0)
        self.pad_roughness_um = None if pad_roughness_um is None else _number("pad_roughness_um", pad_roughness_um)
        if self.pad_roughness_um is not None and self.pad_roughness_um < 0:
            raise UserInputError(f"responder 'simulated': pad_roughness_um: expected a number >= 0, "
                                 f"got {pad_roughness_um!r}")
        self.pad_material = None if pad_material is None else str(pad_material)
        self.pad_contact = pad_contact not in (False, "false", "False", "0", 0)
        self._pad_cache: dict = {}
        self.person: SimulatedPerson | None = None
        self._trial_state: dict[int, tuple[np.random.Generator, float]] = {}
        self._learned: set[int] = set()

    # -- set-up ----------------------------------------------------------------------------
    def begin_session(self, session) -> None:
        super().begin_session(session)
        participant = getattr(session, "participant", None)
        self.person = self.make_person(participant)
        if self.seed is None:
            name = participant.id if participant is not None else "anonymous"
            self.seed = _stable_seed(f"{name}:{getattr(session, 'seed', '')}")
        self.log("simulated_participant", seed=self.seed, observer=self.observer.describe(),
                 **self.person.describe())
        self._relearn_opening_familiarisation(getattr(session, "schedule", ()) or ())

    def _relearn_opening_familiarisation(self, schedule) -> None:
        """Learn the real-sample familiarisation trials that open the schedule.

        Their percepts depend only on the physics and ``(seed, trial_index)``, so learning them
        here gives the same templates as learning them one by one, and a resumed session (whose
        responder is new) gets its templates back.
        """
        from experiments.responders.base import TrialStimulus
        for trial in schedule:
            if not _is_familiarisation(trial):
                break
            if trial.mode != "simulated":
                self._learn(trial, TrialStimulus(mode="real", roughness_id=trial.roughness_id,
                                                 roughness_um=trial.roughness_um))

    def make_person(self, participant=None) -> SimulatedPerson:
        """The :class:`SimulatedPerson` for a :class:`participants_schema.Participant` (or None)
        and this responder's options."""
        thickness_m = participant.measured_skin_m if participant is not None else None
        if self._overrides["skin_thickness_um"]:
            thickness_m = float(self._overrides["skin_thickness_um"]) * 1e-6
        if thickness_m is None:
            raise UserInputError("responder 'simulated': skin_thickness_um: expected an option or "
                                 "the participant record's skin_thickness.total_um, got neither")
        fraction = self._overrides["dermis_fraction"]
        if fraction is None and participant is not None:
            fraction = participant.dermis_fraction
        temperature = self._overrides["skin_temperature_C"]
        if not temperature:
            temperature = participant.initial_skin_temperature_C if participant is not None else None
            temperature = 35.75 if temperature is None else temperature
        try:
            return SimulatedPerson(skin_thickness_m=thickness_m,
                                   dermis_fraction=0.6 if fraction is None else float(fraction),
                                   skin_temperature_C=float(temperature), params=self.params)
        except ValueError as exc:
            raise UserInputError(f"responder 'simulated': {exc}") from None

    def _ensure_person(self) -> SimulatedPerson:
        if self.person is None:
            self.person = self.make_person(None)
        if self.seed is None:
            self.seed = 0
        return self.person

    def _trial(self, trial) -> tuple[np.random.Generator, float]:
        """This trial's random generator and skin temperature (made once per trial index)."""
        index = int(trial.trial_index)
        if index not in self._trial_state:
            person = self._ensure_person()
            rng = np.random.default_rng([self.seed, index])
            self._trial_state[index] = (rng, person.trial_skin_temperature(rng))
        return self._trial_state[index]

    # -- the trial -------------------------------------------------------------------------
    def cue(self) -> bool:
        return True   # the model "hears" the cue; nothing to play

    def touch(self, trial, display) -> None:
        """Script the emulator: the sample (real trials) and the finger."""
        person = self._ensure_person()
        _, skin_temperature = self._trial(trial)
        reply = press(display, sample=(None if trial.mode == "simulated"
                                       else _sample_for(self.session, trial, self.params)),
                      press_after_s=self.press_after_s, force_N=self._force(trial),
                      hold_s=self.hold_for(trial), skin_thickness_m=person.skin_thickness_m,
                      skin_temperature_C=skin_temperature)
        if hasattr(self.session, "log_finger_model"):
            self.session.log_finger_model(trial.trial_index, reply)
        if _is_familiarisation(trial) and trial.mode != "simulated":
            # A real sample is felt by physics alone: learn now, whether or not the protocol
            # asks for an answer on familiarisation trials (``response = false``).
            from experiments.responders.base import TrialStimulus
            self._learn(trial, TrialStimulus(mode="real", roughness_id=trial.roughness_id,
                                             roughness_um=trial.roughness_um))

    def hold_for(self, trial) -> float:
        """How long the finger stays on for ``trial``, s (see the ``hold_s`` option).

        A participant asked for an answer feels, answers and lets go (:attr:`hold_s`), and so
        does one being familiarised (``feedback = true``: told the sample, learning how it
        feels, which takes the same feature window). On a recording (a block with
        ``response = false`` and no feedback, e.g. Exp. 1's) the finger stays on until the
        display has recorded (real samples: ``contact.record_s``) or played
        (``max_contact_s``) the whole contact.
        """
        if self.hold_given:
            return self.hold_s
        protocol = getattr(self.session, "protocol", None)
        block = _block_of(protocol, trial)
        contact = getattr(protocol, "contact", None)
        if (block is None or contact is None or getattr(block, "response", True)
                or getattr(block, "feedback", False)):
            return self.hold_s
        needed = contact.max_contact_s if trial.mode == "simulated" else contact.record_s
        return max(self.hold_s, float(needed) + HOLD_MARGIN_S)

    def _force(self, trial) -> float:
        """This trial's press, N: ``force_N``, else a draw from the lab (:attr:`lab`) from
        ``(seed, trial_index)`` (its own generator: the trial's other draws are unchanged)."""
        if self.force_N is not None:
            return self.force_N
        self._ensure_person()
        rng = np.random.default_rng([self.seed, int(trial.trial_index), 0xF0]
                                    if trial is not None else [self.seed, 0xF0])
        return float(self.lab.draw_forces(rng))

    def trial_force(self, stimulus, trial=None) -> float:
        """The force of this trial's contact, N: what the display measured (the mean summed
        force over the contact, :attr:`TrialStimulus.contact_force_N`), else the scripted press."""
        measured = getattr(stimulus, "contact_force_N", None)
        return round(float(measured), 2) if measured is not None else self._force(trial)

    def feel(self, trial, stimulus) -> tuple[np.ndarray, np.ndarray, float]:
        """The receptor temperature trace this trial produced: ``(t_s, receptor_C, skin_C)``."""
        person = self._ensure_person()
        _, skin_temperature = self._trial(trial)
        if _played(stimulus):
            t, surface = _contact_trace(stimulus)
            t, rec = person.feel_imposed(t, surface, skin_temperature_C=skin_temperature,
                                         pad_resistance=self.pad_resistance())
        else:
            sample = _sample_for(self.session, trial, self.params, stimulus.sample)
            t, rec = person.feel_real(sample["roughness_m"], material=sample["material"],
                                      sample_thickness_m=sample["thickness_m"],
                                      material_temperature_C=sample["temperature_C"],
                                      skin_temperature_C=skin_temperature,
                                      force_N=self.trial_force(stimulus, trial))   # Eq. 5
        # the scene planner's decision for what was felt: model, method, tolerance, error bound
        self.log("simulated_receptor_model", trial_index=int(trial.trial_index),
                 **(person.last_plan or {}))
        return t, rec, skin_temperature

    def pad_resistance(self) -> float | None:
        """This person's finger–pad contact resistance on the display, m² K/W (or None).

        Eq. 5 for the pad's face against the person's own skin
        (:meth:`SimulatedPerson.pad_resistance`); the face is the protocol's ``[simulation]
        pad_roughness_um`` / ``pad_material`` unless the options say otherwise (default 0.4 µm
        copper, the emulated pad's).  ``pad_contact=false`` imposes the pad temperature on the
        skin directly (no contact resistance, the model before the pad contact was modelled).
        """
        if not self.pad_contact:
            return None
        sim = getattr(getattr(self.session, "protocol", None), "simulation", None)
        roughness_um = self.pad_roughness_um
        if roughness_um is None:
            roughness_um = getattr(sim, "pad_roughness_um", PAD_ROUGHNESS_M * 1e6)
        pad_material = self.pad_material or getattr(sim, "pad_material", PAD_MATERIAL)
        key = (float(roughness_um), str(pad_material))
        if key not in self._pad_cache:
            try:
                self._pad_cache[key] = self._ensure_person().pad_resistance(key[0] * 1e-6, key[1])
            except ValueError as exc:   # stimuli.ModelInputError: an unknown material
                raise UserInputError(f"responder 'simulated': pad_material: {exc}") from None
        return self._pad_cache[key]

    def _learn(self, trial, stimulus) -> None:
        """Add this familiarisation trial's percept to its class template (once per trial)."""
        index = int(trial.trial_index)
        if index in self._learned:
            return
        person = self._ensure_person()
        rng, _ = self._trial(trial)
        t, rec, skin_temperature = self.feel(trial, stimulus)
        person.learn(trial.roughness_id, person.perceive(person.features(t, rec, skin_temperature), rng),
                     mode="simulated" if _played(stimulus) else "real")
        self._learned.add(index)

    def respond(self, trial, stimulus) -> Response:
        person = self._ensure_person()
        rng, _ = self._trial(trial)
        rt = person.response_time(rng)
        index = int(trial.trial_index)
        usable = stimulus.status == "ok" and not (stimulus.mode == "simulated" and len(stimulus.time_s) < 2)
        if _is_familiarisation(trial):
            if usable:
                self._learn(trial, stimulus)
            answer = int(trial.roughness_id)
        elif not usable:
            answer = int(rng.choice(RESPONSE_IDS))
        else:
            t, rec, skin_temperature = self.feel(trial, stimulus)
            features = person.features(t, rec, skin_temperature)
            percept = person.perceive(features, rng)
            kind = "simulated" if _played(stimulus) else "real"
            answer = self._decide(trial, percept, rng, kind)
            if self.log_percepts:
                self.log("simulated_percept", trial_index=index, felt_as=kind,
                         pad_resistance_m2K_W=self.pad_resistance() if kind == "simulated" else None,
                         skin_temperature_C=round(skin_temperature, 4),
                         feature_names=list(feature_names(person.params)),
                         features=[round(float(v), 4) for v in features],
                         percept=[round(float(v), 4) for v in percept],
                         log_likelihoods={str(k): round(v, 3) for k, v in
                                          person.log_likelihoods(percept, kind).items()},
                         templates=getattr(self, "_judged_against", None),
                         answer=answer)
        self._trial_state.pop(index, None)
        return Response(answer, rt, source="simulated")

    def _decide(self, trial, percept, rng, kind: str) -> int:
        """The observer's answer to this trial (lapse first, as :meth:`SimulatedPerson.decide`).

        The block's earlier percepts and answers are kept (per block name) for the observers
        that judge within the block; the absolute observer ignores them.
        """
        from experiments.participant_model.observers import BlockContext
        person = self._ensure_person()
        mode = kind if kind == "real" else self.observer.template_mode_for_simulated
        templates = person.template_set(mode)
        self._judged_against = next((k for k, v in person.templates.items() if v is templates), None)
        lapse = rng.random() < self.params.lapse_rate
        history = self._blocks.setdefault(str(getattr(trial, "block", "")), ([], []))
        if lapse or not templates:
            answer = int(rng.choice(RESPONSE_IDS))
        else:
            ids = sorted(templates)
            means = np.array([templates[k][0] / templates[k][1] for k in ids])[None]
            counts = np.array([[float(templates[k][1]) for k in ids]])
            block = _block_of(getattr(self.session, "protocol", None), trial)
            ctx = BlockContext(means, counts, self.params.noise_sd,
                               int(getattr(block, "repetitions", 3) or 3))
            seen = np.array(history[0] + [np.asarray(percept, dtype=float)])[None]
            given = np.array([[ids.index(a) if a in ids else -1 for a in history[1]]], dtype=int)
            answer = int(ids[int(self.observer.choose(seen, given.reshape(1, -1), ctx)[0])])
        history[0].append(np.asarray(percept, dtype=float))
        history[1].append(answer)
        return answer

    def rewarm(self, seconds: float) -> None:
        self.sleep(seconds)


def _played(stimulus) -> bool:
    """Whether the display played a profile (else a real sample was touched)."""
    return stimulus.mode == "simulated" or (
        stimulus.mode == "familiarise" and stimulus.profile_parameters is not None)


def _block_of(protocol, trial):
    """The protocol's block of ``trial`` (None without a protocol or such a block)."""
    try:
        return protocol.block(trial.block)
    except (AttributeError, KeyError, LookupError, ValueError):
        return None


def _is_familiarisation(trial) -> bool:
    return trial.mode == "familiarise" or str(getattr(trial, "block", "")).startswith("familiar")


def _contact_trace(stimulus) -> tuple[np.ndarray, np.ndarray]:
    """The contact-temperature trace from contact on (times shifted to start at 0)."""
    t = np.asarray(stimulus.time_s, dtype=float)
    g = np.asarray(stimulus.contact_C, dtype=float)
    if t.size and t.min() < 0:
        keep = t >= 0
        t, g = t[keep], g[keep]
    if t.size:
        t = t - t[0]
    return t, g


def _sample_for(session, trial, params: PerceptionParameters, sample: dict | None = None) -> dict:
    """The physical sample of a trial: from the stimulus, else the protocol, else the defaults."""
    sample = dict(sample or {})
    protocol_sample = _protocol_sample(session)
    def pick(*names, default=None):
        for source in (sample, protocol_sample):
            for n in names:
                if source.get(n) is not None:
                    return source[n]
        return default
    thickness = pick("thickness_m")
    if thickness is None and pick("thickness_mm") is not None:
        thickness = float(pick("thickness_mm")) * 1e-3
    if thickness is None:
        thickness = params.sample_thickness_m
    temperature = pick("temperature_C", "material_temperature_C", "room_temperature_C",
                       default=params.material_temperature_C)
    roughness = pick("roughness_m")
    if roughness is None:
        roughness = float(trial.roughness_um) * 1e-6
    return {"material": pick("material", default="stainless_steel"), "roughness_m": float(roughness),
            "thickness_m": None if thickness is None else float(thickness),
            "temperature_C": float(temperature)}


def _protocol_sample(session) -> dict:
    """Sample settings from the session's protocol (``[material]``, ``[environment]``), if any."""
    protocol = getattr(session, "protocol", None)
    data = getattr(protocol, "data", None)
    if not isinstance(data, dict):
        return {}
    out = {}
    material = data.get("material")
    if isinstance(material, dict):
        if material.get("name") is not None:
            out["material"] = material["name"]
        for key in ("thickness_m", "thickness_mm", "temperature_C"):
            if material.get(key) is not None:
                out[key] = material[key]
    elif isinstance(material, str):
        out["material"] = material
    environment = data.get("environment")
    if isinstance(environment, dict) and environment.get("room_temperature_C") is not None:
        out.setdefault("temperature_C", environment["room_temperature_C"])
    return out
