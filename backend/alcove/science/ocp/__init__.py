"""Multi-phase optimal control of the multibody model (DMOCC transcription, IPOPT via CasADi).

* :mod:`.task_spec` -- the user's task definition (pydantic) and the task presets;
* :mod:`.contact` -- the contact-model slot and the ``none`` / smooth ``aux`` models;
* :mod:`.dmocc` -- the discrete-mechanics transcription and DEL rollouts;
* :mod:`.solve` -- ``solve_task`` (cached NLPs, initial guesses, retries) and ``OcpSolution``.
"""

from alcove.science.ocp.contact import ContactModelError, aux_contact, contact_from_spec, no_contact
from alcove.science.ocp.solve import OcpSolution, solve_task
from alcove.science.ocp.task_spec import TaskSpec, TaskSpecError, parse_task, task_preset

__all__ = [
    "ContactModelError",
    "OcpSolution",
    "TaskSpec",
    "TaskSpecError",
    "aux_contact",
    "contact_from_spec",
    "no_contact",
    "parse_task",
    "solve_task",
    "task_preset",
]
