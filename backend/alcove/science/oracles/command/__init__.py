"""The ``command`` oracle: an external solver (LS-DYNA, Abaqus, a cluster script) as an oracle.

An administrator defines each external solver in a server-side YAML catalogue (see
``docs/external-solvers.md``); web users only choose an entry by name and may supply a text
template and the numeric parameters the entry declares. Nothing a user enters is executed:
commands are argument lists from the catalogue (never a shell string, never ``shell=True``),
and templates are rendered by plain substitution of a fixed set of ``{{ name }}``
placeholders.

One concern per module:

* :mod:`.spec` -- a catalogue entry and the parameters a user may set (pydantic models);
* :mod:`.catalogue` -- reading the administrator's YAML catalogue into entries;
* :mod:`.contract` -- the file contract of one run: input and output files, their formats,
  the environment and the template placeholders the external program can rely on;
* :mod:`.template` -- rendering a template with the placeholder values of a trajectory;
* :mod:`.process` -- running the command in its own process group with a timeout and
  cooperative cancellation;
* :mod:`.gate` -- the quality gate: whether the output is usable as data;
* :mod:`.oracle` -- :class:`CommandOracle`, which runs one entry on a trajectory.
"""

from alcove.science.oracles.command.catalogue import load_command_catalogue
from alcove.science.oracles.command.contract import (
    DIAGNOSTICS_FILE,
    PARAMS_FILE,
    RESERVED_FILES,
    STDERR_FILE,
    STDOUT_FILE,
    TEMPLATE_PLACEHOLDERS,
    TRAJECTORY_FILE,
)
from alcove.science.oracles.command.oracle import CommandOracle
from alcove.science.oracles.command.process import POLL_SECONDS, TERMINATE_GRACE_SECONDS
from alcove.science.oracles.command.spec import (
    ENTRY_NAME,
    PLAIN_FILE_NAME,
    CatalogueError,
    CommandOracleParams,
    CommandOracleSpec,
    CommandParameter,
    params_model,
)
from alcove.science.oracles.command.template import (
    PLACEHOLDER,
    card_number,
    curve_lines,
    render_template,
    template_values,
)

__all__ = [
    "DIAGNOSTICS_FILE",
    "ENTRY_NAME",
    "PARAMS_FILE",
    "PLACEHOLDER",
    "PLAIN_FILE_NAME",
    "POLL_SECONDS",
    "RESERVED_FILES",
    "STDERR_FILE",
    "STDOUT_FILE",
    "TEMPLATE_PLACEHOLDERS",
    "TERMINATE_GRACE_SECONDS",
    "TRAJECTORY_FILE",
    "CatalogueError",
    "CommandOracle",
    "CommandOracleParams",
    "CommandOracleSpec",
    "CommandParameter",
    "card_number",
    "curve_lines",
    "load_command_catalogue",
    "params_model",
    "render_template",
    "template_values",
]
