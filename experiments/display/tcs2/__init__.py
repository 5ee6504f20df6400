"""A QST.Lab TCS II thermode as a thermocue display.

:mod:`.profile_compiler` turns a target profile into the device's linear segments with a stated
error; :mod:`.commands` formats and parses its ASCII commands; :mod:`.link` reads and writes
them as lines; :mod:`.url` reads a ``tcs2://`` URL; :mod:`.backend` is the display backend of
``tcs2://PORT`` and :mod:`.trial` one armed trial on it; a TCS II in software is
:mod:`experiments.emulators.tcs2` (``tcs2://emulator`` opens its ``tcs2emu://`` pyserial URL,
registered by the emulators' entry point). See ``docs/tcs2.md``.
"""
