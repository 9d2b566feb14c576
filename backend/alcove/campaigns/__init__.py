"""The campaign domain: the active-learning loop as a durable state machine.

* :mod:`.state_machine`: pure ``(state, event) -> decision``;
* :mod:`.schemas`: pydantic settings, requests and reads;
* :mod:`.service`: rules (never commits; returns the jobs to send after commit);
* :mod:`.repository`: all queries;
* :mod:`.flows`: the step executors run by the Celery jobs;
* :mod:`.reconciler`: re-enqueues steps whose worker died or whose message was lost.
"""
