"""Every stand-in device: software twins of the displays the host drives.

:mod:`.thermocue` is the thermocue display's emulator (its firmware's commands, states, limits
and watchdog, the pad's and finger's physics, fault injection) and :mod:`.tcs2` a QST.Lab TCS II;
both are pyserial URL handlers (``emulator://``, ``tcs2emu://``) on :mod:`.port.emulated_port`.
:mod:`.pty_server` serves either on a real pseudo-terminal (``thermocue emulator``), with the
options of :mod:`.options`. :mod:`.backends` registers ``emulator://`` with the display registry
through the ``thermocue.displays`` entry point, as a third-party backend would.

The emulators import of the display only its wire format (``experiments.display.thermocue``'s
``framing`` and ``messages``), :mod:`.backends` excepted; the display never imports them.
"""
