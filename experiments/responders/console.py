"""A responder on the terminal: prompts on stdout, answers 1-4 typed on stdin."""
from __future__ import annotations

import sys
import time

from experiments.responders.base import RESPONSE_IDS, Responder, ResponderClosed, Response

__all__ = ["ConsoleResponder"]


class ConsoleResponder(Responder, name="console", aliases=("terminal",)):
    """Prompts on ``stdout``; reads the experimenter's confirmations and the answers on ``stdin``.

    Parameters
    ----------
    stdin, stdout, stderr : file-like, optional
        Default ``sys.stdin``, ``sys.stdout`` and ``sys.stderr`` (read at call time, so pytest's
        capture works).
    bell : bool
        Whether :meth:`cue` rings the terminal bell (it is the only cue a terminal has).

    The bell is written to the first of ``stdout``, ``stderr`` that is a terminal; when neither
    is (output piped or redirected to a file, no terminal to ring), :meth:`cue` returns False and
    logs ``cue_unavailable`` with the reason, so ``cue_played`` says whether a bell could sound.

    Notes
    -----
    ``rt_s`` runs from the question being printed to the line being read; terminal line
    buffering makes it coarse (the Enter key ends the answer).

    This terminal is the participant's: it shows instructions, the cue, the question and, only
    for blocks with ``feedback = true``, whether the answer was right. The experimenter's lines
    (which sample to place, progress, warnings) go to stderr: in a lab, send them to another
    terminal (``2>/dev/pts/N``) or use the PsychoPy window.

    With the protocol's ``[presentation] answer_mode = "spoken"`` nothing is printed for the
    participant: the bell marks the touch and, rung twice, the question; everything else goes
    to the experimenter (stderr), who types the spoken answer (1-4, Enter), then Enter to
    confirm it, ``u`` to undo it or another number to replace it. The answer is timed from the
    question's bell to the answer's line (``answer_keyed_after_cue_s``).
    """

    def __init__(self, stdin=None, stdout=None, bell: bool = True, stderr=None):
        super().__init__()
        self._stdin = stdin
        self._stdout = stdout
        self._stderr = stderr
        self.bell = bool(bell)

    @property
    def stdin(self):
        return self._stdin if self._stdin is not None else sys.stdin

    @property
    def stdout(self):
        return self._stdout if self._stdout is not None else sys.stdout

    @property
    def stderr(self):
        return self._stderr if self._stderr is not None else sys.stderr

    def _terminal(self):
        """The first of stdout, stderr that is a terminal, or None."""
        for stream in (self.stdout, self.stderr):
            try:
                if stream is not None and stream.isatty():
                    return stream
            except (AttributeError, ValueError, OSError):   # no isatty, or a closed stream
                continue
        return None

    def _print(self, text: str, end: str = "\n") -> None:
        self.stdout.write(text + end)
        self.stdout.flush()

    def _readline(self, what: str) -> str:
        line = self.stdin.readline()
        if line == "":
            raise ResponderClosed(f"stdin: expected {what}, got end of input")
        return line.strip()

    def begin_session(self, session) -> None:
        super().begin_session(session)
        shown = getattr(getattr(session, "protocol", None), "presentation", None)
        self.spoken = getattr(shown, "answer_mode", "keyed") == "spoken"

    spoken = False

    def _tell(self, text: str, end: str = "\n") -> None:
        """A line for the experimenter (stderr)."""
        self.stderr.write(text + end)
        self.stderr.flush()

    def _for_participant(self, text: str) -> None:
        """``text`` on the participant's terminal, or (spoken answers) for the experimenter to say."""
        if self.spoken:
            self._tell(f"say to the participant: {text!r}")
        else:
            self._print(text)

    def show_text(self, text: str) -> None:
        self._for_participant(text)

    def prompt_experimenter(self, text: str) -> None:
        """Wait for the experimenter's Enter; ``text`` (it names the sample) is not printed here:
        the session has put it on the experimenter's channel (stderr, or their screen)."""
        if self.spoken:
            self._tell("press Enter when the sample is placed")
        else:
            self._print("Please wait (experimenter: press Enter when ready)")
        self._readline("Enter")

    def show_label(self, text: str | None) -> None:
        if text:
            self._for_participant(text)

    def feedback(self, text: str, seconds: float = 0.0) -> None:
        """Correct or not, printed only for blocks with ``feedback = true``."""
        self._for_participant(text)

    def _bell(self, times: int = 1) -> tuple[bool, str | None]:
        """Ring the terminal bell; (rung, why not)."""
        if not self.bell:
            return False, "bell turned off (bell=false)"
        term = self._terminal()
        if term is None:
            return False, "no terminal to ring the bell on (stdout and stderr are not terminals)"
        try:
            term.write("\a" * times)
            term.flush()
            return True, None
        except (OSError, ValueError) as exc:
            return False, f"bell not written: {type(exc).__name__}: {exc}"

    def cue(self) -> bool:
        """Ring the terminal bell; True only if it was written to a terminal."""
        played = False
        if not self.bell:
            self.log("cue_unavailable", reason="bell turned off (bell=false)")
        else:
            term = self._terminal()
            if term is None:
                self.log("cue_unavailable", reason="no terminal to ring the bell on (stdout and "
                                                   "stderr are not terminals)")
            else:
                try:
                    term.write("\a")
                    term.flush()
                    played = True
                except (OSError, ValueError) as exc:
                    self.log("cue_unavailable", reason=f"bell not written: {type(exc).__name__}: {exc}")
        if not self.spoken:
            self._print(">>> Touch now")
        return played

    def _spoken_answer(self, trial) -> Response:
        """The experimenter types the participant's spoken answer, then confirms or undoes it."""
        choices = {str(i) for i in RESPONSE_IDS}
        rung, why = self._bell(2)
        t0 = time.perf_counter()
        self.log("question_cue", trial_index=trial.trial_index, played=rung,
                 **({} if rung else {"reason": why}))
        answer, rt = None, None
        while True:
            if answer is None:
                self._tell(f"trial {trial.trial_index}: type the participant's spoken answer "
                           f"(1-4) and Enter: ", end="")
                text = self._readline("a spoken answer 1-4")
                if text not in choices:
                    self._tell(f"expected one of 1, 2, 3, 4, got {text!r}")
                    continue
                answer, rt = text, time.perf_counter() - t0
                self.log("answer_keyed", trial_index=trial.trial_index, key=answer,
                         after_cue_s=round(rt, 4))
            self._tell(f"answer {answer}: Enter confirms, u undoes, another number replaces it: ",
                       end="")
            text = self._readline("Enter, u or a number")
            if text == "":
                self.log("answer_confirmed", trial_index=trial.trial_index, key=answer)
                return Response(int(answer), rt, source="experimenter:console", answer_mode="spoken")
            if text in choices:
                self.log("answer_undone", trial_index=trial.trial_index, key=answer, replaced_by=text)
                answer, rt = text, time.perf_counter() - t0
                self.log("answer_keyed", trial_index=trial.trial_index, key=answer,
                         after_cue_s=round(rt, 4))
            elif text.lower() == "u":
                self.log("answer_undone", trial_index=trial.trial_index, key=answer)
                answer = None

    def respond(self, trial, stimulus) -> Response:
        if self.spoken:
            return self._spoken_answer(trial)
        choices = ", ".join(str(i) for i in RESPONSE_IDS)
        t0 = time.perf_counter()
        while True:
            self._print(f"Which roughness ({choices})? ", end="")
            text = self._readline(f"an answer {choices}")
            rt = time.perf_counter() - t0
            if text in {str(i) for i in RESPONSE_IDS}:
                return Response(int(text), rt, source="console")
            self._print(f"expected one of {choices}, got {text!r}; try again")
