"""The campaign domain: the active-learning loop as a durable state machine.

* deciding: :mod:`.state_machine` (pure ``(state, event) -> decision``), :mod:`.transitions`
  (a decision applied to the rows), :mod:`.fan` (a batch iteration's slots);
* running, in a worker: :mod:`.protocol` (the job protocol), :mod:`.steps` (which domain
  computes each step), :mod:`.reconciler` (re-enqueues steps whose worker died or whose
  message was lost);
* showing: :mod:`.results`, :mod:`.picks`, :mod:`.validation`, :mod:`.live`, :mod:`.export`;
* the lifecycle: :mod:`.service` (create, edit, start, pause, resume, cancel, retry, fork;
  never commits), :mod:`.router`, :mod:`.config` and :mod:`.schemas`, :mod:`.repository`.

docs/architecture.md lists every module.
"""
