"""``thermocue monitor``: the experimenter's live view of a session folder, as a local web page.

It reads the folder only (``session.json``, ``events.jsonl``, ``trials.csv``, ``traces/``) and
imports nothing that talks to a display or runs a session (tests/test_import_layers.py):
:mod:`.folder` follows the folder as it is written, :mod:`.time_left` estimates the time left
(the terminal's progress line uses the same estimate), :mod:`.server` serves the page
(``static/``) and its updates over server-sent events.
"""
