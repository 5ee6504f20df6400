"""The session folder, the ground floor: its format, its writers, its reader (standard library,
plus numpy for the traces' arrays; nothing of ``experiments``, ``analysis`` or ``stimuli``).

:mod:`sessionfiles.columns` (the trials table's columns, one table), :mod:`sessionfiles.logformat`
(the files' format and tolerant readers), :mod:`sessionfiles.logbook` (the event log and
``trials.csv`` writer), :mod:`sessionfiles.session_files` (the folder, ``session.json``, the
traces), :mod:`sessionfiles.session_reader` (the one checked reader of a session folder),
:mod:`sessionfiles.atomicfile` (files written whole) and :mod:`sessionfiles.errors`. The session
(:mod:`experiments.session`) writes through it; :mod:`analysis` reads through it and imports
nothing else of the tree but :mod:`stimuli.paper`'s sample names.
"""
