"""The campaign domain: the active-learning loop as a durable state machine, in three wings
around the lifecycle.

* :mod:`.machine`: deciding (the pure state machine, a decision written to the rows, a batch
  iteration's parallel slots, the owner's running-campaigns limit);
* :mod:`.run`: what runs in a worker (the job protocol, the steps, the reconciler, the
  candidate rows the steps write);
* :mod:`.views`: what the UI and the API read (detail, lists, events, picks, the validation
  suite, export, live streams) and their routes;
* here, the lifecycle: :mod:`.service` (create, edit, start, pause, resume, cancel, retry,
  fork; never commits), :mod:`.router`, :mod:`.schemas`, the checks of a new campaign
  (:mod:`.draft`, :mod:`.sizes`, :mod:`.references`), :mod:`.presets`; and what every wing
  reads: :mod:`.config` (the settings), :mod:`.repository` and :mod:`.candidate_queries`
  (the queries), :mod:`.suite` (the validation suite the settings ask for).

``run`` and ``views`` never import each other; neither imports the lifecycle. docs/architecture.md
lists every module.
"""
