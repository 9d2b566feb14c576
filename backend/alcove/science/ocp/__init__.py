"""Multi-phase optimal control of the multibody model (DMOCC transcription, IPOPT via CasADi).

* :mod:`.task_spec` -- the user's task definition (pydantic) and the task presets;
* :mod:`.problem` -- the resolved multi-phase problem (phases, bounds, boundary conditions);
* :mod:`.contact` -- the contact-model slot and the ``none`` / smooth ``aux`` models;
* :mod:`.discrete_mechanics` -- discrete Lagrangian and forces of one interval;
* :mod:`.dmocc` -- the DMOCC transcription into an NLP (:mod:`.derivatives`: its exact derivatives);
* :mod:`.rollout` -- forward rollouts of the discrete Euler-Lagrange equations;
* :mod:`.solve` -- ``solve_task`` (cached NLPs, initial guesses, retries) and ``OcpSolution``.
"""

from importlib import import_module
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # the real names for type checkers; at run time they load on first use
    from alcove.science.ocp.contact import ContactModelError, aux_contact, contact_from_spec, no_contact
    from alcove.science.ocp.solve import OcpSolution, solve_task
    from alcove.science.ocp.task_spec import TaskSpec, TaskSpecError, parse_task, task_preset

# Re-exports resolve on first use (PEP 562): importing ``task_spec`` alone (e.g. to validate a
# task in the API process) must not import CasADi.
_EXPORTS = {
    "ContactModelError": "contact",
    "aux_contact": "contact",
    "contact_from_spec": "contact",
    "no_contact": "contact",
    "OcpSolution": "solve",
    "solve_task": "solve",
    "TaskSpec": "task_spec",
    "TaskSpecError": "task_spec",
    "parse_task": "task_spec",
    "task_preset": "task_spec",
}


def __getattr__(name: str) -> Any:
    if name in _EXPORTS:
        return getattr(import_module(f"alcove.science.ocp.{_EXPORTS[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


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
